"""What a bus knows of each motor beyond its model: learnt from what it sent and what came back.

One object, because these records move and go together: a motor that changes its ID takes
them all to the new one (:meth:`MotorMemory.rekey_after_id_change`), one that leaves the bus
as it speaks (another baud rate) or is reset loses them (:meth:`MotorMemory.forget`). The
models themselves are the bus's public ``motors`` dict (which a user may replace), given to
the calls that move or drop a motor.
"""

from __future__ import annotations

from typing import Any

from ..models import Model


class MotorMemory:
    """Per motor ID: status return level, hardware-error alerts, mode and limits, the
    REG_WRITE waiting for ACTION, return delay, torque."""

    __slots__ = ("alerts", "angle_limits", "answered", "goal_facts", "levels", "registered",
                 "return_delays", "torque")

    def __init__(self) -> None:
        #: status return levels the bus knows other than the factory 2 (or told: see
        #: :attr:`.Bus.status_return_level`, which is this dict)
        self.levels: dict[int, int] = {}
        #: motors whose last status reported a hardware error: ID -> its error bits
        self.alerts: dict[int, int] = {}
        #: (1.0) each motor's raw CW and CCW angle limits as last written or read: its mode
        self.angle_limits: dict[int, tuple[int, int]] = {}
        #: each motor's REG_WRITE waiting for ACTION: (start address, block)
        self.registered: dict[int, tuple[int, bytes]] = {}
        #: (2.0) each motor's mode and limits (GOAL_FACTS_2), raw, as read or written
        self.goal_facts: dict[int, dict[str, int]] = {}
        #: each motor's Return Delay Time (s) as read (:meth:`.Bus.contact`)
        self.return_delays: dict[int, float] = {}
        #: each motor's torque_enable as this bus last wrote or read it, until a goal (which
        #: may switch it on) is written
        self.torque: dict[int, int] = {}
        #: motors seen to answer a WRITE (status return level 2, though not in ``levels``)
        self.answered: set[int] = set()

    def _records(self, models: dict[int, Model]) -> list[dict[int, Any]]:
        return [models, self.levels, self.alerts, self.angle_limits, self.registered,
                self.goal_facts, self.return_delays, self.torque]

    def known_ids(self, models: dict[int, Model]) -> set[int]:
        """Every ID the bus has a record of (``models``: the bus's): the motors a broadcast
        reaches, as far as it knows them."""
        return {*models, *self.levels, *self.alerts, *self.angle_limits,
                *self.registered}

    def rekey_after_id_change(self, old: int, new: int, models: dict[int, Model]) -> None:
        """What the bus knows of the motor at ``old`` (its model in ``models``), now at
        ``new`` (and nothing of whatever was at ``new`` before)."""
        for record in self._records(models):
            if old in record:
                record[new] = record.pop(old)
            else:
                record.pop(new, None)
        if old in self.answered:
            self.answered.discard(old)
            self.answered.add(new)
        else:
            self.answered.discard(new)

    def forget(self, motor_id: int, models: dict[int, Model]) -> None:
        """Everything the bus knows of ``motor_id`` (no longer on this bus as it speaks),
        its model in ``models`` too."""
        for record in self._records(models):
            record.pop(motor_id, None)
        self.answered.discard(motor_id)

    def forget_settings(self, motor_id: int) -> None:
        """What a factory reset puts back to the factory's: level, mode and limits, return
        delay, torque, a waiting REG_WRITE (the model and alerts stay)."""
        for record in (self.levels, self.registered, self.angle_limits, self.goal_facts,
                       self.return_delays, self.torque):
            record.pop(motor_id, None)
        self.answered.discard(motor_id)
