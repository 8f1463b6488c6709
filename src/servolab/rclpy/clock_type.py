"""``rclpy.clock_type``: :class:`ClockType`, with rcl's values (``rcl/time.h``)."""

from enum import IntEnum


class ClockType(IntEnum):
    """Enum for clock type (rcl_clock_type_t)."""

    UNINITIALIZED = 0
    ROS_TIME = 1
    SYSTEM_TIME = 2
    STEADY_TIME = 3


__all__ = ["ClockType"]
