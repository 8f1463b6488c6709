"""``servolab id``: give a motor another ID, as the Dynamixel Wizard's ID setting does.

New motors all leave the factory as ID 1, so this is a first-day task: one motor at a time on
the bus, ``servolab id --port P 1 12``, the next, ``servolab id --port P 1 13``, and so on. An
ID that already answers is refused with nothing written (two motors at one ID answer
together and garble each other), and the motor is PINGed at its new ID before success is
said. The Dynamixel layer is imported inside the functions, so that ``servolab --help`` does
not load it.
"""

from __future__ import annotations

import argparse
from typing import TextIO

from .arguments import add_bus
from .registry import Command


def set_id(device: str, motor_id: int, new_id: int, *, protocol: int | None = None,
           baudrate: int, model: str | None = None,
           stdout: TextIO | None = None) -> int:
    """Give the motor at ``motor_id`` the ID ``new_id``; returns the new ID."""
    from ._bus import change_id, hint_protocol, open_bus

    with open_bus(device, protocol, baudrate, model, motor_id) as bus, hint_protocol(bus):
        change_id(bus, motor_id, new_id, stdout)
    return new_id


def _add_arguments(p: argparse.ArgumentParser) -> None:
    add_bus(p)
    p.add_argument("--model", help="the motor's model, e.g. xm430-w350 (default: learnt by a "
                   "PING)")
    p.add_argument("old", type=int, metavar="OLD", help="the motor's ID now")
    p.add_argument("new", type=int, metavar="NEW", help="the ID to give it (must be free)")


def _run(args: argparse.Namespace) -> int:
    set_id(args.port, args.old, args.new, protocol=args.protocol, baudrate=args.baud,
           model=args.model)
    return 0


COMMAND = Command(
    name="id", group="bus", help="give a motor another ID (a free one)",
    description="Give the motor at ID OLD the ID NEW. Refused, with nothing written, when a "
    "motor already answers at NEW; on a protocol 2.0 motor torque must be off (the ID is in "
    "EEPROM). The motor is pinged at NEW before success is said.",
    examples=("servolab id --port /dev/ttyUSB0 1 12",
              "servolab id --port /dev/ttyUSB0 --protocol 1 --baud 1000000 1 3"),
    add_arguments=_add_arguments, run=_run)
