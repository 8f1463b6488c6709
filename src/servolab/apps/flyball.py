"""``servolab flyball``: seed 002's machine-insect interface, and ``servolab flyball analyze
RUN``, chapter 3's analysis of a run's logs.

The command only parses; :mod:`servolab.robots.treadmill.run` runs the closed loop on the
simulated fly, ball and robot, and :mod:`servolab.robots.treadmill.analysis` computes and draws
what the thesis reports.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import TYPE_CHECKING

from .arguments import PORT_HELP, add_out, nonnegative_int, positive_float
from .registry import Command
from .view import add_view_flag, view_request

if TYPE_CHECKING:
    from ..runs import RunFolder


def _add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--duration", type=positive_float, metavar="S",
                   help="simulated seconds to run (default 100, the thesis's experiment)")
    p.add_argument("--seed", type=nonnegative_int,
                   help="seed of the fly's walk and the camera's noise (default 0)")
    p.add_argument("--frames", metavar="DIR|VIDEO|BIN", help="track a recording instead of "
                   "the simulated fly: a folder of images in name order, a video OpenCV can "
                   "open, or the thesis's Fly_Image.bin (raw frames; see --size); one record "
                   "per frame")
    p.add_argument("--camera", metavar="INDEX|DEVICE", help="track a live camera (an OpenCV "
                   "device index such as 0, or a path such as /dev/video0) until stopped "
                   "with Ctrl-C; each frame is stamped when it was captured")
    p.add_argument("--size", type=_size, metavar="WxH", help="the camera's frame size, for "
                   "--frames BIN or --camera: short for --set camera.width=W --set "
                   "camera.height=H (default the rig's, 640x376; give controller.target too)")
    p.add_argument("--port", metavar="PORT", help="with --frames or --camera: the "
                   "treadmill's real motors (IDs 100-102, Protocol 2.0, 1 Mbps) on this "
                   "port: " + PORT_HELP + "; default emulated")
    p.add_argument("--fps", type=positive_float, metavar="HZ",
                   help="with --frames: the rate the recording was made at (default: a "
                   "video's own, else the rig camera's 66)")
    p.add_argument("--rig", metavar="FILE", help="the rig's file: ball, camera, tracker, "
                   "controller (default: the thesis's rig, servolab's treadmill.yaml; copy "
                   "it to start yours)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="overrides",
                   help="change one value of the rig, as in --set tracker.polarity=dark "
                   "(repeatable)")
    p.add_argument("--record-video", metavar="FILE", help="write every camera frame to FILE: "
                   ".avi (lossless FFV1), .mp4, or .bin (the thesis's Fly_Image.bin)")
    p.add_argument("--clamp", choices=("scaled", "per-wheel"), default="scaled",
                   help="how the robot brings wheel speeds past its limit back: scaled "
                   "together, keeping its path (default), or per-wheel, each on its own as "
                   "the thesis's Listing 4 does")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_view_flag(p)
    add_out(p)
    sub = p.add_subparsers(dest="action", metavar="analyze")
    analyze = sub.add_parser("analyze", help="chapter 3's analysis of a run folder's logs",
                             description="Read RUN/fly_data.bin and RUN/robot_encoders.bin "
                             "(the thesis's binary layouts) and write the mean distance and "
                             "angle errors, the sphere's and the robot's paths and the "
                             "response delay to RUN/analysis.json, with RUN/flyball.png.")
    analyze.add_argument("run", metavar="RUN", help="a run folder of servolab flyball, or "
                         "any folder holding the two logs")
    analyze.add_argument("--partial", action="store_true", help="read the whole records of "
                         "a log cut off by a crash (says how many)")


def _size(text: str) -> tuple[int, int]:
    width, x, height = text.lower().partition("x")
    if not (x and width.isdigit() and height.isdigit() and int(width) > 0 and int(height) > 0):
        raise argparse.ArgumentTypeError(f"{text!r} is not a size WxH, as in 640x376")
    return int(width), int(height)


def _analyze(args: argparse.Namespace) -> int:
    import json
    import warnings
    from pathlib import Path

    import numpy as np

    from ..errors import UsageError
    from ..robots.treadmill.analysis import analyze, plot_analysis
    from ..robots.treadmill.logs import ENCODER_RECORD, FlyLogError, read_encoder_log, read_fly_log

    run = Path(args.run)
    if not run.is_dir():
        raise UsageError(f"{run} is not a folder")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fly = read_fly_log(run / "fly_data.bin", partial=args.partial)
        robot = run / "robot_encoders.bin"  # a treadmill without a robot has none
        encoders = (read_encoder_log(robot, partial=args.partial) if robot.exists()
                    else np.zeros(0, dtype=ENCODER_RECORD))
    for warning in caught:
        print(f"servolab flyball analyze: {warning.message}")
    if len(fly) < 2:
        raise FlyLogError(run / "fly_data.bin", f"holds {len(fly)} record(s); the analysis "
                          "needs at least two frames")
    result, series = analyze(fly, encoders)
    (run / "analysis.json").write_text(json.dumps(result.summary(), indent=2) + "\n")
    plot = plot_analysis(result, series, fly, run / "flyball.png")
    print(f"{result.frames} frames ({result.frames_with_fly} with the fly): mean distance "
          f"error {result.mean_distance_error_mm:.3f} mm (thesis 1.821), mean angle error "
          f"{result.mean_angle_error_deg:.2f}° (thesis 7.039); {run / 'analysis.json'}, {plot}")
    return 0


def _run(args: argparse.Namespace) -> int:
    view = view_request(args)  # checked before the run folder is made
    if args.action == "analyze":
        return _analyze(args)
    from ..errors import UsageError
    from ..robots.treadmill.config import load_rig
    from ..robots.treadmill.run import run_flyball, run_recorded
    from ..runs import RunFolder

    real = args.frames is not None or args.camera is not None
    if args.frames is not None and args.camera is not None:
        raise UsageError("--frames and --camera are two sources of frames: give one")
    if real and (args.duration is not None or args.seed is not None):
        raise UsageError("--duration and --seed are the simulated fly's; a recording "
                         "(--frames) runs as long as it is, a camera until Ctrl-C")
    if args.fps is not None and args.frames is None:
        raise UsageError("--fps is the rate a recording was made at: give --frames too (a "
                         "camera's frames are stamped as captured; the simulated camera "
                         "runs at the rig's camera.frame_rate)")
    if args.size is not None and not real:
        raise UsageError("--size is the size of --frames BIN or --camera frames; the "
                         "simulated camera's is the rig's (--set camera.width=...)")
    if args.record_video is not None:
        from pathlib import Path

        from ..vision.frame_writer import SUFFIXES

        if Path(args.record_video).suffix.lower() not in SUFFIXES:
            raise UsageError(f"--record-video {args.record_video}: the file's suffix says "
                             f"how it is written: one of {', '.join(SUFFIXES)}")
    if args.size is not None:
        args.overrides += [f"camera.width={args.size[0]}", f"camera.height={args.size[1]}"]
    if args.port is not None and not real:
        raise UsageError("--port drives the real treadmill, which needs real frames: give "
                         "--frames or --camera too (the simulated fly is on a simulated ball)")
    rig = load_rig(args.rig, args.overrides)  # a bad rig: before a run folder
    size = rig.camera.size
    if args.frames is not None:
        from ..vision.frame_source import FrameSource

        FrameSource.open(args.frames, size=size).close()  # a bad recording, likewise
    if real:
        with RunFolder.create("flyball", args.out) as run:
            run_recorded(run, args.frames, camera=args.camera, port=args.port,
                         fps=args.fps, show_progress=not args.no_progress, rig=rig,
                         size=size, record_video=args.record_video,
                         view=view)
    else:
        with RunFolder.create("flyball", args.out) as run:
            run_flyball(run, duration=100.0 if args.duration is None else args.duration,
                        seed=args.seed or 0, show_progress=not args.no_progress,
                        wheel_clamp=args.clamp, rig=rig, record_video=args.record_video,
                        view=view)
    print(f"run folder: {run.path}")
    return 0



def _demo(run_folder: RunFolder, say: Callable[[str], None]) -> dict[str, object]:
    """Seed 002: a simulated fly on the ball treadmill steers the robot, for 10 s."""
    from ..robots.treadmill.run import run_flyball

    say("Seed 002's machine-insect interface: a simulated fruit fly walks on a ball, the")
    say("   camera finds it 66 times a second, three wheels turn the ball back, a robot follows")
    say("   (servolab flyball; see docs/treadmill.md)")
    summary = run_flyball(run_folder, duration=10.0, say=lambda text: say("   " + text),
                          show_progress=False)
    return {k: summary[k] for k in ("frames", "analysis", "bag", "plot")}

COMMAND = Command(
    name="flyball", group="robots", help="seed 002's fly on the ball treadmill steering a "
    "robot (simulated), and its analysis",
    description="A fruit fly walks on a ball; a camera below finds it, three omni-wheels turn "
    "the ball to bring it back to the image centre (Listing 1's tracker and controller, one "
    "SYNC_WRITE and one SYNC_READ per frame at 66 frames/s), and a TurtleBot3 Waffle is driven "
    "by the same error. Simulated fly, ball and robot. The run folder gets fly_data.bin and "
    "robot_encoders.bin in the thesis's binary layouts, flyball_bag/ (MCAP), flyball.png and "
    "summary.json with chapter 3's figures.",
    examples=("servolab flyball --duration 100",
              "servolab flyball --frames Fly_Image_Mar_28.bin --fps 66",
              "servolab flyball --camera 0 --rig my_rig.yaml --record-video raw.avi",
              "servolab flyball --set tracker.polarity=dark --set tracker.threshold=200",
              "servolab flyball --duration 20 --seed 3 --out runs/fly-a",
              "servolab flyball --duration 20 --view",
              "servolab flyball analyze runs/fly-a"),
    add_arguments=_add_arguments, run=_run, demo=_demo)
