"""``rclpy.utilities``: ``remove_ros_args``, ``ok``, ``get_default_context``."""

from ._arguments import remove_ros_args


def ok(context: object = None) -> bool:
    from servolab import rclpy
    return rclpy.ok()


def get_default_context() -> object:
    from servolab import rclpy
    return rclpy.get_default_context()


__all__ = ["get_default_context", "ok", "remove_ros_args"]
