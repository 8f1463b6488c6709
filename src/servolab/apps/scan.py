"""``servolab scan``: which motors answer on a port, like the Dynamixel Wizard's scan.

:func:`scan` takes plain values (already parsed), prints for a person and returns what it
found, so tests and other code can call it without a shell. The Dynamixel layer is imported
inside the functions, so that ``servolab --help`` does not load it.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, TextIO

from .arguments import add_out, add_port, baud, int_range, protocol
from .registry import Command

if TYPE_CHECKING:
    from ..dynamixel.bus import PingResult
    from ..runs import RunFolder

#: Baud rates the Dynamixel Wizard offers, per protocol, most common first.
COMMON_BAUDS = {
    1: [57600, 1_000_000, 115_200, 500_000, 400_000, 250_000, 200_000, 9_600],
    2: [57600, 1_000_000, 115_200, 2_000_000, 3_000_000, 4_000_000, 9_600],
}


def scan(device: str, *, protocols: Sequence[int], baudrates: Sequence[int] | None,
         ids: Iterable[int] | None, run: RunFolder | None = None,
         stdout: TextIO = sys.stdout, stderr: TextIO = sys.stderr) -> list[tuple[int,
                                                                          PingResult]]:
    """Ping every ID at every baud rate on each protocol and list what answers, like the
    Dynamixel Wizard's scan."""
    from ..dynamixel.bus import Bus

    found: list[tuple[int, PingResult]] = []
    id_list = list(ids) if ids is not None else None
    for version in protocols:
        rates = list(baudrates) if baudrates else COMMON_BAUDS[version]
        with Bus.open(device, protocol=version, baudrate=rates[0], retries=0) as bus:
            last = [-1]

            live = stderr.isatty()

            def progress(baud: int, motor_id: int, version: int = version,
                         last: list[int] = last, live: bool = live) -> None:
                if live:  # one line that counts up, for a person watching
                    print(f"\rscanning protocol {version}.0 at {baud} bps: ID {motor_id:>3}",
                          end="", file=stderr, flush=True)
                elif baud != last[0]:
                    print(f"scanning protocol {version}.0 at {baud} bps ...", file=stderr,
                          flush=True)
                last[0] = baud

            ids_here = id_list if id_list is not None else range(bus.proto.max_id + 1)
            found += [(version, r) for r in bus.scan(ids_here, rates, progress=progress)]
            if live:
                print(file=stderr)
    print(f"{'ID':>4}  {'model':<12} {'number':>6}  {'firmware':>8}  {'protocol':>8}  "
          f"{'baud':>8}", file=stdout)
    for version, r in found:
        print(f"{r.id:>4}  {r.model_name:<12} {r.model_number:>6}  {r.firmware!s:>8}  "
              f"{version}.0{'':>5}  {r.baudrate:>8}", file=stdout)
    print(f"{len(found)} motor(s) found", file=stdout, flush=True)
    if run is not None:
        run.write_summary({"device": device, "found": [
            {"id": r.id, "model": r.model_name, "model_number": r.model_number,
             "firmware": r.firmware, "protocol": v, "baudrate": r.baudrate}
            for v, r in found]})
    return found


def _add_arguments(p: argparse.ArgumentParser) -> None:
    add_port(p)
    p.add_argument("--baud", type=baud, nargs="+", metavar="B",
                   help="baud rates to try (default: the common ones)")
    p.add_argument("--protocol", type=protocol, action="append",
                   help="1 or 2; repeat for both (default: both)")
    p.add_argument("--ids", type=int_range, metavar="A-B", help="ID range (default: all)")
    add_out(p)


def _run(args: argparse.Namespace) -> int:
    from ..runs import RunFolder

    found = scan(args.port, protocols=args.protocol or [1, 2], baudrates=args.baud,
                 ids=args.ids, run=RunFolder.create("scan", args.out))
    return 0 if found else 1


COMMAND = Command(
    name="scan", group="bus", help="find motors on a port (ID, model, firmware)",
    description="Ping every ID at every baud rate on each protocol and list the motors that "
    "answer; exit status 1 if none does.",
    examples=("servolab scan --port /dev/ttyUSB0",
              "servolab scan --port /dev/ttyUSB0 --protocol 1 --baud 57600 --ids 1-30"),
    add_arguments=_add_arguments, run=_run)
