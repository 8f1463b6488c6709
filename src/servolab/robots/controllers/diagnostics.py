"""``/diagnostics`` (``diagnostic_msgs/msg/DiagnosticArray``) as ROS ``dynamixel_serial_proxy``
publishes it: one status for the bus, one per motor.

The bus's status carries its baud rate, ID range, desired and actual update rates and error
counts, WARN when the actual rate is more than 5 Hz below the desired one; each motor's its
model, goal, position, error, speed, load, voltage and temperature, and a level from its
temperature: ERROR "OVERHEATING" from ``error_level_temp``, WARN "VERY HOT" from
``warn_level_temp``, else OK (``__publish_diagnostic_information``, the same keys and
messages). servolab adds, per motor, the errors its reads met and two ERRORs the original
leaves to the log: a hardware error its status reports (``overload``, ...) and a motor that
has not answered for longer than ``silent_timeout``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

from .motor_health import CHECKSUM, DROPPED, NON_FATAL, MotorHealth

if TYPE_CHECKING:
    from .config import SerialPortConfig
    from .motor_state import MotorReading

DIAGNOSTIC_ARRAY = "diagnostic_msgs/msg/DiagnosticArray"
#: DiagnosticStatus levels (diagnostic_msgs/msg/DiagnosticStatus)
OK, WARN, ERROR = 0, 1, 2


def motor_level(port: SerialPortConfig, health: MotorHealth, silent: float
                ) -> tuple[int, str]:
    """A motor's level and message (see the module docstring); ``silent`` is the seconds
    since it last answered."""
    if silent > port.silent_timeout:
        return ERROR, f"NOT RESPONDING for {silent:.1f} s"
    if health.hardware:
        return ERROR, ", ".join(h.upper() for h in health.hardware)
    temperature = health.temperature
    if temperature is not None and temperature >= port.error_level_temp:
        return ERROR, "OVERHEATING"
    if temperature is not None and temperature >= port.warn_level_temp:
        return WARN, "VERY HOT"
    return OK, "OK"


def _values(pairs: Sequence[tuple[str, object]]) -> list[dict[str, str]]:
    return [{"key": k, "value": str(v)} for k, v in pairs]


def diagnostics(port: SerialPortConfig, *, baud_rate: int, actual_rate: float,
                models: Mapping[int, str], health: Mapping[int, MotorHealth],
                readings: Mapping[int, MotorReading], now: float, since: float,
                stamp_ns: int) -> dict[str, object]:
    """The fields of one DiagnosticArray (``since``: when the manager started, for a motor
    never heard)."""
    totals = {kind: sum(h.errors[kind] for h in health.values())
              for kind in (NON_FATAL, CHECKSUM, DROPPED)}
    slow = actual_rate - port.update_rate < -5
    statuses: list[dict[str, object]] = [{
        "level": WARN if slow else OK,
        "name": f"Dynamixel Serial Bus ({port.name})",
        "message": "Actual update rate is lower than desired" if slow else "OK",
        "hardware_id": f"Dynamixel Serial Bus on port {port.port_name}",
        "values": _values([("Baud Rate", baud_rate), ("Min Motor ID", port.min_motor_id),
                           ("Max Motor ID", port.max_motor_id),
                           ("Desired Update Rate", port.update_rate),
                           ("Actual Update Rate", round(actual_rate, 2)),
                           ("# Non Fatal Errors", totals[NON_FATAL]),
                           ("# Checksum Errors", totals[CHECKSUM]),
                           ("# Dropped Packet Errors", totals[DROPPED])])}]
    for motor_id, record in health.items():
        level, message = motor_level(port, record, record.silent_for(now, since))
        pairs: list[tuple[str, object]] = [("Model Name", models.get(motor_id, "?"))]
        reading = readings.get(motor_id)
        if reading is not None:
            state = reading.as_message()
            pairs += [("Goal", state["goal"]), ("Position", state["position"]),
                      ("Error", state["error"]), ("Velocity", state["speed"]),
                      ("Load", state["load"]), ("Voltage", state["voltage"]),
                      ("Temperature", state["temperature"]), ("Moving", state["moving"])]
        pairs += [("# Retries", record.retried),
                  ("# Non Fatal Errors", record.errors[NON_FATAL]),
                  ("# Checksum Errors", record.errors[CHECKSUM]),
                  ("# Dropped Packet Errors", record.errors[DROPPED])]
        statuses.append({"level": level,
                         "name": f"Robotis Dynamixel Motor {motor_id} on port {port.name}",
                         "message": message, "hardware_id": f"DXL-{motor_id}@{port.name}",
                         "values": _values(pairs)})
    return {"header": {"stamp": {"sec": stamp_ns // 1_000_000_000,
                                 "nanosec": stamp_ns % 1_000_000_000}},
            "status": statuses}
