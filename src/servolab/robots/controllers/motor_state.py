"""One motor's state as the controller manager reads it: one READ of the registers from
``goal_position`` to ``moving`` (RX-28: addresses 30..46, the 17 bytes ``dynamixel_io``'s
``get_feedback`` reads), never one packet per register, kept both in SI (for the joint
controllers) and as ``dynamixel_msgs/MotorState`` has it (raw position units, 0.111 rpm
speed units: the message's own, 001 Figure 3.2). The goal is the one the motor holds, read
back, so a goal that never reached the motor shows as one."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ...dynamixel.bus import Bus

#: The state registers, contiguous on the RX-28 and the other Protocol 1.0 models: one READ.
STATE_REGISTERS = ["goal_position", "moving_speed", "torque_limit", "present_position",
                   "present_speed", "present_load", "present_voltage", "present_temperature",
                   "moving"]


@dataclass(frozen=True)
class MotorReading:
    """What one READ said of one motor, at ``timestamp`` (s, the clock of the read)."""

    id: int
    timestamp: float
    goal: int               # raw goal position, as the motor holds it
    position: int           # raw present position
    position_si: float      # rad
    speed_si: float         # rad/s, signed
    speed_units: int        # signed, in the model's speed unit (0.111 rpm on the RX-28)
    load: float             # fraction of the maximum torque, signed
    voltage: float          # V
    temperature: float      # deg C
    moving: bool
    torque_limit: float = 1.0   # fraction of the maximum torque (0 after a shutdown)

    @classmethod
    def read(cls, bus: Bus, motor_id: int, timestamp: float, *,
             retries: int | None = None) -> MotorReading:
        raw = bus.read(motor_id, STATE_REGISTERS, raw=True, retries=retries)
        si = {name: float(bus.to_si(motor_id, name, int(value))) for name, value in raw.items()}
        unit = float(bus.to_si(motor_id, "present_speed", 1))
        return cls(motor_id, timestamp, int(raw["goal_position"]), int(raw["present_position"]),
                   si["present_position"], si["present_speed"],
                   round(si["present_speed"] / unit), si["present_load"],
                   si["present_voltage"], si["present_temperature"], bool(raw["moving"]),
                   si["torque_limit"])

    def as_message(self) -> dict[str, object]:
        """The fields of ``dynamixel_msgs/msg/MotorState``."""
        return {"timestamp": self.timestamp, "id": self.id, "goal": self.goal,
                "position": self.position, "error": self.position - self.goal,
                "speed": self.speed_units, "load": self.load, "voltage": self.voltage,
                "temperature": round(self.temperature), "moving": self.moving}
