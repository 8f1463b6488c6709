"""What ``servolab read`` and ``servolab write`` share: the bus of the one motor they address.

A helper (its name starts with ``_``), so the registry does not import it for
``servolab --help`` and it may import the Dynamixel layer at the top.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from ..dynamixel.bus import Bus
from ..dynamixel.errors import NoResponse


def open_bus(device: str, protocol: int | None, baudrate: int, model: str | None,
             motor_id: int) -> Bus:
    """The bus on ``device``; ``model`` declares the motor's model, which skips the PING that
    would learn it. ``protocol`` None lets the port decide (an emulated bus speaks its
    models' protocol, a serial port 2.0)."""
    bus = Bus.open(device, protocol=protocol, baudrate=baudrate)
    if model is not None:
        bus.declare(motor_id, model)
    return bus


@contextmanager
def hint_protocol(bus: Bus) -> Iterator[Bus]:
    """A motor that stays silent may simply speak the other protocol (an RX-28 on a bus
    opened for 2.0, the default of a serial port): say so in the one-line error."""
    try:
        yield bus
    except NoResponse as exc:
        other = 1 if bus.proto.version == 2 else 2
        raise NoResponse(f"{exc}; if it speaks protocol {other}.0, add --protocol {other}",
                         motor_id=exc.motor_id, instruction=exc.instruction) from None
