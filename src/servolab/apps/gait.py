"""``servolab gait generate``: the walking-pattern generator of seed 001 (Appendix D and E),
written as a motion file with its plots.

Parameters are named as in Table 5.1 (``--l-step 40``); each defaults to the seed's value.
"""

from __future__ import annotations

import argparse
import dataclasses

from .arguments import add_out
from .registry import Command

#: Table 5.1 of seed 001: parameter -> (unit, meaning)
PARAMETERS = {
    "t_step": ("ms", "time of a step (half cycle)"),
    "d_step": ("mm", "how far the hip is lowered"),
    "l_step": ("mm", "step length"),
    "c_step": ("", "number of steps (half cycles)"),
    "h_step": ("mm", "how high the swing foot is lifted"),
    "s_step": ("mm", "how far the hip moves sideways"),
}


def _add_arguments(p: argparse.ArgumentParser) -> None:
    from ..gait.walking import GaitParameters

    sub = p.add_subparsers(dest="action", required=True, metavar="ACTION")
    g = sub.add_parser("generate", help="write gait.csv, its plots and summary.json",
                       description="Generate one walking sequence with the parameters of "
                       "001 Table 5.1 (each defaulting to the seed's) into the run folder.")
    defaults = GaitParameters()
    for name, (unit, meaning) in PARAMETERS.items():
        kind = int if name == "c_step" else float
        value = getattr(defaults, name)
        g.add_argument(f"--{name.replace('_', '-')}", type=kind, default=value,
                       metavar=unit.upper() or "N",
                       help=f"{meaning} (default {value:g}{' ' + unit if unit else ''})")
    add_out(g)


def _run(args: argparse.Namespace) -> int:
    from ..gait.motionfile import write_motion_file
    from ..gait.plots import plot_foot_positions, plot_joint_angles
    from ..gait.walking import GaitParameters, generate_walk
    from ..runs import RunFolder

    # a parameter out of range, a foot out of reach: GaitValueError, one line (exit 2)
    params = GaitParameters(**{name: getattr(args, name) for name in PARAMETERS})
    walk = generate_walk(params)
    with RunFolder.create("gait", args.out) as run:  # a summary also when stopped
        csv = run.file("gait.csv")
        write_motion_file(csv, walk.motion())
        feet = plot_foot_positions(walk, run.file("feet.png"))
        angles = plot_joint_angles(walk, run.file("joint_angles.png"))
        run.write_summary({"parameters": dataclasses.asdict(params),
                           "rows": int(walk.motors.shape[0]), "columns": list(walk.columns),
                           "motion_file": str(csv), "plots": [str(feet), str(angles)],
                           "duration_ms": float(walk.time_ms[-1])})
    print(f"wrote {walk.motors.shape[0]} rows to {csv}; plots {feet.name}, {angles.name}")
    print(f"run folder: {run.path}")
    return 0


COMMAND = Command(
    name="gait", group="robots", help="generate the biped's walking sequence (seed 001)",
    description="The walking-pattern generator of seed 001 (Appendix D and E): one sequence "
    "of motor angles as a motion file, with plots of the feet and joint angles.",
    examples=("servolab gait generate", "servolab gait generate --l-step 30 --h-step 15"),
    add_arguments=_add_arguments, run=_run)
