"""``rclpy.time``: :class:`Time`, a point in time of one clock type, in nanoseconds, with
rclpy's shape (``rclpy/time.py``): ``Time(seconds=..., nanoseconds=..., clock_type=...)``
(never negative), ``seconds_nanoseconds()``, ``Time + Duration`` and ``Time - Duration``
are Times, ``Time - Time`` is a Duration, comparisons only between one clock type's times
(a TypeError otherwise), ``to_msg``/``from_msg`` with ``builtin_interfaces/msg/Time``."""

from __future__ import annotations

from typing import Any, overload

from .clock_type import ClockType
from .duration import S_TO_NS, Duration, _builtin


class Time:
    """Represents a point in time: a duration since an epoch, and a clock type."""

    __slots__ = ("_clock_type", "_nanoseconds")

    def __init__(self, *, seconds: float = 0, nanoseconds: int = 0,
                 clock_type: ClockType = ClockType.SYSTEM_TIME) -> None:
        if not isinstance(clock_type, ClockType):
            raise TypeError("Clock type must be a ClockType enum")
        if seconds < 0:
            raise ValueError("Seconds value must not be negative")
        if nanoseconds < 0:
            raise ValueError("Nanoseconds value must not be negative")
        total = int(seconds * S_TO_NS) + int(nanoseconds)
        if total >= 2**63:
            raise OverflowError("Total nanoseconds value is too large to store in C time point.")
        self._nanoseconds = total
        self._clock_type = clock_type

    @property
    def nanoseconds(self) -> int:
        return self._nanoseconds

    def seconds_nanoseconds(self) -> tuple[int, int]:
        return (self._nanoseconds // S_TO_NS, self._nanoseconds % S_TO_NS)

    @property
    def clock_type(self) -> ClockType:
        return self._clock_type

    def __repr__(self) -> str:
        return f"Time(nanoseconds={self._nanoseconds}, clock_type={self._clock_type.name})"

    def __add__(self, other: Duration) -> Time:
        if isinstance(other, Duration):
            try:
                return Time(nanoseconds=self._nanoseconds + other.nanoseconds,
                            clock_type=self._clock_type)
            except OverflowError as e:
                raise OverflowError("Addition leads to overflow in C storage.") from e
        return NotImplemented

    def __radd__(self, other: Duration) -> Time:
        return self.__add__(other)

    @overload
    def __sub__(self, other: Time) -> Duration: ...

    @overload
    def __sub__(self, other: Duration) -> Time: ...

    def __sub__(self, other: Time | Duration) -> Time | Duration:
        if isinstance(other, Time):
            if self._clock_type != other._clock_type:
                raise TypeError("Can't subtract times with different clock types")
            return Duration(nanoseconds=self._nanoseconds - other._nanoseconds)
        if isinstance(other, Duration):
            try:
                return Time(nanoseconds=self._nanoseconds - other.nanoseconds,
                            clock_type=self._clock_type)
            except ValueError as e:
                raise ValueError("Subtraction leads to negative time.") from e
        return NotImplemented

    def _check(self, other: Time) -> None:
        if self._clock_type != other._clock_type:
            raise TypeError("Can't compare times with different clock types")

    def __eq__(self, other: object) -> bool:
        if isinstance(other, Time):
            self._check(other)
            return self._nanoseconds == other._nanoseconds
        return NotImplemented

    def __ne__(self, other: object) -> bool:
        if isinstance(other, Time):
            return not self.__eq__(other)
        return NotImplemented

    def __lt__(self, other: object) -> bool:
        if isinstance(other, Time):
            self._check(other)
            return self._nanoseconds < other._nanoseconds
        return NotImplemented

    def __le__(self, other: object) -> bool:
        if isinstance(other, Time):
            self._check(other)
            return self._nanoseconds <= other._nanoseconds
        return NotImplemented

    def __gt__(self, other: object) -> bool:
        if isinstance(other, Time):
            self._check(other)
            return self._nanoseconds > other._nanoseconds
        return NotImplemented

    def __ge__(self, other: object) -> bool:
        if isinstance(other, Time):
            self._check(other)
            return self._nanoseconds >= other._nanoseconds
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]  # as rclpy's: __eq__ without __hash__

    def to_msg(self) -> Any:
        """A ``builtin_interfaces/msg/Time``."""
        TimeMsg = _builtin("Time")
        seconds, nanoseconds = self.seconds_nanoseconds()
        return TimeMsg(sec=seconds, nanosec=nanoseconds)

    @classmethod
    def from_msg(cls, msg: Any, clock_type: ClockType = ClockType.ROS_TIME) -> Time:
        if getattr(msg, "__msgtype__", None) != "builtin_interfaces/msg/Time":
            raise TypeError("Must pass a builtin_interfaces.msg.Time object")
        return cls(seconds=msg.sec, nanoseconds=msg.nanosec, clock_type=clock_type)


__all__ = ["Time"]
