"""``servolab write``: one register of one motor, in SI units or raw.

:func:`write` takes plain values (already parsed), prints for a person and returns the raw
value written, so tests and other code can call it without a shell. The Dynamixel layer is
imported inside the functions, so that ``servolab --help`` does not load it.
"""

from __future__ import annotations

import argparse
import sys
from typing import TextIO

from .arguments import add_bus, add_motor
from .registry import Command


def write(device: str, motor_id: int, name: str, value: str, *, protocol: int | None = None,
          baudrate: int, raw: bool = False, model: str | None = None,
          stdout: TextIO = sys.stdout) -> int:
    """Write one register of one motor (SI units unless ``raw``); returns the raw value.

    ``protocol`` None: the port's (see :func:`servolab.apps._bus.open_bus`)."""
    from ..dynamixel.errors import ConfigError
    from ._bus import hint_protocol, open_bus

    number = parse_value(value, name)
    with open_bus(device, protocol, baudrate, model, motor_id) as bus, hint_protocol(bus):
        m = bus.model_of(motor_id)
        reg = m.register(name)
        if not reg.writable:
            raise ConfigError(f"{m.name} {name} is read-only")
        if raw and not number.is_integer():
            raise ConfigError(f"{m.name} {name}: raw value {value!r} is not an integer")
        raw_value = int(number) if raw else bus.from_si(motor_id, name, number)
        if raw:
            reg.check(raw_value, m)
        bus.write(motor_id, name, raw_value, raw=True)
        print(f"motor {motor_id} ({m.name}): {name} <- {value} (raw {raw_value})", file=stdout)
        return raw_value


def parse_value(text: str, name: str) -> float:
    """A number, or on/off/true/false for the switches (torque_enable, led)."""
    from ..dynamixel.errors import ConfigError

    words = {"on": 1.0, "off": 0.0, "true": 1.0, "false": 0.0}
    if text.lower() in words:
        return words[text.lower()]
    try:
        return float(text)
    except ValueError:
        raise ConfigError(f"{name}: value {text!r} is not a number") from None


def _add_arguments(p: argparse.ArgumentParser) -> None:
    add_bus(p)
    add_motor(p)
    p.add_argument("--raw", action="store_true", help="VALUE is a raw register value")
    p.add_argument("register", metavar="REGISTER",
                   help="a writable register of the motor's control table, e.g. goal_position")
    p.add_argument("value", metavar="VALUE",
                   help="in SI units (rad, rad/s, ...), or on/off; raw with --raw")


def _run(args: argparse.Namespace) -> int:
    write(args.port, args.motor_id, args.register, args.value, protocol=args.protocol,
          baudrate=args.baud, raw=args.raw, model=args.model)
    return 0


COMMAND = Command(
    name="write", group="bus", help="write one register of one motor (SI units)",
    description="Write one register of one motor. The value is checked against the motor's "
    "control table before anything is sent.",
    examples=("servolab write --port /dev/ttyUSB0 --id 1 torque_enable on",
              "servolab write --port /dev/ttyUSB0 --id 1 goal_position 0.5"),
    add_arguments=_add_arguments, run=_run)
