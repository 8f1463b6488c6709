"""``servolab read``: registers of one motor, in SI units and raw, or raw bytes by address.

:func:`read` takes plain values (already parsed), prints for a person and returns what it
read, so tests and other code can call it without a shell. The Dynamixel layer is imported
inside the functions, so that ``servolab --help`` does not load it.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import TYPE_CHECKING, TextIO

from .arguments import add_bus, add_motor
from .registry import Command

if TYPE_CHECKING:
    from ..dynamixel.models import Model


def read(device: str, motor_id: int, names: Sequence[str], *, protocol: int | None = None,
         baudrate: int, raw: bool = False, model: str | None = None,
         address: int | None = None, size: int | None = None,
         stdout: TextIO | None = None) -> dict[str, float | int]:
    """Read registers of one motor and print each in SI units (and raw); or, with
    ``address``, ``size`` raw bytes from that address (returned as ``{"@ADDRESS": value}``,
    the bytes read as one little-endian unsigned integer).

    ``protocol`` None: the port's (see :func:`servolab.apps._bus.open_bus`)."""
    from ..dynamixel import units
    from ..dynamixel.bus import register_of
    from ..dynamixel.errors import ConfigError
    from ._bus import hint_protocol, open_bus

    if address is not None and names:
        raise ConfigError("read by --address or by register names, not both")
    if address is None and size is not None:
        raise ConfigError("--size goes with --address")
    if address is None and not names:
        raise ConfigError("name a register to read (e.g. present_position), or give "
                          "--address A --size N")
    with open_bus(device, protocol, baudrate, model, motor_id) as bus, hint_protocol(bus):
        if address is not None:
            m = bus.known_model(motor_id)
            size = _size(m, address, size)
            data = bus.read_address(motor_id, address, size)
            value = int.from_bytes(data, "little")
            signed = int.from_bytes(data, "little", signed=True)
            print(f"address {address}, {size} byte{'s' if size > 1 else ''}: "
                  f"{data.hex(' ')} = {value}{f' (signed {signed})' if signed != value else ''}"
                  f"{_covers(m, address, size)}", file=stdout)
            return {f"@{address}": value}
        m = bus.model_of(motor_id)
        for name in names:
            register_of(m, name)  # unknown names fail before anything is sent
        values = bus.read(motor_id, list(names), raw=True)
        out: dict[str, float | int] = {}
        for name in names:
            reg = m.register(name)
            if raw:
                out[name] = values[name]
                print(f"{name} = {values[name]}", file=stdout)
                continue
            si = bus.to_si(motor_id, name, int(values[name]))  # by the motor's mode
            out[name] = si
            unit = units.KINDS.get(reg.unit, "")
            print(f"{name} = {_fmt(si)}{' ' + unit if unit else ''} (raw {values[name]})",
                  file=stdout)
        return out


def _size(m: Model | None, address: int, size: int | None) -> int:
    """``size``, or the size of the register that starts at ``address``."""
    from ..dynamixel.errors import ConfigError

    if size is not None:
        return size
    reg = m.register_at(address) if m is not None else None
    if reg is None:
        why = (f"no register of {m.name} starts there" if m is not None else
               "servolab has no table for this motor's model")
        raise ConfigError(f"--size N is needed at address {address}: {why}")
    return reg.size


def _covers(m: Model | None, address: int, size: int) -> str:
    """``; goal_position`` and the like: the registers of ``m`` those bytes hold."""
    if m is None:
        return ""
    end = address + size
    names = [r.name if address <= r.address and r.address + r.size <= end else
             f"part of {r.name}" for r in m.registers
             if address < r.address + r.size and r.address < end]
    return f" ({', '.join(names)})" if names else " (no register of its table)"


def _fmt(value: float) -> str:
    return f"{value:.6g}" if isinstance(value, float) else str(value)


def _add_arguments(p: argparse.ArgumentParser) -> None:
    add_bus(p)
    add_motor(p)
    p.add_argument("--raw", action="store_true", help="print raw register values only")
    p.add_argument("--address", type=int, metavar="A",
                   help="read raw bytes from this address instead of registers by name")
    p.add_argument("--size", type=int, metavar="N",
                   help="how many bytes to read at --address (default: the size of the "
                   "register there)")
    p.add_argument("registers", nargs="*", metavar="REGISTER",
                   help="register names from the motor's control table, e.g. "
                   "present_position")


def _run(args: argparse.Namespace) -> int:
    read(args.port, args.motor_id, args.registers, protocol=args.protocol,
         baudrate=args.baud, raw=args.raw, model=args.model, address=args.address,
         size=args.size)
    return 0


COMMAND = Command(
    name="read", group="bus", help="read registers of one motor (SI units), or raw bytes",
    description="Read registers of one motor and print each in SI units (rad, rad/s, V, "
    "degC, ...) and as the raw register value; or, with --address A --size N, N raw bytes "
    "from address A (little-endian), for registers servolab has no name for.",
    examples=("servolab read --port /dev/ttyUSB0 --id 1 present_position present_voltage",
              "servolab read --port emu://rx28:11-16 --id 12 present_position --raw",
              "servolab read --port /dev/ttyUSB0 --id 1 --address 132 --size 4"),
    add_arguments=_add_arguments, run=_run)
