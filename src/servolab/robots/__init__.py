"""servolab's robots: one subpackage a robot, each wiring the pure algorithms to the Dynamixel
bus and to topics as nodes, with its default configuration files beside its code.

- :mod:`.controllers`: the ports of ROS ``dynamixel_motor`` (controller configuration, manager,
  joint position controllers, motor states) that any Dynamixel robot uses;
- :mod:`.armstrong`: seed 001's biped; :mod:`.base`: differential-drive bases (seed 000's,
  a TurtleBot3 Waffle); :mod:`.navigation`: seed 000's navigation around a base;
  :mod:`.treadmill`: seed 002's ball treadmill.

``servolab.robots.load("armstrong")`` gives a robot by name (:mod:`.registry`); each robot's
``run`` module is its command's body and nothing else imports it.
"""

from .registry import ROBOTS, RobotEntry, entry, load

__all__ = ["ROBOTS", "RobotEntry", "entry", "load"]
