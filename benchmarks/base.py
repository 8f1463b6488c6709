"""The base node's control rate on the emulated buses of both bases, against the wire-time
limit of one cycle (issue 17).

Two bases, as servolab ships them (``servolab robots``): seed 000's two EX-106+ in wheel
mode (Protocol 1.0, 1 Mbps) and a TurtleBot3 Waffle's two XM430-W210 in velocity mode
(Protocol 2.0, 1 Mbps). Each is emulated on a simulated floor (``MobileBase.emulated``) and
driven by a :class:`~servolab.robots.base.node.BaseNode` whose ``rate`` parameter is lifted to
10 000 Hz, so that its timer is always due and only the bus bounds the loop. A ``/cmd_vel``
(0.1 m/s, 0.3 rad/s; the watchdog lifted) keeps the wheels turning. Each cycle is what the
node does: one SYNC_WRITE of both wheels' speeds and the reads of ``present_position`` (one
SYNC_READ of both on Protocol 2.0, a READ a side on 1.0), then ``/odom``, ``/tf``,
``/joint_states`` and ``/sensor_state``. The context spins on the simulation's
virtual clock, which on the emulated bus advances by each transaction's wire time (10 bits a
byte, plus each motor's return delay before its status), so the rate achieved is the rate the
wire allows this node; the host's CPU time and a USB adapter's latency are not in it. (The
ratio achieved / limit is therefore 1 by construction when the node sends exactly the packets
counted: it checks the packets, not a real bus's speed.)

Beside it, in the same run:

- the **wire-time limit** of one cycle, computed here from the protocols' framing (not from
  the driver or the emulator): the SYNC_WRITE (1.0: ``FF FF FE LEN 83 addr size`` + per motor
  ``ID data`` + ``CHK``; 2.0: ``FF FF FD 00 FE LEN_L LEN_H 83 addr_L addr_H size_L size_H`` +
  per motor ``ID data`` + ``CRC_L CRC_H``) of the speed register (1.0 ``moving_speed``,
  2 bytes; 2.0 ``goal_velocity``, 4 bytes), and the reads of ``present_position`` (1.0: a
  READ a side, 2 bytes; 2.0: one SYNC_READ of both, 4 bytes each) with their status packets
  and the motors' return delays, read from the motors themselves (``return_delay_time`` x
  2 us); limit = 1 / that time, and the ratio achieved / limit;
- the **host time per cycle**: the wall-clock time of the run over its cycles (driver,
  emulator, floor physics, executor, message building), and its ratio to the wire time of a
  cycle (below 1: the host keeps up with a real bus);
- the node at its **default rate** (30 Hz), which should give 30 Hz;
- on the Waffle's bus, what a READ a side would give instead of the SYNC_READ (the EX-106+ on
  Protocol 1.0 has neither SYNC_READ nor BULK_READ, so seed 000's base READs each side).

Run: ``.venv/bin/python benchmarks/base.py [--quick] [--json PATH]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import math
import platform
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.robots.base.config import SHIPPED_DIR, BaseConfig, load
from servolab.robots.base.mobile_base import MobileBase
from servolab.robots.base.node import BaseNode

CONFIGS = SHIPPED_DIR  # the shipped bases
BASES = ("base_seed000.yaml", "base_turtlebot3_waffle.yaml")
FULL_CYCLES, QUICK_CYCLES = 2000, 60
FULL_DEFAULT_S, QUICK_DEFAULT_S = 10.0, 1.0   # virtual seconds at the default rate
LIFTED_RATE = 10_000.0     # Hz: the node's timer always due
DEFAULT_RATE = 30.0        # the node's default rate parameter (Hz)
BITS_PER_BYTE = 10         # start + 8 data + stop
RETURN_DELAY_UNIT = 2e-6   # s per raw unit of return_delay_time (EX-106+ and XM430 e-Manuals)
TWIST = "geometry_msgs/msg/Twist"

# Protocol framing, in bytes.
P1_HEADER = 5              # FF FF ID LEN INST
P1_TAIL = 1                # CHK
P2_HEADER = 8              # FF FF FD 00 ID LEN_L LEN_H INST
P2_TAIL = 2                # CRC_L CRC_H


def read_bytes(protocol: int, size: int) -> tuple[int, int]:
    """(instruction, status) bytes of a READ of ``size`` bytes."""
    if protocol == 1:
        # FF FF ID LEN 02 addr count CHK; FF FF ID LEN err <data> CHK
        return P1_HEADER + 2 + P1_TAIL, P1_HEADER + size + P1_TAIL
    # FF FF FD 00 ID LEN LEN 02 aL aH nL nH CRC CRC; FF FF FD 00 ID LEN LEN 55 err <data> CRC CRC
    return P2_HEADER + 4 + P2_TAIL, P2_HEADER + 1 + size + P2_TAIL


def sync_write_bytes(protocol: int, size: int, motors: int) -> int:
    """Bytes of a SYNC_WRITE of ``size`` bytes to each of ``motors`` motors."""
    if protocol == 1:
        return P1_HEADER + 2 + motors * (1 + size) + P1_TAIL     # + addr, size
    return P2_HEADER + 4 + motors * (1 + size) + P2_TAIL          # + addr (2), size (2)


def sync_read_bytes(size: int, motors: int) -> tuple[int, int]:
    """(instruction, statuses) bytes of a Protocol 2.0 SYNC_READ of ``size`` bytes from
    ``motors`` motors."""
    return P2_HEADER + 4 + motors + P2_TAIL, motors * read_bytes(2, size)[1]


@dataclasses.dataclass
class WireCycle:
    """One cycle's bytes and wire time, computed from the packet sizes."""

    bytes_out: int
    bytes_in: int
    return_delays_s: float
    seconds: float

    @property
    def limit_hz(self) -> float:
        return 1.0 / self.seconds


def cycle_limit(config: BaseConfig, delays: Sequence[float]) -> WireCycle:
    """The node's cycle: the SYNC_WRITE of every wheel motor's speed, then one READ of
    present_position from each side's first motor (return delays ``delays``, s)."""
    protocol = config.protocol
    speed = config.model.register("moving_speed" if protocol == 1 else "goal_velocity").size
    position = config.model.register("present_position").size
    out = sync_write_bytes(protocol, speed, len(config.motors))
    inst, status = read_bytes(protocol, position)
    out += len(delays) * inst
    into = len(delays) * status
    wait = float(sum(delays))
    return WireCycle(out, into, wait, (out + into) * BITS_PER_BYTE / config.baudrate + wait)


def sync_read_cycle_limit(config: BaseConfig, delays: Sequence[float]) -> WireCycle:
    """The same cycle with one SYNC_READ of both present positions (Protocol 2.0 only)."""
    speed = config.model.register("goal_velocity").size
    position = config.model.register("present_position").size
    inst, statuses = sync_read_bytes(position, len(delays))
    out = sync_write_bytes(2, speed, len(config.motors)) + inst
    wait = float(sum(delays))
    return WireCycle(out, statuses, wait,
                     (out + statuses) * BITS_PER_BYTE / config.baudrate + wait)


@dataclasses.dataclass
class BaseRate:
    """One base's figures (rates in cycles per second of simulated time = wire time)."""

    name: str
    model: str
    protocol: int
    baudrate: int
    motors: int
    return_delay_ms: list[float]
    cycles: int
    transactions_per_cycle: float
    bytes_per_cycle: float          # measured on the bus (out + in)
    achieved_hz: float              # node at the lifted rate
    wire_ms_per_cycle: float        # simulated time per cycle
    limit_bytes_out: int
    limit_bytes_in: int
    limit_hz: float                 # computed from the packet sizes
    ratio_achieved_limit: float
    host_us_per_cycle: float        # wall-clock time of the run / cycles
    ratio_host_wire: float          # host time per cycle / wire time per cycle
    default_rate_hz: float          # node at its default 30 Hz
    default_cycles: int
    reads_limit_hz: float | None  # a READ a side instead of the SYNC_READ (2.0 only)
    ratio_reads_limit: float | None

    @property
    def label(self) -> str:
        return (f"{self.name}: {self.motors} x {self.model}, protocol {self.protocol}.0, "
                f"{self.baudrate} bps")


def _rig(config: BaseConfig, rate: float | None) -> tuple[MobileBase, Context]:
    """The emulated base, and a context holding its node and a teleop that sent one
    ``/cmd_vel``."""
    base = MobileBase.emulated(config)
    context = Context.open(clock=base.clock)
    overrides: dict[str, float] = {"watchdog": 1e9}
    if rate is not None:
        overrides["rate"] = rate
    BaseNode(context, base, parameter_overrides=overrides)  # the context holds it
    probe = Node(context, "teleop")
    probe.create_publisher(TWIST, "/cmd_vel").publish(
        probe.message(TWIST, linear={"x": 0.1}, angular={"z": 0.3}))
    return base, context


def _rate(stamps: Sequence[float]) -> float:
    """Cycles per second between the first and the last of ``stamps``."""
    return (len(stamps) - 1) / (stamps[-1] - stamps[0])


def measure(path: Path, cycles: int, default_seconds: float) -> BaseRate:
    config = load(path)
    quiet = logging.root.manager.disable
    logging.disable(logging.WARNING)
    try:
        # The node as fast as the bus allows.
        base, context = _rig(config, LIFTED_RATE)
        try:
            delays = [int(base.bus.read(config.side(side)[0].id, "return_delay_time", raw=True))
                      * RETURN_DELAY_UNIT for side in ("left", "right")]
            context.spin_until(lambda: len(base.commands) >= 2)  # the twist taken, running
            first = len(base.commands)
            stats = base.bus.stats
            sent, bytes0 = stats.transactions, stats.bytes_out + stats.bytes_in
            sim0 = base.clock.now()
            wall0 = time.perf_counter()
            context.spin_until(lambda: len(base.commands) >= first + cycles)
            wall = time.perf_counter() - wall0
            done = len(base.commands) - first
            elapsed = base.clock.now() - sim0
            per_cycle = (stats.transactions - sent) / done
            bytes_per_cycle = (stats.bytes_out + stats.bytes_in - bytes0) / done
            stamps = [t for t, _, _ in base.commands[first - 1:]]
            achieved = _rate(stamps)
            moved = base.truth()["distance"]
        finally:
            context.close()
            base.bus.close()
        if not moved > 0:
            raise RuntimeError(f"{config.name}: the wheels did not turn")

        # The node at its default rate.
        base, context = _rig(config, None)
        try:
            start = len(base.commands)
            context.spin_for(default_seconds)
            stamps = [t for t, _, _ in base.commands[start:]]
            default_rate = _rate(stamps)
        finally:
            context.close()
            base.bus.close()
    finally:
        logging.disable(quiet)

    # the base reads both positions in one SYNC_READ on 2.0, a READ a side on 1.0
    wire = (sync_read_cycle_limit(config, delays) if config.protocol == 2
            else cycle_limit(config, delays))
    reads_limit = cycle_limit(config, delays).limit_hz if config.protocol == 2 else None
    wire_per_cycle = elapsed / done
    host = wall / done
    return BaseRate(
        config.name, config.model.name, config.protocol, config.baudrate, len(config.motors),
        [d * 1e3 for d in delays], done, per_cycle, bytes_per_cycle, achieved,
        wire_per_cycle * 1e3, wire.bytes_out, wire.bytes_in, wire.limit_hz,
        achieved / wire.limit_hz, host * 1e6, host / wire_per_cycle, default_rate,
        len(stamps), reads_limit, None if reads_limit is None else reads_limit / wire.limit_hz)


def report(rows: Sequence[BaseRate]) -> str:
    lines = [
        "base node control rate: emulated bases on a simulated floor, simulated wire time",
        f"{'base':19}{'achieved':>10}{'limit':>9}{'ach/lim':>9}{'wire':>9}{'host':>9}"
        f"{'host/wire':>11}{'at 30 Hz':>10}{'tx/cyc':>8}{'B/cyc':>7}",
        f"{'':19}{'Hz':>10}{'Hz':>9}{'':>9}{'ms/cyc':>9}{'us/cyc':>9}{'':>11}{'Hz':>10}"
        f"{'':>8}{'':>7}",
    ]
    for r in rows:
        lines.append(f"{r.name:19}{r.achieved_hz:10.1f}{r.limit_hz:9.1f}"
                     f"{r.ratio_achieved_limit:9.3f}{r.wire_ms_per_cycle:9.3f}"
                     f"{r.host_us_per_cycle:9.0f}{r.ratio_host_wire:11.3f}"
                     f"{r.default_rate_hz:10.2f}{r.transactions_per_cycle:8g}"
                     f"{r.bytes_per_cycle:7g}")
    lines.append("achieved: the node's timer lifted to 10 000 Hz; a cycle is one SYNC_WRITE of "
                 "the wheel speeds and the reads of present_position: one SYNC_READ of both "
                 "(Protocol 2.0), a READ a side (1.0)")
    lines.append("limit: 1 / (the cycle's bytes x 10 / baud + the motors' return delays), from "
                 "the protocols' framing")
    lines.append("host: wall-clock time of the run / cycles (driver, emulator, floor, executor, "
                 "messages); host/wire < 1: keeps up with a real bus")
    for r in rows:
        delays = " + ".join(f"{d:g}" for d in r.return_delay_ms)
        lines.append(f"  {r.label}: limit = {r.limit_bytes_out} + {r.limit_bytes_in} bytes + "
                     f"{delays} ms return delay; ratio achieved/limit = "
                     f"{r.ratio_achieved_limit:.3f}; ratio host/wire = {r.ratio_host_wire:.3f}; "
                     f"at the default rate {r.default_rate_hz:.2f} Hz "
                     f"(ratio {r.default_rate_hz / DEFAULT_RATE:.3f} of 30 Hz)")
    lines.append("one read transaction per cycle: the EX-106+ on Protocol 1.0 has neither "
                 "SYNC_READ nor BULK_READ, so seed000 READs each side")
    for r in rows:
        if r.reads_limit_hz is not None and r.ratio_reads_limit is not None:
            lines.append(f"  {r.name}: a READ a side instead of the SYNC_READ would allow "
                         f"{r.reads_limit_hz:.1f} Hz (computed; ratio READs/SYNC_READ = "
                         f"{r.ratio_reads_limit:.3f})")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true",
                        help=f"{QUICK_CYCLES} cycles, {QUICK_DEFAULT_S:g} s at 30 Hz: checks "
                        "that it runs")
    parser.add_argument("--json", type=Path, metavar="PATH", help="also write the figures here")
    args = parser.parse_args(argv)
    cycles = QUICK_CYCLES if args.quick else FULL_CYCLES
    seconds = QUICK_DEFAULT_S if args.quick else FULL_DEFAULT_S
    print(f"servolab base benchmark: Python {platform.python_version()}, "
          f"{platform.machine()}{' (quick)' if args.quick else ''}; {cycles} cycles per base")
    rows = [measure(CONFIGS / name, cycles, seconds) for name in BASES]
    print(report(rows))
    sane = all(math.isfinite(v) and v > 0 for r in rows
               for v in (r.achieved_hz, r.limit_hz, r.ratio_achieved_limit,
                         r.host_us_per_cycle, r.wire_ms_per_cycle, r.default_rate_hz))
    sane = sane and all(r.achieved_hz <= 1.01 * r.limit_hz for r in rows)
    if args.json:
        out = {"quick": args.quick, "cycles": cycles, "default_seconds": seconds,
               "lifted_rate_hz": LIFTED_RATE,
               "bases": {r.name: dataclasses.asdict(r) | {"label": r.label} for r in rows}}
        args.json.write_text(json.dumps(out, indent=2) + "\n")
        print(f"\nfigures written to {args.json}")
    return 0 if sane else 1


if __name__ == "__main__":
    sys.exit(main())
