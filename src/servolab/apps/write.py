"""``servolab write``: one register of one motor, in SI units or raw, or raw bytes by address.

:func:`write` takes plain values (already parsed), prints for a person and returns the raw
value written, so tests and other code can call it without a shell. The Dynamixel layer is
imported inside the functions, so that ``servolab --help`` does not load it.

``id`` and ``baud_rate`` are written as ``servolab id`` and ``servolab baud`` write them: an ID
already answering is refused, and the motor is pinged at its new ID or rate.

``--broadcast`` (instead of ``--id``) writes every motor at once, to the broadcast ID 254, which
no motor answers: the value is checked first against the table of every motor a scan finds at
the port's rate and protocol (or of ``--model``), see :meth:`.Bus.broadcast_write`.
"""

from __future__ import annotations

import argparse
from typing import TextIO

from .arguments import add_bus
from .registry import Command


def write(device: str, motor_id: int, name: str | None, value: str, *,
          protocol: int | None = None, baudrate: int, raw: bool = False,
          model: str | None = None, address: int | None = None, size: int | None = None,
          stdout: TextIO | None = None, broadcast: bool = False) -> int:
    """Write one register of one motor (SI units unless ``raw``); returns the raw value.
    With ``address`` (``name`` None), write ``value``, an integer, as ``size`` little-endian
    bytes at that address. ``broadcast``: every motor at once (``motor_id`` is not used;
    returns the number of motors the write was checked for).

    ``protocol`` None: the port's (see :func:`servolab.apps._bus.open_bus`)."""
    from ..dynamixel.bus import register_of
    from ..dynamixel.errors import ConfigError
    from ..dynamixel.packets import BROADCAST_ID
    from ._bus import change_baud, change_id, hint_protocol, open_bus

    if broadcast:
        if address is not None or size is not None:
            raise ConfigError("--broadcast writes a register by name; --address and --size "
                              "go to one motor")
        if name is None:
            raise ConfigError("name the register to write, e.g. torque_enable")
        return _write_broadcast(device, name, value, protocol=protocol, baudrate=baudrate,
                                raw=raw, model=model, stdout=stdout)
    if motor_id == BROADCAST_ID:
        raise ConfigError(f"motor ID {BROADCAST_ID} is the broadcast ID: to write every motor "
                          f"at once, give --broadcast instead of --id {BROADCAST_ID}")
    if address is not None:
        if name is not None:
            raise ConfigError("write by --address or by register name, not both")
        return _write_address(device, motor_id, address, size, value, protocol=protocol,
                              baudrate=baudrate, model=model, stdout=stdout)
    if size is not None:
        raise ConfigError("--size goes with --address")
    if name is None:
        raise ConfigError("name the register to write, e.g. goal_position")
    number = parse_value(value, name)
    with open_bus(device, protocol, baudrate, model, motor_id) as bus, hint_protocol(bus):
        m = bus.model_of(motor_id)
        reg = register_of(m, name)
        if not reg.writable:
            raise ConfigError(f"{m.name} {name} is read-only")
        if raw and not number.is_integer():
            raise ConfigError(f"{m.name} {name}: raw value {value!r} is not an integer")
        raw_value = int(number) if raw else bus.from_si(motor_id, name, number)
        if raw:
            reg.check(raw_value, m)
        if name == "id":
            change_id(bus, motor_id, raw_value, stdout)
            return raw_value
        if name == "baud_rate":
            if raw:
                change_baud(bus, motor_id, 0, stdout, value=raw_value)
            else:
                change_baud(bus, motor_id, int(number), stdout)
            return raw_value
        bus.write(motor_id, name, raw_value, raw=True)
        print(f"motor {motor_id} ({m.name}): {name} <- {value} (raw {raw_value})", file=stdout)
        return raw_value


def _write_address(device: str, motor_id: int, address: int, size: int | None, value: str,
                   *, protocol: int | None, baudrate: int, model: str | None,
                   stdout: TextIO | None) -> int:
    from ..dynamixel.errors import ConfigError
    from ._bus import hint_protocol, open_bus, parse_int
    from .read import _covers, _size

    number = parse_int(value, "VALUE")
    with open_bus(device, protocol, baudrate, model, motor_id) as bus, hint_protocol(bus):
        m = bus.known_model(motor_id)
        size = _size(m, address, size)
        try:
            data = number.to_bytes(size, "little", signed=number < 0)
        except OverflowError:
            raise ConfigError(f"VALUE {number} does not fit {size} byte(s): "
                              f"{-(1 << (8 * size - 1))}..{(1 << (8 * size)) - 1}") from None
        bus.write_address(motor_id, address, data)
        print(f"motor {motor_id}: address {address}, {size} byte{'s' if size > 1 else ''} <- "
              f"{data.hex(' ')} ({number}){_covers(m, address, size)}", file=stdout)
        return number


def _write_broadcast(device: str, name: str, value: str, *, protocol: int | None,
                     baudrate: int, raw: bool, model: str | None,
                     stdout: TextIO | None) -> int:
    """``servolab write --broadcast``: scan the port's rate and protocol (unless ``model``
    names the motors' model), then one WRITE to every motor, checked against each table."""
    from ..dynamixel.bus import Bus
    from ..dynamixel.errors import ConfigError

    number = parse_value(value, name)
    if raw and not number.is_integer():
        raise ConfigError(f"{name}: raw value {value!r} is not an integer")
    given = int(number) if raw else number
    with Bus.open(device, protocol=protocol, baudrate=baudrate) as bus:
        version = bus.proto.version
        if model is not None:
            bus.broadcast_write(name, given, raw=raw, models=[model])
            checked = f"checked against the {bus.proto.version}.0 model {model}'s table"
            count = 0
        else:
            found = [r for r in bus.scan() if r.model is not None]
            if not found:
                raise ConfigError(f"no motor servolab knows answers at {bus.baudrate} bps on "
                                  f"protocol {version}.0 ('servolab scan' looks at other "
                                  "rates and protocols); nothing was written")
            ids = bus.broadcast_write(name, given, raw=raw)
            names = sorted({bus.motors[i].name for i in ids})
            checked = (f"checked for the {len(ids)} motor(s) found, "
                       f"{', '.join(map(str, ids))} ({', '.join(names)})")
            count = len(ids)
        print(f"every motor (broadcast ID 254, protocol {version}.0, {bus.baudrate} bps): "
              f"{name} <- {value}{' (raw)' if raw else ''}; {checked}; no status is "
              "expected", file=stdout)
        return count


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
    target = p.add_mutually_exclusive_group(required=True)
    target.add_argument("--id", type=int, dest="motor_id", metavar="ID", help="the motor's ID")
    target.add_argument("--broadcast", action="store_true",
                        help="write every motor at once (broadcast ID 254, no status "
                        "answers it), checked first against the table of each motor a scan "
                        "of the port's rate and protocol finds")
    p.add_argument("--model", help="the motor's model, e.g. rx28; skips the PING that learns "
                   "it (with --broadcast: the model of every motor, which skips the scan)")
    p.add_argument("--raw", action="store_true", help="VALUE is a raw register value")
    p.add_argument("--address", type=int, metavar="A",
                   help="write raw bytes at this address instead of a register by name: "
                   "then give VALUE only, an integer (2048, -1, 0x800)")
    p.add_argument("--size", type=int, metavar="N",
                   help="how many bytes VALUE takes at --address, little-endian (default: "
                   "the size of the register there)")
    p.add_argument("register", nargs="?", metavar="REGISTER",
                   help="a writable register of the motor's control table, e.g. goal_position")
    p.add_argument("value", nargs="?", metavar="VALUE",
                   help="in SI units (rad, rad/s, ...), or on/off; raw with --raw")


def _run(args: argparse.Namespace) -> int:
    from ..dynamixel.errors import ConfigError
    from ..dynamixel.packets import BROADCAST_ID

    register, value = args.register, args.value
    if args.address is not None:
        if value is not None or register is None:
            raise ConfigError("with --address give VALUE only, e.g. "
                              "servolab write ... --address 116 --size 4 2048")
        register, value = None, register
    elif register is None or value is None:
        raise ConfigError("give REGISTER and VALUE, e.g. servolab write ... goal_position 0.5")
    motor_id = BROADCAST_ID if args.broadcast else args.motor_id
    write(args.port, motor_id, register, value, protocol=args.protocol,
          baudrate=args.baud, raw=args.raw, model=args.model, address=args.address,
          size=args.size, broadcast=args.broadcast)
    return 0


COMMAND = Command(
    name="write", group="bus", help="write one register of one motor (SI units), or raw bytes",
    description="Write one register of one motor. The value is checked against the motor's "
    "control table, its mode and limits (and, for EEPROM, that torque is off) before "
    "anything is sent. id and baud_rate are changed as 'servolab id' and 'servolab baud' "
    "change them. With --address A --size N, VALUE goes as N raw little-endian bytes.",
    examples=("servolab write --port /dev/ttyUSB0 --id 1 torque_enable on",
              "servolab write --port /dev/ttyUSB0 --id 1 goal_position 0.5",
              "servolab write --port /dev/ttyUSB0 --id 1 id 12",
              "servolab write --port /dev/ttyUSB0 --broadcast torque_enable off",
              "servolab write --port /dev/ttyUSB0 --id 1 --address 65 --size 1 1"),
    add_arguments=_add_arguments, run=_run)
