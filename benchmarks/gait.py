"""What vectorising the walking-pattern generator buys: the time to generate a walk of N steps
(half cycles, seed 001 Appendix D) and solve both legs' inverse kinematics and motor angles
(Appendix E), through ``servolab.gait.walking.generate_walk`` (numpy, whole arrays), against a
per-sample Python loop of the same maths (Appendix D statement by statement, the closed-form
leg of seeds/README.md with ``math``, the same motor signs and arm swing).

Both are timed in the same run, best of a few repeats, so their ratio carries over to other
machines better than the absolute figures. The loop's result is checked against the
vectorised one (the run fails if they differ by more than 1e-9 degrees).

**Controller manager update rate** (issues 16 and 27). The emulated Armstrong (20 RX-28,
Protocol 1.0) on four buses: 57142 bps and 1 000 000 bps, each with the RX-28's factory return
delay (raw 250 = 0.5 ms) and with return delay 0 (written to every motor before the manager
starts, so its own wire time sees it). The manager's bus time belongs to its ``BusOwner``
(``servolab.robots.bus_owner``), background work of the context's executor: pending goals
(the newest per motor) go out in one SYNC_WRITE between single READs of the state sweep, and
each motor's state is one READ of the 17 bytes from goal_position to moving (RX-28 addresses
30..46, ``STATE_REGISTERS``, as ``dynamixel_io``'s ``get_feedback`` reads them). Every
controller is given a new goal after each published sweep, so every update is one
SYNC_WRITE of the 20 goals and 20 READs. The owner's sweep period (the configured
``update_rate``, which the manager caps at the wire limit it computes) is lifted here to 0,
so that sweeps run back to back and only the wire bounds them. It all runs on the
simulation's virtual clock; on the emulated bus that clock advances by each transaction's
wire time, so the achieved rate is the rate the wire allows this driver (the host's CPU time
and the USB adapter's latency are not in it). The owner's own figures (``sweep_rate``,
``sweep_time``, goals written and replaced) are reported beside it. Beside it:

- the wire-time limit, computed here from the Protocol 1.0 packet sizes: per motor a READ
  instruction of 8 bytes, a status of 6 + 17 = 23 bytes and one return delay, plus the
  SYNC_WRITE of 8 + 3 x 20 bytes, at 10 bits a byte; the limit is 1 / that time, and the
  ratio achieved / limit says how close the manager gets to it;
- what one READ per register would give (nine READs per motor, as a driver reading register
  by register would send): its limit computed the same way, and the rate measured by reading
  ``bus.read(id, name)`` register by register (plus the same SYNC_WRITE) on the same emulated
  bus, as a ratio against the one-READ figure;
- the original's: seed 001's ROS driver achieved 3 to 4 Hz at 57142 bps.

**Real time over a pty** (issue 27). ``servolab sim --pty --motors
rx28:11-16,21-26,31-33,41-43,51,61 --baud B`` in its own process, walked by ``servolab walk
--steps 1 --port PTY`` in another, as a user with the real robot does (at 1 000 000 bps with a
copy of the shipped armstrong.yaml saying ``baud_rate: 1000000.0``; nothing else changed, so
its ``update_rate`` of 20 Hz still caps the sweep). From the walk's run folder: per bus, the
gait's rows delivered to the 12 leg motors over the rows commanded (from the bag with
``tests/robots/armstrong/delivery.py``: a row counts as delivered to a motor when its goal
register read it back within one row period, 1 / 4.5 s; the 40 stand poses before the gait's
17 rows are left out, and so is a row that repeats the goal before it, which a read-back
cannot tell: 146 of the 12 x 17 leg rows change a goal), the worst delay, and
``summary.json``'s state rate achieved against its wire limit (the manager's wire time, as
above) and the configured update_rate. Wall-clock time: the host and the pty are in these
figures. Before the bus owner (issue 27) the controllers processed 144 of 1 197 commands at
57142 bps, 1 140 at 1 Mbps. Both buses take about 15 s each (mostly the manager pinging IDs
1..65, 5 tries each, as a user's start does); ``--quick`` walks at 57142 bps only, its
manager pinging each absent ID once.

Run: ``.venv/bin/python benchmarks/gait.py [--quick] [--no-pty] [--pty-out DIR] [--json PATH]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import math
import platform
import subprocess
import sys
import tempfile
import time
import timeit
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from servolab.dynamixel.models import model
from servolab.gait.walking import GaitParameters, generate_walk
from servolab.kinematics.leg import ARMSTRONG_LEG, LegGeometry
from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.robots.armstrong import hardware as armstrong
from servolab.robots.armstrong.poses import MOTORS
from servolab.robots.controllers.manager import MOTOR_STATE_LIST, DynamixelManager
from servolab.robots.controllers.motor_state import STATE_REGISTERS
from servolab.sim.simulation import Simulation

FULL_STEPS, QUICK_STEPS = 1000, 20
LEFT_SIGNS = (1.0, -1.0, 1.0, -1.0, 1.0, -1.0)   # m11..m16 (seeds/README.md)
RIGHT_SIGNS = (1.0, -1.0, 1.0, 1.0, -1.0, -1.0)  # m21..m26

Point = tuple[float, float, float]


def loop_feet(p: GaitParameters, leg: LegGeometry) -> tuple[list[Point], list[Point]]:
    """Appendix D, one sample at a time."""
    z0 = -(leg.length - p.d_step)
    x1, y1, z1, x2, y2, z2 = p.l_step / 2, -p.y_start, z0, -p.l_step / 2, p.y_start, z0
    left, right = [(x1, y1, z1)], [(x2, y2, z2)]
    for half in range(1, p.c_step + 1):
        for phase in range(1, 5):
            sign = (-1) ** (4 * half - 4 + phase)
            if phase in (1, 4):
                n1, n2 = (x1, y1 + sign * p.s_step, z1), (x2, y2 - sign * p.s_step, z2)
            else:
                sway = sign * p.s_step * p.h_step / (leg.length - p.d_step)
                lift = p.h_step if phase == 2 else -p.h_step
                n1 = (x1 - p.l_step / 2, y1 + sway, z1)
                n2 = (x2 + p.l_step / 2, y2 - sway, z2 + lift)
            if half % 2 == 0:
                right.append((n1[0], n2[1] + p.d_step / 2, n1[2]))
                left.append((n2[0], n2[1] - p.d_step / 2, n2[2]))
            else:
                right.append((n2[0], n1[1] + p.d_step / 2, n2[2]))
                left.append((n1[0], n1[1] - p.d_step / 2, n1[2]))
            (x1, y1, z1), (x2, y2, z2) = n1, n2
            if phase == 4:
                x1, x2 = n2[0], n1[0]
    return left, right


def loop_motors(target: Point, leg: LegGeometry, signs: Sequence[float]) -> list[float]:
    """One foot: flat-foot IK in degrees, then the motor columns m?1..m?6."""
    x, y, z = target
    height = -(z + leg.l1 + leg.l4)
    distance = math.sqrt(x * x + y * y + height * height)
    if height <= 0 or distance > leg.l2 + leg.l3:
        raise ValueError(f"foot position {target} is out of reach")
    roll = math.atan2(y, height)
    at_hip = math.acos(min(1.0, (leg.l2**2 + distance**2 - leg.l3**2)
                           / (2 * leg.l2 * distance)))
    inner = math.acos(max(-1.0, min(1.0, (leg.l2**2 + leg.l3**2 - distance**2)
                                     / (2 * leg.l2 * leg.l3))))
    hip = math.atan2(x, math.hypot(y, height)) + at_hip
    knee = math.pi - inner
    joints = (0.0, hip, roll, knee, knee - hip, roll)  # motor order: yaw, pitch, roll, ...
    return [math.degrees(q) * s for q, s in zip(joints, signs, strict=True)]


def loop_walk(p: GaitParameters, leg: LegGeometry = ARMSTRONG_LEG) -> list[list[float]]:
    left, right = loop_feet(p, leg)
    rows = []
    for index, (lf, rf) in enumerate(zip(left, right, strict=True)):
        swing = p.arm_swing if index % 2 == 0 else -p.arm_swing
        upper = [swing, 0.0, 0.0, swing, 0.0, 0.0, 0.0, 0.0, 0.0]
        rows.append(loop_motors(lf, leg, LEFT_SIGNS) + loop_motors(rf, leg, RIGHT_SIGNS)
                    + upper)
    return rows


def best_time(work: object, repeat: int) -> float:
    return min(timeit.repeat(work, number=1, repeat=repeat))  # type: ignore[arg-type]


# -- part 2: the controller manager's update rate ------------------------------------------

FULL_UPDATES, QUICK_UPDATES = 200, 4  # virtual time: 4 updates already give the same figures
#: (baud rate, RX-28 return_delay_time raw): factory 250 (x 2 us = 0.5 ms), then tuned to 0
MANAGER_BUSES = [(57_142, 250), (57_142, 0), (1_000_000, 250), (1_000_000, 0)]
RETURN_DELAY_UNIT = 2e-6   # s per raw unit of return_delay_time (RX-28 e-Manual)
BITS_PER_BYTE = 10         # start + 8 data + stop
READ_INSTRUCTION = 8       # FF FF id len READ address count checksum (Protocol 1.0)
STATUS_OVERHEAD = 6        # FF FF id len error <data> checksum
SYNC_WRITE_OVERHEAD = 8    # FF FF FE len SYNC_WRITE address size <id data...> checksum
SEED_ROS_HZ = (3.0, 4.0)   # seed 001's ROS driver at 57142 bps


def wire_limits(baud: int, delay_raw: int, motors: int) -> tuple[float, float]:
    """Updates per second the wire allows: (one READ of the state registers per motor,
    one READ per register), both with the SYNC_WRITE of every motor's goal."""
    rx28 = model(armstrong.MODEL)
    registers = [rx28.register(n) for n in STATE_REGISTERS]
    span = registers[-1].address + registers[-1].size - registers[0].address
    goal = rx28.register("goal_position")
    delay = delay_raw * RETURN_DELAY_UNIT
    byte = BITS_PER_BYTE / baud
    sync = (SYNC_WRITE_OVERHEAD + (1 + goal.size) * motors) * byte
    one_read = motors * ((READ_INSTRUCTION + STATUS_OVERHEAD + span) * byte + delay) + sync
    per_register = motors * sum((READ_INSTRUCTION + STATUS_OVERHEAD + r.size) * byte + delay
                                for r in registers) + sync
    return 1.0 / one_read, 1.0 / per_register


@dataclasses.dataclass
class ManagerRate:
    """One bus's figures (rates in updates per second of the simulation's time)."""

    baudrate: int
    return_delay_raw: int
    return_delay_ms: float
    motors: int
    updates: int
    transactions_per_update: float
    manager_wire_ms: float          # the manager's own wire_time()
    achieved_hz: float              # the manager's bus owner, one READ per motor
    owner_sweep_hz: float           # the owner's own sweep_rate (its last sweeps)
    owner_sweep_ms: float           # the owner's sweep_time: mean time of one sweep's READs
    goals_per_update: float         # goals the owner wrote per update (20: one SYNC_WRITE)
    goals_replaced: int             # goals replaced before written (0: one goal per sweep)
    limit_hz: float                 # computed from the packet sizes
    ratio_achieved_limit: float
    per_register_hz: float          # measured: one READ per register
    per_register_limit_hz: float
    ratio_per_register_limit: float   # per-register limit / one-READ limit
    ratio_per_register_achieved: float  # per-register measured / one-READ achieved

    @property
    def label(self) -> str:
        return f"{self.baudrate} bps, return delay {self.return_delay_ms:g} ms"


def measure_manager(baud: int, delay_raw: int, updates: int) -> ManagerRate:
    """The emulated Armstrong at ``baud`` with ``delay_raw``: the manager's achieved rate,
    then one READ per register on the same bus."""
    config = armstrong.load_config()
    sim = Simulation()
    bus, port = armstrong.open_bus(config, simulation=sim, baudrate=baud)
    context = Context.open(clock=sim)
    quiet = logging.root.manager.disable
    logging.disable(logging.CRITICAL)  # the manager's start-up messages (motor 62 absent...)
    try:
        present = [c.motor.id for c in config.controllers if c.motor.id not in armstrong.ABSENT]
        for motor_id in present:
            if int(bus.read(motor_id, "return_delay_time", raw=True)) != delay_raw:
                bus.write(motor_id, "return_delay_time", delay_raw, raw=True)
        # The configured update_rate (20 Hz) lifted, and the bus owner's sweep period (which
        # the manager caps at its wire_time()) set to 0: sweeps run back to back, so the
        # wire alone bounds them.
        port = dataclasses.replace(port, update_rate=1e6)
        manager = DynamixelManager(context, bus, port, config.controllers)
        owner = manager.owner
        owner.period = 0.0
        controllers = list(manager.controllers.values())
        motors = len(manager.motors)
        flip = [0]

        def new_goals() -> None:  # a goal for every controller before each update
            flip[0] ^= 1
            for controller in controllers:
                controller.command(0.01 * flip[0])

        # One update first: it switches every motor's torque on (20 WRITEs, once).
        new_goals()
        manager.update()

        # Each published state brings new goals, which the next update SYNC_WRITEs.
        probe = Node(context, "goal_setter")
        probe.create_subscription(MOTOR_STATE_LIST, f"/motor_states/{port.name}",
                                  lambda msg: new_goals())
        new_goals()  # for the first timed update
        start, first, sent = sim.now(), manager.updates, bus.stats.transactions
        written, replaced = owner.goals_written, owner.goals_replaced
        context.spin_until(lambda: manager.updates >= first + updates)
        elapsed = sim.now() - start
        done = manager.updates - first
        per_update = (bus.stats.transactions - sent) / done
        achieved = done / elapsed
        sweep_hz, sweep_ms = owner.sweep_rate, owner.sweep_time * 1e3
        goals = (owner.goals_written - written) / done
        replaced = owner.goals_replaced - replaced
        wire_ms = manager.wire_time() * 1e3

        # One READ per register, and the same SYNC_WRITE, on the same bus.
        start = sim.now()
        for _ in range(updates):
            new_goals()
            manager.flush_goals()
            for motor_id in manager.motors:
                for name in STATE_REGISTERS:
                    bus.read(motor_id, name, raw=True)
        per_register = updates / (sim.now() - start)
    finally:
        logging.disable(quiet)
        context.close()
        bus.close()

    limit, per_register_limit = wire_limits(baud, delay_raw, motors)
    return ManagerRate(baud, delay_raw, delay_raw * RETURN_DELAY_UNIT * 1e3, motors, done,
                       per_update, wire_ms, achieved, sweep_hz, sweep_ms, goals, replaced,
                       limit, achieved / limit, per_register, per_register_limit,
                       per_register_limit / limit, per_register / achieved)


def manager_report(rows: Sequence[ManagerRate]) -> str:
    per_motor = len(STATE_REGISTERS)
    lines = [
        "",
        "controller manager update rate: emulated Armstrong, 20 RX-28 (Protocol 1.0), "
        "simulated wire time, the bus owner sweeping back to back",
        f"{'bus':36}{'achieved':>10}{'limit':>9}{'ach/lim':>9}"
        f"{'per-reg':>10}{'p-r lim':>9}{'p-r/one':>9}",
        f"{'':36}{'Hz':>10}{'Hz':>9}{'':>9}{'Hz':>10}{'Hz':>9}{'':>9}",
    ]
    for r in rows:
        lines.append(f"{r.label:36}{r.achieved_hz:10.2f}{r.limit_hz:9.2f}"
                     f"{r.ratio_achieved_limit:9.3f}{r.per_register_hz:10.2f}"
                     f"{r.per_register_limit_hz:9.2f}{r.ratio_per_register_achieved:9.3f}")
    lines.append("achieved: updates a second of the manager's bus owner: one READ of the 17 "
                 "bytes goal_position..moving per motor + one SYNC_WRITE of 20 goals per update")
    lines.append("limit: 1 / (20 x ((8 + 23) bytes x 10 / baud + return delay) + (8 + 3 x 20) "
                 f"bytes x 10 / baud); per-reg: {per_motor} READs per motor instead")
    for r in rows:
        lines.append(f"  {r.label}: ratio achieved/limit = {r.ratio_achieved_limit:.3f}, "
                     f"ratio per-register/one-READ = {r.ratio_per_register_achieved:.3f} "
                     f"(limits {r.ratio_per_register_limit:.3f}), "
                     f"{r.transactions_per_update:g} transactions/update; owner: sweep_rate "
                     f"{r.owner_sweep_hz:.2f} Hz (x{r.owner_sweep_hz / r.achieved_hz:.3f} of "
                     f"achieved), sweep_time {r.owner_sweep_ms:.2f} ms, "
                     f"{r.goals_per_update:g} goals written/update, "
                     f"{r.goals_replaced} replaced")
    lines.append("(the manager's configured update_rate, 20 Hz in the shipped armstrong.yaml, and "
                 "the owner's sweep period were lifted here; with them the 1 000 000 bps buses "
                 "update at 20 Hz)")
    slow = [r for r in rows if r.baudrate == 57_142]
    lines.append(f"original (seed 001's ROS driver, 57142 bps): {SEED_ROS_HZ[0]:g}-"
                 f"{SEED_ROS_HZ[1]:g} Hz; here at 57142 bps: "
                 + ", ".join(f"{r.achieved_hz:.1f} Hz (return delay {r.return_delay_ms:g} ms,"
                             f" x{r.achieved_hz / SEED_ROS_HZ[1]:.1f}-"
                             f"{r.achieved_hz / SEED_ROS_HZ[0]:.1f})" for r in slow))
    return "\n".join(lines)


# -- part 3: a real-time walk over a pty ----------------------------------------------------

ROOT = Path(__file__).resolve().parents[1]
PTY_BAUDS = (57_142, 1_000_000)
PTY_MOTORS = "rx28:11-16,21-26,31-33,41-43,51,61"
STAND_ROWS, GAIT_ROWS = 40, 17      # the stand's 20 Hz poses, then one step of the gait
LEG_MOTORS = 12                     # m11..m16, m21..m26: the first twelve motor columns
SHIPPED_BAUD = "baud_rate: 57142.0"
PING_RANGE = "      max_motor_id: 65\n"
WALK_TIMEOUT = 180.0                # s


@dataclasses.dataclass
class PtyWalk:
    """One real-time walk: ``servolab walk --steps 1`` over ``servolab sim --pty``."""

    baudrate: int
    rows_played: int
    rows_commanded: int             # gait rows that changed a leg motor's goal (of 12 x 17)
    rows_delivered: int             # of those, read back in the goal register within a row
    ratio_delivered: float          # delivered / commanded
    never_read_back: int
    row_period_ms: float
    worst_delay_ms: float | None    # the longest a row took to be read back (of those that were)
    ratio_worst_delay_row: float | None  # worst delay / row period
    state_rate_hz: float            # summary.json: the sweep rate achieved
    state_rate_wire_limit_hz: float
    ratio_state_limit: float        # achieved / wire limit
    update_rate_hz: float           # configured: the owner sweeps at most this often
    ratio_state_asked: float        # achieved / min(update_rate, wire limit)
    goals_written: int
    goals_replaced: int
    walk_wall_s: float              # the walk process, start-up (pinging) and all

    @property
    def label(self) -> str:
        return f"pty {self.baudrate} bps"


def _repo_helpers() -> tuple[Any, Any]:
    """tests/simproc.py's ``sim_process`` and tests/robots/armstrong/delivery.py's
    ``goal_deliveries``: the ones the real-time test uses (the repository's root on the path,
    as pytest has it)."""
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    from tests.robots.armstrong.delivery import goal_deliveries
    from tests.simproc import sim_process
    return sim_process, goal_deliveries


def robot_config(baud: int, folder: Path, *, ping_once: bool = False) -> Path | None:
    """The configuration for ``baud``: None (the shipped one) at its 57142 bps, else a copy
    saying ``baud_rate: <baud>.0`` and nothing else changed; with ``ping_once`` (``--quick``)
    a copy whose manager pings each absent ID once rather than five times, which is not what
    the figures measure (the walk's rows and state rate), and 8 s of its start at 57142 bps."""
    shipped = Path(str(armstrong.CONFIG)).read_text()
    if f"baud_rate: {baud:.1f}" in shipped and not ping_once:
        return None
    if shipped.count(SHIPPED_BAUD) != 1 or shipped.count(PING_RANGE) != 1:
        raise RuntimeError(f"{armstrong.CONFIG}: expected one {SHIPPED_BAUD!r} and one "
                           f"{PING_RANGE.strip()!r} to replace")
    text = shipped.replace(SHIPPED_BAUD, f"baud_rate: {baud:.1f}")
    if ping_once:
        text = text.replace(PING_RANGE, PING_RANGE + "      ping_retries: 1\n")
    path = folder / f"armstrong_{baud}.yaml"
    path.write_text(text)
    return path


def measure_pty(baud: int, folder: Path, *, ping_once: bool = False) -> PtyWalk:
    """``servolab sim --pty`` at ``baud`` and ``servolab walk --steps 1`` on it, in real
    time; the figures from the walk's run folder."""
    sim_process, goal_deliveries = _repo_helpers()
    folder.mkdir(parents=True, exist_ok=True)
    config_path = robot_config(baud, folder, ping_once=ping_once)
    config = armstrong.load_config(config_path)
    legs = {f"m{c.motor.id}": c for c in config.controllers}
    inits = {legs[m].motor.id: legs[m].motor.init for m in MOTORS[:LEG_MOTORS]}
    port = config.manager.serial_ports[0]
    out = folder / "walk"
    with sim_process("--motors", PTY_MOTORS, "--baud", str(baud),
                     out_dir=folder / "sim") as (pty, _):
        cmd = [sys.executable, "-m", "servolab", "walk", "--steps", "1", "--port", pty,
               "--no-progress", "--out", str(out)]
        if config_path is not None:
            cmd += ["--config", str(config_path)]
        began = time.perf_counter()
        result = subprocess.run(cmd, capture_output=True, text=True, timeout=WALK_TIMEOUT,
                                stdin=subprocess.DEVNULL)
        wall = time.perf_counter() - began
    if result.returncode != 0:
        raise RuntimeError(f"servolab walk at {baud} bps: exit {result.returncode}: "
                           f"{result.stderr[-2000:]}")
    summary = json.loads((out / "summary.json").read_text())
    row_period = 1.0 / float(summary["rate_hz"])
    deliveries = goal_deliveries(Path(summary["bag"]), inits,
                                 rows=slice(STAND_ROWS, STAND_ROWS + GAIT_ROWS))
    delays = [d for delivery in deliveries.values() for d in delivery.delays]
    seen = [d for d in delays if d is not None]
    delivered = sum(d <= row_period for d in seen)
    worst = max(seen) if seen else None
    rate = float(summary["state_rate_hz"])
    limit = float(summary["state_rate_wire_limit_hz"])
    asked = float(port.update_rate)
    return PtyWalk(
        baud, int(summary["rows_played"]), len(delays), delivered,
        delivered / len(delays) if delays else math.nan, len(delays) - len(seen),
        row_period * 1e3, None if worst is None else worst * 1e3,
        None if worst is None else worst / row_period, rate, limit, rate / limit, asked,
        rate / min(asked, limit), int(summary["goals"]["written"]),
        int(summary["goals"]["replaced_before_written"]), wall)


def pty_report(rows: Sequence[PtyWalk]) -> str:
    lines = [
        "",
        f"real time over a pty: servolab sim --pty --motors {PTY_MOTORS}, servolab walk "
        "--steps 1 (wall clock)",
        f"{'bus':18}{'delivered':>11}{'del/cmd':>9}{'worst':>9}{'wst/row':>9}"
        f"{'state':>9}{'limit':>9}{'st/lim':>8}{'asked':>8}{'st/ask':>8}",
        f"{'':18}{'rows':>11}{'':>9}{'ms':>9}{'':>9}{'Hz':>9}{'Hz':>9}{'':>8}{'Hz':>8}{'':>8}",
    ]
    for r in rows:
        worst = "-" if r.worst_delay_ms is None else f"{r.worst_delay_ms:.1f}"
        worst_ratio = "-" if r.ratio_worst_delay_row is None else f"{r.ratio_worst_delay_row:.3f}"
        lines.append(f"{r.label:18}{f'{r.rows_delivered}/{r.rows_commanded}':>11}"
                     f"{r.ratio_delivered:9.3f}{worst:>9}{worst_ratio:>9}"
                     f"{r.state_rate_hz:9.2f}{r.state_rate_wire_limit_hz:9.2f}"
                     f"{r.ratio_state_limit:8.3f}{r.update_rate_hz:8.3g}"
                     f"{r.ratio_state_asked:8.3f}")
    lines.append(f"delivered: gait rows (index {STAND_ROWS}..{STAND_ROWS + GAIT_ROWS - 1} of the "
                 f"commands, after the stand) x {LEG_MOTORS} leg motors read back in the goal "
                 "register within one row period; worst: the longest delay of those read back")
    lines.append("state: summary.json's state_rate_hz; limit: its state_rate_wire_limit_hz (the "
                 "manager's wire time); asked: the configured update_rate; st/ask: state / "
                 "min(asked, limit)")
    for r in rows:
        lines.append(f"  {r.label}: ratio delivered/commanded = {r.ratio_delivered:.3f} "
                     f"({r.never_read_back} never read back), ratio state/limit = "
                     f"{r.ratio_state_limit:.3f}, {r.rows_played} rows played, "
                     f"{r.goals_written} goals written, {r.goals_replaced} replaced before "
                     f"written, walk {r.walk_wall_s:.1f} s")
    lines.append("before the bus owner (issue 27): the controllers processed 144 of 1 197 "
                 "commands at 57142 bps, 1 140 of 1 197 at 1 000 000 bps")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true",
                        help=f"{QUICK_STEPS} steps, one repeat, {QUICK_UPDATES} manager "
                        "updates: checks that it runs (the pty walks are the same: one step "
                        "each, on both buses)")
    parser.add_argument("--no-pty", action="store_true",
                        help="leave out the real-time walks over a pty")
    parser.add_argument("--pty-out", type=Path, metavar="DIR",
                        help="keep the pty walks' run folders here (default: a temporary "
                        "folder)")
    parser.add_argument("--json", type=Path, metavar="PATH", help="also write the figures here")
    args = parser.parse_args(argv)
    steps = QUICK_STEPS if args.quick else FULL_STEPS
    repeat = 1 if args.quick else 5
    params = GaitParameters(c_step=steps)

    vectorised = generate_walk(params).motors
    looped = np.asarray(loop_walk(params))
    error = float(np.max(np.abs(vectorised - looped)))
    t_vec = best_time(lambda: generate_walk(params), repeat)
    t_loop = best_time(lambda: loop_walk(params), repeat)
    samples = vectorised.shape[0]

    print(f"servolab gait benchmark: Python {platform.python_version()}, numpy "
          f"{np.__version__}, {platform.machine()}{' (quick)' if args.quick else ''}")
    print(f"{steps} steps = {samples} samples x 21 motors (generate + IK of both legs)")
    print(f"vectorised (numpy):  {t_vec * 1e3:9.3f} ms  ({t_vec / samples * 1e6:.2f} us/sample)")
    print(f"per-sample loop:     {t_loop * 1e3:9.3f} ms  ({t_loop / samples * 1e6:.2f} us/sample)")
    print(f"ratio loop / vectorised: x{t_loop / t_vec:.1f}")
    print(f"largest difference between the two: {error:.2e} deg")

    updates = QUICK_UPDATES if args.quick else FULL_UPDATES
    rows = [measure_manager(baud, delay, updates) for baud, delay in MANAGER_BUSES]
    print(manager_report(rows))
    sane = all(math.isfinite(v) and v > 0 for r in rows
               for v in (r.achieved_hz, r.limit_hz, r.per_register_hz, r.per_register_limit_hz,
                         r.owner_sweep_hz, r.owner_sweep_ms))

    walks: list[PtyWalk] = []
    if not args.no_pty:
        with tempfile.TemporaryDirectory(prefix="servolab-gait-bench-") as scratch:
            base = args.pty_out or Path(scratch)
            bauds = PTY_BAUDS[:1] if args.quick else PTY_BAUDS
            walks = [measure_pty(baud, base / f"pty_{baud}", ping_once=args.quick)
                     for baud in bauds]
        print(pty_report(walks))
        if args.pty_out:
            print(f"(run folders in {args.pty_out})")
        sane = sane and all(
            w.rows_played == GAIT_ROWS and 0 < w.rows_commanded <= LEG_MOTORS * GAIT_ROWS
            and 0 <= w.rows_delivered <= w.rows_commanded
            and all(math.isfinite(v) and v > 0 for v in (w.state_rate_hz,
                                                          w.state_rate_wire_limit_hz))
            and w.state_rate_hz <= 1.02 * min(w.update_rate_hz, w.state_rate_wire_limit_hz)
            for w in walks)
    if args.json:
        figures = {
            "quick": args.quick,
            "gait": {"steps": steps, "samples": samples, "vectorised_s": t_vec,
                     "loop_s": t_loop, "ratio_loop_vectorised": t_loop / t_vec,
                     "max_difference_deg": error},
            "manager": {"updates": updates, "seed_ros_hz": list(SEED_ROS_HZ),
                        "buses": [dataclasses.asdict(r) | {"label": r.label} for r in rows]},
            "pty": None if args.no_pty else {
                "motors": PTY_MOTORS, "stand_rows": STAND_ROWS, "gait_rows": GAIT_ROWS,
                "leg_motors": LEG_MOTORS,
                "buses": [dataclasses.asdict(w) | {"label": w.label} for w in walks]},
        }
        args.json.write_text(json.dumps(figures, indent=2) + "\n")
        print(f"\nfigures written to {args.json}")
    return 0 if error < 1e-9 and math.isfinite(t_loop / t_vec) and sane else 1


if __name__ == "__main__":
    sys.exit(main())
