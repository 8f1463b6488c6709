"""servolab's robots: each wires the pure algorithms to the Dynamixel bus and to topics, as a
set of nodes (the biped's controller manager and joint controllers, ...)."""

from pathlib import Path

#: ``configs/`` of a clone of the repository: the robots' shipped configurations
CONFIGS = Path(__file__).resolve().parents[3] / "configs"
