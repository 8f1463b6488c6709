"""Lets the tests import servolab from src/ while the package is not installed yet."""

import sys
from pathlib import Path

try:
    import servolab  # noqa: F401
except ImportError:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import os

# No test may reach a well-known port: without this, every Zenoh session a test opens would
# look for a ROS router at tcp/localhost:7447 (the default; see servolab.middleware
# .zenoh_transport), and find a developer's real one. Tests that need a router start their
# own on a free port and name it here themselves.
os.environ["SERVOLAB_ZENOH_ROUTER"] = ""
