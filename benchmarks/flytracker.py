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

Run: ``.venv/bin/python benchmarks/flytracker.py [--quick] [--json PATH]``. ``--quick`` uses
fewer frames and repeats (a second or two); the full run takes a few seconds.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import statistics
import sys
import tempfile
import time
from collections.abc import Sequence
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


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0] if __doc__ else "")
    parser.add_argument("--quick", action="store_true", help="fewer frames and repeats")
    parser.add_argument("--json", metavar="PATH", help="write the figures as JSON")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    if args.quick:
        fig = bench(QUICK_FRAMES, QUICK_PASSES, QUICK_REPEATS)
    else:
        fig = bench(FULL_FRAMES, FULL_PASSES, FULL_REPEATS)
    print("\n".join(report(fig)))
    elapsed = time.perf_counter() - t0
    print(f"\n(total {elapsed:.1f} s)")
    if args.json:
        figures = {"quick": args.quick, "seed": SEED, "noise_std": NOISE_STD, **fig,
                   "opencv": cv2.__version__, "opencv_threads": cv2.getNumThreads(),
                   "elapsed_s": elapsed}
        Path(args.json).write_text(json.dumps(figures, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
