"""The biped's safety supervisor: what ends a walk, and how.

After every state sweep of the :class:`~servolab.robots.controllers.manager.DynamixelManager`
it looks at each running joint's motor (:attr:`DynamixelManager.health`) and raises an
:class:`Alarm`, once per motor and cause, for

- ``silent``: no answer for longer than the port's ``silent_timeout`` (0.5 s by default;
  single failed reads are counted and survived, as ``dynamixel_serial_proxy`` counts them);
- ``overload``: the motor's status reports the overload error (e-Manual: "the current load
  cannot be controlled with the set maximum torque"; the RX-28's alarm_shutdown switches its
  torque off);
- ``overheating``: the status reports it, or the temperature read is at or above
  ``error_level_temp`` (75 deg C by default, ``dynamixel_serial_proxy``'s "OVERHEATING").
  From ``warn_level_temp`` it only warns, once;
- ``controller stopped``: a joint controller that ran when the supervisor started no longer
  does (``stop_controller`` called mid-walk: its joint would take no more commands).

It watches the motors of the controllers running at each sweep (one started later is
watched from then on).

An alarm stops the gait at the next row, and the walk then *finishes to double support*:
from the pose last sent, the joints go to the stand pose of Table 4.2 (both feet down) over
:data:`FINISH_DURATION` s — the same for Ctrl-C or SIGTERM. Moving is chosen over holding
because a biped left in a one-foot pose falls when anything gives; a joint whose motor is
silent or shut down simply does not follow, and the others still bring both feet down. The
one case that holds instead is a bus that is gone (the port failed): nothing can be sent, and
the motors keep the last goals they received.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from .series import Series

if TYPE_CHECKING:
    from collections.abc import Iterable

    from ..controllers.manager import DynamixelManager

#: Seconds the move to double support takes after an alarm or a stop signal.
FINISH_DURATION = 1.0


@dataclass(frozen=True)
class Alarm:
    """One alarm: when (seconds since the supervisor started, the robot's clock), which
    motor, the cause (``silent``, ``overload``, ``overheating``) and what was seen."""

    time: float
    motor: int
    cause: str
    detail: str

    def as_dict(self) -> dict[str, object]:
        return {"time_s": round(self.time, 4), "motor": self.motor, "cause": self.cause,
                "detail": self.detail}

    def __str__(self) -> str:
        return f"t={self.time:.2f} s motor {self.motor}: {self.cause} ({self.detail})"


class SafetySupervisor:
    """Watches ``motors`` (IDs) of ``manager``; see the module docstring."""

    def __init__(self, manager: DynamixelManager, motors: Iterable[int] = ()) -> None:
        self.manager = manager
        #: the controllers that must keep running, by name -> motor ID
        self.required = {name: c.motor_id for name, c in manager.controllers.items()}
        self.motors = sorted(set(motors) | set(self.required.values()))
        self.port = manager.port
        self.started = manager.context.clock.now()
        self.alarms: list[Alarm] = []
        #: per watched motor, after every sweep: (s since start; deg C, load (None: NaN) and
        #: s since it last answered) — what the run's alarm plot shows, in a bounded series
        self.history: dict[int, Series] = {}
        self._raised: set[tuple[int, str]] = set()
        self._warned: set[int] = set()
        self._log = manager.get_logger()
        manager.sweep_listeners.append(self.check)

    @property
    def tripped(self) -> bool:
        """True once any alarm was raised: the walk must end."""
        return bool(self.alarms)

    def check(self, now: float) -> list[Alarm]:
        """Look at every watched motor after a sweep; returns the alarms raised now."""
        port = self.port
        new: list[Alarm] = []
        running = self.manager.controllers
        for name, motor_id in self.required.items():
            if name not in running:
                new += self._raise(now, motor_id, "controller stopped",
                                   f"{name} no longer runs: its joint takes no commands")
        self.motors = sorted(set(self.motors) | {c.motor_id for c in running.values()})
        for motor_id in self.motors:
            health = self.manager.health.get(motor_id)
            if health is None:
                continue
            silent = health.silent_for(now, self.manager.started)
            reading = self.manager.latest.get(motor_id)
            series = self.history.get(motor_id)
            if series is None:
                series = self.history[motor_id] = Series(3)
            series.append(now - self.started, health.temperature,
                          None if reading is None else reading.load, silent)
            if silent > port.silent_timeout:
                new += self._raise(now, motor_id, "silent",
                                   f"no answer for {silent:.2f} s (silent_timeout "
                                   f"{port.silent_timeout:g} s)")
            if "overload" in health.hardware:
                new += self._raise(now, motor_id, "overload", "its status reports overload")
            temperature = health.temperature
            if "overheating" in health.hardware:
                new += self._raise(now, motor_id, "overheating",
                                   "its status reports overheating"
                                   + (f" at {temperature:g} deg C" if temperature else ""))
            elif temperature is not None and temperature >= port.error_level_temp:
                new += self._raise(now, motor_id, "overheating",
                                   f"{temperature:g} deg C >= error_level_temp "
                                   f"{port.error_level_temp:g}")
            elif (temperature is not None and temperature >= port.warn_level_temp
                  and motor_id not in self._warned):
                self._warned.add(motor_id)
                self._log.warning(f"motor {motor_id}: {temperature:g} deg C >= "
                                  f"warn_level_temp {port.warn_level_temp:g} (VERY HOT)")
        return new

    def _raise(self, now: float, motor_id: int, cause: str, detail: str) -> list[Alarm]:
        if (motor_id, cause) in self._raised:
            return []
        self._raised.add((motor_id, cause))
        alarm = Alarm(now - self.started, motor_id, cause, detail)
        self.alarms.append(alarm)
        self._log.error(f"ALARM {alarm}: ending the walk in double support")
        return [alarm]

    def reset(self) -> None:
        """Forget the alarms (once their cause is dealt with), so that the robot may move
        again; a cause still there raises its alarm again at the next sweep."""
        self.alarms.clear()
        self._raised.clear()
        self.required = {name: c.motor_id for name, c in self.manager.controllers.items()}

    def close(self) -> None:
        if self.check in self.manager.sweep_listeners:
            self.manager.sweep_listeners.remove(self.check)
