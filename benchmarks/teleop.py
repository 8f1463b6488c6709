"""How fast leader–follower teleoperation runs on two real-time serial lines, against what the
wires allow, and how closely the follower tracks.

``servolab teleop``'s loop (:mod:`servolab.robots.teleop.loop`) reads the leader's five present
positions in one SYNC_READ on its bus and writes the follower's five goal positions in one
SYNC_WRITE on its own, as fast as it can; every 20 ms it also reads the follower's state (one
SYNC_READ, Goal Position to Present Position), which checks that the last goals arrived.

**1. Wire time of one cycle.** Two emulated OpenMANIPULATOR-X (five XM430-W350, Protocol 2.0,
1 Mbps, return delay 0 as their URDF block sets it) on a simulation's virtual clock: the
clock's advance over a cycle (state reads off) is the time it occupies real wires. Beside it
the figure from the packet sizes (:func:`~servolab.robots.teleop.loop.cycle_wire_s`: SYNC_READ
of 5 positions + 5 statuses + SYNC_WRITE of 5 goals, 133 bytes, 1.33 ms): the *wire limit* is
its inverse, 752 Hz.

**2. On two ``servolab sim --pty`` at 1 Mbps, every core busy.** The leader is ``servolab sim
--robot open_manipulator_x_leader --pty`` (its horns moved by the scripted hand, in real time),
the follower ``servolab sim --robot open_manipulator_x --pty`` (on its table in MuJoCo, under
gravity), each a process of its own; one busy process per core loads the machine; the loop
runs in this process (``run_teleop``, as ``servolab teleop --leader PTY --follower PTY`` does)
for ``--seconds``. Printed: the achieved rate against the wire limit; against the *anchor*,
servolab's bare ``Bus`` sending the loop's packets (the SYNC_READ and the SYNC_WRITE, and the
state read every 20 ms) in a tight loop on the same ptys: what the ptys and the host allow,
measured in the same run, so that loop / anchor is what the loop's own work (the mapping, the
recording's thread) costs; the follower's tracking error
(|present - goal| at each state read, arm joints, p50 and p99); the commands lost (goals the
follower did not hold when its state was read: 0 expected).

Goal: no command lost, and the loop at >= 80 % of the anchor.

Run: ``.venv/bin/python benchmarks/teleop.py [--seconds S] [--load P] [--virtual] [--json
[PATH]]`` (``--json`` alone prints the report as JSON; ``--virtual``: part 1 and the loop on
in-process emulated arms only, no pty: what the quick test runs).
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from contextlib import ExitStack
from pathlib import Path
from typing import Any

from servolab.dynamixel import Bus
from servolab.robots.registry import default_robot
from servolab.robots.teleop.arms import STATE
from servolab.robots.teleop.hand import Episodes
from servolab.robots.teleop.leader import leader_of
from servolab.robots.teleop.loop import LoopOptions, cycle_wire_s
from servolab.robots.teleop.run import Arm, TeleopRequest, run_teleop
from servolab.runs import RunFolder
from servolab.sim.pty_process import pty_process

Say = Callable[[str], None]
BAUD = 1_000_000
#: the arm teleop runs by default, and its leader plug-in (what servolab sim serves)
DEFAULT_ARM = default_robot("teleop")
DEFAULT_LEADER = getattr(leader_of(DEFAULT_ARM), "name", f"{DEFAULT_ARM}_leader")
#: cycles whose virtual wire time part 1 averages
CYCLES = 50
#: rad/s: how fast the follower is brought to the leader before the run (servolab teleop's)
ENGAGE_SPEED = LoopOptions().engage_speed


def virtual_cycle(out: Path) -> dict[str, float]:
    """Part 1: seconds of virtual wire a cycle takes (state reads off), against the packet
    sizes."""
    from servolab.robots.teleop.run import TeleopTask, prepare

    request = TeleopRequest(camera=False, world="emulated",
                            options=LoopOptions(state_rate=1e-6))
    task = TeleopTask(RunFolder.create("teleop", out), prepare(request), lambda _: None, None)
    with ExitStack() as opened:
        task.open(opened)
        loop = task.loop
        assert loop is not None and task.simulation is not None and task.bag is not None
        loop.cycle()  # the first one (and the one state read) warms up
        start = task.simulation.now()
        for _ in range(CYCLES):
            loop.cycle()
        measured = (task.simulation.now() - start) / CYCLES
        task.bag.close()
    n = len(Arm.named(DEFAULT_ARM).system.joints)
    return {"virtual_s": measured, "packets_s": cycle_wire_s(n, n, BAUD, 0.0)}


def teleop(out: Path, seconds: float, leader: str, follower: str,
           engage_speed: float = ENGAGE_SPEED) -> dict[str, Any]:
    """One run of ``seconds`` (one episode), its summary."""
    request = TeleopRequest(leader=leader, follower=follower, camera=False,
                            episodes=Episodes(seconds, 1, 0.0),
                            options=LoopOptions(engage_speed=engage_speed))
    return run_teleop(RunFolder.create("teleop", out), request, say=lambda _: None)


def anchor_rate(leader: str, follower: str, seconds: float) -> float:
    """Cycles a second servolab's bare Bus makes on the two ptys with the loop's packets: one
    SYNC_READ of the leader's positions, one SYNC_WRITE of the follower's goals (where it
    holds), and every 1 / ``state_rate`` s the follower's state read; nothing else."""
    system = Arm.named(DEFAULT_ARM).system
    ids = [j.id for j in system.joints]
    every = 1.0 / LoopOptions().state_rate
    with Bus.open(leader, protocol=2, baudrate=BAUD) as lead, \
            Bus.open(follower, protocol=2, baudrate=BAUD) as follow:
        held = follow.sync_read("goal_position", ids, raw=True)
        count, start = 0, time.perf_counter()
        state = start
        while (now := time.perf_counter()) - start < seconds:
            lead.sync_read("present_position", ids)
            follow.sync_write("goal_position", held, raw=True)
            if now >= state:
                follow.sync_read(list(STATE), ids, raw=True)
                state += every
            count += 1
        return count / (time.perf_counter() - start)


def figures(summary: dict[str, Any]) -> dict[str, Any]:
    """What the report keeps of a run's summary."""
    loop = summary["loop"]
    arm = loop.get("tracking_error_arm_rad", {})
    return {"achieved_hz": loop["achieved_hz"], "cycles": loop["cycles"],
            "of_wire_limit": loop.get("of_wire_limit"),
            "tracking_p50_rad": arm.get("p50"), "tracking_p99_rad": arm.get("p99"),
            "commands_sent": loop["commands_sent"], "commands_checked":
            loop["commands_checked"], "commands_lost": loop["commands_lost"],
            "leader_failures": loop["leader_failures"], "engage_s": loop["engage_s"]}


def load(processes: int) -> ExitStack:
    """``processes`` busy processes, killed when the stack closes."""
    stack = ExitStack()
    for _ in range(processes):
        burner = subprocess.Popen([sys.executable, "-c", "while True: pass"],
                                  stdin=subprocess.DEVNULL)
        stack.callback(burner.wait)
        stack.callback(burner.kill)
    return stack


def say_run(run: dict[str, Any], limit: float, say: Say) -> None:
    say(f"   achieved {run['achieved_hz']:7.1f} Hz = {run['achieved_hz'] / limit:5.1%} of "
        f"the wire limit ({run['cycles']} cycles)")
    if run["tracking_p50_rad"] is not None:
        say(f"   tracking error (arm joints): p50 {run['tracking_p50_rad'] * 1e3:.1f} mrad, "
            f"p99 {run['tracking_p99_rad'] * 1e3:.1f} mrad")
    say(f"   commands lost: {run['commands_lost']} of {run['commands_checked']} checked "
        f"({run['commands_sent']} sent); leader reads failed: {run['leader_failures']}")


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=5.0,
                        help="the loop's measured run (after the follower engages)")
    parser.add_argument("--load", type=int, default=os.cpu_count() or 2,
                        help="busy processes while the ptys run (default: one per core)")
    parser.add_argument("--virtual", action="store_true",
                        help="in-process emulated arms on virtual time only (no pty)")
    parser.add_argument("--engage-speed", type=float, default=ENGAGE_SPEED, metavar="RAD_S",
                        help="how fast the follower is brought to the leader before the "
                        f"measured run (default {ENGAGE_SPEED:g}, servolab teleop's)")
    parser.add_argument("--json", nargs="?", const="-", default=None, metavar="PATH",
                        help="the report as JSON: printed (no PATH) or written to PATH")
    args = parser.parse_args(argv)
    # the lines for a person go to stderr when the JSON goes to stdout
    say: Say = functools.partial(print, file=sys.stderr if args.json == "-" else sys.stdout)
    report: dict[str, Any] = {"arm": DEFAULT_ARM, "baud": BAUD, "seconds": args.seconds}
    say(f"teleoperation: two {DEFAULT_ARM}, Protocol 2.0 at {BAUD} bps")
    with tempfile.TemporaryDirectory() as tmp:
        wire = virtual_cycle(Path(tmp) / "wire")
        limit = 1.0 / wire["packets_s"]
        report["wire"] = {**wire, "wire_limit_hz": limit}
        say(f"\n1. One cycle: {wire['virtual_s'] * 1e3:.3f} ms on the virtual wire, "
            f"{wire['packets_s'] * 1e3:.3f} ms from the packet sizes -> wire limit "
            f"{limit:.1f} Hz")
        if args.virtual:
            say("\n2. (--virtual) the loop on in-process emulated arms, in virtual time:")
            run = figures(teleop(Path(tmp) / "virtual", args.seconds, "emu://", "emu://",
                                 args.engage_speed))
            report["virtual"] = run
            say_run(run, limit, say)
        else:
            report.update(on_ptys(Path(tmp), args, limit, say))
    if args.json == "-":
        print(json.dumps(report, indent=2))
    elif args.json:
        Path(args.json).write_text(json.dumps(report, indent=2))
    return 0


def on_ptys(tmp: Path, args: argparse.Namespace, limit: float, say: Say) -> dict[str, Any]:
    """Part 2: the loop and the anchor on two ptys, every core busy."""
    seconds, processes = args.seconds, args.load
    say(f"\n2. On two servolab sim --pty at {BAUD} bps ({DEFAULT_LEADER}: the scripted "
        f"hand; {DEFAULT_ARM}: MuJoCo), {processes} busy processes, {seconds:g} s")
    with pty_process("--robot", DEFAULT_LEADER, out_dir=tmp / "leader") as (leader, _), \
            pty_process("--robot", DEFAULT_ARM, out_dir=tmp / "follower") as (follower, _), \
            load(processes):
        # the anchor before and after the loop: the load on a shared machine drifts
        before = anchor_rate(leader, follower, min(seconds, 3.0) / 2)
        run = figures(teleop(tmp / "run", seconds, leader, follower, args.engage_speed))
        anchor = (before + anchor_rate(leader, follower, min(seconds, 3.0) / 2)) / 2
    say_run(run, limit, say)
    run["of_anchor"] = run["achieved_hz"] / anchor
    say(f"   anchor (bare Bus, same packets): {anchor:7.1f} Hz = {anchor / limit:5.1%} of "
        f"the wire limit; the loop at {run['of_anchor']:5.1%} of it")
    met = run["commands_lost"] == 0 and run["of_anchor"] >= 0.8
    say(f"\nGoal (no command lost, >= 80 % of the anchor): {'met' if met else 'not met'}")
    return {"pty": run, "anchor_hz": anchor, "load_processes": processes, "goal_met": met}


if __name__ == "__main__":
    raise SystemExit(main())
