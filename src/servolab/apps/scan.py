"""``servolab scan``: which motors answer on a port, like the Dynamixel Wizard's scan, in seconds.

With no options it looks where new motors are: both protocols at the baud rates the models
servolab knows leave the factory with (57600 and 1 Mbps), 2.0 by one broadcast PING per rate
and 1.0 by a PING per ID spaced by wire time (:meth:`servolab.dynamixel.bus.Bus.scan`): a few
seconds. ``--all-bauds`` sweeps every rate the models can be set to, and says first how long
that takes. It says how long any scan will take before it starts, and shows its progress.

:func:`scan` takes plain values (already parsed), prints for a person and returns what it
found, so tests and other code can call it without a shell. The Dynamixel layer is imported
inside the functions, so that ``servolab --help`` does not load it.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Any, TextIO

from .arguments import add_out, add_port, baud, int_range, protocol
from .registry import Command

if TYPE_CHECKING:
    from ..dynamixel.bus import PingResult
    from ..runs import RunFolder

#: Protocol 2.0 first: its broadcast PING finds its motors at once.
PROTOCOLS = (2, 1)


def factory_baudrates(version: int) -> list[int]:
    """The rates (as a host sets its port: an RX-28's 57142 bps is 57600) at which the models
    servolab knows of protocol ``version`` leave the factory, by their tables' default
    baud_rate; the most common first."""
    from ..dynamixel.bus import line_rate
    from ..dynamixel.models import MODELS

    rates: dict[int, int] = {}
    for m in MODELS.values():
        if m.protocol == version and m.has("baud_rate"):
            default = m.register("baud_rate").default
            if default is not None:
                rate = line_rate(m.baud_from_register(default))
                rates[rate] = rates.get(rate, 0) + 1
    return sorted(rates, key=lambda r: (-rates[r], r))


def every_baudrate(version: int) -> list[int]:
    """Every common rate (:func:`~servolab.dynamixel.bus.usable_rates`) that some model of
    protocol ``version`` servolab knows can be set to, slowest first."""
    from ..dynamixel.bus import usable_rates
    from ..dynamixel.models import MODELS

    return sorted({rate for m in MODELS.values() if m.protocol == version
                   for rate in usable_rates(m)})


def scan_plan(protocols: Sequence[int], baudrates: Sequence[int] | None, *,
              all_bauds: bool = False) -> list[tuple[int, list[int]]]:
    """(rate, protocols to scan at it) in the order they are scanned. ``baudrates`` given:
    each of them in every protocol; else each protocol at its models' factory rates (or, with
    ``all_bauds``, at every rate its models can use) and nowhere else: 1.0 is not looked for
    at 4 Mbps, where no 1.0 model runs."""
    versions = [v for v in PROTOCOLS if v in set(protocols)]
    if baudrates:
        return [(rate, list(versions)) for rate in dict.fromkeys(baudrates)]
    plan: dict[int, list[int]] = {}
    for version in versions:
        for rate in every_baudrate(version) if all_bauds else factory_baudrates(version):
            plan.setdefault(rate, []).append(version)
    order = sorted(plan) if all_bauds else list(plan)
    return [(rate, plan[rate]) for rate in order]


def _rates_text(rates: Sequence[int]) -> str:
    return " and ".join(map(str, rates)) if len(rates) < 3 else (
        f"{len(rates)} rates, {rates[0]} to {rates[-1]}")


def scan(device: str, *, protocols: Sequence[int], baudrates: Sequence[int] | None,
         ids: Iterable[int] | None, run: RunFolder | None = None, all_bauds: bool = False,
         stdout: TextIO | None = None, stderr: TextIO | None = None
         ) -> list[tuple[int, PingResult]]:
    """Find the motors on ``device``: each protocol of ``protocols`` at each rate of
    ``baudrates`` (default: the factory rates of servolab's models, or every rate they take
    with ``all_bauds``), every ID or ``ids``; list what answers. Says first how long it will
    take; a progress bar on a terminal, a line per rate and protocol otherwise."""
    from ..dynamixel.bus import Bus
    from ..dynamixel.errors import ConfigError

    stdout = stdout or sys.stdout
    stderr = stderr or sys.stderr
    if all_bauds and baudrates:
        raise ConfigError("--all-bauds sweeps every rate; give it or --baud, not both")
    plan = scan_plan(protocols, baudrates, all_bauds=all_bauds)
    id_list = list(ids) if ids is not None else None
    found: list[tuple[int, PingResult]] = []
    # (no rate: emulated motors run at their factory rates, not at the one opened with)
    with Bus.open(device, retries=0) as bus:
        estimates = [bus.scan_time(id_list, [rate], protocols=versions)
                     for rate, versions in plan]
        total = sum(estimates)
        rates = [rate for rate, _ in plan]
        versions_text = " and ".join(f"{v}.0" for v in PROTOCOLS if v in set(protocols))
        which = ("every ID" if id_list is None else
                 f"IDs {id_list[0]}-{id_list[-1]}" if id_list == list(
                     range(id_list[0], id_list[-1] + 1)) and len(id_list) > 1
                 else f"ID{'s' if len(id_list) != 1 else ''} "
                 f"{', '.join(map(str, id_list))}")
        what = (f"sweeping every baud rate the models take ({_rates_text(rates)} bps)"
                if all_bauds else f"scanning at {_rates_text(rates)} bps")
        print(f"{what}, protocol {versions_text}, {which}: this takes about {total:.1f} s",
              file=stderr, flush=True)
        clock = bus.port.clock
        started = clock.now()
        with _Progress(total, stderr) as show:
            for (rate, versions), estimate in zip(plan, estimates, strict=True):
                show.step(rate, versions, estimate)
                found += [(r.protocol or versions[0], r) for r in bus.scan(
                    id_list, [rate], protocols=versions,
                    progress=lambda b, i: show.tick(clock.now() - started))]
        elapsed = clock.now() - started
    print(f"{'ID':>4}  {'model':<12} {'number':>6}  {'firmware':>8}  {'protocol':>8}  "
          f"{'baud':>8}", file=stdout)
    for version, r in found:
        print(f"{r.id:>4}  {r.model_name:<12} {r.model_number:>6}  {r.firmware!s:>8}  "
              f"{version}.0{'':>5}  {r.baudrate:>8}", file=stdout)
    print(f"{len(found)} motor(s) found", file=stdout, flush=True)
    print(f"scan took {elapsed:.1f} s", file=stderr, flush=True)
    if run is not None:
        run.write_summary({"device": device, "scan_s": round(elapsed, 3),
                           "estimate_s": round(total, 3),
                           "plan": [{"baudrate": rate, "protocols": versions}
                                    for rate, versions in plan],
                           "found": [
            {"id": r.id, "model": r.model_name, "model_number": r.model_number,
             "firmware": r.firmware, "protocol": v, "baudrate": r.baudrate}
            for v, r in found]})
    return found


class _Progress:
    """A tqdm bar over the scan's estimated seconds on a terminal; elsewhere a line per rate
    and protocol (what a log can keep)."""

    def __init__(self, total: float, stderr: TextIO) -> None:
        self.stderr = stderr
        self.live = stderr.isatty()
        self.total = total
        self.bar: Any = None

    def __enter__(self) -> _Progress:
        if self.live:
            from tqdm import tqdm

            self.bar = tqdm(total=round(self.total, 1), unit="s", file=self.stderr,
                            leave=False, bar_format="{desc}{bar}| {n:.1f}/{total:.1f} s")
        return self

    def step(self, rate: int, versions: Sequence[int], estimate: float) -> None:
        text = " and ".join(f"{v}.0" for v in versions)
        if self.bar is not None:
            self.bar.set_description_str(f"protocol {text} at {rate} bps ")
        else:
            print(f"scanning protocol {text} at {rate} bps (about {estimate:.1f} s) ...",
                  file=self.stderr, flush=True)

    def tick(self, elapsed: float) -> None:
        bar = self.bar
        if bar is not None:
            elapsed = min(elapsed, self.total)
            if elapsed > bar.n:
                bar.update(elapsed - bar.n)  # tqdm redraws at most every 0.1 s

    def __exit__(self, *exc: object) -> None:
        if self.bar is not None:
            self.bar.close()


def _add_arguments(p: argparse.ArgumentParser) -> None:
    add_port(p)
    rates = p.add_mutually_exclusive_group()
    rates.add_argument("--baud", type=baud, nargs="+", action="extend", metavar="B",
                       help="baud rates to scan, e.g. --baud 57600 1000000 or --baud 57600 "
                       "--baud 1000000 (default: the models' factory rates, 57600 and "
                       "1000000)")
    rates.add_argument("--all-bauds", action="store_true",
                       help="every baud rate the models can be set to (says first how long "
                       "it takes: about half a minute)")
    p.add_argument("--protocol", type=protocol, action="append",
                   help="1 or 2; repeat for both (default: both, 2.0 first)")
    p.add_argument("--ids", type=int_range, metavar="A-B", help="ID range (default: all)")
    add_out(p)


def _run(args: argparse.Namespace) -> int:
    from ..runs import RunFolder

    found = scan(args.port, protocols=args.protocol or list(PROTOCOLS), baudrates=args.baud,
                 ids=args.ids, all_bauds=args.all_bauds,
                 run=RunFolder.create("scan", args.out))
    return 0 if found else 1


COMMAND = Command(
    name="scan", group="bus", help="find motors on a port (ID, model, firmware)",
    description="Find the motors on a port and list them; exit status 1 if none answers. "
    "By default both protocols at the rates new motors come at (57600 and 1000000 bps): "
    "2.0 by one broadcast PING per rate, 1.0 by a PING per ID, a few seconds in all. "
    "It says how long it will take before it starts.",
    examples=("servolab scan --port /dev/ttyUSB0",
              "servolab scan --port /dev/ttyUSB0 --baud 57600 --baud 1000000",
              "servolab scan --port /dev/ttyUSB0 --all-bauds",
              "servolab scan --port /dev/ttyUSB0 --protocol 1 --baud 57600 --ids 1-30"),
    add_arguments=_add_arguments, run=_run)
