"""``servolab drive MOVE``: seed 000's moves on a differential-drive base, recorded.

The command only parses; :mod:`servolab.robots.base.run` runs the base. SI units: metres,
metres a second, degrees for a rotation's angle (the seed's centimetres are converted, never
assumed). Two options of ``line`` take seed 000 A.2's own units so that final.m can be run as
written: ``--percent`` (its "Speed Percentage") and ``--counts-per-mm`` (its 5265/575); they
are converted at the edge, in :mod:`servolab.robots.base`.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from typing import TYPE_CHECKING

from .arguments import PORT_HELP, add_namespace, add_out, finite_float, positive_float
from .registry import Command
from .view import add_view_flag, view_request

if TYPE_CHECKING:
    from ..runs import RunFolder


def counts_per_mm(text: str) -> float:
    """An argparse type: encoder counts a millimetre, > 0, as a number or as a ratio written
    the way final.m writes it (``5265/575``)."""
    top, slash, bottom = text.partition("/")
    try:
        value = float(top) / float(bottom) if slash else float(text)
    except (ValueError, ZeroDivisionError):
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of counts a mm (a number "
                                         "or a ratio such as 5265/575)") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"{text} must be a number of counts a mm > 0")
    return value


def _common(p: argparse.ArgumentParser) -> None:
    from ..robots.base import DEFAULT_BASE, SHIPPED

    p.add_argument("--base", metavar="NAME|YAML", help="a shipped base by name ("
                   f"{', '.join(SHIPPED)}: 'servolab robots') or a base file (default "
                   f"{DEFAULT_BASE}, {SHIPPED[DEFAULT_BASE]})")
    p.add_argument("--port", metavar="PORT", help="the base's port: " + PORT_HELP +
                   "; default: the base emulated on a simulated floor")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--slip", type=finite_float, default=0.0, metavar="FRACTION",
                   help="emulated floor: the part of each wheel's turn that does not move the "
                   "base (default 0), so that odometry drifts from the truth")
    p.add_argument("--slip-jitter", type=finite_float, default=0.0, metavar="FRACTION",
                   help="emulated floor: a random slip on top, seeded (default 0)")
    p.add_argument("--encoder-noise", type=finite_float, default=0.0, metavar="RAD",
                   help="emulated floor: noise on each wheel position read, standard "
                   "deviation in rad (default 0)")
    p.add_argument("--real-time", action="store_true", help="emulated base: move at the "
                   "wall clock's pace (default: as fast as the computer allows)")
    add_namespace(p, "the base's topics in the bag and the view")
    add_view_flag(p)
    add_out(p)


def _add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="move", required=True, metavar="MOVE")
    line = sub.add_parser("line", help="a straight line, stopping at the distance (encoders)")
    line.add_argument("--distance", type=finite_float, required=True, metavar="M",
                      help="metres (negative: backwards)")
    pace = line.add_mutually_exclusive_group()
    pace.add_argument("--speed", type=positive_float, default=0.1, metavar="M_S",
                      help="m/s (default 0.1)")
    pace.add_argument("--percent", type=positive_float, metavar="S",
                      help="seed 000 A.2's speed: S %% of a wheel-mode motor's full output "
                      "(final.m's round(S/100*1023) to moving speed; EX-106+ bases only)")
    line.add_argument("--counts-per-mm", type=counts_per_mm, metavar="C",
                      help="stop as final.m does, when one motor's encoder has counted "
                      "round(C x mm) counts (final.m: 5265/575); default: stop on odometry")
    line.add_argument("--as-printed", action="store_true",
                      help="with --counts-per-mm: count as final.m is printed, slips included "
                      "(a wrap adds 65535, and so does a read equal to the one before)")
    circle = sub.add_parser("circle", help="a circle (000 Figure A3)")
    circle.add_argument("--radius", type=positive_float, required=True, metavar="M")
    circle.add_argument("--speed", type=positive_float, default=0.1, metavar="M_S")
    turn = circle.add_mutually_exclusive_group()
    turn.add_argument("--cw", dest="clockwise", action="store_true", help="clockwise")
    turn.add_argument("--ccw", dest="clockwise", action="store_false",
                      help="counter-clockwise (default)")
    circle.add_argument("--turns", type=positive_float, default=1.0, metavar="N")
    eight = sub.add_parser("eight", help="a figure of eight (000 Figure A4)")
    eight.add_argument("--radius", type=positive_float, required=True, metavar="M")
    eight.add_argument("--speed", type=positive_float, default=0.1, metavar="M_S")
    rotate = sub.add_parser("rotate", help="turn in place")
    rotate.add_argument("--angle", type=finite_float, required=True, metavar="DEG",
                        help="degrees, positive counter-clockwise")
    rpm = sub.add_parser("rpm", help="read each wheel's speed in rpm")
    stop = sub.add_parser("stop", help="stop every wheel")
    for p in (line, circle, eight, rotate, rpm, stop):
        _common(p)


def _run(args: argparse.Namespace) -> int:
    from ..errors import UsageError
    from ..robots.base.run import check_move, prepare, run_drive
    from ..runs import RunFolder

    view = view_request(args)  # checked before the run folder is made
    distance: float = getattr(args, "distance", 1.0)
    speed: float = getattr(args, "speed", 0.1)
    radius: float = getattr(args, "radius", 0.5)
    turns: float = getattr(args, "turns", 1.0)
    angle_deg: float = getattr(args, "angle", 90.0)
    percent: float | None = getattr(args, "percent", None)
    cpm: float | None = getattr(args, "counts_per_mm", None)
    as_printed: bool = getattr(args, "as_printed", False)
    if as_printed and cpm is None:
        raise UsageError("--as-printed counts as final.m does: give its --counts-per-mm "
                         "(5265/575)")
    # the move, the floor and the base checked before a run folder is made
    base = prepare(args.move, args.base, slip=args.slip, slip_jitter=args.slip_jitter,
                   encoder_noise=args.encoder_noise)
    # an absurd move (--angle 1e9): one line, no run folder made and nothing moved
    check_move(base, args.move, distance=distance, speed=speed, percent=percent,
               radius=radius, turns=turns, angle_deg=angle_deg, counts_per_mm=cpm)
    with RunFolder.create("drive", args.out) as run:
        run_drive(run, args.move, distance=distance, speed=speed, radius=radius,
                  clockwise=getattr(args, "clockwise", False), turns=turns,
                  angle_deg=angle_deg, base=base, port=args.port,
                  show_progress=not args.no_progress, slip=args.slip,
                  slip_jitter=args.slip_jitter, encoder_noise=args.encoder_noise,
                  real_time=args.real_time, percent=percent, counts_per_mm=cpm,
                  as_printed=as_printed, view=view, namespace=args.namespace)
    print(f"run folder: {run.path}")
    return 0



def _demo(run_folder: RunFolder, say: Callable[[str], None]) -> dict[str, object]:
    """Seed 000's two-wheel robot drives a figure of eight on the simulated floor."""
    from ..robots.base.run import run_drive

    say("Seed 000's two-wheel robot (EX-106+ wheels) drives a figure of eight on a floor")
    say("   (servolab drive eight; see docs/mobile.md)")
    summary = run_drive(run_folder, "eight", radius=0.3, speed=0.1,
                        say=lambda text: say("   " + text), show_progress=False)
    return {k: summary[k] for k in ("measured", "bag", "plot")}

COMMAND = Command(
    name="drive", group="robots", help="seed 000's moves on a wheeled base (line, circle, ...)",
    description="Drive a differential-drive base: a straight line, a circle, a figure of "
    "eight, a rotation, read the wheels' rpm or stop them. On the emulated seed-000 robot on a "
    "simulated floor by default; the run folder gets an MCAP bag, a plot of the path (truth "
    "and odometry) and summary.json.",
    examples=("servolab drive line --distance 1.0 --speed 0.1",
              "servolab drive circle --radius 0.5 --speed 0.2 --cw --turns 2",
              "servolab drive eight --radius 0.3 --speed 0.1",
              "servolab drive rotate --angle 90",
              "servolab drive line --distance 1 --percent 30 --counts-per-mm 5265/575 "
              "--base seed000_4motor",
              "servolab drive circle --radius 0.5 --base turtlebot3_waffle",
              "servolab drive circle --radius 0.5 --view"),
    add_arguments=_add_arguments, run=_run, demo=_demo)
