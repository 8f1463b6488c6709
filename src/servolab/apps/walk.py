"""``servolab walk``: Armstrong stands up and walks (seed 001's control node), recorded.

The command only parses; :mod:`servolab.robots.armstrong.run` runs the robot.
"""

from __future__ import annotations

import argparse
import math
import sys
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from .arguments import PORT_HELP, add_log_level, add_out, log_level
from .registry import Command
from .view import add_view_flag, view_request

if TYPE_CHECKING:
    from ..robots.armstrong.description import Assumptions
    from ..runs import RunFolder


def _add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--file", metavar="CSV", help="motion file to play (columns m11..m62, "
                   "degrees, as 001 Table 4.3); default: the seed's gait, generated now")
    p.add_argument("--gait", choices=("seed", "zmp"), default="seed",
                   help="without --file: 'seed' (default), seed 001's gait (Appendix D/E), "
                   "played --steps times; 'zmp', servolab's own (Kajita's preview control of "
                   "the zero-moment point), --steps footsteps (even; default 10) played once")
    p.add_argument("--steps", type=int, metavar="N",
                   help="how many times the sequence is played (default 1); with --gait zmp "
                   "the number of footsteps")
    p.add_argument("--rate", type=float, metavar="HZ",
                   help="rows a second (default 4.5: 17 rows, 3.78 s a step, as the seed; "
                   "10 for --gait zmp, the rate it is made for)")
    p.add_argument("--port", metavar="PORT", help="the robot's port: " + PORT_HELP +
                   "; default: the emulated robot (20 RX-28, motor 62 absent, as in the seed)")
    p.add_argument("--config", metavar="YAML", help="controller configuration "
                   "(default: the seed's, armstrong.yaml; 'servolab robots show armstrong' "
                   "prints it)")
    p.add_argument("--world", choices=("kinematic", "mujoco"), default="kinematic",
                   help="what the emulated robot stands in: 'kinematic' (default: joints go "
                   "where they are sent, nothing falls; the quick check of a motion file) or "
                   "'mujoco' (gravity, contacts, the RX-28 firmware's torque: does it fall?)")
    p.add_argument("--assume", action="append", default=[], metavar="NAME=VALUE",
                   help="with --world mujoco: change one of the description's assumptions "
                   "(SI units, e.g. --assume hip_width=0.12 --assume chest_mass=0.3; "
                   "'servolab robots show armstrong.assumptions' lists them)")
    p.add_argument("--video", metavar="FILE", help="with --world mujoco: render the run to "
                   "FILE (.mp4 or .avi), headless (needs EGL)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_view_flag(p)
    add_log_level(p)
    add_out(p)


def _run(args: argparse.Namespace) -> int:
    from ..gait.motionfile import MotionFileWarning
    from ..middleware.logger import console_log
    from ..robots.armstrong.control_node import PLAY_RATE
    from ..robots.armstrong.motions import load_motion, zmp_motion
    from ..robots.armstrong.run import run_walk
    from ..runs import RunFolder

    view = view_request(args)  # checked before the run folder is made
    steps = _check(args)
    assumptions = _assumptions(args.assume)
    rate = args.rate if args.rate is not None else PLAY_RATE
    with warnings.catch_warnings(record=True) as caught:  # one line each, not Python's two
        warnings.simplefilter("always", MotionFileWarning)
        if args.gait == "zmp":   # generated for this robot, checked before anything moves
            from ..gait.zmp_walk import ZmpWalkParameters

            asked = ZmpWalkParameters() if args.rate is None else ZmpWalkParameters(
                rate=args.rate)    # planned for the rate it will be played at
            motion, rate = zmp_motion(steps, args.config, assumptions, asked)
            steps = 1            # the footsteps are in the motion: it is played once
        else:
            motion = load_motion(args.file, args.config)  # checked whole before it moves
    for warning in caught:
        print(f"servolab walk: warning: {warning.message}", file=sys.stderr)
    log_level(args)
    with console_log(), RunFolder.create("walk", args.out) as run:
        run_walk(run, motion, steps=steps, rate=rate, port=args.port,
                 config=args.config, show_progress=not args.no_progress, world=args.world,
                 assumptions=assumptions, video=Path(args.video) if args.video else None,
                 gait=args.file or args.gait, view=view)
    print(f"run folder: {run.path}")
    return 0


def _check(args: argparse.Namespace) -> int:
    """The options checked together before anything is made; the number of steps."""
    from ..errors import UsageError

    if args.file and args.gait != "seed":
        raise UsageError("--file plays a motion file; --gait generates one: give one of them")
    steps: int = args.steps if args.steps is not None else (10 if args.gait == "zmp" else 1)
    if steps < 1:
        raise UsageError(f"--steps {steps}: must be 1 or more")
    if (args.assume or args.video) and args.world != "mujoco":
        raise UsageError(("--assume" if args.assume else "--video") + " needs --world mujoco "
                         "(the kinematic world has no bodies)")
    if args.port and args.world != "kinematic":
        raise UsageError(f"--world {args.world}: a robot on --port {args.port} walks in the "
                         "real world; worlds are for the emulated robot (leave out --port)")
    if args.video:
        from ..sim.mujoco_video import FOURCC

        video = Path(args.video)
        if video.suffix.lower() not in FOURCC:
            raise UsageError(f"--video {video}: name it .mp4 or .avi (the suffix says which "
                             "video OpenCV writes)")
        if not video.parent.is_dir():
            raise UsageError(f"--video {video}: the folder {video.parent} does not exist")
    if args.rate is not None and not (math.isfinite(args.rate) and args.rate > 0):
        raise UsageError(f"--rate {args.rate:g}: must be a number > 0")
    return steps


def _assumptions(items: list[str]) -> Assumptions | None:
    """The description's assumptions changed by ``--assume NAME=VALUE``, or None."""
    from ..errors import UsageError

    values: dict[str, float] = {}
    for item in items:
        name, sep, text = item.partition("=")
        try:
            number = float(text)
        except ValueError:
            sep = ""
        if not sep:
            raise UsageError(f"--assume {item!r}: give NAME=NUMBER, e.g. hip_width=0.12")
        if name.strip() in values:
            raise UsageError(f"--assume {name.strip()} is given twice")
        values[name.strip()] = number
    if not values:
        return None
    from ..robots.armstrong.description import Assumptions

    return Assumptions.with_values(values)



def _demo(run_folder: RunFolder, say: Callable[[str], None]) -> dict[str, object]:
    """Armstrong (seed 001) stands up and walks one step, recorded (see docs/biped.md)."""
    from ..robots.armstrong.motions import load_motion
    from ..robots.armstrong.run import run_walk

    say("Armstrong, the biped of seed 001: 20 emulated RX-28 stand up and walk one step")
    say("   (servolab walk; see docs/biped.md)")
    summary = run_walk(run_folder, load_motion(None), steps=1,
                       say=lambda text: say("   " + text), show_progress=False)
    return {k: summary[k] for k in ("rows_played", "walked_s", "bag", "plot")}

COMMAND = Command(
    name="walk", group="robots", help="Armstrong stands up and walks (seed 001), recorded",
    description="Move Armstrong to the stand pose of 001 Table 4.2, then play a motion "
    "sequence N times at 4.5 rows a second, as the seed's control node does; commands and "
    "motor states go to the run folder's MCAP bag, with a plot of commanded against present "
    "angles. Ctrl-C, SIGTERM, SIGHUP or an alarm (a motor silent, overloaded or overheating) "
    "end the gait at the next row and bring the joints to the stand pose, both feet down, "
    "with torque on (a biped that went limp would fall); the bag is closed and summary.json "
    "says what ended the run and lists the alarms.",
    examples=("servolab walk --steps 2", "servolab walk --file gait.csv --steps 4",
              "servolab walk --world mujoco --steps 4 --video walk.mp4",
              "servolab walk --world mujoco --gait zmp --steps 10",
              "servolab walk --port /dev/ttyUSB0 --steps 1"),
    add_arguments=_add_arguments, run=_run, demo=_demo)
