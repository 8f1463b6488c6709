"""Times as whole nanoseconds, as rclcpp compares them.

Why: ``joint_trajectory_controller`` adds ``time_from_start`` to the trajectory's stamp and
compares the sum with the sample time as ``rclcpp::Time``, integer nanoseconds. Comparing the
same sums in float seconds can put a sample that lands exactly on a point (1.0 s + 0.5 s vs
1.5 s) in the wrong segment; rounding every time to nanoseconds once, and computing durations
from nanosecond differences, makes the segment choice the C++'s.
"""

from __future__ import annotations

import math

from .errors import TrajectoryValueError

_NS_PER_S = 1_000_000_000


def to_ns(seconds: float, what: str = "time") -> int:
    """``seconds`` as whole nanoseconds (rounded); refuses NaN and infinities, which no ROS
    time can hold."""
    value = float(seconds)
    if not math.isfinite(value):
        raise TrajectoryValueError(f"{what} must be finite, got {seconds!r}")
    return round(value * _NS_PER_S)


def to_s(nanoseconds: int) -> float:
    """Seconds of a nanosecond count, as ``rclcpp::Duration::seconds()`` gives them."""
    return nanoseconds / _NS_PER_S
