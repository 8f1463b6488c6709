"""servolab's robots: each a plug-in (:mod:`.plugin`), found by :mod:`.registry` — servolab's
own in their subpackages, a lab's through the ``servolab.robots`` entry point or as a folder on
``SERVOLAB_ROBOT_PATH`` (a URDF with its ``<ros2_control>`` block: :mod:`.robot_folder`).

- :mod:`.controllers`: the ports of ROS ``dynamixel_motor`` (controller configuration, manager,
  joint position controllers, motor states) that any Dynamixel robot uses;
- :mod:`.urdf_robot`: any robot described by a URDF whose ``<ros2_control>`` block names each
  joint's Dynamixel;
- :mod:`.armstrong`: seed 001's biped; :mod:`.base`: differential-drive bases (seed 000's,
  a TurtleBot3 Waffle); :mod:`.navigation`: seed 000's navigation around a base;
  :mod:`.treadmill`: seed 002's ball treadmill.

``servolab.robots.load("armstrong")`` gives a robot by name; each robot's ``run`` module is its
command's body and nothing else imports it.
"""

from .plugin import BusSummary, RobotPlugin, ServedRobot
from .registry import discover, entry, load, robots

__all__ = ["BusSummary", "RobotPlugin", "ServedRobot", "discover", "entry", "load", "robots"]
