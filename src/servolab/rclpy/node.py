"""``rclpy.node``: :class:`Node` (servolab's, which takes rclpy's ``Node("name")`` shape)."""

from servolab.middleware.node import Node

__all__ = ["Node"]
