"""Differential-drive bases: the configuration of a base (``base_*.yaml`` shipped here: seed
000's two-wheel and four-motor robots, a TurtleBot3 Waffle), the base driven by one SYNC_WRITE
with encoder odometry, its node (``/cmd_vel`` in, ``/odom`` out), seed 000's D.4 fusion node,
and ``servolab drive``'s run."""

from collections.abc import Mapping
from typing import Final

#: what stopping this robot does to its motors, on any end of a run (servolab.harness)
ON_STOP = "the wheels stop (goal speed 0)"

#: the bases servolab ships, by name, each with what it is: ``base_<name>.yaml`` beside this
#: package's modules. Kept here, away from the configuration's loader, so that a command's
#: help can name them without importing the Dynamixel layer.
SHIPPED: Final[Mapping[str, str]] = {
    "seed000": "seed 000's two-wheel robot, EX-106+ in wheel mode",
    "seed000_4motor": "seed 000 A.2's four-motor robot",
    "turtlebot3_waffle": "a TurtleBot3 Waffle (seed 002's robot), XM430 wheels",
}
#: the base a command drives when none is named: seed 000's own robot
DEFAULT_BASE: Final = "seed000"
assert DEFAULT_BASE in SHIPPED
