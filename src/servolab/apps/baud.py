"""``servolab baud``: set a motor's baud rate, and speak the new rate to check it.

The rate is looked up in the model's e-Manual baud table (within UART tolerance: 57600 sets an
RX-28's 57142 bps); the motor answers the WRITE at the old rate, then the bus switches to the
new one and PINGs the motor there before success is said. The Dynamixel layer is imported
inside the functions, so that ``servolab --help`` does not load it.
"""

from __future__ import annotations

import argparse
from typing import TextIO

from .arguments import add_bus, add_motor, baud
from .registry import Command


def set_baud(device: str, motor_id: int, rate: int, *, protocol: int | None = None,
             baudrate: int, model: str | None = None,
             stdout: TextIO | None = None) -> int:
    """Set motor ``motor_id`` to ``rate`` bps; returns the rate the bus now speaks to it."""
    from ._bus import change_baud, hint_protocol, open_bus

    with open_bus(device, protocol, baudrate, model, motor_id) as bus, hint_protocol(bus):
        change_baud(bus, motor_id, rate, stdout)
        return bus.baudrate


def _add_arguments(p: argparse.ArgumentParser) -> None:
    add_bus(p)
    add_motor(p)
    p.add_argument("rate", type=baud, metavar="RATE",
                   help="the new baud rate in bps, e.g. 1000000 (one the model's baud table "
                   "has)")


def _run(args: argparse.Namespace) -> int:
    set_baud(args.port, args.motor_id, args.rate, protocol=args.protocol, baudrate=args.baud,
             model=args.model)
    return 0


COMMAND = Command(
    name="baud", group="bus", help="set a motor's baud rate (and check it at the new rate)",
    description="Set the baud rate of one motor to RATE (--baud is the rate it talks at now). "
    "The rate must be in the model's baud table; on a protocol 2.0 motor torque must be off "
    "(the baud rate is in EEPROM). The motor is pinged at RATE before success is said.",
    examples=("servolab baud --port /dev/ttyUSB0 --id 1 1000000",
              "servolab baud --port /dev/ttyUSB0 --protocol 1 --baud 57600 --id 3 1000000"),
    add_arguments=_add_arguments, run=_run)
