"""How fast servolab's ros2_control update loop runs on a real-time serial line, against what
the wire allows.

A controller manager's update (read every motor -> update the active controllers -> write every
goal) is bound by its bus: ``update_rate`` asks for a rate; what it gets is at most the *wire
limit*, one update's bytes at the baud rate plus one return delay per answer. This benchmark
brings an N-joint XM430-W350 robot (Protocol 2.0, 1 Mbps; a URDF with a ``<ros2_control>``
block in the community ``dynamixel_hardware`` dialect, position command, position, velocity
and effort state) up under the controller manager, with ``joint_state_broadcaster`` and a
``JointGroupPositionController`` active, as ``servolab control run`` does.

**1. Wire time of one update.** The robot on emulated motors on a simulation's virtual clock
(every byte takes 10 bits' time, every motor answers after its return delay): the clock's
advance over one ``update_once`` is the time it occupies a real wire. Beside it the same figure
from the packet sizes of the Protocol 2.0 e-Manual (one SYNC_READ of present current, velocity
and position, 10 bytes from address 126, and one SYNC_WRITE of goal position), so the two
cross-check each other. Return delay at the factory 250 (0.5 ms) and at 0, the usual tuning.

**2. Achieved rate on a pty with every core busy.** ``servolab sim --pty`` serves the motors
at 1 Mbps in real time in its own process; one busy process per core loads the machine; the
controller manager runs in this process at each asked ``update_rate`` for ``--seconds``. Per
rate: the achieved rate (the manager's own ``achieved_rate``), achieved / asked, the
overruns (updates that began more than a period late), and achieved / the *anchor*: the same
SYNC_READ and SYNC_WRITE sent by servolab's bare ``Bus`` in a tight loop on the same pty, as
fast as the host and the pty allow, measured in the same run. The anchor over the wire
limit says what the pty and the host cost; the manager over the anchor what the manager,
the controllers and the executor cost on top.

Goal: the asked rate met (>= 95 %) wherever the anchor allows it, and >= 80 % of the anchor
where the asked rate is above what the line can carry.

Run: ``.venv/bin/python benchmarks/control.py [--joints N] [--seconds S] [--rates R ...]
[--load P] [--json PATH]``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from servolab.dynamixel import Bus
from servolab.dynamixel.wire import BITS_PER_BYTE
from servolab.middleware.parameters import ParameterOverrides
from servolab.robots.control.bringup import BringUpOptions, ControlSystem
from servolab.sim.pty_process import pty_process

MODEL = "XM430-W350"
BAUD = 1_000_000
#: the registers one update reads (DynamixelHardware's read: present current, velocity and
#: position, X-series addresses 126..135) and the one it writes
READ = ("present_current", "present_velocity", "present_position")
WRITE = "goal_position"
#: Protocol 2.0 packet sizes (e-Manual, "Protocol 2.0", Instruction and Status Packet):
#: header 4 + ID 1 + length 2 + instruction 1 + CRC 2 = 10 bytes around the parameters
FRAME = 10
READ_SPAN = 10  # bytes from present_current (126) to the end of present_position (135)


def urdf(joints: int, return_delay: int) -> str:
    """An N-joint robot of XM430-W350s at 1 Mbps, IDs 1..N, in dynamixel_hardware's words."""
    rows = []
    for i in range(1, joints + 1):
        rows.append(
            f'<joint name="joint{i}"><param name="id">{i}</param>'
            f'<param name="model">{MODEL}</param>'
            f'<param name="Return_Delay_Time">{return_delay}</param>'
            '<command_interface name="position"/><state_interface name="position"/>'
            '<state_interface name="velocity"/><state_interface name="effort"/></joint>')
    links = "".join(f'<link name="l{i}"/>' for i in range(joints + 1))
    urdf_joints = "".join(
        f'<joint name="joint{i}" type="revolute"><parent link="l{i - 1}"/>'
        f'<child link="l{i}"/><axis xyz="0 0 1"/>'
        '<limit lower="-3.0" upper="3.0" effort="4.1" velocity="4.8"/></joint>'
        for i in range(1, joints + 1))
    return (f'<robot name="bench">{links}{urdf_joints}<ros2_control name="bench" '
            'type="system"><hardware><plugin>dynamixel_hardware/DynamixelHardware</plugin>'
            f'<param name="usb_port">/dev/ttyUSB0</param><param name="baud_rate">{BAUD}'
            f'</param></hardware>{"".join(rows)}</ros2_control></robot>')


def controllers(joints: int, rate: float) -> str:
    names = ", ".join(f"joint{i}" for i in range(1, joints + 1))
    return (f"controller_manager:\n  ros__parameters:\n    update_rate: {rate:g}\n"
            "    joint_state_broadcaster:\n      type: joint_state_broadcaster/"
            "JointStateBroadcaster\n    position_controller:\n      type: position_"
            "controllers/JointGroupPositionController\nposition_controller:\n  "
            f"ros__parameters:\n    joints: [{names}]\n")


def bring_up(joints: int, rate: float, return_delay: int, *, port: str | None = None,
             real_time: bool = False) -> ControlSystem:
    return ControlSystem(urdf(joints, return_delay), "bench.urdf",
                         ParameterOverrides.from_text(controllers(joints, rate)),
                         BringUpOptions(port=port, real_time=real_time, state_publisher=False,
                                        spawn=("joint_state_broadcaster",
                                               "position_controller")))


def analytic_wire(joints: int, return_delay_s: float) -> float:
    """Seconds one update occupies the wire, from the packet sizes: SYNC_READ (address 2 +
    length 2 + N IDs) answered by N statuses (error 1 + the span), SYNC_WRITE (address 2 +
    length 2 + N x (ID + 4 bytes))."""
    sync_read = FRAME + 4 + joints
    statuses = joints * (FRAME + 1 + READ_SPAN)
    sync_write = FRAME + 4 + joints * 5
    return ((sync_read + statuses + sync_write) * BITS_PER_BYTE / BAUD
            + joints * return_delay_s)


def virtual_wire(joints: int, return_delay: int, updates: int = 50) -> float:
    """Seconds of virtual wire one update takes (the mean over ``updates``)."""
    system = bring_up(joints, 100.0, return_delay)
    try:
        simulation = system.simulation
        assert simulation is not None
        system.manager.update_once(simulation.now(), 0.01)  # the first one warms up
        start = simulation.now()
        for _ in range(updates):
            system.manager.update_once(simulation.now(), 0.01)
        return (simulation.now() - start) / updates
    finally:
        system.close()


@contextmanager
def busy(processes: int) -> Iterator[None]:
    spinners = [subprocess.Popen([sys.executable, "-c", "while True: pass"])
                for _ in range(processes)]
    try:
        yield
    finally:
        for p in spinners:
            p.kill()
            p.wait()


def anchor_rate(device: str, joints: int, seconds: float) -> float:
    """Updates a second servolab's bare Bus makes on ``device``: the same SYNC_READ and
    SYNC_WRITE as an update, in a tight loop, nothing else."""
    ids = list(range(1, joints + 1))
    with Bus.open(device, protocol=2, baudrate=BAUD) as bus:
        present = bus.sync_read(list(READ), ids)
        goals = {i: float(present[i]["present_position"]) for i in ids}
        count, start = 0, time.perf_counter()
        while time.perf_counter() - start < seconds:
            bus.sync_read(list(READ), ids)
            bus.sync_write(WRITE, goals)
            count += 1
        return count / (time.perf_counter() - start)


def manager_rate(device: str, joints: int, rate: float, seconds: float) -> dict[str, float]:
    system = bring_up(joints, rate, 0, port=device, real_time=True)
    try:
        manager = system.manager
        warm = manager.updates
        system.context.spin_for(0.5)
        overruns, first = manager.overruns, manager.updates
        start = time.perf_counter()
        system.context.spin_for(seconds)
        elapsed = time.perf_counter() - start
        return {"asked_hz": rate, "achieved_hz": (manager.updates - first) / elapsed,
                "window_hz": manager.achieved_rate,
                "overruns": manager.overruns - overruns, "warm_updates": first - warm}
    finally:
        system.close()


def set_return_delay(device: str, joints: int, raw: int) -> None:
    with Bus.open(device, protocol=2, baudrate=BAUD) as bus:
        for i in range(1, joints + 1):
            bus.write(i, "torque_enable", 0)
            bus.write(i, "return_delay_time", raw, raw=True)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--joints", type=int, default=5)
    parser.add_argument("--seconds", type=float, default=4.0)
    parser.add_argument("--rates", type=float, nargs="+", default=[100.0, 250.0, 500.0,
                                                                   1000.0])
    parser.add_argument("--load", type=int, default=os.cpu_count() or 2,
                        help="busy processes while the pty runs (default: one per core)")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args(argv)
    n = args.joints
    report: dict[str, Any] = {"joints": n, "model": MODEL, "baud": BAUD,
                              "load_processes": args.load}
    print(f"ros2_control update loop: {n} x {MODEL}, Protocol 2.0 at {BAUD} bps")
    print("\n1. Wire time of one update (read all, write all)")
    wire: dict[str, dict[str, float]] = {}
    for raw, label in ((250, "factory (0.5 ms)"), (0, "0")):
        measured = virtual_wire(n, raw)
        computed = analytic_wire(n, raw * 2e-6)
        wire[str(raw)] = {"virtual_s": measured, "packets_s": computed}
        print(f"   return delay {label:>16}: {measured * 1e3:6.3f} ms on the virtual wire, "
              f"{computed * 1e3:6.3f} ms from the packet sizes -> wire limit "
              f"{1 / measured:7.1f} Hz")
    report["wire"] = wire
    limit = 1 / wire["0"]["virtual_s"]
    print(f"\n2. On servolab sim --pty at {BAUD} bps, return delay 0, {args.load} busy "
          f"processes, {args.seconds:g} s a rate")
    rows = []
    motors = ("--motors", f"xm430-w350:1-{n}", "--baud", str(BAUD))
    with tempfile.TemporaryDirectory() as tmp, \
            pty_process(*motors, out_dir=Path(tmp) / "sim") as (device, _):
        set_return_delay(device, n, 0)
        with busy(args.load):
            anchor = anchor_rate(device, n, args.seconds)
            print(f"   anchor (bare Bus, same packets): {anchor:7.1f} Hz = "
                  f"{anchor / limit:5.1%} of the wire limit {limit:.1f} Hz")
            for rate in args.rates:
                row = manager_rate(device, n, rate, args.seconds)
                row["of_asked"] = row["achieved_hz"] / rate
                row["of_anchor"] = row["achieved_hz"] / anchor
                rows.append(row)
                met = "met" if row["of_asked"] >= 0.95 else (
                    "line-bound" if rate > anchor else "NOT met")
                print(f"   asked {rate:7.1f} Hz: achieved {row['achieved_hz']:7.1f} Hz "
                      f"({row['of_asked']:6.1%} of asked, {row['of_anchor']:6.1%} of the "
                      f"anchor), {row['overruns']:.0f} overruns  [{met}]")
    report["anchor_hz"] = anchor
    report["wire_limit_hz"] = limit
    report["rates"] = rows
    goals = [r["of_asked"] >= 0.95 if r["asked_hz"] <= 0.95 * anchor else
             r["of_anchor"] >= 0.80 for r in rows]
    print(f"\nGoal (asked rate met where the anchor allows it, >= 80 % of the anchor above): "
          f"{'met' if all(goals) else 'not met'}")
    if args.json:
        args.json.write_text(json.dumps(report, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
