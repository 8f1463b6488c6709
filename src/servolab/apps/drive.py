"""``servolab drive MOVE``: seed 000's moves on a differential-drive base, recorded.

The command only parses; :mod:`servolab.robots.base.run` runs the base. SI units: metres,
metres a second, degrees for a rotation's angle (the seed's centimetres are converted, never
assumed).
"""

from __future__ import annotations

import argparse

from .arguments import PORT_HELP, add_out, finite_float, positive_float
from .registry import Command


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--base", metavar="NAME|YAML", help="a shipped base by name (seed000, "
                   "seed000_4motor, turtlebot3_waffle: 'servolab robots') or a base file "
                   "(default seed000, seed 000's two-wheel robot)")
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
    add_out(p)


def _add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="move", required=True, metavar="MOVE")
    line = sub.add_parser("line", help="a straight line, stopping at the distance (encoders)")
    line.add_argument("--distance", type=finite_float, required=True, metavar="M",
                      help="metres (negative: backwards)")
    line.add_argument("--speed", type=positive_float, default=0.1, metavar="M_S")
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
    from ..robots.base.run import prepare, run_drive
    from ..runs import RunFolder

    # the move, the floor and the base checked before a run folder is made
    base = prepare(args.move, args.base, slip=args.slip, slip_jitter=args.slip_jitter,
                   encoder_noise=args.encoder_noise)
    with RunFolder.create("drive", args.out) as run:
        run_drive(run, args.move, distance=getattr(args, "distance", 1.0),
                  speed=getattr(args, "speed", 0.1), radius=getattr(args, "radius", 0.5),
                  clockwise=getattr(args, "clockwise", False),
                  turns=getattr(args, "turns", 1.0), angle_deg=getattr(args, "angle", 90.0),
                  base=base, port=args.port, show_progress=not args.no_progress,
                  slip=args.slip, slip_jitter=args.slip_jitter,
                  encoder_noise=args.encoder_noise, real_time=args.real_time)
    print(f"run folder: {run.path}")
    return 0


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
              "servolab drive circle --radius 0.5 --base turtlebot3_waffle"),
    add_arguments=_add_arguments, run=_run)
