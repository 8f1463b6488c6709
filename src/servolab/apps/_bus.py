"""What ``servolab read`` and ``servolab write`` share: the bus of the one motor they address.

A helper (its name starts with ``_``), so the registry does not import it for
``servolab --help`` and it may import the Dynamixel layer at the top.
"""

from __future__ import annotations

from ..dynamixel.bus import Bus


def open_bus(device: str, protocol: int | None, baudrate: int, model: str | None,
             motor_id: int) -> Bus:
    """The bus on ``device``; ``model`` declares the motor's model, which skips the PING that
    would learn it. ``protocol`` None lets the port decide (an emulated bus speaks its
    models' protocol, a serial port 2.0)."""
    bus = Bus.open(device, protocol=protocol, baudrate=baudrate)
    if model is not None:
        bus.declare(motor_id, model)
    return bus
