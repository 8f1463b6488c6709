"""What the manager knows of each motor's health: the errors its reads met, when it last
answered, the hardware errors its status reported and its temperature.

ROS ``dynamixel_serial_proxy`` counts a bus's non-fatal, checksum and dropped-packet errors
and goes on; servolab counts them per motor as well, so that a run's summary and
``/diagnostics`` say *which* motor the errors came from (a loose connector shows as one
motor's count climbing).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

from ...dynamixel.errors import CorruptResponse, MotorError, NoResponse

#: The error kinds counted, named as dynamixel_serial_proxy's diagnostics name them.
DROPPED, CHECKSUM, NON_FATAL = "dropped", "checksum", "non_fatal"


def error_kind(error: Exception) -> str:
    """``dropped`` (no answer), ``checksum`` (a garbled one) or ``non_fatal`` (the motor
    said the instruction failed)."""
    if isinstance(error, NoResponse):
        return DROPPED
    if isinstance(error, CorruptResponse):
        return CHECKSUM
    if isinstance(error, MotorError):
        return NON_FATAL
    return DROPPED


@dataclass
class MotorHealth:
    """One motor's record (see the module docstring). Times are the manager's clock (s)."""

    id: int
    errors: Counter[str] = field(default_factory=Counter)
    #: sweeps in which the motor was skipped: its READ failed after every retry
    skipped: int = 0
    #: READs of it sent again (each a transient error survived)
    retried: int = 0
    last_heard: float | None = None
    #: hardware errors of its last status, by the e-Manual's names ("overload", ...)
    hardware: tuple[str, ...] = ()
    temperature: float | None = None

    def failed(self, error: Exception) -> None:
        self.errors[error_kind(error)] += 1
        self.skipped += 1

    def heard(self, now: float, temperature: float, hardware: tuple[str, ...]) -> None:
        self.last_heard = now
        self.temperature = temperature
        self.hardware = hardware

    def silent_for(self, now: float, since: float) -> float:
        """Seconds since the motor last answered (since ``since`` if it never has)."""
        return now - (self.last_heard if self.last_heard is not None else since)

    def as_dict(self) -> dict[str, object]:
        return {"errors": dict(self.errors), "skipped": self.skipped, "retried": self.retried,
                "hardware_errors": list(self.hardware), "temperature": self.temperature}
