"""What the bus commands (read, write, id, baud) share: the bus of the one motor they address,
and the two commissioning steps, said the same way whichever command asked for them.

A helper (its name starts with ``_``), so the registry does not import it for
``servolab --help`` and it may import the Dynamixel layer at the top.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import TextIO

from ..dynamixel.bus import Bus, PingResult
from ..dynamixel.errors import ConfigError, NoResponse


def open_bus(device: str, protocol: int | None, baudrate: int, model: str | None,
             motor_id: int) -> Bus:
    """The bus on ``device``; ``model`` declares the motor's model, which skips the PING that
    would learn it. ``protocol`` None lets the port decide (an emulated bus speaks its
    models' protocol, a serial port 2.0)."""
    bus = Bus.open(device, protocol=protocol, baudrate=baudrate)
    if model is not None:
        try:
            bus.declare(motor_id, model)
        except BaseException:
            bus.close()
            raise
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


def change_id(bus: Bus, motor_id: int, new_id: int, stdout: TextIO | None) -> PingResult:
    """Give motor ``motor_id`` the ID ``new_id`` (refused, nothing written, if that ID
    answers already) and say where it answers now."""
    found = bus.change_id(motor_id, new_id)
    if new_id == motor_id:
        print(f"motor {motor_id} ({found.model_name}) is ID {motor_id} already; nothing was "
              "written", file=stdout)
    else:
        print(f"motor {motor_id} ({found.model_name}) is now ID {new_id}: it answers there at "
              f"{bus.baudrate} bps", file=stdout)
    return found


def change_baud(bus: Bus, motor_id: int, rate: int, stdout: TextIO | None, *,
                value: int | None = None) -> PingResult:
    """Set motor ``motor_id`` to ``rate`` bps (or, when ``value`` is given, to that raw
    baud_rate register value), follow it there and say so."""
    m = bus.model_of(motor_id)
    if value is None:
        found = bus.change_baud(motor_id, rate)   # (a rate the model cannot use: refused)
        value = m.baud_register_for(rate)
    else:
        bus.write(motor_id, "baud_rate", value, raw=True)
        found = bus.ping(motor_id)
    exact = m.baud_from_register(value)
    print(f"motor {motor_id} ({found.model_name}) now talks at {exact} bps (baud_rate "
          f"{value}): it answers there, the bus at {bus.baudrate} bps; use --baud "
          f"{bus.baudrate} from now on", file=stdout)
    return found


def parse_int(text: str, what: str) -> int:
    """An integer as a person writes one: ``2048``, ``-1``, ``0x800``."""
    try:
        return int(text, 0)
    except ValueError:
        raise ConfigError(f"{what} {text!r} is not an integer (write 2048, -1 or 0x800)"
                          ) from None
