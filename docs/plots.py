"""Make the figures of docs/dynamixel.md, sim.md, biped.md, mobile.md, navigation.md,
treadmill.md, arm.md and fleets.md from the code itself, and the numbers those docs quote from
a run: ``python docs/plots.py [DIR] [--quick] [--spread]``.

Every figure is measured on emulated motors with the virtual clock, so they are exact and take
seconds to make, but for the 100 s treadmill run (about a minute), and but for fleet_scale.png
and sim_speed.png, measured in real time by benchmarks/fleet.py and benchmarks/sim.py (they
show this machine; no doc quotes a number from them). ``--quick`` shortens that
run to 10 s, for the test, and the corner run of docs/navigation.md (a figure only, no number)
to its first 10 s. The numbers go to ``DIR/figures.json`` (see :data:`FIGURES`);
``--spread`` also runs seeds 1 to 3 of every seeded run and prints how far each number moves
from seed 0's, the noise a doc states beside it.

``tests/test_docs.py`` runs this script with ``--quick``, so a figure in the docs cannot drift
from what the code does, and checks the numbers: each doc must write each number as
``figures.json`` has it, and the new run must give it again within the noise the doc states.
"""

from __future__ import annotations

import json
import math
import os
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from servolab.dynamixel import Bus

#: the seeds --spread runs besides seed 0
SPREAD_SEEDS = (1, 2, 3)
#: how long the treadmill runs, in simulated seconds: the docs' run, and --quick's
TREADMILL_S, TREADMILL_QUICK_S = 100.0, 10.0
#: how long --quick lets the corner run of :func:`navigation_loop` drive, in simulated seconds
#: (it reaches its goal in about 38 s): its figure is drawn all the same, of the way so far
CORNER_QUICK_S = 10.0


@dataclass(frozen=True)
class Figure:
    """A number a doc quotes from a run: the doc, the noise it states beside the number (the
    largest difference from seed 0's value over seeds 1 to 3, as ``--spread`` prints it,
    rounded up; 0 where no seed changes it), and how the doc writes the two."""

    doc: str
    tolerance: float
    text: Callable[[float, float], str]
    #: the run that gives the number, as a user would type it
    run: str
    #: the number comes from the 100 s treadmill run, which --quick shortens
    shortened: bool = False


def _grouped(value: float) -> str:
    """``6599`` as the docs write it: ``6 599``."""
    return f"{value:,.0f}".replace(",", " ")


_FLYBALL = f"servolab flyball --duration {TREADMILL_S:g} --seed 0"
_NAVIGATE = "servolab navigate --goal 3.3 2.3 --seed 0"
_SLIP = "servolab drive circle --radius 0.5 --speed 0.2 --slip 0.05 --slip-jitter 0.1"
_FUSION = "docs/plots.py's fusion(): the circle of tests/estimation/test_kalman.py, rng seed 0"

#: Every number the docs quote from a run, by key. The text is searched in the doc with its
#: line breaks and repeated spaces made one space.
FIGURES: dict[str, Figure] = {
    "dynamixel.rx28_cycle_ms": Figure(
        "docs/dynamixel.md", 0.0, lambda v, t: f"about {v:.0f} ms per write-and-read cycle",
        "20 emulated RX-28 at 57142 bps, return delay 0: one SYNC_WRITE and 20 READs"),
    "dynamixel.rx28_cycle_1mbps_ms": Figure(
        "docs/dynamixel.md", 0.0, lambda v, t: f"At 1 Mbps the same cycle takes {v:.1f} ms",
        "20 emulated RX-28 at 1 Mbps, return delay 0: one SYNC_WRITE and 20 READs"),
    "biped.update_ms": Figure(
        "docs/biped.md", 0.0, lambda v, t: f"an update takes {v:.0f} ms",
        "Armstrong(): its controller manager's wire time of one update"),
    "biped.update_rate_hz": Figure(
        "docs/biped.md", 0.0, lambda v, t: f"updates at {v:.1f} Hz",
        "Armstrong(): the rate its controller manager updates at"),
    "biped.seed_fell_after_s": Figure(
        "docs/biped.md", 0.0, lambda v, t: f"falls {v:.2f} s after its first row",
        "servolab walk --world mujoco --steps 4"),
    "biped.zmp_forward_m": Figure(
        "docs/biped.md", 0.0, lambda v, t: f"{v:.3f} m forward",
        "servolab walk --world mujoco --gait zmp --steps 10"),
    "biped.zmp_margin_mm": Figure(
        "docs/biped.md", 0.0, lambda v, t: f"never nearer than {v:.1f} mm to the edge",
        "servolab walk --world mujoco --gait zmp --steps 10"),
    "biped.fault_rows": Figure(
        "docs/biped.md", 0.0, lambda v, t: f"after {v:.0f} of its 17 rows",
        "docs/plots.py's biped(): the knee made to overheat from row 5"),
    "mobile.circle_raw_slow": Figure(
        "docs/mobile.md", 0.0, lambda v, t: f"the same circle goes out as {v:.0f} and", _SLIP),
    "mobile.circle_raw_fast": Figure(
        "docs/mobile.md", 0.0, lambda v, t: f"and {v:.0f}, which is", _SLIP),
    "mobile.slip_closure_m": Figure(
        "docs/mobile.md", 0.01, lambda v, t: f"the truth ends {v:.2f} ± {t:g} m short", _SLIP),
    "mobile.fused_rmse": Figure(
        "docs/mobile.md", 0.6, lambda v, t: f"the fused estimate's RMSE is {v:.2f} ± {t:g}",
        _FUSION),
    "mobile.odometry_rmse": Figure(
        "docs/mobile.md", 0.8, lambda v, t: f"{v:.2f} ± {t:g} for odometry alone", _FUSION),
    "mobile.tracker_rmse": Figure(
        "docs/mobile.md", 0.15, lambda v, t: f"{v:.2f} ± {t:g} for the tracker alone",
        _FUSION),
    "navigation.path_length_m": Figure(
        "docs/navigation.md", 0.04, lambda v, t: f"drove {v:.2f} ± {t:g} m", _NAVIGATE),
    "navigation.seconds": Figure(
        "docs/navigation.md", 4.0, lambda v, t: f"in {v:.1f} ± {t:g} s of simulated time",
        _NAVIGATE),
    "navigation.goal_distance_mm": Figure(
        "docs/navigation.md", 30.0, lambda v, t: f"stopped {v:.0f} ± {t:g} mm from the goal",
        _NAVIGATE),
    "navigation.goal_yaw_error_deg": Figure(
        "docs/navigation.md", 5.0, lambda v, t: f"ended {v:.1f} ± {t:g}° from the goal's",
        _NAVIGATE),
    "navigation.min_clearance_mm": Figure(
        "docs/navigation.md", 70.0, lambda v, t: f"at least {v:.0f} ± {t:g} mm clear",
        _NAVIGATE),
    "navigation.estimate_error_mm": Figure(
        "docs/navigation.md", 1.5, lambda v, t: f"ended {v:.0f} ± {t:g} mm and", _NAVIGATE),
    "navigation.estimate_yaw_error_deg": Figure(
        "docs/navigation.md", 2.5, lambda v, t: f"and {v:.1f} ± {t:g}° from the truth",
        _NAVIGATE),
    "navigation.camera_frames": Figure(
        "docs/navigation.md", 40.0, lambda v, t: f"in all {v:.0f} ± {t:g} frames", _NAVIGATE),
    "navigation.repair_cells": Figure(
        "docs/navigation.md", 0.0, lambda v, t: f"The map changed in {v:.0f} cells", _NAVIGATE),
    "navigation.calibration_fx_px": Figure(
        "docs/navigation.md", 0.15, lambda v, t: f"fx {v:.2f} ± {t:g} px", _NAVIGATE),
    "navigation.calibration_rms_px": Figure(
        "docs/navigation.md", 0.01, lambda v, t: f"RMS error of {v:.2f} ± {t:g} px", _NAVIGATE),
    "treadmill.mean_distance_error_mm": Figure(
        "docs/treadmill.md", 0.25, lambda v, t: f"| {v:.3f} ± {t:g} mm |", _FLYBALL, True),
    "treadmill.mean_angle_error_deg": Figure(
        "docs/treadmill.md", 2.2, lambda v, t: f"| {v:.2f} ± {t:g}° |", _FLYBALL, True),
    "treadmill.response_delay_ms": Figure(
        "docs/treadmill.md", 4.0, lambda v, t: f"| {v:.0f} ± {t:g} ms |", _FLYBALL, True),
    "treadmill.frames": Figure(
        "docs/treadmill.md", 0.0, lambda v, t: f"| {_grouped(v)}, all", _FLYBALL, True),
    "treadmill.frames_with_fly": Figure(
        "docs/treadmill.md", 0.0, lambda v, t: f"all {_grouped(v)} |", _FLYBALL, True),
    "treadmill.sphere_path_mm": Figure(
        "docs/treadmill.md", 21.0, lambda v, t: f"fictive walk, {v:.0f} ± {t:g} mm long",
        _FLYBALL, True),
    "treadmill.robot_path_m": Figure(
        "docs/treadmill.md", 2.2, lambda v, t: f"from its encoder log: {v:.2f} ± {t:g} m",
        _FLYBALL, True),
    "treadmill.path_disparity": Figure(
        "docs/treadmill.md", 0.15, lambda v, t: f"Here it is {v:.3f} ± {t:g}", _FLYBALL, True),
    "treadmill.per_wheel_disparity": Figure(
        "docs/treadmill.md", 0.31, lambda v, t: f"| per-wheel (Listing 4) | {v:.3f} ± {t:g} |",
        _FLYBALL + " --clamp per-wheel", True),
    "treadmill.per_wheel_robot_path_m": Figure(
        "docs/treadmill.md", 2.5, lambda v, t: f"| {v:.2f} ± {t:g} m |",
        _FLYBALL + " --clamp per-wheel", True),
}


def _summary(run: Any) -> dict[str, Any]:
    """A run folder's ``summary.json``, as the run wrote it."""
    return dict(json.loads(run.file("summary.json").read_text()))


def joint_moves(path: Path) -> None:
    """An RX-28 in joint mode, sent to three goals at three moving speeds."""
    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    for speed in (0.5, 1.5, 0.0):
        bus = Bus.open("emu://rx28:1", baudrate=1_000_000)
        clock = bus.port.clock
        bus.write(1, "torque_enable", 1)
        bus.write(1, {"goal_position": 1.0, "moving_speed": speed})
        t0, times, pos = clock.now(), [], []
        while clock.now() - t0 < 2.5:
            times.append(clock.now() - t0)
            pos.append(bus.read(1, "present_position"))
            clock.sleep(0.02)
        label = "moving_speed 0 (= no-load speed)" if speed == 0 else f"moving_speed {speed} rad/s"
        ax.plot(times, pos, label=label)
    ax.axhline(1.0, color="gray", linestyle="--", linewidth=0.8)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("present_position (rad)")
    ax.set_title("Emulated RX-28, joint mode, goal_position 1.0 rad")
    ax.legend(loc="lower right", fontsize=8)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def profile_moves(path: Path) -> None:
    """An XM430-W350's profiles as ROBOTIS's figure draws them (e-Manual, Profile
    Velocity(112): velocity against time, t1 and t3 marked): Velocity Trajectory(136) and
    Present Velocity(128) read over the bus every 5 ms, for a trapezoid (Profile Velocity 100,
    Acceleration 10, 1 024 ticks), a triangle (the same over 300 ticks) and a time-based move
    (Drive Mode bit 2: span 1 000 ms, acceleration time 300 ms, 800 ticks). The dashed
    lines are the e-Manual's t1 = 64 x 100 / 10 ms and t3 = t1 + 1 024 / V."""
    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    moves = (("trapezoidal: V 100, A 10, 1024 ticks", 0, 100, 10, 1024),
             ("triangular: V 100, A 10, 300 ticks", 0, 100, 10, 300),
             ("time-based: 1000 ms, 300 ms, 800 ticks", 4, 1000, 300, 800))
    for label, drive_mode, velocity, acceleration, ticks in moves:
        bus = Bus.open("emu://xm430-w350:1", baudrate=1_000_000)
        clock = bus.port.clock
        bus.write(1, "drive_mode", drive_mode, raw=True)
        bus.write(1, "torque_enable", 1)
        bus.write(1, {"profile_acceleration": acceleration, "profile_velocity": velocity},
                  raw=True)
        start = bus.read(1, "present_position", raw=True)
        t0 = clock.now()
        bus.write(1, "goal_position", start + ticks, raw=True)
        times, desired, present = [], [], []
        while clock.now() - t0 < 1.6:
            raw = bus.read(1, ["velocity_trajectory", "present_velocity"], raw=True)
            times.append(clock.now() - t0)
            desired.append(raw["velocity_trajectory"])
            present.append(raw["present_velocity"])
            clock.sleep(0.005)
        line, = ax.plot(times, desired, label=f"{label} (Velocity Trajectory)")
        ax.plot(times, present, ".", markersize=2, color=line.get_color())
    t1 = 64 * 100 / 10 / 1000
    t3 = t1 + 1024 / (100 * 0.229 * 4096 / 60)
    for t, name in ((t1, "t1"), (t3, "t3")):
        ax.axvline(t, color="gray", linestyle="--", linewidth=0.8)
        ax.text(t, 104, name, ha="center", fontsize=8)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("velocity (0.229 rev/min units)")
    ax.set_title("Emulated XM430-W350: the profile generator (dots: Present Velocity)")
    ax.set_ylim(0, 150)
    ax.legend(loc="upper right", fontsize=7)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def cycle_time(path: Path) -> dict[str, float]:
    """Bus time of one cycle (write every goal, read every present position) vs motor count;
    returns docs/dynamixel.md's numbers, 20 RX-28's cycle at either baud rate."""
    configs = [("rx28", 1, 57142, "RX-28, 1.0, 57142 bps: SYNC_WRITE + READ each"),
               ("rx28", 1, 1_000_000, "RX-28, 1.0, 1 Mbps: SYNC_WRITE + READ each"),
               ("xm430-w210", 2, 1_000_000, "XM430, 2.0, 1 Mbps: SYNC_WRITE + SYNC_READ")]
    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    twenty: dict[tuple[str, int], float] = {}
    for name, _, baud, label in configs:
        counts, millis = [], []
        for n in (1, 2, 5, 10, 15, 20):
            bus = Bus.open(f"emu://{name}:1-{n}", baudrate=baud)
            ids = list(range(1, n + 1))
            bus.sync_write("return_delay_time", {i: 0 for i in ids})
            clock = bus.port.clock
            t0 = clock.now()
            bus.sync_write("goal_position", {i: 0.1 for i in ids})
            bus.sync_read("present_position", ids)
            counts.append(n)
            millis.append((clock.now() - t0) * 1000)
        twenty[name, baud] = millis[-1]
        ax.plot(counts, millis, marker="o", label=label)
    ax.axhline(50, color="gray", linestyle=":", linewidth=0.8)
    ax.text(1, 51, "20 Hz", fontsize=8, color="gray")
    ax.set_xlabel("motors on the bus")
    ax.set_ylabel("bus time per cycle (ms)")
    ax.set_yscale("log")
    ax.set_title("Wire time of one control cycle (return delay 0)")
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return {"dynamixel.rx28_cycle_ms": twenty["rx28", 57142],
            "dynamixel.rx28_cycle_1mbps_ms": twenty["rx28", 1_000_000]}


def floor_world(path: Path) -> None:
    """The floor world's example: two wheels told to drive an arc, the base's true path beside
    what the driver reads back from the wheel motors."""
    from servolab.sim import DiffDriveFloor, Simulation, port_to

    sim = Simulation()
    world = DiffDriveFloor.example(sim)
    bus = Bus(port_to(sim.emulators[0], sim, 1_000_000))
    times, xs, ys, left, right = [], [], [], [], []
    while sim.now() < 6.0:
        truth = world.ground_truth()
        speeds = bus.sync_read("present_velocity", [1, 2])
        times.append(sim.now())
        xs.append(truth["x"])
        ys.append(truth["y"])
        left.append(speeds[1])
        right.append(speeds[2])
        sim.advance(0.05)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9, 3.6))
    ax1.plot(xs, ys)
    ax1.plot(xs[0], ys[0], "o", color="tab:green", label="start")
    ax1.set_aspect("equal")
    ax1.set_xlabel("x (m)")
    ax1.set_ylabel("y (m)")
    ax1.set_title("Ground truth: the base's path")
    ax1.legend(fontsize=8)
    ax2.plot(times, left, label="left wheel (ID 1)")
    ax2.plot(times, right, label="right wheel (ID 2)")
    ax2.set_xlabel("time (s)")
    ax2.set_ylabel("present_velocity (rad/s)")
    ax2.set_title("What the driver reads on the bus")
    ax2.legend(fontsize=8)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def biped(out: Path) -> dict[str, float]:
    """docs/biped.md's figures: the seed's gait (feet, joint angles) and a walk of two steps
    on the emulated Armstrong (commanded against present angles); returns the wire time of
    the controller manager's update and the rate it updates at, as it prints them."""
    import shutil
    import tempfile

    from servolab.gait.plots import plot_foot_positions, plot_joint_angles
    from servolab.gait.walking import generate_walk
    from servolab.robots.armstrong.control_node import Armstrong
    from servolab.robots.armstrong.motions import load_motion
    from servolab.robots.armstrong.run import run_walk
    from servolab.runs import RunFolder

    walk = generate_walk()
    plot_foot_positions(walk, out / "gait_feet.png")
    plot_joint_angles(walk, out / "gait_joint_angles.png")
    with tempfile.TemporaryDirectory() as tmp:
        summary = run_walk(RunFolder.create("walk", tmp), load_motion(None), steps=2,
                           say=lambda text: None, show_progress=False)
        shutil.copy(str(summary["plot"]), out / "biped_walk.png")
        # a fault: the knee, warm (70 deg C) and quick to heat, made to hold 95 % of its torque
        # from row 5 (tests/robots/armstrong/test_supervisor.py's overheat)
        def heat(robot: Armstrong, row: int) -> None:
            if row == 5:
                motor = robot.bus.port.emulator.motor(14)  # type: ignore[attr-defined]
                motor.temperature = 70.0
                motor.thermal_time_constant = 2.0
                motor.external_load = 0.95

        fault = run_walk(RunFolder.create("walk", Path(tmp) / "fault"), load_motion(None),
                         steps=1, say=lambda text: None, show_progress=False, on_row=heat)
        shutil.copy(str(fault["alarm_plot"]), out / "biped_fault.png")
    with Armstrong() as robot:
        return {"biped.update_ms": robot.manager.update_time * 1000,
                "biped.update_rate_hz": robot.manager.rate,
                "biped.fault_rows": float(fault["rows_played"])}


def walk_in_mujoco(out: Path, plot: str, motion: Any, **walk: Any) -> tuple[dict[str, Any],
                                                                             Any]:
    """``servolab walk --world mujoco`` with ``motion``: its balance plot copied to
    ``out/plot``; returns the summary and the MuJoCo world (for frames to render)."""
    import shutil
    import tempfile

    from servolab.robots.armstrong.run import run_walk
    from servolab.runs import RunFolder

    captured: dict[str, Any] = {}

    def keep(robot: Any, row: int) -> None:
        captured["world"] = robot.physics.world

    with tempfile.TemporaryDirectory() as tmp:
        summary = run_walk(RunFolder.create("walk", tmp), motion, world="mujoco",
                           say=lambda text: None, show_progress=False, on_row=keep, **walk)
        shutil.copy(str(summary["physics_plot"]), out / plot)
    return summary, captured["world"]


def frame_at(world: Any, sample: Any, path: Path) -> None:
    """One sample of a MuJoCo walk drawn as the video draws it."""
    from servolab.sim.mujoco_video import render_frame

    render_frame(world.model, np.array(sample.qpos), path, track_body="pelvis")


def biped_physics(out: Path, *, quick: bool) -> dict[str, float]:
    """docs/biped.md's physics: the seed's gait as printed in the MuJoCo world (its balance
    plot, and a frame as it starts to tip), servolab's own gait (:func:`zmp_walk`), and — not
    with ``--quick``, 54 walks — the sweep of the assumptions the seed leaves open."""
    from servolab.robots.armstrong.motions import load_motion

    summary, world = walk_in_mujoco(out, "biped_physics_seed.png", load_motion(None),
                                    steps=4)
    physics = summary["physics"]
    tipping = physics.get("tipping_from_s", physics["fell_at_s"])
    frame_at(world, min(world.samples, key=lambda s: abs(s.t - (tipping + 0.25))),
             out / "biped_fall_frame.png")
    if not quick:
        sweep_figure(out)
    return {"biped.seed_fell_after_s": physics["fell_after_gait_start_s"], **zmp_walk(out)}


def zmp_walk(out: Path) -> dict[str, float]:
    """docs/biped.md's own gait: its plan (footsteps, ZMP reference, centre of mass), the
    walk of 10 steps in MuJoCo (its balance plot) and a frame in mid-stride."""
    from servolab.gait.plots import plot_zmp_walk
    from servolab.gait.zmp_walk import plan_zmp_walk
    from servolab.robots.armstrong.motions import zmp_motion

    plot_zmp_walk(plan_zmp_walk(), out / "biped_zmp_plan.png")
    motion, rate = zmp_motion(10)
    summary, world = walk_in_mujoco(out, "biped_physics_zmp.png", motion, rate=rate,
                                    gait="zmp")
    # mid-stride: the sample where one foot carries the least, halfway through the walk
    middle = [s for s in world.samples if abs(s.t - world.samples[-1].t / 2) < 1.5]
    frame_at(world, min(middle, key=lambda s: min(s.feet)), out / "biped_zmp_frame.png")
    physics = summary["physics"]
    return {"biped.zmp_forward_m": physics["torso_forward_m"],
            "biped.zmp_margin_mm": physics["zmp_margin_min_m"] * 1000}


def sweep_figure(out: Path) -> None:
    """The seed's gait and servolab's own under every case of
    ``servolab.robots.armstrong.sweep.cases()``: how long each walked before it fell (or the
    whole gait), coloured by the way it fell; the results as biped_sweep.json and
    biped_sweep_zmp.json (docs/biped.md's text is written from them)."""
    import logging

    import matplotlib.pyplot as plt

    from servolab.robots.armstrong.motions import load_motion, zmp_motion
    from servolab.robots.armstrong.sweep import cases, sweep

    logging.disable(logging.WARNING)   # 54 robots' start-up: motor 62 is absent in each
    try:
        seed = sweep(load_motion(None), cases(), steps=4)
        own = sweep(lambda case: zmp_motion(10, assumptions=case.assumptions()), cases())
    finally:
        logging.disable(logging.NOTSET)
    (out / "biped_sweep.json").write_text(json.dumps(seed, indent=1) + "\n")
    (out / "biped_sweep_zmp.json").write_text(json.dumps(own, indent=1) + "\n")
    colours = {"forwards": "C0", "backwards": "C1", "to its left": "C2", "to its right": "C3"}
    figure, axes = plt.subplots(1, 2, figsize=(13, 7.5), sharey=True)
    labels = [r["label"] for r in seed]
    for ax, results, title in ((axes[0], seed, "the seed's gait, 4 steps (15.1 s)"),
                               (axes[1], own, "servolab's own (--gait zmp), 10 steps")):
        for k, r in enumerate(results):
            if "refused" in r:
                ax.text(0.1, k, "not made: " + r["refused"].split(":")[0] + " (joint speed)",
                        va="center", fontsize="x-small", color="grey")
                continue
            walked = r.get("fell_after_gait_start_s")
            if walked is None:
                ax.barh(k, r["torso_forward_m"] * 100, color="C7")
                ax.text(r["torso_forward_m"] * 100 + 0.3, k, "walked, did not fall",
                        va="center", fontsize="x-small")
            else:
                ax.barh(k, walked, color=colours.get(str(r.get("tipped")), "grey"))
        ax.set_title(title)
        ax.grid(True, axis="x", alpha=0.3)
    axes[0].set_yticks(range(len(labels)), labels, fontsize="small")
    axes[0].invert_yaxis()
    axes[0].set_xlabel("fell this long after the gait's first row [s]")
    axes[1].set_xlabel("torso forward [cm] (grey bars)")
    for way, colour in colours.items():
        axes[0].barh([0], [0], color=colour, label=f"fell {way}")
    axes[0].legend(loc="lower right", fontsize="small")
    figure.suptitle("In MuJoCo under 27 sets of the unknowns (masses, hip width, feet)")
    figure.tight_layout()
    figure.savefig(out / "biped_sweep.png", dpi=100)
    plt.close(figure)


def mobile(out: Path) -> dict[str, float]:
    """docs/mobile.md's figures: seed 000's robot drives a figure of eight on the floor, and
    a circle on a floor that slips; returns the circle's raw wheel commands and how far short
    of its start it ended, from the run's summary.json, and the fusion's RMSEs."""
    import shutil
    import tempfile

    from servolab.robots.base.run import run_drive
    from servolab.runs import RunFolder

    with tempfile.TemporaryDirectory() as tmp:
        summary = run_drive(RunFolder.create("drive", tmp), "eight", radius=0.3, speed=0.1,
                            say=lambda text: None, show_progress=False)
        shutil.copy(str(summary["plot"]), out / "mobile_eight.png")
    with tempfile.TemporaryDirectory() as tmp:
        run = RunFolder.create("drive", tmp)
        summary = run_drive(run, "circle", radius=0.5, speed=0.2, slip=0.05, slip_jitter=0.1,
                            say=lambda text: None, show_progress=False)
        shutil.copy(str(summary["plot"]), out / "mobile_slip.png")
        written = _summary(run)
    raw = sorted(written["wheel_commands"][0]["raw"].values())  # the circle's first command
    return {"mobile.circle_raw_slow": raw[0], "mobile.circle_raw_fast": raw[1],
            "mobile.slip_closure_m": written["measured"]["closure_m"],
            **fusion(out / "mobile_fusion.png")}


def slip_closure(seed: int) -> float:
    """How far from its start the slipping circle of :func:`mobile` ends, with the floor's
    jitter drawn from ``seed`` (``servolab drive`` always draws it from seed 0)."""
    from servolab.robots.base.config import load, shipped_base
    from servolab.robots.base.mobile_base import MobileBase

    base = MobileBase.emulated(load(shipped_base("seed000")), slip=0.05, slip_jitter=0.1,
                               seed=seed)
    start = base.truth()
    base.circle(0.5, 0.2)
    end = base.truth()
    base.close()
    return math.hypot(end["x"] - start["x"], end["y"] - start["y"])


def fusion_run(seed: int = 0) -> dict[str, Any]:
    """Seed 000's D.4 fusion on a simulated circle, the run of tests/estimation/test_kalman.py:
    one circle of radius 50 in the seed's 1471 samples, odometry drifting slowly (a random
    walk of 0.05 a sample plus noise of 1), the tracker noisy with D.4's variances."""
    import numpy as np

    from servolab.estimation.kalman import SEED_000_FUSION, fuse_seed_000

    samples = 1471
    rng = np.random.default_rng(seed)
    angle = 2 * np.pi * np.arange(samples) / (samples - 1)
    truth = np.column_stack([50 * np.cos(angle), 50 * np.sin(angle)])
    drift = np.cumsum(rng.normal(0.0, 0.05, (samples, 2)), axis=0)
    odometry = truth + drift + rng.normal(0.0, 1.0, (samples, 2))
    tracker = truth + rng.normal(0.0, 1.0, (samples, 2)) * np.sqrt(
        SEED_000_FUSION.tracker_variance)
    fused = fuse_seed_000(odometry, tracker)

    def rmse(track: np.ndarray) -> float:
        return float(np.sqrt(np.mean(np.sum((track - truth) ** 2, axis=1))))

    return {"tracks": (truth, odometry, tracker, fused),
            "mobile.fused_rmse": rmse(fused), "mobile.odometry_rmse": rmse(odometry),
            "mobile.tracker_rmse": rmse(tracker)}


def fusion(path: Path) -> dict[str, float]:
    """The figure of :func:`fusion_run`; returns its RMSEs."""
    run = fusion_run()
    truth, odometry, tracker, fused = run.pop("tracks")
    fig, ax = plt.subplots(figsize=(6, 6))
    ax.plot(*truth.T, color="black", linewidth=1, label="truth")
    ax.plot(*tracker.T, ".", markersize=2, alpha=0.4,
            label=f"tracker (RMSE {run['mobile.tracker_rmse']:.2f})")
    ax.plot(*odometry.T, label=f"odometry (RMSE {run['mobile.odometry_rmse']:.2f})")
    ax.plot(*fused.T, label=f"fused, D.4 (RMSE {run['mobile.fused_rmse']:.2f})")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title("Kalman fusion as seed 000's D.4 (simulated)")
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=100, bbox_inches="tight")
    plt.close(fig)
    return run


def navigation(out: Path) -> None:
    """docs/navigation.md's figures: per-image reprojection errors of a calibration on
    synthetic boards (like the seed's Figure C4), and a plan with and without inflation."""
    import tempfile

    import cv2
    import numpy as np

    from servolab.robots.navigation.plan import load_problem, plan, plot_plan
    from servolab.vision.calibration import calibrate
    from servolab.vision.synthetic import PinholeCamera, random_board_poses, render_checkerboard

    camera = PinholeCamera(fx=820.0, fy=805.0, cx=326.0, cy=236.0, width=640, height=480,
                           distortion=(-0.28, 0.11, 0.0012, -0.0008, -0.02))
    rng = np.random.default_rng(7)
    poses = random_board_poses(camera, (10, 7), 25.0, 16, rng)
    images = [render_checkerboard(camera, (10, 7), 25.0, r, t, noise_std=2.0, rng=rng)
              for r, t in poses]
    calib = calibrate(images, (10, 7), 25.0)
    fig, ax = plt.subplots(figsize=(6.4, 3.2))
    errors = np.asarray(calib.per_image_errors)
    ax.bar(np.arange(1, len(errors) + 1), errors)
    ax.axhline(float(np.mean(errors)), color="gray", linestyle="--",
               label=f"mean of the images {np.mean(errors):.3f} px")
    ax.set_xlabel("image")
    ax.set_ylabel("RMS reprojection error (px)")
    ax.set_title("Calibration on 16 synthetic views of a 10x7-square board")
    ax.legend(fontsize=8)
    fig.savefig(out / "navigation_calibration.png", dpi=110, bbox_inches="tight")
    plt.close(fig)

    grid = np.full((60, 90), 255, dtype=np.uint8)  # a room with two walls and a pillar
    grid[0, :] = grid[-1, :] = grid[:, 0] = grid[:, -1] = 0
    grid[0:40, 30:33] = 0
    grid[20:60, 58:61] = 0
    grid[38:46, 12:20] = 0
    with tempfile.TemporaryDirectory() as tmp:
        image = Path(tmp) / "room.png"
        cv2.imwrite(str(image), grid)
        for name, inflation in (("navigation_plan.png", True),
                                ("navigation_plan_no_inflation.png", False)):
            problem = load_problem(image, (8, 50), (82, 8), inflation=inflation)
            _, path = plan(problem)
            plot_plan(problem, path, out / name)


def navigate_run(out: Path, seed: int = 0) -> dict[str, Any]:
    """``servolab navigate --goal 3.3 2.3 --seed SEED`` in ``out``: its summary.json."""
    from servolab.robots.navigation.run import prepare, run_navigate
    from servolab.runs import RunFolder

    run = RunFolder.create("navigate", out)
    run_navigate(run, prepare((3.3, 2.3)), seed=seed, say=lambda _: None, show_progress=False)
    return _summary(run)


def navigation_figures(summary: dict[str, Any]) -> dict[str, float]:
    """docs/navigation.md's numbers, from a navigate run's summary.json."""
    truth, estimate = summary["final_truth"], summary["final_estimate"]
    yaw_error = math.remainder(truth["yaw"] - estimate["yaw"], 2 * math.pi)
    return {
        "navigation.path_length_m": summary["path_length_m"],
        "navigation.seconds": summary["seconds"],
        "navigation.goal_distance_mm": summary["goal_distance_m"] * 1000,
        "navigation.goal_yaw_error_deg": math.degrees(abs(summary["goal_yaw_error_rad"])),
        "navigation.min_clearance_mm": summary["min_clearance_m"] * 1000,
        "navigation.estimate_error_mm": 1000 * math.hypot(truth["x"] - estimate["x"],
                                                          truth["y"] - estimate["y"]),
        "navigation.estimate_yaw_error_deg": math.degrees(abs(yaw_error)),
        "navigation.camera_frames": summary["camera_frames"],
        "navigation.repair_cells": sum(r["cells"] for r in summary["repairs"]),
        "navigation.calibration_fx_px": summary["calibration"]["fx"],
        "navigation.calibration_rms_px": summary["calibration"]["rms_px"],
    }


def navigation_loop(out: Path, *, quick: bool = False) -> dict[str, float]:
    """docs/navigation.md's runs of `servolab navigate`: the shipped scene, where an obstacle
    appears on the plan at 6 s, and a box's corner that D.3's DWA once did not get round (only
    its first :data:`CORNER_QUICK_S` s when ``quick``); returns the first run's numbers."""
    import contextlib
    import shutil
    import tempfile

    from servolab.robots.base.config import SHIPPED_DIR
    from servolab.robots.navigation.run import GoalNotReached, prepare, run_navigate
    from servolab.runs import RunFolder
    from servolab.sim.scene import DEFAULT_SCENE

    with tempfile.TemporaryDirectory() as tmp:
        figures = navigation_figures(navigate_run(Path(tmp) / "loop"))
        shutil.copy(Path(tmp) / "loop" / "navigate.png", out / "navigation_loop.png")
        text = DEFAULT_SCENE.read_text()
        scene = Path(tmp) / "corner.yaml"
        scene.write_text(text[:text.index("\nobstacles:") + 1] + "obstacles:\n"
                         "  - {box: {x: 1.9, y: 0.0, width: 0.2, depth: 1.6}}\n")
        shutil.copy(SHIPPED_DIR / "base_seed000.yaml", Path(tmp) / "base_seed000.yaml")
        run = RunFolder.create("navigate", Path(tmp) / "corner")
        with contextlib.suppress(GoalNotReached):  # the plot is the point, reached or not
            run_navigate(run, prepare((3.3, 0.6), goal_yaw=0.0, scene=scene),
                         say=lambda _: None, show_progress=False,
                         **({"timeout": CORNER_QUICK_S} if quick else {}))
        shutil.copy(run.file("navigate.png"), out / "navigation_corner.png")
    return figures


def flyball_run(out: Path, duration: float, seed: int = 0, clamp: str = "scaled"
                ) -> dict[str, Any]:
    """``servolab flyball --duration DURATION --seed SEED --clamp CLAMP`` in ``out``: its
    summary.json."""
    from servolab.robots.treadmill.run import run_flyball
    from servolab.runs import RunFolder

    run = RunFolder.create("flyball", out)
    run_flyball(run, duration=duration, seed=seed, say=lambda _: None, show_progress=False,
                wheel_clamp=clamp)
    return _summary(run)


def flyball_runs(out: Path, duration: float, seed: int = 0) -> dict[str, float]:
    """The numbers of a flyball run and of the same run with Listing 4's per-wheel clamp."""
    scaled = flyball_run(out / "scaled", duration, seed)
    per_wheel = flyball_run(out / "per_wheel", duration, seed, "per-wheel")
    return {**treadmill_figures(scaled),
            "treadmill.per_wheel_disparity": per_wheel["analysis"]["path_disparity"],
            "treadmill.per_wheel_robot_path_m": per_wheel["analysis"]["robot_path_length_m"]}


def treadmill_figures(summary: dict[str, Any]) -> dict[str, float]:
    """docs/treadmill.md's numbers, from a flyball run's summary.json (chapter 3's analysis)."""
    a = summary["analysis"]
    return {"treadmill.mean_distance_error_mm": a["mean_distance_error_mm"],
            "treadmill.mean_angle_error_deg": a["mean_angle_error_deg"],
            "treadmill.response_delay_ms": a["response_delay_s"] * 1000,
            "treadmill.frames": a["frames"],
            "treadmill.frames_with_fly": a["frames_with_fly"],
            "treadmill.sphere_path_mm": a["sphere_path_length_m"] * 1000,
            "treadmill.robot_path_m": a["robot_path_length_m"],
            "treadmill.path_disparity": a["path_disparity"]}


def treadmill(out: Path, *, quick: bool = False
              ) -> tuple[dict[str, float] | None, dict[str, float]]:
    """docs/treadmill.md's figures: one synthetic frame as Listing 1 sees it (Figures 3 and
    13 of the thesis), and the analysis of a closed-loop run of 100 s, or 10 s when ``quick``
    (Figures 14, 16, 18, 20 and 21). Returns the numbers of the 100 s run (None when
    ``quick``) and of the 10 s run, which the test makes again."""
    import shutil
    import tempfile

    import cv2
    import numpy as np
    from matplotlib.patches import Circle

    from servolab.robots.treadmill.control import FlyControllerConfig
    from servolab.vision.fly_render import FlyPose, render_fly
    from servolab.vision.fly_tracker import draw_overlay, track_fly

    image, _ = render_fly(FlyPose(402.0, 151.0, 0.6), noise_std=4.0,
                          rng=np.random.default_rng(2))
    sighting = track_fly(image)
    config = FlyControllerConfig()
    _, mask = cv2.threshold(image, 50, 255, cv2.THRESH_BINARY)
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    fig, ax = plt.subplots(figsize=(7.0, 4.4))
    ax.imshow(image, cmap="gray", vmin=0, vmax=255)
    biggest = max(contours, key=cv2.contourArea)[:, 0, :]
    ax.plot(*np.vstack([biggest, biggest[:1]]).T, color="tab:green", lw=1, label="contour")
    ax.plot(sighting.cx, sighting.cy, "o", mfc="none", color="magenta", label="centroid")
    length = 40
    ax.plot([sighting.cx - length * np.cos(sighting.theta),
             sighting.cx + length * np.cos(sighting.theta)],
            [sighting.cy - length * np.sin(sighting.theta),
             sighting.cy + length * np.sin(sighting.theta)], color="magenta", lw=1,
            label=f"axis, theta {np.degrees(sighting.theta):.1f}°")
    tx, ty, _ = config.target
    ax.add_patch(Circle((tx, ty), config.dead_band_px, fill=False, color="red", lw=1,
                            label="dead band, 50 px"))
    ax.set_title(f"one 640 x 376 frame: the fly at ({sighting.cx:.1f}, {sighting.cy:.1f}), "
                 f"area {sighting.area:.0f} px²", fontsize=9)
    ax.legend(fontsize=7, loc="lower left")
    fig.savefig(out / "treadmill_frame.png", dpi=100, bbox_inches="tight")
    plt.close(fig)
    # the live view: what /image_converter/output_video carries for this frame, as drawn by
    # the node itself (servolab.vision.fly_tracker.draw_overlay)
    cv2.imwrite(str(out / "treadmill_overlay.png"), draw_overlay(image, sighting))
    with tempfile.TemporaryDirectory() as tmp:
        short = flyball_runs(Path(tmp) / "short", TREADMILL_QUICK_S)
        if quick:
            shutil.copy(Path(tmp) / "short" / "scaled" / "flyball.png",
                        out / "treadmill_run.png")
            return None, short
        full = flyball_runs(Path(tmp) / "full", TREADMILL_S)
        shutil.copy(Path(tmp) / "full" / "scaled" / "flyball.png", out / "treadmill_run.png")
        return full, short


def arm_pick(path: Path) -> None:
    """docs/arm.md's picture of a pick: ``servolab arm pick 0.2 0.05 --place 0.15 -0.12
    --render`` on the OpenMANIPULATOR-X's table in MuJoCo (seed 0), its ``pick.png``."""
    import shutil
    import tempfile

    from servolab.robots.arm.run import ArmRequest, Where, arm_command
    from servolab.robots.arm.spec import arm_spec

    with tempfile.TemporaryDirectory() as run:
        summary = arm_command(arm_spec(),   # the default arm: the OpenMANIPULATOR-X
                              ArmRequest("pick", pick=(0.2, 0.05), place=(0.15, -0.12),
                                         render=True),
                              Where(world="robot"), out=str(Path(run) / "pick"),
                              say=lambda _: None)
        assert summary["placed"] and summary["render"] == "pick.png", summary
        shutil.copy(Path(run) / "pick" / "pick.png", path)


def fleet_scale(path: Path, *, quick: bool) -> None:
    """docs/fleets.md's curves: graph discovery time, memory per node and message rate as a
    fleet grows from 10 to 200 nodes (--quick: 5 and 20, peer to peer only), servolab beside
    bare Zenoh, measured by benchmarks/fleet.py's own ``measure`` in real time (the one figure
    here that is: what it shows is the machine's, so docs/fleets.md quotes no number from it)."""
    import runpy

    fleet = runpy.run_path(str(Path(__file__).resolve().parents[1] / "benchmarks" / "fleet.py"),
                           run_name="fleet_bench")
    sizes = fleet["QUICK_NODES"] if quick else fleet["NODES"]
    topologies = ("peer",) if quick else fleet["TOPOLOGIES"]
    rows = [fleet["measure"](engine, topology, n, fleet["QUICK_MESSAGES"] if quick
                             else fleet["MESSAGES"])
            for topology in topologies for n in sizes for engine in fleet["ENGINES"]]
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6))
    panels = (("discovery_s", "graph discovery (s)"), ("rss_per_node_kib", "memory per node (KiB)"),
              ("messages_per_s", "messages per second, all nodes"))
    styles = {"servolab": "-o", "zenoh": "--s"}
    for ax, (field, label) in zip(axes, panels, strict=True):
        for topology in topologies:
            for engine in fleet["ENGINES"]:
                mine = [r for r in rows if (r.engine, r.topology) == (engine, topology)]
                ax.plot([r.nodes for r in mine], [getattr(r, field) for r in mine],
                        styles[engine], label=f"{engine if engine == 'servolab' else 'bare Zenoh'}"
                        f", {topology}", alpha=0.8)
        ax.set_xscale("log")
        ax.set_xticks(list(sizes), [str(n) for n in sizes])
        ax.minorticks_off()
        ax.set_xlabel("nodes in one process")
        ax.set_title(label, fontsize=10)
        ax.grid(alpha=0.3)
    axes[0].set_yscale("log")
    axes[0].legend(fontsize=7)
    fig.suptitle("A fleet's graph as it grows: servolab and bare Zenoh, measured in one run",
                 fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def sim_speed(path: Path, *, quick: bool) -> None:
    """docs/sim.md's and docs/performance.md's bars: the real-time factor of each scenario of
    benchmarks/sim.py, measured by its own ``measure`` in real time on one core (10
    simulated seconds each, the median of three runs; --quick: one of 0.5), beside issue 49's
    goals and, for the MuJoCo biped, the physics limit: MuJoCo's own step alone, as that run
    took it. Like fleet_scale.png it shows this machine, so no doc quotes a number from it."""
    import runpy

    bench = runpy.run_path(str(Path(__file__).resolve().parents[1] / "benchmarks" / "sim.py"),
                           run_name="sim_bench")
    seconds = 0.5 if quick else 10.0
    cores = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else None
    bench["pin_to_one_core"]()  # as the benchmark runs: one core (it measures one)
    try:
        # each scenario's median of three runs (--quick: one): a run of (a) is a tenth of a
        # second, which one pause of a shared machine moves
        runs = 1 if quick else 3
        results = [sorted((bench["measure"](key, seconds, breakdown=False)
                           for _ in range(runs)), key=lambda r: r.rtf)[runs // 2]
                   for key in bench["SCENARIOS"]]
        for r in results:   # MuJoCo's own step from a second, timed run, as the benchmark's
            if r.key == "e":
                timed = bench["measure"](r.key, seconds, breakdown=True)
                r.mj_step_s = timed.mj_step_s * r.simulated_s / timed.simulated_s
    finally:
        if cores is not None:
            os.sched_setaffinity(0, cores)
    goals = {"a": bench["TARGET_RTF"], "e": bench["TARGET_MUJOCO_RTF"]}
    fig, ax = plt.subplots(figsize=(8, 3.8))
    rows = range(len(results))
    ax.barh(rows, [r.rtf for r in results], color="tab:blue", alpha=0.8,
            label="servolab, this run")
    for row, r in zip(rows, results, strict=True):
        ax.text(r.rtf, row, f" {r.rtf:.0f}x", va="center", fontsize=8)
        if r.key in goals:
            ax.plot([goals[r.key]] * 2, [row - 0.4, row + 0.4], color="tab:red", lw=2,
                    label="issue 49's goal" if r.key == "a" else None)
        if r.mj_step_s:
            ax.plot([r.physics_limit] * 2, [row - 0.4, row + 0.4], color="k", ls="--", lw=1.5,
                    label="MuJoCo's own step alone")
    ax.set_yticks(list(rows), [f"({r.key}) {r.title.split(':')[0]}" for r in results],
                  fontsize=7)
    ax.invert_yaxis()
    ax.set_xlabel("real-time factor (simulated s per host s), one core")
    ax.grid(axis="x", alpha=0.3)
    ax.legend(fontsize=7, loc="lower right")
    fig.suptitle(f"benchmarks/sim.py, {seconds:g} simulated s a scenario, median of three runs",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_figures(path: Path, values: dict[str, float], full: dict[str, float] | None,
                  short: dict[str, float]) -> None:
    """``figures.json``: each number of :data:`FIGURES` with its doc, the run it comes from,
    its value, the noise the doc states and the text the doc writes; a number of the 100 s
    treadmill run also has the 10 s run's value, which ``--quick`` makes again (``value`` and
    ``text`` are null in --quick's file)."""
    entries: dict[str, dict[str, Any]] = {}
    for key, figure in FIGURES.items():
        value = (None if full is None else full[key]) if figure.shortened else values[key]
        value = None if value is None else round(float(value), 6)
        entry: dict[str, Any] = {
            "doc": figure.doc, "run": figure.run, "value": value,
            "tolerance": figure.tolerance,
            "text": None if value is None else figure.text(value, figure.tolerance)}
        if figure.shortened:
            entry["quick"] = {"run": figure.run.replace(f"--duration {TREADMILL_S:g}",
                                                        f"--duration {TREADMILL_QUICK_S:g}"),
                              "value": round(float(short[key]), 6)}
        entries[key] = entry
    about = ("The numbers docs/*.md quote from a run, written by docs/plots.py; "
             "tests/test_docs.py checks that each doc holds each text and that a new run "
             "gives each value within its tolerance.")
    path.write_text(json.dumps({"about": about, "figures": entries}, indent=2,
                               ensure_ascii=False) + "\n")


def spread(seed_0: dict[str, float], *, quick: bool) -> None:
    """Print how far each number moves from seed 0's over seeds 1 to 3 of its run, beside the
    noise its doc states (:attr:`Figure.tolerance`)."""
    import tempfile

    moved: dict[str, float] = {}
    for seed in SPREAD_SEEDS:
        with tempfile.TemporaryDirectory() as tmp:
            other = {**navigation_figures(navigate_run(Path(tmp) / "nav", seed)),
                     **flyball_runs(Path(tmp) / "fly",
                                    TREADMILL_QUICK_S if quick else TREADMILL_S, seed),
                     "mobile.slip_closure_m": slip_closure(seed)}
        run = fusion_run(seed)
        run.pop("tracks")
        other.update(run)
        for key, value in other.items():
            moved[key] = max(moved.get(key, 0.0), abs(value - seed_0[key]))
    print(f"{'number':36} {'seed 0':>10} {'moved by':>10} {'doc states':>10}")
    for key, figure in FIGURES.items():
        if key not in moved:
            print(f"{key:36} {seed_0[key]:10.4g} {'no seed':>10} {figure.tolerance:10g}")
            continue
        flag = "" if moved[key] <= figure.tolerance else "  <- more than the doc states"
        print(f"{key:36} {seed_0[key]:10.4g} {moved[key]:10.4g} {figure.tolerance:10g}{flag}")


def main(argv: list[str]) -> None:
    quick = "--quick" in argv  # the docs test: every figure made, the long runs shortened
    with_spread = "--spread" in argv
    argv = [a for a in argv if a not in ("--quick", "--spread")]
    out = Path(argv[0]) if argv else Path(__file__).parent / "img"
    out.mkdir(parents=True, exist_ok=True)
    values: dict[str, float] = {}
    joint_moves(out / "rx28_joint_moves.png")
    profile_moves(out / "xm430_profiles.png")
    values.update(cycle_time(out / "bus_cycle_time.png"))
    floor_world(out / "floor_world.png")
    values.update(biped(out))
    values.update(biped_physics(out, quick=quick))
    values.update(mobile(out))
    navigation(out)
    values.update(navigation_loop(out, quick=quick))
    full, short = treadmill(out, quick=quick)
    arm_pick(out / "arm_pick.png")
    fleet_scale(out / "fleet_scale.png", quick=quick)
    sim_speed(out / "sim_speed.png", quick=quick)
    write_figures(out / "figures.json", values, full, short)
    print(f"figures written to {out}")
    if with_spread:
        spread({**values, **(short if full is None else full)}, quick=quick)


if __name__ == "__main__":
    main(sys.argv[1:])
