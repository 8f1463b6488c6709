"""Whether the fly tracker and the treadmill's per-frame loop keep up with the camera (issue 19).

Seed 002's camera gives 640 x 376 frames at 66 frames/s (Listing 3), so every frame's work has
to fit in one frame period, 1/66 s = 15.15 ms, or frames queue up and the treadmill servoes on
an old position. Measured on ``FRAMES`` synthetic dark-field frames of a fly at varied poses
(:func:`servolab.vision.fly_render.render_fly`, noise 4 grey levels, seeded), all rendered
before any timing:

- the **tracker** alone (:func:`servolab.vision.fly_tracker.track_fly`, Listing 1's defaults),
  in frames per second;
- the **anchor**: a bare OpenCV pipeline written here with nothing around it (``threshold`` 50
  ``THRESH_BINARY``, ``findContours`` ``RETR_EXTERNAL``/``CHAIN_APPROX_SIMPLE``, the largest
  ``contourArea``, its ``moments``, the centroid and ``0.5 atan2`` axis angle), on the same
  frames in the same run; the ratio tracker fps / bare fps is what the tracker's own Python
  (checks, dataclasses, the absent-fly rule) costs over OpenCV's work, which no tracker built
  on these calls can avoid. Both must find the same centroid and angle (the run fails
  otherwise), so the anchor does the same work;
- the **whole per-frame loop** as :meth:`servolab.robots.treadmill.node.TreadmillNode._frame` does
  it, in a plain loop without the middleware (no executor, no timer, no publishing): the
  frame, ``track_fly``, ``fly_command``, one SYNC_WRITE of ``goal_velocity`` and one
  SYNC_READ of ``present_position`` to the three XM430-W210 (IDs 100-102, 1 Mbps, emulated,
  set up as the node's ``motor_init`` does) and the 17-value record written with
  :class:`~servolab.robots.treadmill.logs.FlyLogWriter` (flushed each frame) to a temporary file.
  Its frames per second, and the per-frame latency p50 and p99 against the frame period.

The emulated bus runs on a virtual clock: its wire time (10 bits a byte at 1 Mbps, the motors'
return delays) is simulated, not waited for, so the loop's times here are the **host's**
(driver, emulator, tracker, control, log), not a real bus's; the simulated wire time of a frame
is printed beside them, a real rig pays both. Every figure is the median of ``REPEATS``
repeats (each ``PASSES`` passes over the frames, tracker and anchor interleaved in each
repeat), so one slow repeat does not decide; rates are also given as multiples of the camera's
66 frames/s.

**The real-time loop on ``servolab sim --pty``** (issue 28). The whole loop as a user runs it
on the real treadmill, in real time (wall clock): ``servolab flyball --frames DIR --port PTY``'s
:func:`~servolab.robots.treadmill.run.run_recorded` (the camera node publishing the recording
on ``/image_raw`` on its timer at 66 frames/s, the treadmill node tracking each frame with its
SYNC_WRITE and SYNC_READ, the log, FicTrac's ``.dat``, the bag) against ``servolab sim --pty
--motors xm430-w210:100-102 --baud 1000000`` in its own process (started and stopped as
``benchmarks/gait.py``'s pty walks are: ``tests/simproc.py``), on a recording of
``LIVE_FRAMES`` PNG frames of a fly walking a smooth seeded path (rendered before any timing).
From the node's own timing (:meth:`~servolab.robots.treadmill.node.TreadmillNode.timing`,
:mod:`servolab.robots.treadmill.timing`): the achieved frames per second, the interval
between handled frames (p50, p99, largest), the late frames (handled more than a frame period
after capture) and the dropped ones (a gap of more than one period in the camera's sequence:
a folder's frames are stamped when read, so a camera tick more than 1.5 periods after the one
before counts as a frame dropped). Two anchors, as ratios: the **ideal** (66 frames/s, every
interval 15.15 ms) and the **same loop on the in-process emulated bus** (the same
``run_recorded``, port ``emu://xm430-w210:100-102``), run just before it in the same run: its
wire time is simulated, not waited for, so pty / in-process is what the pty, the simulator's
own process and the 1 Mbps wire cost the loop. Each is run on an idle CPU and (not with
``--quick``) on a busy one: every core kept busy by another process spinning in Python, as
``tests/robots/test_stop_signals.py``'s ``busy_cpu`` does (``servolab sim`` raises its own
priority when allowed, as it does for a user). One run each; p99 of ``LIVE_FRAMES - 1``
intervals is about the fourth largest. A run that ends in an error (a motor that did not
answer within the driver's timeout) is reported with its figures up to the error, the
others still run, and the benchmark exits 1.

Run: ``.venv/bin/python benchmarks/flytracker.py [--quick] [--no-pty] [--pty-out DIR]
[--json PATH]``. ``--quick`` uses fewer frames and repeats, and the real-time loop on an idle
CPU only (under ten seconds); the full run takes about a minute. ``--no-pty`` leaves the
real-time part out (a few seconds, or a second or two with ``--quick``).
"""

from __future__ import annotations

import argparse
import importlib
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from servolab.dynamixel.bus import Bus
from servolab.robots.treadmill.control import FlyControllerConfig, fly_command
from servolab.robots.treadmill.logs import FLY_RECORD, FlyLogWriter, read_fly_log
from servolab.robots.treadmill.node import FRAME_RATE, TREADMILL_BAUDRATE, TREADMILL_IDS
from servolab.robots.treadmill.run import run_recorded
from servolab.runs import RunFolder
from servolab.signals import on_stop_signals, raise_keyboard_interrupt
from servolab.vision.fly_render import DEFAULT_SIZE, FlyPose, render_fly
from servolab.vision.fly_tracker import FlyTrackerConfig, track_fly

Image = npt.NDArray[np.uint8]

FULL_FRAMES, QUICK_FRAMES = 64, 16
FULL_PASSES, QUICK_PASSES = 10, 2     # passes over the frames per repeat
FULL_REPEATS, QUICK_REPEATS = 5, 3
SEED = 19
NOISE_STD = 4.0
MARGIN = 60                           # px: poses kept this far in from the frame's edges
FRAME_PERIOD_S = 1.0 / FRAME_RATE     # Listing 3's 66 frames/s: 15.15 ms
THRESHOLD = 50.0                      # Listing 1


def render_frames(count: int, seed: int) -> list[Image]:
    """``count`` frames of a fly at seeded random poses anywhere but the frame's margins, so
    that the controller sees flies inside and outside its dead band."""
    rng = np.random.default_rng(seed)
    width, height = DEFAULT_SIZE
    frames = []
    for _ in range(count):
        pose = FlyPose(float(rng.uniform(MARGIN, width - MARGIN)),
                       float(rng.uniform(MARGIN, height - MARGIN)),
                       float(rng.uniform(-math.pi, math.pi)))
        image, truth = render_fly(pose, noise_std=NOISE_STD, rng=rng)
        if truth is None:  # pragma: no cover - the margins keep the fly in the frame
            raise RuntimeError(f"the fly at {pose} is outside the frame")
        frames.append(image)
    return frames


def bare_track(image: Image) -> tuple[float, float, float, float]:
    """The anchor: Listing 1's OpenCV calls and nothing else (no checks, no absent-fly rule);
    ``(cx, cy, theta, area)`` of the largest external contour."""
    _, binary = cv2.threshold(image, THRESHOLD, 255.0, cv2.THRESH_BINARY)
    contours, _ = cv2.findContours(binary, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    areas = [cv2.contourArea(c) for c in contours]
    best = int(np.argmax(areas))
    mu = cv2.moments(contours[best])
    cx, cy = mu["m10"] / mu["m00"], mu["m01"] / mu["m00"]
    theta = 0.5 * math.atan2(2.0 * mu["mu11"], mu["mu20"] - mu["mu02"])
    return cx, cy, theta, float(areas[best])


def check_same(frames: Sequence[Image]) -> None:
    """The tracker and the anchor must agree on every frame (centroid to 1e-6 px, the axis
    angle modulo pi to 1e-6 rad), or the ratio would compare different work."""
    for index, image in enumerate(frames):
        s = track_fly(image)
        cx, cy, theta, area = bare_track(image)
        turn = (s.theta - theta) % math.pi
        if not (s.present and math.isclose(s.cx, cx, abs_tol=1e-6)
                and math.isclose(s.cy, cy, abs_tol=1e-6) and min(turn, math.pi - turn) < 1e-6
                and s.area == area):
            raise RuntimeError(f"frame {index}: tracker {s} but bare OpenCV "
                               f"{(cx, cy, theta, area)}")


def time_pass(frames: Sequence[Image], passes: int, bare: bool) -> float:
    """Host seconds for ``passes`` passes of the tracker (or the anchor) over ``frames``."""
    track = bare_track if bare else track_fly
    t0 = time.perf_counter()
    for _ in range(passes):
        for image in frames:
            track(image)
    return time.perf_counter() - t0


@dataclass
class LoopRun:
    """One repeat of the per-frame loop: host seconds per frame, and the stages' shares."""

    latencies_s: list[float]
    total_s: float
    wire_s: float                     # simulated wire time, over all frames
    stages_s: dict[str, float]        # host seconds per stage, over all frames


class Rig:
    """The treadmill's three emulated wheels and the node's state between frames, so that the
    loop below does per frame exactly what ``TreadmillNode._frame`` does minus the publishing."""

    def __init__(self, log_path: Path) -> None:
        self.bus = Bus.open(f"emu://xm430-w210:{TREADMILL_IDS[0]}-{TREADMILL_IDS[-1]}",
                            baudrate=TREADMILL_BAUDRATE)
        self.ids = TREADMILL_IDS
        self.tracker = FlyTrackerConfig()
        # As the node does: the wheel speeds clamped to the motors' own velocity_limit.
        self.controller = FlyControllerConfig(max_wheel_speed=min(
            float(v) for v in self.bus.sync_read("velocity_limit", self.ids, raw=True).values()))
        # motor_init: torque off, velocity mode, torque on.
        self.bus.sync_write("torque_enable", dict.fromkeys(self.ids, 0))
        self.bus.sync_write("operating_mode", dict.fromkeys(self.ids, 1), raw=True)
        self.bus.sync_write("torque_enable", dict.fromkeys(self.ids, 1))
        self.log = FlyLogWriter(log_path)
        self.frames = 0
        self.compensating = 0

    def close(self) -> None:
        """motor_deinit, then the log and the bus closed."""
        try:
            self.bus.sync_write("goal_velocity", dict.fromkeys(self.ids, 0), raw=True)
            self.bus.sync_write("torque_enable", dict.fromkeys(self.ids, 0))
        finally:
            self.log.close()
            self.bus.close()

    def run(self, frames: Sequence[Image], passes: int) -> LoopRun:
        """``passes`` passes of the per-frame loop over ``frames``. The frame's time (the
        record's ``time`` and the sampling time the controller divides by) is the camera's,
        one frame period apart, as the node's timer gives it; a recorded frame stands in for
        the camera's callback."""
        clock = self.bus.port.clock
        target = self.controller.target
        ids, bus, log = self.ids, self.bus, self.log
        perf = time.perf_counter
        latencies: list[float] = []
        stages = dict.fromkeys(("track", "control", "bus", "log"), 0.0)
        wire0 = clock.now()
        t_start = perf()
        for _ in range(passes):
            for image in frames:
                started = perf()
                now = self.frames * FRAME_PERIOD_S
                sampling_us = 0.0 if self.frames == 0 else FRAME_PERIOD_S * 1e6
                sighting = track_fly(image, self.tracker, target=(target[0], target[1]))
                t_track = perf()
                command = fly_command(sighting, sampling_us, self.controller)
                raw = {i: int(v) for i, v in zip(ids, command.wheel_speeds, strict=True)}
                t_control = perf()
                bus.sync_write("goal_velocity", raw, raw=True)
                present = bus.sync_read("present_position", ids, raw=True)
                positions = [float(present[i]) for i in ids]
                t_bus = perf()
                loop_us = (t_bus - started) * 1e6
                log.write([float(self.frames), loop_us, sampling_us, sighting.cx, sighting.cy,
                           sighting.theta, command.dxm, command.dym, command.dthm,
                           *command.wheel_speeds, sighting.area, *positions, now])
                ended = perf()
                latencies.append(ended - started)
                stages["track"] += t_track - started
                stages["control"] += t_control - t_track
                stages["bus"] += t_bus - t_control
                stages["log"] += ended - t_bus
                self.compensating += command.compensating
                self.frames += 1
        total = perf() - t_start
        return LoopRun(latencies, total, clock.now() - wire0, stages)


def percentile(values: Sequence[float], q: float) -> float:
    return float(np.percentile(np.asarray(values), q))


def bench(count: int, passes: int, repeats: int) -> dict[str, Any]:
    frames = render_frames(count, SEED)
    check_same(frames)
    time_pass(frames, 1, bare=False)  # warm up: OpenCV's first calls allocate
    time_pass(frames, 1, bare=True)
    n = count * passes
    tracker_fps, bare_fps = [], []
    for _ in range(repeats):
        tracker_fps.append(n / time_pass(frames, passes, bare=False))
        bare_fps.append(n / time_pass(frames, passes, bare=True))

    with tempfile.TemporaryDirectory() as tmp:
        log_path = Path(tmp) / "fly_data.bin"
        rig = Rig(log_path)
        try:
            rig.run(frames[:4], 1)  # warm up the driver's plans
            runs = [rig.run(frames, passes) for _ in range(repeats)]
        finally:
            rig.close()
        records = read_fly_log(log_path)
        if len(records) != rig.frames:
            raise RuntimeError(f"the log holds {len(records)} records for {rig.frames} frames")
        log_bytes = log_path.stat().st_size
    loop_fps = [n / r.total_s for r in runs]
    p50 = [percentile(r.latencies_s, 50) for r in runs]
    p99 = [percentile(r.latencies_s, 99) for r in runs]
    camera = FRAME_RATE
    tracker = statistics.median(tracker_fps)
    bare = statistics.median(bare_fps)
    loop = statistics.median(loop_fps)
    loop_p50, loop_p99 = statistics.median(p50), statistics.median(p99)
    stage_us = {name: statistics.median(r.stages_s[name] / n for r in runs) * 1e6
                for name in runs[0].stages_s}
    wire_ms = statistics.median(r.wire_s / n for r in runs) * 1e3
    return {
        "frames": count, "passes": passes, "repeats": repeats, "frames_per_repeat": n,
        "camera_fps": camera, "frame_period_ms": FRAME_PERIOD_S * 1e3,
        "tracker": {"fps": tracker, "fps_repeats": tracker_fps, "ratio_camera": tracker / camera},
        "bare": {"fps": bare, "fps_repeats": bare_fps, "ratio_camera": bare / camera},
        "ratio_tracker_bare": tracker / bare,
        "loop": {"fps": loop, "fps_repeats": loop_fps, "ratio_camera": loop / camera,
                 "latency_p50_ms": loop_p50 * 1e3, "latency_p99_ms": loop_p99 * 1e3,
                 "p50_share_of_period": loop_p50 / FRAME_PERIOD_S,
                 "p99_share_of_period": loop_p99 / FRAME_PERIOD_S,
                 "latency_max_ms": max(max(r.latencies_s) for r in runs) * 1e3,
                 "latency_p50_ms_repeats": [v * 1e3 for v in p50],
                 "latency_p99_ms_repeats": [v * 1e3 for v in p99],
                 "stage_us": stage_us, "simulated_wire_ms_per_frame": wire_ms,
                 "records_logged": len(records), "log_bytes": log_bytes,
                 "record_bytes": FLY_RECORD.itemsize,
                 "compensating_share": rig.compensating / rig.frames},
    }


def report(fig: dict[str, Any]) -> list[str]:
    camera = fig["camera_fps"]
    t, b, lp = fig["tracker"], fig["bare"], fig["loop"]
    period = fig["frame_period_ms"]
    stages = ", ".join(f"{k} {v:.0f} us" for k, v in lp["stage_us"].items())
    return [
        f"Fly tracker on {fig['frames']} synthetic {DEFAULT_SIZE[0]} x {DEFAULT_SIZE[1]} frames "
        f"(noise {NOISE_STD:g}), {fig['passes']} passes a repeat, median of {fig['repeats']} "
        f"repeats; host time (OpenCV {cv2.__version__}, {cv2.getNumThreads()} threads, "
        f"{platform.python_implementation()} {platform.python_version()})",
        f"  tracker {t['fps']:.0f} fps = {t['ratio_camera']:.1f}x the camera's {camera:g}",
        f"  bare OpenCV {b['fps']:.0f} fps = {b['ratio_camera']:.1f}x the camera's {camera:g}",
        f"  ratio tracker/bare = {fig['ratio_tracker_bare']:.2f} (fps over fps: 1 = nothing over "
        f"OpenCV's own work, below 1 = the tracker's Python costs that share)",
        "Per-frame loop (track + control + SYNC_WRITE goal_velocity + SYNC_READ "
        "present_position on 3 emulated XM430-W210 at 1 Mbps + 17-value record to the log)",
        f"  loop {lp['fps']:.0f} fps = {lp['ratio_camera']:.1f}x the camera's {camera:g}",
        f"  latency p50 {lp['latency_p50_ms']:.3f} ms = {lp['p50_share_of_period']:.3f} of the "
        f"{period:.2f} ms frame period; p99 {lp['latency_p99_ms']:.3f} ms = "
        f"{lp['p99_share_of_period']:.3f} of it; the slowest frame of all "
        f"{lp['latency_max_ms']:.3f} ms",
        f"  mean per frame: {stages}",
        f"  host time only: the emulated bus's wire time is simulated on a virtual clock "
        f"({lp['simulated_wire_ms_per_frame']:.3f} ms a frame, not in the figures above; a "
        f"real bus adds it)",
        f"  {lp['records_logged']} records logged ({lp['log_bytes']} bytes); "
        f"{lp['compensating_share']:.0%} of the frames outside the dead band",
    ]


# -- the real-time loop on `servolab sim --pty` (issue 28) --------------------------------------

ROOT = Path(__file__).resolve().parents[1]
FULL_LIVE_FRAMES, QUICK_LIVE_FRAMES = 400, 66    # 6 s and 1 s at 66 frames/s
LIVE_SEED = 28
WHEELS = f"xm430-w210:{TREADMILL_IDS[0]}-{TREADMILL_IDS[-1]}"
EMULATED_PORT = f"emu://{WHEELS}"
#: a core kept busy in Python, until its parent (this benchmark) is gone, even if it is killed
BURNER = ("import os\nparent = os.getppid()\nwhile os.getppid() == parent:\n"
          "    for _ in range(100_000):\n        pass\n")


def render_recording(folder: Path, count: int, seed: int) -> None:
    """``count`` PNG frames of a fly walking a smooth path over most of the frame (Lissajous,
    seeded phases, heading along the path, noise ``NOISE_STD``): a recording, as
    ``servolab flyball --frames`` reads it."""
    rng = np.random.default_rng(seed)
    width, height = DEFAULT_SIZE
    ax, ay = width / 2 - MARGIN, height / 2 - MARGIN
    px, py = (float(v) for v in rng.uniform(0.0, 2 * math.pi, 2))
    fx, fy = 0.21, 0.33                  # Hz: a path of a few seconds, never repeating on it
    folder.mkdir(parents=True, exist_ok=True)
    for k in range(count):
        t = k / FRAME_RATE
        wx, wy = 2 * math.pi * fx, 2 * math.pi * fy
        pose = FlyPose(width / 2 + ax * math.sin(wx * t + px),
                       height / 2 + ay * math.sin(wy * t + py),
                       math.atan2(ay * wy * math.cos(wy * t + py),
                                  ax * wx * math.cos(wx * t + px)))
        image, truth = render_fly(pose, noise_std=NOISE_STD, rng=rng)
        if truth is None:  # pragma: no cover - the margins keep the fly in the frame
            raise RuntimeError(f"the fly at {pose} is outside the frame")
        if not cv2.imwrite(str(folder / f"{k:04d}.png"), image):
            raise RuntimeError(f"could not write {folder / f'{k:04d}.png'}")


@contextmanager
def busy_cpu(burners: int) -> Iterator[None]:
    """``burners`` processes spinning in Python (0: none), all stopped when the block ends."""
    procs: list[subprocess.Popen[bytes]] = []
    try:
        for _ in range(burners):
            procs.append(subprocess.Popen([sys.executable, "-c", BURNER],
                                          stdin=subprocess.DEVNULL))
        yield
    finally:
        for proc in procs:
            proc.kill()
        for proc in procs:
            proc.wait()


def _sim_process() -> Callable[..., Any]:
    """tests/simproc.py's ``sim_process``, as benchmarks/gait.py's pty walks use it (the
    repository's root on the path, as pytest has it)."""
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    return importlib.import_module("tests.simproc").sim_process  # type: ignore[no-any-return]


def _quiet(line: str) -> None:
    """run_recorded's progress lines: left out (its figures are in the summary)."""


def run_live(frames: Path, folder: Path, port: str
             ) -> tuple[dict[str, Any] | None, float, str | None]:
    """``run_recorded`` of ``frames`` at 66 frames/s with the wheels on ``port``, into
    ``folder``: the node's timing, the run's wall time (s, start-up and analysis too) and the
    error that ended it, if one did (a motor that did not answer in time is a figure of a
    real-time run, not a fault of the benchmark: the timing up to it is kept, from the run's
    ``summary.json``)."""
    started = time.perf_counter()
    try:
        with RunFolder.create("flyball", folder) as run:
            summary = run_recorded(run, frames, port=port, fps=FRAME_RATE, say=_quiet,
                                   show_progress=False)
    except Exception as error:  # not a stop signal (KeyboardInterrupt): that ends the run
        wall = time.perf_counter() - started
        written = folder / "summary.json"
        timing = json.loads(written.read_text()).get("timing") if written.exists() else None
        return timing, wall, f"{type(error).__name__}: {error}"
    return dict(summary["timing"]), time.perf_counter() - started, None


def measure_live(frames: Path, folder: Path, *, pty: bool, burners: int) -> dict[str, Any]:
    """One real-time run, on ``servolab sim --pty`` (``pty``) or on the in-process emulated
    bus, with ``burners`` cores kept busy; its figures."""
    sim_instructions: int | None = None
    with busy_cpu(burners):
        if pty:
            sim_folder = folder / "sim"
            with _sim_process()("--motors", WHEELS, "--baud", str(TREADMILL_BAUDRATE),
                                out_dir=sim_folder) as (device, _):
                timing, wall, error = run_live(frames, folder / "run", device)
        else:
            timing, wall, error = run_live(frames, folder / "run", EMULATED_PORT)
    if pty:  # the simulator's own count: what reached the motors over the pty
        summary = sim_folder / "summary.json"
        if summary.exists():
            sim_instructions = int(json.loads(summary.read_text())["instructions_received"])
    nan = math.nan
    timing = timing or {"frames": 0, "camera_frames": 0, "achieved_fps": nan,
                        "interval_ms": dict.fromkeys(("p50", "p99", "max"), nan),
                        "latency_ms": dict.fromkeys(("p50", "p99", "max"), nan),
                        "late_frames": 0, "dropped_frames": 0, "frames_refused": 0,
                        "fly_found_share": nan}
    handled = int(timing["frames"])
    if error is None and not (handled > 1 and math.isfinite(timing["achieved_fps"])):
        raise RuntimeError(f"{'pty' if pty else 'emulated'} run: {handled} frame(s) handled")
    if sim_instructions is not None and sim_instructions < 2 * handled:
        raise RuntimeError(f"the simulator received {sim_instructions} instructions for "
                           f"{handled} frames (one SYNC_WRITE and one SYNC_READ each)")
    period_ms = FRAME_PERIOD_S * 1e3
    interval, latency = timing["interval_ms"], timing["latency_ms"]
    return {
        "bus": "pty" if pty else "emulated", "busy_cores": burners,
        "label": f"{'pty' if pty else 'in-process'}, {'busy' if burners else 'idle'} CPU",
        "recording_frames": len(list(frames.glob("*.png"))), "handled": handled,
        "camera_frames": int(timing["camera_frames"]),
        "achieved_fps": float(timing["achieved_fps"]),
        "ratio_camera": float(timing["achieved_fps"]) / FRAME_RATE,
        "interval_ms": dict(interval), "p50_share_of_period": interval["p50"] / period_ms,
        "p99_share_of_period": interval["p99"] / period_ms,
        "max_share_of_period": interval["max"] / period_ms,
        "latency_ms": dict(latency), "late_frames": int(timing["late_frames"]),
        "dropped_frames": int(timing["dropped_frames"]),
        "frames_refused": int(timing["frames_refused"]),
        "fly_found_share": float(timing["fly_found_share"]),
        "sim_instructions": sim_instructions, "run_wall_s": wall, "error": error,
    }


def bench_live(count: int, busy: bool, keep: Path | None) -> dict[str, Any]:
    """The recording, then for an idle CPU (and a busy one, ``busy``) the in-process anchor
    and the pty run, one after the other."""
    burners = os.cpu_count() or 1
    loads = (0, burners) if busy else (0,)
    load_before = os.getloadavg()[0]  # what else the machine ran: "idle" is this run's own
    with tempfile.TemporaryDirectory(prefix="servolab-flytracker-bench-") as scratch:
        base = keep or Path(scratch)
        frames = base / "recording"
        render_recording(frames, count, LIVE_SEED)
        runs = []
        for load in loads:
            for pty in (False, True):
                name = f"{'pty' if pty else 'emulated'}_{'busy' if load else 'idle'}"
                runs.append(measure_live(frames, base / name, pty=pty, burners=load))
    for pty_run, anchor in zip(runs[1::2], runs[0::2], strict=True):
        pty_run["ratio_fps_in_process"] = pty_run["achieved_fps"] / anchor["achieved_fps"]
        pty_run["ratio_p99_in_process"] = (pty_run["interval_ms"]["p99"]
                                           / anchor["interval_ms"]["p99"])
    return {"frames": count, "camera_fps": FRAME_RATE, "frame_period_ms": FRAME_PERIOD_S * 1e3,
            "motors": WHEELS, "baudrate": TREADMILL_BAUDRATE, "seed": LIVE_SEED,
            "busy_cores": burners if busy else 0, "cores": burners,
            "load_average_1min": [load_before, os.getloadavg()[0]], "runs": runs}


def live_report(fig: dict[str, Any], wire_ms: float | None) -> list[str]:
    period, camera = fig["frame_period_ms"], fig["camera_fps"]
    lines = [
        "",
        f"Real-time loop (issue 28): run_recorded (servolab flyball --frames --port) on "
        f"{fig['frames']} PNG frames at {camera:g} frames/s, wall clock; wheels {fig['motors']} "
        f"at {fig['baudrate']} bps on servolab sim --pty, or in-process emulated (the anchor)",
        f"{'run':24}{'fps':>7}{'/66':>7}{'p50':>8}{'p99':>8}{'p99/per':>9}{'max':>8}"
        f"{'late':>6}{'drop':>6}{'handled':>9}",
        f"{'':24}{'':>7}{'':>7}{'ms':>8}{'ms':>8}{'':>9}{'ms':>8}{'':>6}{'':>6}{'':>9}",
    ]
    for r in fig["runs"]:
        i = r["interval_ms"]
        handled = f"{r['handled']}/{r['recording_frames']}"
        lines.append(f"{r['label']:24}{r['achieved_fps']:7.2f}{r['ratio_camera']:7.3f}"
                     f"{i['p50']:8.2f}{i['p99']:8.2f}{r['p99_share_of_period']:9.3f}"
                     f"{i['max']:8.2f}{r['late_frames']:6d}{r['dropped_frames']:6d}"
                     f"{handled:>9}")
    lines.append(f"p50, p99, max: the interval between handled frames (ideal: every one "
                 f"{period:.2f} ms); /66 and p99/per: fps over the camera's {camera:g}, p99 "
                 f"over the frame period (ideal: both 1); late: handled more than a period "
                 f"after capture; drop: gaps in the camera's sequence (which a camera tick "
                 f"late by over half a period also makes); handled: frames tracked of the "
                 f"recording's")
    for r in fig["runs"]:
        if r["bus"] != "pty":
            continue
        lines.append(f"  {r['label']}: ratio fps pty/in-process = "
                     f"{r['ratio_fps_in_process']:.3f}, ratio p99 interval pty/in-process = "
                     f"{r['ratio_p99_in_process']:.3f}; latency p99 "
                     f"{r['latency_ms']['p99']:.2f} ms, max {r['latency_ms']['max']:.2f} ms; "
                     f"the simulator received {r['sim_instructions']} instructions; fly "
                     f"found in {r['fly_found_share']:.0%}; run {r['run_wall_s']:.1f} s")
    for r in fig["runs"]:
        if r["error"] is not None:
            lines.append(f"  {r['label']}: FAILED after {r['handled']} frames (its figures "
                         f"are of those): {r['error']}")
    wire = "" if wire_ms is None else f" ({wire_ms:.3f} ms a frame, part 1)"
    lines.append(f"in-process: the emulated bus's wire time is simulated, not waited for{wire}; "
                 "the pty's motors answer in real time at 1 Mbps from their own process")
    before, after = fig["load_average_1min"]
    lines.append(f"idle: no processes of this benchmark's beside the loop; the machine's 1-minute "
                 f"load average was {before:.2f} before these runs and {after:.2f} after "
                 f"({fig['cores']} cores): other work on it is in the figures")
    if fig["busy_cores"]:
        lines.append(f"busy CPU: {fig['busy_cores']} processes spinning in Python, one per "
                     "core, beside the loop (servolab sim raises its own priority where "
                     "allowed)")
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0] if __doc__ else "")
    parser.add_argument("--quick", action="store_true",
                        help="fewer frames and repeats; the real-time loop on an idle CPU "
                        f"only, {QUICK_LIVE_FRAMES} frames")
    parser.add_argument("--no-pty", action="store_true",
                        help="leave out the real-time loop on servolab sim --pty (and its "
                        "in-process anchor)")
    parser.add_argument("--pty-out", type=Path, metavar="DIR",
                        help="keep the recording and the real-time runs' folders here "
                        "(default: a temporary folder)")
    parser.add_argument("--json", metavar="PATH", help="write the figures as JSON")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    # A stop signal unwinds like Ctrl-C, so that the simulator and the busy processes are
    # stopped on the way out.
    with on_stop_signals(raise_keyboard_interrupt):
        if args.quick:
            fig = bench(QUICK_FRAMES, QUICK_PASSES, QUICK_REPEATS)
        else:
            fig = bench(FULL_FRAMES, FULL_PASSES, FULL_REPEATS)
        print("\n".join(report(fig)), flush=True)
        live, failed = None, []
        if not args.no_pty:
            live = bench_live(QUICK_LIVE_FRAMES if args.quick else FULL_LIVE_FRAMES,
                              busy=not args.quick, keep=args.pty_out)
            print("\n".join(live_report(live, fig["loop"]["simulated_wire_ms_per_frame"])))
            if args.pty_out:
                print(f"(recording and run folders in {args.pty_out})")
            failed = [r["label"] for r in live["runs"] if r["error"] is not None]
    elapsed = time.perf_counter() - t0
    print(f"\n(total {elapsed:.1f} s)")
    if args.json:
        figures = {"quick": args.quick, "seed": SEED, "noise_std": NOISE_STD, **fig,
                   "realtime": live,
                   "opencv": cv2.__version__, "opencv_threads": cv2.getNumThreads(),
                   "elapsed_s": elapsed}
        Path(args.json).write_text(json.dumps(figures, indent=2) + "\n")
    if failed:
        print(f"real-time run(s) failed: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0

if __name__ == "__main__":
    sys.exit(main())
