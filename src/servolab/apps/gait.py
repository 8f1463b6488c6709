"""``servolab gait``: the walking-pattern generator of seed 001 (Appendix D and E), written as
a motion file with its plots (``generate``), and a motion file checked as the robot would
play it (``check``).

Parameters are named as in Table 5.1 (``--l-step 40``); each defaults to the seed's value,
except ``t_step``, derived from the playback rate (``--rate``, 4.5 rows a second as the seed's
control node plays, so 888.9 ms a step; :mod:`servolab.gait.walking` says why). The gait is
checked against the joints' limits of the robot's configuration (``--config``) when it is
generated, not only when it is played.
"""

from __future__ import annotations

import argparse
import dataclasses
from typing import TYPE_CHECKING, Any

from .arguments import add_out
from .registry import Command

if TYPE_CHECKING:
    from ..gait.walking import GaitParameters

#: Table 5.1 of seed 001: parameter -> (unit, meaning)
PARAMETERS = {
    "t_step": ("ms", "time of a step (half cycle)"),
    "d_step": ("mm", "how far the hip is lowered"),
    "l_step": ("mm", "step length"),
    "c_step": ("", "number of steps (half cycles), even"),
    "h_step": ("mm", "how high the swing foot is lifted"),
    "s_step": ("mm", "how far the hip moves sideways"),
}

CONFIG_HELP = ("controller configuration whose joint limits the gait must keep (default: the "
               "seed's, armstrong.yaml; 'servolab robots show armstrong' prints it)")


def _add_arguments(p: argparse.ArgumentParser) -> None:
    from ..gait.walking import PLAY_RATE, GaitParameters

    sub = p.add_subparsers(dest="action", required=True, metavar="ACTION")
    g = sub.add_parser("generate", help="write gait.csv, its plots and summary.json",
                       description="Generate one walking sequence with the parameters of "
                       "001 Table 5.1 (each defaulting to the seed's) into the run folder. "
                       "Refused, before anything is written, if a foot is out of reach, "
                       "c_step is odd (the loop would drag the planted feet), or a joint "
                       "goes beyond its configured limits.")
    defaults = GaitParameters()
    for name, (unit, meaning) in PARAMETERS.items():
        if name == "t_step":
            continue
        kind = int if name == "c_step" else float
        value = getattr(defaults, name)
        g.add_argument(f"--{name.replace('_', '-')}", type=kind, default=value,
                       metavar=unit.upper() or "N",
                       help=f"{meaning} (default {value:g}{' ' + unit if unit else ''})")
    timing = g.add_mutually_exclusive_group()
    timing.add_argument("--t-step", type=float, metavar="MS",
                        help=f"time of a step (half cycle, 4 rows); the rate to play it at "
                        f"is 4 rows / t_step (default {defaults.t_step:.1f} ms: 4 rows at "
                        f"{PLAY_RATE:g} rows a second)")
    timing.add_argument("--rate", type=float, metavar="HZ",
                        help=f"rows a second the gait will be played at (servolab walk "
                        f"--rate); gives t_step = 4 rows / rate (default {PLAY_RATE:g}, "
                        f"the seed's)")
    g.add_argument("--config", metavar="YAML", help=CONFIG_HELP)
    add_out(g)

    c = sub.add_parser("check", help="read a motion file as walk would and measure its loop",
                       description="Read a motion file as 'servolab walk --file' does (all 21 "
                       "columns, within the joints' limits; a file without a header, as "
                       "MATLAB's csvwrite writes, in the seed's column order after a "
                       "warning), then refuse it if played in a loop its wrap, last row to "
                       "first, turns a joint more than two rows inside it do.")
    c.add_argument("file", metavar="CSV", help="the motion file")
    c.add_argument("--rate", type=float, default=PLAY_RATE, metavar="HZ",
                   help=f"rows a second it will be played at (default {PLAY_RATE:g})")
    c.add_argument("--config", metavar="YAML", help=CONFIG_HELP)
    _add_send(sub)


def _add_send(sub: Any) -> None:
    from ..gait.walking import PLAY_RATE
    from .arguments import add_transport, positive_float

    s = sub.add_parser("send", help="send a motion to Armstrong's legs_controller as one "
                       "FollowJointTrajectory goal",
                       description="Send a motion (the seed's gait by default) to a running "
                       "'servolab control run armstrong' as one FollowJointTrajectory goal "
                       "for its legs_controller (joint_trajectory_controller): each row one "
                       "period after the last, at --rate rows a second, the leg columns as "
                       "the URDF's joint angles. Waits for the result; exit 0 when it "
                       "succeeded, 1 otherwise; Ctrl-C cancels the goal (the legs hold).")
    s.add_argument("file", metavar="CSV", nargs="?", default=None,
                   help="the motion file (default: the seed's gait, generated now)")
    s.add_argument("--steps", type=int, default=1, metavar="N",
                   help="how many times the sequence is played (default 1)")
    s.add_argument("--rows", type=int, default=None, metavar="N",
                   help="send only the first N rows of the whole")
    s.add_argument("--rate", type=positive_float, default=PLAY_RATE, metavar="HZ",
                   help=f"rows a second (default {PLAY_RATE:g}, the seed's)")
    s.add_argument("--controller", default="/legs_controller", metavar="NAME",
                   help="the joint_trajectory_controller (default /legs_controller)")
    s.add_argument("--timeout", type=positive_float, default=30.0, metavar="S",
                   help="s to wait for the controller's action server (default 30)")
    s.add_argument("--config", metavar="YAML", help=CONFIG_HELP)
    add_transport(s)


def _send(args: argparse.Namespace) -> int:
    from servolab.errors import UsageError
    from servolab.middleware.context import Context

    from ..robots.armstrong.motions import load_motion
    from ..robots.armstrong.ros2_control import legs_trajectory
    from ._graph import say
    from .action import STATUS_SUCCEEDED, send_goal_message
    from .arguments import transport_options

    # the motion and its trajectory are checked before the graph is joined
    motion = load_motion(args.file, args.config)
    trajectory = legs_trajectory(motion, rate=args.rate, steps=args.steps, rows=args.rows,
                                 config=args.config)
    action = f"{args.controller.rstrip('/')}/follow_joint_trajectory"
    kind = "control_msgs/action/FollowJointTrajectory"
    with Context.open(transport_options(args)) as ctx:
        goal = ctx.types.from_value(f"{kind}_Goal", {"trajectory": trajectory.fields()})
        say(f"{len(trajectory.times)} points of {len(trajectory.joint_names)} joints over "
            f"{trajectory.duration:.2f} s to {action}")
        try:
            status = send_goal_message(ctx, action, kind, goal, say, timeout=args.timeout,
                                       show_goal=False)
        except UsageError as exc:  # nobody serves the action: say what to start
            raise UsageError(f"{exc}; start the legs under ros2_control with: servolab "
                             "control run armstrong --spawn joint_state_broadcaster "
                             "legs_controller") from None
    return 0 if status == STATUS_SUCCEEDED else 1


def _parameters(args: argparse.Namespace) -> GaitParameters:
    from ..gait.walking import GaitParameters

    given = {name: getattr(args, name) for name in PARAMETERS if name != "t_step"}
    if args.rate is not None:
        return GaitParameters.at_rate(args.rate, **given)
    if args.t_step is not None:
        return GaitParameters(t_step=args.t_step, **given)
    return GaitParameters(**given)


def _play_hint(csv: object, rate: float) -> str:
    from ..gait.walking import PLAY_RATE

    option = "" if rate == PLAY_RATE else f" --rate {rate:g}"
    return f"servolab walk --file {csv}{option}"


def _generate(args: argparse.Namespace) -> int:
    from ..gait.motionfile import write_motion_file
    from ..gait.plots import plot_foot_positions, plot_joint_angles
    from ..gait.walking import generate_walk, loop_jumps
    from ..robots.armstrong.hardware import joint_limits, load_config
    from ..runs import RunFolder

    # a parameter out of range, a foot out of reach, an odd c_step, a joint beyond its
    # configured limits: GaitValueError, one line (exit 2), before the run folder exists
    params = _parameters(args)
    limits = joint_limits(load_config(args.config))
    walk = generate_walk(params, limits=limits)
    rows = int(walk.motors.shape[0])
    wrap, inner = loop_jumps(walk.motors)
    with RunFolder.create("gait", args.out) as run:  # a summary also when stopped
        csv = run.file("gait.csv")
        write_motion_file(csv, walk.motion())
        feet = plot_foot_positions(walk, run.file("feet.png"))
        angles = plot_joint_angles(walk, run.file("joint_angles.png"))
        run.write_summary({"parameters": dataclasses.asdict(params),
                           "rows": rows, "columns": list(walk.columns),
                           "motion_file": str(csv), "plots": [str(feet), str(angles)],
                           "duration_ms": float(walk.time_ms[-1]),
                           "play_rate_hz": params.play_rate,
                           "played_s": rows / params.play_rate,
                           "wrap_deg": float(wrap.max()),
                           "largest_row_change_deg": float(inner.max())})
    print(f"wrote {rows} rows to {csv}; plots {feet.name}, {angles.name}")
    print(f"t_step {params.t_step:g} ms: play it at {params.play_rate:g} rows a second "
          f"({rows / params.play_rate:.2f} s a sequence): {_play_hint(csv, params.play_rate)}")
    print(f"run folder: {run.path}")
    return 0


def _check(args: argparse.Namespace) -> int:
    import math
    import warnings

    from ..errors import UsageError
    from ..gait.walking import check_loop, loop_jumps
    from ..robots.armstrong.motions import load_motion

    if not (math.isfinite(args.rate) and args.rate > 0):
        raise UsageError(f"--rate {args.rate:g}: must be a number > 0")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        motion = load_motion(args.file, args.config)
    for warning in caught:
        print(f"servolab gait check: warning: {warning.message}")
    check_loop(motion.angles, motion.names, what=str(args.file))
    wrap, inner = loop_jumps(motion.angles)
    print(f"{args.file}: {motion.poses} rows x {len(motion.names)} motors, within the joints' "
          f"limits; {motion.poses / args.rate:.2f} s a sequence at {args.rate:g} rows a second "
          f"(t_step {4000 / args.rate:.1f} ms); looped, the wrap turns a joint at most "
          f"{wrap.max():.2f} degrees (rows inside: at most {inner.max():.2f})")
    return 0


def _run(args: argparse.Namespace) -> int:
    if args.action == "check":
        return _check(args)
    if args.action == "send":
        return _send(args)
    return _generate(args)


COMMAND = Command(
    name="gait", group="robots", help="generate the biped's walking sequence (seed 001)",
    description="The walking-pattern generator of seed 001 (Appendix D and E): one sequence "
    "of motor angles as a motion file, with plots of the feet and joint angles; a motion "
    "file checked as the robot would play it; and a motion sent to the legs under "
    "ros2_control as one trajectory goal.",
    examples=("servolab gait generate", "servolab gait generate --l-step 30 --h-step 15",
              "servolab gait generate --rate 2", "servolab gait check gait.csv",
              "servolab gait send --steps 2   # to servolab control run armstrong"),
    add_arguments=_add_arguments, run=_run)
