"""``rclpy.duration``: :class:`Duration`, a signed span of time in nanoseconds, with rclpy's
shape (``rclpy/duration.py``): keyword-only ``seconds``/``nanoseconds``, comparisons, no
arithmetic of its own (``Time`` adds and subtracts it), ``to_msg``/``from_msg`` with
``builtin_interfaces/msg/Duration``, ``repr`` ``Duration(nanoseconds=N)``."""

from __future__ import annotations

import importlib
from typing import Any

S_TO_NS = 1_000_000_000


def _builtin(name: str) -> Any:
    """A ``builtin_interfaces/msg`` class (servolab.interfaces makes them at run time)."""
    return getattr(importlib.import_module("servolab.interfaces.builtin_interfaces.msg"), name)
#: rmw's RMW_DURATION_INFINITE: the largest signed 64-bit count of nanoseconds
_INFINITE_NS = 2**63 - 1


class Duration:
    """A period between two time points, with nanosecond precision."""

    __slots__ = ("_nanoseconds",)

    def __init__(self, *, seconds: float = 0, nanoseconds: int = 0) -> None:
        total = int(seconds * S_TO_NS) + int(nanoseconds)
        if total >= 2**63 or total < -2**63:
            raise OverflowError("Total nanoseconds value is too large to store in C duration.")
        self._nanoseconds = total

    @property
    def nanoseconds(self) -> int:
        return self._nanoseconds

    def __repr__(self) -> str:
        return f"Duration(nanoseconds={self._nanoseconds})"

    def __str__(self) -> str:
        if self._nanoseconds == _INFINITE_NS:
            return "Infinite"
        return f"{self._nanoseconds} nanoseconds"

    def __eq__(self, other: object) -> bool:
        if isinstance(other, Duration):
            return self._nanoseconds == other._nanoseconds
        return NotImplemented

    def __ne__(self, other: object) -> bool:
        if isinstance(other, Duration):
            return self._nanoseconds != other._nanoseconds
        return NotImplemented

    def __lt__(self, other: object) -> bool:
        if isinstance(other, Duration):
            return self._nanoseconds < other._nanoseconds
        return NotImplemented

    def __le__(self, other: object) -> bool:
        if isinstance(other, Duration):
            return self._nanoseconds <= other._nanoseconds
        return NotImplemented

    def __gt__(self, other: object) -> bool:
        if isinstance(other, Duration):
            return self._nanoseconds > other._nanoseconds
        return NotImplemented

    def __ge__(self, other: object) -> bool:
        if isinstance(other, Duration):
            return self._nanoseconds >= other._nanoseconds
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]  # as rclpy's: __eq__ without __hash__

    def to_msg(self) -> Any:
        """A ``builtin_interfaces/msg/Duration``."""
        DurationMsg = _builtin("Duration")
        seconds, nanoseconds = divmod(self._nanoseconds, S_TO_NS)
        return DurationMsg(sec=seconds, nanosec=nanoseconds)

    @classmethod
    def from_msg(cls, msg: Any) -> Duration:
        if getattr(msg, "__msgtype__", None) != "builtin_interfaces/msg/Duration":
            raise TypeError("Must pass a builtin_interfaces.msg.Duration object")
        return cls(seconds=msg.sec, nanoseconds=msg.nanosec)


Infinite = Duration(nanoseconds=_INFINITE_NS)

__all__ = ["Duration", "Infinite"]
