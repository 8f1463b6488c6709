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

from .arguments import (
    add_namespace,
    add_out,
    add_transport,
    finite_float,
    nonnegative_int,
    positive_float,
    transport_options,
)
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
    robot = p.add_argument_group(
        "a robot on the graph (--map)", "navigate a robot that runs elsewhere (servolab "
        "control run turtlebot3_waffle, a TurtleBot3's bringup) rather than the simulated "
        "floor: the map from a map_server map.yaml, the pose from the robot's odometry and "
        "its start, commands on its cmd_vel; --timeout is then in seconds of the wall clock")
    robot.add_argument("--map", metavar="YAML", help="the map (map_server's map.yaml)")
    robot.add_argument("--initial-pose", type=finite_float, nargs="+", metavar="V",
                       help="X Y [YAW]: where the robot stands on the map when its odometry "
                       "reads zero, in metres and degrees (default yaw 0)")
    robot.add_argument("--cmd-vel", default="cmd_vel", metavar="TOPIC",
                       help="the robot's command topic, in its namespace (default cmd_vel, "
                       "TurtleBot3's; diff_drive_controller/cmd_vel for servolab control run)")
    robot.add_argument("--odom", default="odom", metavar="TOPIC",
                       help="the robot's odometry topic (default odom; "
                       "diff_drive_controller/odom for servolab control run)")
    add_transport(p)


#: the options of each of the two kinds of run, refused in the other
_SIMULATED_ONLY = ("scene", "calib", "board_at", "view")
_ON_GRAPH_ONLY = ("initial_pose", "listen", "connect", "domain_id")


def _given(args: argparse.Namespace, names: tuple[str, ...]) -> list[str]:
    return [f"--{n.replace('_', '-')}" for n in names if getattr(args, n) not in (None, [])]


def _run(args: argparse.Namespace) -> int:
    from ..errors import UsageError
    from ..robots.navigation.run import prepare, run_navigate
    from ..runs import RunFolder

    if len(args.goal) not in (2, 3):
        raise UsageError(f"--goal takes X Y or X Y YAW, not {len(args.goal)} number(s)")
    x, y = args.goal[:2]
    yaw = math.radians(args.goal[2]) if len(args.goal) == 3 else None
    if args.map is not None:
        return _run_on_graph(args, (x, y), yaw)
    given = _given(args, _ON_GRAPH_ONLY)
    if args.transport != "zenoh":  # the simulated floor's nodes share one process
        given.append(f"--transport {args.transport}")
    if given:
        raise UsageError(f"{', '.join(given)}: for a robot on the graph, with --map")
    view = view_request(args)  # checked before the run folder is made
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


def _run_on_graph(args: argparse.Namespace, goal: tuple[float, float],
                  yaw: float | None) -> int:
    from ..errors import UsageError
    from ..robots.navigation.on_graph import prepare, run_navigate_on_graph
    from ..runs import RunFolder

    if given := _given(args, _SIMULATED_ONLY):
        raise UsageError(f"{', '.join(given)}: for the simulated floor, not with --map")
    if args.initial_pose is None or len(args.initial_pose) not in (2, 3):
        raise UsageError("--map needs --initial-pose X Y [YAW]: where the robot stands on the "
                         "map when its odometry reads zero")
    x0, y0, *turn = args.initial_pose
    navigation = prepare(args.map, (x0, y0, math.radians(turn[0]) if turn else 0.0), goal,
                         transport_options(args), goal_yaw=yaw, costmap=args.costmap,
                         dwa=args.dwa, move_base=args.move_base, namespace=args.namespace,
                         cmd_vel=args.cmd_vel, odom=args.odom)
    with RunFolder.create("navigate", args.out) as run:
        run_navigate_on_graph(run, navigation, timeout=args.timeout,
                              show_progress=not args.no_progress)
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
              "servolab navigate --goal 3.3 2.3 --namespace /robot1",
              "servolab navigate --map map.yaml --initial-pose 0.5 0.5 --goal 2 1 "
              "--namespace /robot1 --cmd-vel diff_drive_controller/cmd_vel "
              "--odom diff_drive_controller/odom --connect tcp/router.local:7447"),
    add_arguments=_add_arguments, run=_run, demo=_demo)
