"""One motor's state as the controller manager reads it, on any model: the registers that play
the state's roles (:data:`~servolab.dynamixel.models.ROLES`) in the fewest READs, kept both in
SI (for the joint controllers) and as ``dynamixel_msgs/MotorState`` has it.

On the RX-28 and the other Protocol 1.0 models the roles are the 17 bytes from Goal Position(30)
to Moving(46) that ``dynamixel_io``'s ``get_feedback`` reads: one READ. On the X-series they are
Goal PWM(100) to Present Temperature(146), the present_* block 126..146 contiguous: one READ of
47 bytes, cheaper than two (each READ costs an instruction and a status header). The goal is
the one the motor holds, read back, so a goal that never reached the motor shows as one.

``MotorState`` stays what ``dynamixel_driver`` publishes: raw goal, position and error;
``speed`` in the model's own speed unit, signed (0.111 rpm on the RX-28, 0.229 rpm a unit of
Present Velocity(128) on the XM430, e-Manual); ``load`` a signed ratio of the maximum. Where the
model reports Present Current instead of Present Load (XM430, MX-64(2.0), ...) ``load`` is that
current over the most the firmware can be allowed, the top of Current Limit(38)'s range
(XM430-W350: 1,193 x 2.69 mA = 3.21 A, e-Manual xm430-w350.md): 1.0 means the motor's
ceiling as Present Load's 100 % does, and it is the scale :meth:`~.joint_position_controller.
JointPositionController.set_torque_limit`'s fractions are given in.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from ...dynamixel import units

if TYPE_CHECKING:
    from ...dynamixel.bus import Bus
    from ...dynamixel.models import Model

#: The roles of a motor's state, in the order the RX-28 lays out their registers.
STATE_ROLES = ("goal_position", "moving_speed", "torque_limit", "present_position",
               "present_speed", "present_load", "present_voltage", "present_temperature",
               "moving")
#: The state registers of the RX-28 and the other Protocol 1.0 models (their names are the
#: roles'), contiguous: one READ.
STATE_REGISTERS = list(STATE_ROLES)


@dataclass(frozen=True)
class StatePlan:
    """How one model's state is read: the register of each role, and the READs (each a list
    of register names, read as one contiguous block)."""

    model: Model
    registers: dict[str, str]           # role -> register name
    reads: tuple[tuple[str, ...], ...]
    full_current: float = 0.0           # A: the ratio's denominator where load is a current
    speed_unit: float = 0.0             # rad/s of one unit of the present speed role

    @classmethod
    def of(cls, model: Model, overhead: int) -> StatePlan:
        """The plan for ``model``; ``overhead`` is what one more READ costs in bytes on the
        wire (its instruction and its status header): a gap narrower than that is read
        through rather than split."""
        chosen = {role: model.role(role) for role in STATE_ROLES}
        ordered = sorted(chosen.values(), key=lambda r: r.address)
        groups: list[list[str]] = [[ordered[0].name]]
        end = ordered[0].address + ordered[0].size
        for register in ordered[1:]:
            if register.address - end > overhead:
                groups.append([])
            groups[-1].append(register.name)
            end = max(end, register.address + register.size)
        full = 0.0
        if chosen["present_load"].unit == "current":
            full = model.role("current_limit").raw_max * model.current_unit_a
        speed = chosen["present_speed"]
        return cls(model, {role: r.name for role, r in chosen.items()},
                   tuple(tuple(g) for g in groups), full,
                   float(units.to_si(model, speed, 1)))

    @classmethod
    def for_motor(cls, bus: Bus, motor_id: int) -> StatePlan:
        proto = bus.proto
        overhead = len(proto.encode_instruction(proto.read(motor_id, 0, 1))) \
            + proto.status_size(0)
        return cls.of(bus.model_of(motor_id), overhead)

    def spans(self) -> list[tuple[int, int]]:
        """(start address, length) of each READ."""
        return [self.model.span(list(names)) for names in self.reads]

    def load_ratio(self, si: float) -> float:
        """The present load role's SI value as ``MotorState.load``: a signed ratio of the
        maximum (see the module docstring)."""
        return si / self.full_current if self.full_current else si


@dataclass(frozen=True)
class MotorReading:
    """What one sweep read of one motor, at ``timestamp`` (s, the clock of the read)."""

    id: int
    timestamp: float
    goal: int               # raw goal position, as the motor holds it
    position: int           # raw present position
    position_si: float      # rad
    speed_si: float         # rad/s, signed
    speed_units: int        # signed, in the model's speed unit (0.111 rpm on the RX-28)
    load: float             # ratio of the maximum, signed (see the module docstring)
    voltage: float          # V
    temperature: float      # deg C
    moving: bool
    torque_limit: float = 1.0   # fraction of the maximum output (0 after a shutdown)

    @classmethod
    def read(cls, bus: Bus, motor_id: int, timestamp: float, *,
             retries: int | None = None, plan: StatePlan | None = None) -> MotorReading:
        plan = plan if plan is not None else StatePlan.for_motor(bus, motor_id)
        values = {}
        for names in plan.reads:
            values.update(bus.read(motor_id, names, raw=True, retries=retries))
        registers = plan.registers

        def raw(role: str) -> int:
            return int(values[registers[role]])

        def si(role: str) -> float:
            return float(bus.to_si(motor_id, registers[role], raw(role)))

        speed = si("present_speed")
        return cls(motor_id, timestamp, raw("goal_position"), raw("present_position"),
                   si("present_position"), speed, round(speed / plan.speed_unit),
                   plan.load_ratio(si("present_load")), si("present_voltage"),
                   si("present_temperature"), bool(raw("moving")), si("torque_limit"))

    def as_message(self) -> dict[str, object]:
        """The fields of ``dynamixel_msgs/msg/MotorState``."""
        return {"timestamp": self.timestamp, "id": self.id, "goal": self.goal,
                "position": self.position, "error": self.position - self.goal,
                "speed": self.speed_units, "load": self.load, "voltage": self.voltage,
                "temperature": round(self.temperature), "moving": self.moving}
