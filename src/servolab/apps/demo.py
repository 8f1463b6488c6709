"""``servolab demo``: a tour of what servolab does, on emulated motors, in a few seconds.

It shows the Dynamixel layer: it builds an emulated bus like Armstrong's legs (RX-28 on
Protocol 1.0 at 57142 bps) and one like the fly treadmill's (XM430-W210 on Protocol 2.0 at
1 Mbps), scans them, moves a motor and prints what it saw; then the middleware: a talker and a
listener node on ``/cmd_vel``, recorded to an MCAP bag; then a simulated world: two wheels on a
floor, stepped by the simulation that owns time; last, each robot command's own short run (its
``Command.demo``): the biped stands up and walks a step, seed 000's wheeled robot drives a
figure of eight and navigates to a goal with its overhead camera, D* Lite and DWA, and a
simulated fly on the ball treadmill of seed 002 steers a robot. It saves plots, bags and
summary.json in the run folder. A robot whose command has a ``demo`` joins the tour by itself.

The Dynamixel layer, the middleware and matplotlib are imported inside the functions, so that
``servolab --help`` does not load them.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from typing import TYPE_CHECKING, TextIO

from .arguments import add_out
from .registry import Command

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from ..runs import RunFolder


def run(run_folder: RunFolder, stdout: TextIO = sys.stdout) -> dict[str, object]:
    import matplotlib

    matplotlib.use("Agg")

    def say(text: str = "") -> None:
        print(text, file=stdout, flush=True)

    figures: dict[str, object] = {}
    figures["rx28"], motion = _rx28(say)
    say()
    figures["xm430"] = _xm430(say)
    say()
    figures["nodes"] = _nodes(run_folder, say)
    say()
    figures["floor"] = _floor(say)
    say()
    figures.update(_robots(run_folder, say, first=5))

    plot = run_folder.save_figure(_motion_figure(*motion), "demo_motion.png")
    summary = run_folder.write_summary(figures)
    say()
    say(f"Plot: {plot}\nSummary: {summary}")
    return figures


Motion = tuple[list[float], list[float], list[float]]  # times (s), positions (rad), speeds (rad/s)


def _rx28(say: Callable[[str], None]) -> tuple[dict[str, object], Motion]:
    """Armstrong's left leg: six RX-28 on Protocol 1.0 at the factory 57142 bps; one moves."""
    from ..dynamixel.bus import Bus

    say("1. An emulated bus like Armstrong's left leg: RX-28 IDs 11-16, protocol 1.0, 57142 bps")
    bus = Bus.open("emu://rx28:11-16", baudrate=57142)
    clock = bus.port.clock
    found = bus.scan(range(0, 20))
    for r in found:
        say(f"   found ID {r.id:>2}: {r.model_name} (model number {r.model_number}, "
            f"firmware {r.firmware})")
    say("   torque on, moving_speed 1.5 rad/s, goal_position of motor 12 <- 0.8 rad")
    bus.write(12, "torque_enable", 1)
    bus.write(12, {"goal_position": 0.8, "moving_speed": 1.5})
    times: list[float] = []
    positions: list[float] = []
    speeds: list[float] = []
    t0 = clock.now()
    while clock.now() - t0 < 1.0:
        state = bus.read(12, ["present_position", "present_speed"])
        times.append(clock.now() - t0)
        positions.append(float(state["present_position"]))
        speeds.append(float(state["present_speed"]))
        clock.sleep(0.05)
    for i in range(0, len(times), 4):
        say(f"   t = {times[i]:5.3f} s   present_position = {positions[i]:+.3f} rad   "
            f"present_speed = {speeds[i]:+.3f} rad/s")
    say(f"   motor 12 reached {positions[-1]:+.3f} rad "
        f"(goal 0.8 rad, one RX-28 tick is {bus.model_of(12).rad_per_tick:.4f} rad)")
    return ({"motors_found": [r.id for r in found], "final_position_rad": positions[-1],
             "bus_stats": vars(bus.stats)}, (times, positions, speeds))


def _xm430(say: Callable[[str], None]) -> dict[str, object]:
    """The fly treadmill: three XM430-W210 on Protocol 2.0 at 1 Mbps, in velocity mode."""
    from ..dynamixel.bus import Bus

    say("2. An emulated bus like the fly treadmill: XM430-W210 IDs 1-3, protocol 2.0, 1 Mbps")
    xbus = Bus.open("emu://xm430-w210:1-3", baudrate=1_000_000)
    xclock = xbus.port.clock
    for r in xbus.broadcast_ping():
        say(f"   broadcast ping: ID {r.id}: {r.model_name} (firmware {r.firmware})")
    ids = [1, 2, 3]
    xbus.sync_write("operating_mode", {i: 1 for i in ids}, raw=True)  # velocity mode
    xbus.sync_write("torque_enable", {i: 1 for i in ids})
    goals = {1: 2.0, 2: -1.0, 3: 0.5}
    say(f"   SYNC_WRITE goal_velocity {goals} rad/s, then one SYNC_READ per 15 ms frame")
    t_cycle = xclock.now()
    xbus.sync_write("goal_velocity", goals)
    present = xbus.sync_read("present_position", ids)
    cycle_ms = (xclock.now() - t_cycle) * 1000
    xclock.sleep(1.0)
    present = xbus.sync_read("present_position", ids)
    for i in ids:
        say(f"   motor {i}: present_position after 1 s = {present[i]:+.3f} rad")
    say(f"   one write+read cycle takes {cycle_ms:.3f} ms of bus time at 1 Mbps")
    return {"present_position_rad": present, "cycle_ms": cycle_ms}


def _motion_figure(times: list[float], positions: list[float], speeds: list[float]) -> Figure:
    """The RX-28's move of section 1: position against its goal, and speed."""
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(6, 5), sharex=True)
    ax1.plot(times, positions, marker=".", label="present_position")
    ax1.axhline(0.8, color="gray", linestyle="--", label="goal_position")
    ax1.set_ylabel("rad")
    ax1.legend()
    ax1.set_title("Emulated RX-28 (ID 12) moving to 0.8 rad at 1.5 rad/s")
    ax2.plot(times, speeds, marker=".", color="tab:orange")
    ax2.set_ylabel("present_speed (rad/s)")
    ax2.set_xlabel("time (s)")
    return fig


def _robots(run_folder: RunFolder, say: Callable[[str], None], *, first: int
            ) -> dict[str, object]:
    """Each robot command's own short run (its ``Command.demo``), numbered from ``first``:
    the tour names no robot, so a robot that brings a command with a demo joins it."""
    from .registry import commands

    figures: dict[str, object] = {}
    for number, command in enumerate((c for c in commands() if c.demo is not None), first):
        if number > first:
            say("")
        assert command.demo is not None
        figures[command.name] = command.demo(run_folder, _numbered(say, number))
    return figures


def _numbered(say: Callable[[str], None], number: int) -> Callable[[str], None]:
    """``say``, with the section's number before its first line."""
    headed = False

    def numbered(text: str) -> None:
        nonlocal headed
        say(text if headed else f"{number}. {text}")
        headed = True

    return numbered


def _floor(say: Callable[[str], None]) -> dict[str, object]:
    """The smallest world: a two-wheel base on a floor, its wheels emulated XM430s."""
    import time

    from ..sim import DiffDriveFloor, Simulation

    say("4. A simulated world: two emulated XM430-W210 wheels on a floor (see docs/sim.md)")
    sim = Simulation()
    world = DiffDriveFloor.example(sim)  # velocity mode, left 2 rad/s, right 3 rad/s
    started = time.perf_counter()
    sim.advance(5.0)
    host = time.perf_counter() - started
    truth = world.ground_truth()
    say(f"   after 5 s of simulated time ({sim.steps} physics steps of 1 ms, "
        f"{5.0 / host:.0f}x faster than real time): x = {truth['x']:+.3f} m, "
        f"y = {truth['y']:+.3f} m, yaw = {truth['yaw']:+.3f} rad")
    return {"ground_truth": truth, "physics_steps": sim.steps,
            "real_time_factor": 5.0 / host}


def _nodes(run_folder: RunFolder, say: Callable[[str], None]) -> dict[str, object]:
    """Two nodes and a recorder on the in-process transport, in virtual time."""
    from ..clock import VirtualClock
    from ..middleware.bag import BagReader
    from ..middleware.context import Context
    from ..middleware.demo_nodes import Listener, Talker
    from ..middleware.recorder import Recorder

    say("3. Nodes and topics: a talker publishes /cmd_vel at 10 Hz, a listener and a recorder")
    say("   subscribe (in one process, in virtual time; see docs/middleware.md)")
    bag_path = run_folder.file("demo_bag")
    if bag_path.exists():
        import shutil

        shutil.rmtree(bag_path)
    with Context.open(clock=VirtualClock()) as ctx:
        Talker(ctx, parameter_overrides={"rate": 10.0})
        listener = Listener(ctx)
        recorder = Recorder(ctx, str(bag_path), ["/cmd_vel"])
        ctx.spin_until(lambda: len(listener.heard) >= 20, timeout=5.0)
        recorder.destroy()
    info = BagReader(bag_path, ctx.types).info()
    last = listener.heard[-1]
    say(f"   the listener heard {len(listener.heard)} Twist messages; the last: linear.x = "
        f"{last.linear.x:.2f} m/s, angular.z = {last.angular.z:+.3f} rad/s")
    say(f"   recorded {info.message_count} messages to {bag_path} "
        f"(open it with Foxglove, or: servolab bag info {bag_path})")
    return {"heard": len(listener.heard), "recorded": info.message_count,
            "bag": str(bag_path)}


def _run(args: argparse.Namespace) -> int:
    from ..runs import RunFolder

    run(RunFolder.create("demo", args.out))
    return 0


COMMAND = Command(
    name="demo", group="tools", help="a short tour on emulated motors (what 'make demo' runs)",
    description="A short tour of servolab on emulated motors and nodes, in a few seconds: "
    "it scans two buses, moves a motor, records a topic, and leaves a plot, a bag and "
    "summary.json in its run folder.",
    examples=("servolab demo", "servolab demo --out /tmp/demo"),
    add_arguments=add_out, run=_run)
