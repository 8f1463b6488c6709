"""What vectorising the walking-pattern generator buys: the time to generate a walk of N steps
(half cycles, seed 001 Appendix D) and solve both legs' inverse kinematics and motor angles
(Appendix E), through ``servolab.gait.walking.generate_walk`` (numpy, whole arrays), against a
per-sample Python loop of the same maths (Appendix D statement by statement, the closed-form
leg of seeds/README.md with ``math``, the same motor signs and arm swing).

Both are timed in the same run, best of a few repeats, so their ratio carries over to other
machines better than the absolute figures. The loop's result is checked against the
vectorised one (the run fails if they differ by more than 1e-9 degrees).

**Controller manager update rate** (issue 16). The emulated Armstrong (20 RX-28, Protocol 1.0)
on four buses: 57142 bps and 1 000 000 bps, each with the RX-28's factory return delay (raw
250 = 0.5 ms) and with return delay 0 (written to every motor before the manager starts, so
its own wire time sees it). Every controller is given a new goal before each update, so every
update SYNC_WRITEs the 20 goals and READs each motor's state registers (present_position ..
moving, 11 bytes) in one packet. The manager runs on its own timer (its configured
update_rate lifted, so that only the wire bounds it) through the context's executor on the
simulation's virtual clock; on the emulated bus that clock advances by each transaction's
wire time, so the achieved rate is the rate the wire allows this driver (the host's CPU time
and the USB adapter's latency are not in it). Beside it:

- the wire-time limit, computed here from the Protocol 1.0 packet sizes: per motor a READ
  instruction of 8 bytes, a status of 6 + 11 bytes and one return delay, plus the SYNC_WRITE
  of 8 + 3 x 20 bytes, at 10 bits a byte; the limit is 1 / that time, and the ratio achieved /
  limit says how close the manager gets to it;
- what one READ per register would give (six READs per motor, as a driver reading register by
  register would send): its limit computed the same way, and the rate measured by reading
  ``bus.read(id, name)`` register by register (plus the same SYNC_WRITE) on the same emulated
  bus, as a ratio against the one-READ figure;
- the original's: seed 001's ROS driver achieved 3 to 4 Hz at 57142 bps.

Run: ``.venv/bin/python benchmarks/gait.py [--quick] [--json PATH]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import math
import platform
import sys
import timeit
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from servolab.dynamixel.models import model
from servolab.gait.walking import GaitParameters, generate_walk
from servolab.kinematics.leg import ARMSTRONG_LEG, LegGeometry
from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.robots.armstrong import hardware as armstrong
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

FULL_UPDATES, QUICK_UPDATES = 200, 10
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
    achieved_hz: float              # the manager on its timer, one READ per motor
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
        # The configured update_rate (20 Hz) lifted: the manager updates as fast as its
        # wire_time() says the wire allows.
        port = dataclasses.replace(port, update_rate=1e6)
        manager = DynamixelManager(context, bus, port, config.controllers)
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
        context.spin_until(lambda: manager.updates >= first + updates)
        elapsed = sim.now() - start
        done = manager.updates - first
        per_update = (bus.stats.transactions - sent) / done
        achieved = done / elapsed
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
                       per_update, wire_ms, achieved, limit, achieved / limit, per_register,
                       per_register_limit, per_register_limit / limit, per_register / achieved)


def manager_report(rows: Sequence[ManagerRate]) -> str:
    lines = [
        "",
        "controller manager update rate: emulated Armstrong, 20 RX-28 (Protocol 1.0), "
        "simulated wire time",
        f"{'bus':36}{'achieved':>10}{'limit':>9}{'ach/lim':>9}"
        f"{'per-reg':>10}{'p-r lim':>9}{'p-r/one':>9}",
        f"{'':36}{'Hz':>10}{'Hz':>9}{'':>9}{'Hz':>10}{'Hz':>9}{'':>9}",
    ]
    for r in rows:
        lines.append(f"{r.label:36}{r.achieved_hz:10.2f}{r.limit_hz:9.2f}"
                     f"{r.ratio_achieved_limit:9.3f}{r.per_register_hz:10.2f}"
                     f"{r.per_register_limit_hz:9.2f}{r.ratio_per_register_achieved:9.3f}")
    lines.append("achieved: the manager on its timer, one READ of present_position..moving per "
                 "motor + one SYNC_WRITE of 20 goals per update")
    lines.append("limit: 1 / (20 x ((8 + 17) bytes x 10 / baud + return delay) + 68 bytes x 10 "
                 "/ baud); per-reg: six READs per motor instead")
    for r in rows:
        lines.append(f"  {r.label}: ratio achieved/limit = {r.ratio_achieved_limit:.3f}, "
                     f"ratio per-register/one-READ = {r.ratio_per_register_achieved:.3f} "
                     f"(limits {r.ratio_per_register_limit:.3f}), "
                     f"{r.transactions_per_update:g} transactions/update")
    lines.append("(the manager's configured update_rate, 20 Hz in the shipped armstrong.yaml, was "
                 "lifted here; with it the 1 000 000 bps buses update at 20 Hz)")
    slow = [r for r in rows if r.baudrate == 57_142]
    lines.append(f"original (seed 001's ROS driver, 57142 bps): {SEED_ROS_HZ[0]:g}-"
                 f"{SEED_ROS_HZ[1]:g} Hz; here at 57142 bps: "
                 + ", ".join(f"{r.achieved_hz:.1f} Hz (return delay {r.return_delay_ms:g} ms,"
                             f" x{r.achieved_hz / SEED_ROS_HZ[1]:.1f}-"
                             f"{r.achieved_hz / SEED_ROS_HZ[0]:.1f})" for r in slow))
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true",
                        help=f"{QUICK_STEPS} steps, one repeat, {QUICK_UPDATES} manager "
                        "updates: checks that it runs")
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
               for v in (r.achieved_hz, r.limit_hz, r.per_register_hz, r.per_register_limit_hz))
    if args.json:
        figures = {
            "quick": args.quick,
            "gait": {"steps": steps, "samples": samples, "vectorised_s": t_vec,
                     "loop_s": t_loop, "ratio_loop_vectorised": t_loop / t_vec,
                     "max_difference_deg": error},
            "manager": {"updates": updates, "seed_ros_hz": list(SEED_ROS_HZ),
                        "buses": [dataclasses.asdict(r) | {"label": r.label} for r in rows]},
        }
        args.json.write_text(json.dumps(figures, indent=2) + "\n")
        print(f"\nfigures written to {args.json}")
    return 0 if error < 1e-9 and math.isfinite(t_loop / t_vec) and sane else 1


if __name__ == "__main__":
    sys.exit(main())
