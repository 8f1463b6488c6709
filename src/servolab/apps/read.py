"""``servolab read``: registers of one motor, in SI units and raw.

:func:`read` takes plain values (already parsed), prints for a person and returns what it
read, so tests and other code can call it without a shell. The Dynamixel layer is imported
inside the functions, so that ``servolab --help`` does not load it.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import TextIO

from .arguments import add_bus, add_motor
from .registry import Command


def read(device: str, motor_id: int, names: Sequence[str], *, protocol: int | None = None,
         baudrate: int, raw: bool = False, model: str | None = None,
         stdout: TextIO = sys.stdout) -> dict[str, float | int]:
    """Read registers of one motor and print each in SI units (and raw).

    ``protocol`` None: the port's (see :func:`servolab.apps._bus.open_bus`)."""
    from ..dynamixel import units
    from ._bus import hint_protocol, open_bus

    with open_bus(device, protocol, baudrate, model, motor_id) as bus, hint_protocol(bus):
        m = bus.model_of(motor_id)
        for name in names:
            m.register(name)  # unknown names fail before anything is sent
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


def _fmt(value: float) -> str:
    return f"{value:.6g}" if isinstance(value, float) else str(value)


def _add_arguments(p: argparse.ArgumentParser) -> None:
    add_bus(p)
    add_motor(p)
    p.add_argument("--raw", action="store_true", help="print raw register values only")
    p.add_argument("registers", nargs="+", metavar="REGISTER",
                   help="register names from the motor's control table, e.g. "
                   "present_position")


def _run(args: argparse.Namespace) -> int:
    read(args.port, args.motor_id, args.registers, protocol=args.protocol,
         baudrate=args.baud, raw=args.raw, model=args.model)
    return 0


COMMAND = Command(
    name="read", group="bus", help="read registers of one motor (SI units)",
    description="Read registers of one motor and print each in SI units (rad, rad/s, V, "
    "degC, ...) and as the raw register value.",
    examples=("servolab read --port /dev/ttyUSB0 --id 1 present_position present_voltage",
              "servolab read --port emu://rx28:11-16 --id 12 present_position --raw"),
    add_arguments=_add_arguments, run=_run)
