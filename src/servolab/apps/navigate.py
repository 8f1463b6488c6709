"""``servolab navigate --goal X Y [YAW]``: seed 000's navigation loop on the simulated floor.

The command only parses; :mod:`servolab.robots.navigation.run` runs the loop (its docstring
lists the nodes, the calibration and the parameter files). Coordinates are metres on the
floor's map: the scene's frame without --calib, else the frame of the calibration board that
lay on the floor (placed with --board-at); the yaw is in degrees, as a user types it.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from typing import TYPE_CHECKING

from .arguments import add_namespace, add_out, finite_float, nonnegative_int, positive_float
from .registry import Command
from .view import add_view_flag, view_request

if TYPE_CHECKING:
    from ..runs import RunFolder


def _add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--goal", required=True, type=finite_float, nargs="+", metavar="V",
                   help="X Y [YAW]: the goal on the floor in metres, and the heading to end "
                   "with in degrees (default: the direction from the start to the goal)")
    p.add_argument("--scene", metavar="YAML", help="the simulated world: floor, overhead "
                   "camera, obstacles (some appearing mid-run) and the robot's start "
                   "(default: the shipped nav_scene; 'servolab robots show nav_scene' prints it)")
    p.add_argument("--calib", metavar="YAML", help="the camera's calibration with its floor "
                   "plane, from 'servolab calibrate ... --floor IMAGE' (default: calibrate the "
                   "scene's camera first, on synthetic board images)")
    p.add_argument("--board-at", type=finite_float, nargs="+", metavar="V",
                   help="with --calib: X Y [YAW] where the floor board lay, its first inner "
                   "corner in metres and its first row's heading in degrees (default 0 0 0: "
                   "the board's corner is the map's origin)")
    p.add_argument("--costmap", metavar="YAML", help="costmap_2d parameters (default: seed "
                   "000's D.2, 'servolab robots show costmap_params')")
    p.add_argument("--dwa", metavar="YAML", help="dwa_local_planner parameters (default: "
                   "seed 000's D.3, 'servolab robots show dwa_params')")
    p.add_argument("--move-base", metavar="YAML", help="move_base parameters (default: "
                   "turtlebot's, controller_frequency 5 Hz: 'servolab robots show "
                   "move_base_params')")
    p.add_argument("--timeout", type=positive_float, default=180.0, metavar="S",
                   help="give up after this many simulated seconds (default 180)")
    p.add_argument("--seed", type=nonnegative_int, default=0, help="seed of the camera's "
                   "image noise and the calibration views (default 0)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_namespace(p, "the run's nodes (base, camera, tracker, localiser, navigator)")
    add_view_flag(p)
    add_out(p)


def _run(args: argparse.Namespace) -> int:
    from ..errors import UsageError
    from ..robots.navigation.run import prepare, run_navigate
    from ..runs import RunFolder

    view = view_request(args)  # checked before the run folder is made
    if len(args.goal) not in (2, 3):
        raise UsageError(f"--goal takes X Y or X Y YAW, not {len(args.goal)} number(s)")
    x, y = args.goal[:2]
    yaw = math.radians(args.goal[2]) if len(args.goal) == 3 else None
    board_at = None
    if args.board_at is not None:
        if len(args.board_at) not in (2, 3):
            raise UsageError(f"--board-at takes X Y or X Y YAW, not {len(args.board_at)} "
                             "number(s)")
        bx, by, *turn = args.board_at
        board_at = (bx, by, math.radians(turn[0]) if turn else 0.0)
    # everything read and checked before a run folder is made or anything moves
    navigation = prepare((x, y), goal_yaw=yaw, scene=args.scene, calib=args.calib,
                         board_at=board_at, costmap=args.costmap, dwa=args.dwa,
                         move_base=args.move_base, namespace=args.namespace)
    with RunFolder.create("navigate", args.out) as run:
        run_navigate(run, navigation, timeout=args.timeout, seed=args.seed,
                     show_progress=not args.no_progress, view=view)
    print(f"run folder: {run.path}")
    return 0



def _demo(run_folder: RunFolder, say: Callable[[str], None]) -> dict[str, object]:
    """Seed 000's loop: overhead camera, D* Lite, DWA; an obstacle appears on the way."""
    from ..robots.navigation.run import prepare, run_navigate

    say("Seed 000's navigation: the overhead camera is calibrated, then the robot drives to")
    say("   (3.3, 2.3) with D* Lite and DWA; at 6 s an obstacle appears on its path")
    say("   (servolab navigate --goal 3.3 2.3; see docs/navigation.md)")
    summary = run_navigate(run_folder, prepare((3.3, 2.3)),
                           say=lambda text: say("   " + text), show_progress=False)
    return {k: summary[k] for k in ("status", "goal_distance_m", "min_clearance_m", "repairs",
                                    "bag", "plot")}

COMMAND = Command(
    name="navigate", group="robots", help="drive to a goal with the overhead camera, D* Lite "
    "and DWA (simulated)",
    description="Seed 000's navigation on the simulated floor: the overhead camera (synthetic, "
    "calibrated first unless --calib is given) gives the map and the robot's position, D* Lite "
    "plans on the costmap and repairs the plan when an obstacle appears, DWA drives the "
    "emulated base through /cmd_vel on the pose fused from odometry and the camera, and the "
    "robot stops within the goal tolerances. The run folder gets navigate_bag/ (MCAP), "
    "navigate.png, calibration.yaml and summary.json.",
    examples=("servolab navigate --goal 2.6 1.6",
              "servolab navigate --goal 2.6 1.6 90 --scene my_scene.yaml --out runs/nav-a",
              "servolab navigate --goal 3.3 2.3 --namespace /robot1"),
    add_arguments=_add_arguments, run=_run, demo=_demo)
