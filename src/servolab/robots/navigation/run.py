"""``servolab navigate``'s run: seed 000's whole loop on the simulated floor, recorded and plotted.

The nodes, in one process, in the floor's simulated time (as fast as the computer allows):

- the synthetic overhead camera (:class:`~servolab.sim.overhead_camera.OverheadCameraNode`)
  draws the scene at the robot's true pose, obstacles appearing at their time;
- the overhead tracker (:class:`~.tracker_node.OverheadTrackerNode`) turns each frame,
  through the camera's calibration, into ``/map`` and the robot's ``/tracker/pose``;
- the localiser (:class:`~servolab.robots.base.fusion_node.FusionNode`) predicts from
  ``/odom`` at a fixed rate and corrects with the tracker, as robot_localization's EKF does,
  into ``/fused_pose``, ``/odometry/filtered`` (with covariance) and ``map -> odom`` on ``/tf``;
- the navigator (:class:`~.navigator.NavigatorNode`) plans with D* Lite on the inflated map,
  repairs the plan when the map changes, and drives with DWA through ``/cmd_vel``;
- the base node (:class:`~servolab.robots.base.node.BaseNode`) turns ``/cmd_vel`` into wheel
  speeds on the emulated Dynamixel bus, and the floor's ground truth is published beside it.

**The calibration.** With ``calib`` (a file of ``servolab calibrate ... --floor``) the tracker
uses it, the floor board having lain at ``board_at`` in the map (its first inner corner at
``(x, y)`` m, its first row at ``yaw``; see :func:`~servolab.vision.calibration.in_map`, which
also turns the board's z-into-the-floor frame into a z-up map frame). Without one the run first
calibrates the scene's camera as a user would (:func:`calibrate_synthetic`): 15 views of a
10 x 7-square board, then one of a larger board lying face up on the floor at
:data:`BOARD_AT`.
The scene's camera is the truth the calibration must recover; the run writes what it found to
``calibration.yaml`` (the board's own frame, as ``servolab calibrate`` writes it).

**The parameters** are seed 000's: D.2's costmap (``costmap_params.yaml``), D.3's DWA
(``dwa_params.yaml``) and turtlebot's move_base (``move_base_params.yaml``, all three shipped here),
whose ``controller_frequency`` sets DWA's period (DWAPlanner finds it by ``searchParam``).

The context publishes ``/clock`` in the floor's simulated time and every stamp is in that
time, as under Gazebo with ``use_sim_time``.

Afterwards the run folder holds ``navigate_bag/`` (MCAP: the topics of :data:`RECORDED`, among
them what the navigator thinks as Nav2 publishes it -- ``/global_costmap/costmap``,
``/local_plan``, ``/path``, ``/goal_pose``, see :mod:`~.navigator` -- beside ``/plan``; the
TF tree is ``map -> odom`` (the localiser) and ``odom -> base_footprint`` (the base); the
camera's frames are not recorded, 300 kB each), ``navigate.png`` (the map, every plan, the path
driven and the truth), ``map.yaml`` + ``map.pgm`` (the last map the camera gave, as map_server's
map_saver writes one: ``servolab plan --map`` and ROS's map_server read it) and
``summary.json`` (with the goal refused before driving and why, warnings, the recovery
behaviours that ran).
"""

from __future__ import annotations

import dataclasses
import math
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ...harness import RunEnding, interruption, stops_deferred
from ...planning.dwa import DwaConfig
from ...sim.scene import Scene
from ...vision.calibration import (
    CameraCalibration,
    FloorExtrinsics,
    in_map,
)
from ...vision.calibration import load as load_calibration
from ...vision.calibration import save as save_calibration
from ...vision.overhead import FloorGrid
from ..base import ON_STOP as BASE_ON_STOP
from ..base.config import load as load_base
from ..base.mobile_base import MobileBase
from ..errors import RobotError
from .navigator import NavigationStatus, NavigatorNode, Patience
from .params import (
    DEFAULT_COSTMAP,
    DEFAULT_DWA,
    DEFAULT_MOVE_BASE,
    CostmapParams,
    MoveBaseParams,
    load_costmap,
    load_dwa,
    load_move_base,
    load_nav_scene,
)
from .session import (
    BOARD,
    BOARD_AT,
    MAP_MARGIN,
    POSE_TIMEOUT_FRAMES,
    VIEWS,
    NavigationError,
    calibrate_synthetic,
    fusion_for,
    map_grid,
)

if TYPE_CHECKING:
    from ...middleware.view.run_view import ViewRequest
    from ...middleware.view.server import ViewServer
    from ...runs import RunFolder

Say = Callable[[str], None]
RECORDED = ("/odom", "/ground_truth", "/cmd_vel", "/tracker/pose", "/fused_pose", "/plan",
            "/map", "/odometry/filtered", "/tf", "/clock", "/navigate_to_pose/_action/status",
            # what the navigator thinks, as Nav2 publishes it (navigator.py, display.py)
            "/global_costmap/costmap", "/local_plan", "/path", "/goal_pose")


class GoalNotReached(RobotError):
    """The robot did not reach its goal; the message says why (move_base gave up, time ran
    out) and where the run folder is. ``summary`` holds the run's figures, written already."""

    def __init__(self, message: str, summary: dict[str, Any] | None = None) -> None:
        super().__init__(message)
        self.summary = summary


@dataclass(frozen=True)
class Navigation:
    """A navigation read and checked, ready to run (:func:`prepare`)."""

    world: Scene
    costmap: CostmapParams
    dwa: DwaConfig
    move_base: MoveBaseParams
    goal: tuple[float, float, float]
    #: the camera's calibration and floor board from a file, None: calibrate synthetically
    calibration: tuple[CameraCalibration, FloorExtrinsics] | None
    board_at: tuple[float, float, float]
    ignored: tuple[str, ...]


def prepare(goal: tuple[float, float], *, goal_yaw: float | None = None,
            scene: str | Path | None = None, calib: str | Path | None = None,
            board_at: tuple[float, float, float] | None = None,
            costmap: str | Path | None = None, dwa: str | Path | None = None,
            move_base: str | Path | None = None) -> Navigation:
    """Read and check everything a run needs, before anything is made or moves: the scene,
    the three parameter files, the goal (on the floor) and the calibration file if any.
    ``goal_yaw`` None: arrive facing the way from the start to the goal. ``board_at`` (m, m,
    rad) goes with ``calib`` only; without it, the file's own ``board_at`` (a run's
    ``calibration.yaml`` has one), else the map's origin."""
    world = load_nav_scene(scene)
    costmap_params = load_costmap(costmap or DEFAULT_COSTMAP)
    dwa_params = load_dwa(dwa or DEFAULT_DWA)
    move_base_params = load_move_base(move_base or DEFAULT_MOVE_BASE)
    ignored = tuple(f"{loaded.path}: not used by servolab: {', '.join(loaded.ignored)}"
                    for loaded in (costmap_params, dwa_params, move_base_params)
                    if loaded.ignored)
    # DWAPlanner's sim_period comes from move_base's controller_frequency (searchParam)
    dwa_config = dataclasses.replace(DwaConfig.from_params(dwa_params),
                                     controller_frequency=move_base_params.controller_frequency)
    gx, gy = (float(v) for v in goal)
    if not (math.isfinite(gx) and math.isfinite(gy)):
        raise NavigationError(f"goal ({gx!r}, {gy!r}) must be finite numbers (m)")
    if not (0.0 <= gx <= world.width and 0.0 <= gy <= world.depth):
        raise NavigationError(f"goal ({gx:g}, {gy:g}) is outside the floor of {world.path} "
                              f"(x 0..{world.width:g}, y 0..{world.depth:g} m)")
    if goal_yaw is None:
        goal_yaw = math.atan2(gy - world.start[1], gx - world.start[0])
    elif not math.isfinite(goal_yaw):
        raise NavigationError(f"goal yaw {goal_yaw!r} must be a finite number (rad)")
    if board_at is not None and calib is None:
        raise NavigationError("board_at says where the floor board of a calibration file lay; "
                              "it needs a calibration file (--calib)")
    loaded = None
    if calib is not None:
        calibration, board = load_calibration(calib)
        if board is None:
            raise NavigationError(f"{calib}: has no floor extrinsics; calibrate with "
                                  "--floor IMAGE (a board lying on the floor)")
        if tuple(calibration.image_size) != world.camera.pinhole().image_size:
            raise NavigationError(f"{calib}: is for {calibration.image_size[0]}x"
                                  f"{calibration.image_size[1]} images, the scene's camera "
                                  f"gives {world.camera.width}x{world.camera.height}")
        loaded = (calibration, board)
        board_at = board_at or board.board_at or (0.0, 0.0, 0.0)
    if world.camera.rate < dwa_config.controller_frequency:
        raise NavigationError(
            f"{world.path}: the camera's rate {world.camera.rate:g} frames/s is below "
            f"move_base's controller_frequency {dwa_config.controller_frequency:g} Hz: the "
            "controller would drive on poses older than its period")
    # the goal against what the scene has at the start (the first map shows it again)
    body = costmap_params.inscribed_radius
    clearance = world.clearance(gx, gy, 0.0)
    if clearance <= 0:
        raise NavigationError(f"goal ({gx:g}, {gy:g}) is inside an obstacle of {world.path}")
    if clearance <= body:
        raise NavigationError(
            f"goal ({gx:g}, {gy:g}) is {clearance:.3g} m from an obstacle of {world.path}, "
            f"within the robot's inscribed radius {body:.3g} m: the robot cannot stand there")
    return Navigation(world, costmap_params, dwa_config, move_base_params, (gx, gy, goal_yaw),
                      loaded, board_at or BOARD_AT, ignored)


def run_navigate(run_folder: RunFolder, navigation: Navigation, *, timeout: float = 180.0,
                 seed: int = 0, say: Say = print, show_progress: bool = True,
                 view: ViewRequest | None = None) -> dict[str, Any]:
    """Drive to the goal (see the module docstring); writes the summary and returns it, or
    raises :class:`GoalNotReached` when the goal is not reached. Stopped by a signal or an
    error, the wheels stop, the bag closes, and the summary and plot are written with
    ``interrupted`` before the stop goes on to the caller. ``timeout`` is in the floor's
    simulated seconds."""
    from ...middleware.clock_node import start_clock
    from ...middleware.context import Context
    from ...middleware.recorder import Recorder
    from ...middleware.view.run_view import serve_run
    from ...sim.overhead_camera import OverheadCameraNode
    from ...sim.truth_node import GroundTruthNode
    from ...vision.map_file import save_map
    from ..base.fusion_node import FusionNode
    from ..base.node import BaseNode
    from .tracker_node import OverheadTrackerNode

    world = navigation.world
    costmap_params, dwa_config = navigation.costmap, navigation.dwa
    move_base_params = navigation.move_base
    gx, gy, goal_yaw = navigation.goal
    board_at = navigation.board_at
    for line in navigation.ignored:
        say(line)
    if navigation.calibration is not None:
        calibration, board = navigation.calibration
    else:
        say(f"calibrating the overhead camera: {VIEWS} views of a {BOARD[0]}x{BOARD[1]} board")
        calibration, board = calibrate_synthetic(world, np.random.default_rng(seed))
    save_calibration(calibration, dataclasses.replace(board, board_at=board_at),
                     run_folder.file("calibration.yaml"))
    extrinsics = in_map(board, (board_at[0] * 1000.0, board_at[1] * 1000.0, board_at[2]))
    grid = map_grid(world, costmap_params.resolution)

    base = MobileBase.emulated(load_base(world.base), start=world.start, seed=seed)
    assert base.floor is not None
    bag = run_folder.file("navigate_bag")
    if bag.exists():  # a run folder's files are replaced (servolab.runs)
        shutil.rmtree(bag)
    context = Context.open(clock=base.clock)
    start_clock(context)  # /clock in the floor's simulated time, as Gazebo's use_sim_time
    wall = time.perf_counter()
    interrupted: BaseException | None = None
    viewer: ViewServer | None = None
    try:
        BaseNode(context, base)
        GroundTruthNode(context, base.floor)
        camera = OverheadCameraNode(context, world, base.floor, seed=seed)
        tracker = OverheadTrackerNode(context, calibration, extrinsics, grid)
        FusionNode(context, pose_filter=fusion_for(world))
        navigator = NavigatorNode(
            context, (gx, gy), costmap=costmap_params, dwa=dwa_config, goal_yaw=goal_yaw,
            patience=Patience(move_base_params.planner_patience,
                              move_base_params.controller_patience,
                              move_base_params.oscillation_timeout,
                              move_base_params.oscillation_distance),
            recovery=move_base_params.behaviors(costmap_params.circumscribed_radius),
            planner_frequency=move_base_params.planner_frequency,
            pose_timeout=POSE_TIMEOUT_FRAMES / world.camera.rate)
        Recorder(context, str(bag), list(RECORDED))
        start = base.clock.now()  # before the wait for a viewer, which a stop may end
        if view is not None:  # served from here on, waiting for a viewer if simulated
            viewer = serve_run(context, view, say, name="servolab navigate")
        say(f"navigating from ({world.start[0]:g}, {world.start[1]:g}) to ({gx:g}, {gy:g}) "
            f"on {world.path}")
        _drive(context, navigator, base, start, timeout, show_progress, say)
    except BaseException as error:  # a stop signal or a node's error: stop, keep what happened
        interrupted = error
    ending = RunEnding(interrupted)
    summary: dict[str, Any] = {"motors_on_stop": BASE_ON_STOP}
    with stops_deferred() as late:  # the way out is not cut short by a signal
        with ending.step("stopping the wheels"):
            try:
                base.stop()  # the wheels first, whatever else fails
                summary["wheels_after_stop"] = base.wheel_commands()
            finally:
                try:
                    if viewer is not None:
                        viewer.close()
                    context.close()  # the recorder finishes the bag
                finally:
                    base.bus.close()
        with ending.step("measuring"):
            elapsed = base.clock.now() - start
            summary.update(summarise(
                world, base, navigator, goal=(gx, gy, goal_yaw), elapsed=elapsed,
                calibration=calibration, frames=camera.frames, sightings=tracker.sightings,
                dwa=dwa_config, start=camera.start,
                body_radius=max(world.robot_radius, costmap_params.circumscribed_radius)))
            summary["wall_seconds"] = round(time.perf_counter() - wall, 2)
            #: the simulated time the run started at (the camera's first frame; obstacles
            #: appear at their ``appear_at`` after it): the bag's and the repairs' times count
            #: from the clock's 0
            summary["start_time_s"] = camera.start
        summary["bag"] = str(bag)
        summary["calibration_file"] = str(run_folder.file("calibration.yaml"))
        summary["board_at"] = list(board_at)
        with ending.step("saving the map"):
            if tracker.occupancy is not None:
                yaml_path, _ = save_map(run_folder.file("map"), tracker.occupancy,
                                        grid.resolution, grid.origin)
                summary["map"] = str(yaml_path)
        with ending.step("plotting"):
            summary["plot"] = str(plot_navigation(world, base, navigator, tracker.occupancy,
                                                  grid, run_folder.file("navigate.png")))
        interrupted = ending.settle(late, summary)
        if interrupted is not None:
            summary["status"] = "INTERRUPTED"
            summary["reason"] = f"interrupted: {interruption(interrupted)}"
        elif navigator.status is not NavigationStatus.SUCCEEDED:
            summary["reason"] = navigator.reason or f"not at the goal after {timeout:g} s"
        run_folder.write_summary(summary, interrupted=interrupted)
    ending.raise_if_ended()
    if navigator.status is not NavigationStatus.SUCCEEDED:
        raise GoalNotReached(f"navigation failed: {summary['reason']} (run folder: "
                             f"{run_folder.path})", summary)
    say(f"goal reached in {elapsed:.1f} s: {summary['goal_distance_m'] * 1000:.0f} mm and "
        f"{math.degrees(summary['goal_yaw_error_rad']):.1f}° from the goal (truth), nearest "
        f"obstacle {summary['min_clearance_m'] * 1000:.0f} mm from the robot's edge, "
        f"{len(navigator.repairs)} plan repair(s); bag {bag}, plot {summary['plot']}")
    return summary


def _drive(context: Any, navigator: NavigatorNode, base: MobileBase, start: float,
           timeout: float, show_progress: bool, say: Say) -> None:
    """Spin until the navigator is done or ``timeout`` simulated seconds passed, with a
    progress bar over the straight-line distance still to go."""
    from tqdm import tqdm

    def remaining() -> float:
        truth = base.truth()
        gx, gy = navigator.goal or (truth["x"], truth["y"])
        return math.hypot(gx - truth["x"], gy - truth["y"])

    total = remaining()
    with tqdm(total=round(total, 2), unit="m", disable=not show_progress, leave=False,
              bar_format="{l_bar}{bar}| {n:.2f}/{total:.2f} m") as bar:
        while not navigator.done and base.clock.now() - start < timeout:
            context.spin_until(lambda: navigator.done,
                               timeout=min(0.5, timeout - (base.clock.now() - start)))
            covered = max(0.0, min(total, total - remaining()))
            if covered > bar.n:
                bar.update(covered - bar.n)
            if not show_progress:  # a log (no terminal): a line a simulated second or so
                say(f"{base.clock.now() - start:.1f} s: {remaining():.2f} m to go")


def summarise(world: Scene, base: MobileBase, navigator: NavigatorNode, *,
              goal: tuple[float, float, float], elapsed: float,
              calibration: CameraCalibration, frames: int, sightings: int,
              dwa: DwaConfig, start: float, body_radius: float) -> dict[str, Any]:
    """The run's figures, measured against the floor's truth. ``start`` is the simulated time
    the scene's clock counts from (obstacles appear after it); the clearance is that of a
    robot of ``body_radius`` (the larger of the camera's marker and the costmap's padded
    footprint's circumscribed radius)."""
    truth = base.truth()
    track = np.array(base.track, dtype=np.float64).reshape(-1, 7)
    clearances = [world.clearance(x, y, t - start) - body_radius
                  for t, x, y in track[:, [0, 4, 5]]]
    yaw_error = math.remainder(truth["yaw"] - goal[2], 2 * math.pi)
    return {
        "status": navigator.status.name, "reason": navigator.reason,
        "scene": world.path, "goal": list(goal),
        "start": list(world.start),
        "final_truth": {"x": truth["x"], "y": truth["y"], "yaw": truth["yaw"]},
        "final_estimate": None if navigator.pose is None else dict(
            zip(("x", "y", "yaw"), navigator.pose, strict=True)),
        "goal_distance_m": math.hypot(truth["x"] - goal[0], truth["y"] - goal[1]),
        "goal_yaw_error_rad": abs(yaw_error),
        "xy_goal_tolerance_m": dwa.xy_goal_tolerance,
        "yaw_goal_tolerance_rad": dwa.yaw_goal_tolerance,
        "controller_frequency_hz": dwa.controller_frequency,
        "min_clearance_m": float(min(clearances)) if clearances else math.inf,
        "body_radius_m": body_radius,
        "stale_pose_cycles": navigator.stale_cycles,
        "seconds": elapsed,
        "path_length_m": float(np.sum(np.hypot(*np.diff(track[:, 4:6], axis=0).T)))
        if len(track) > 1 else 0.0,
        "plans": len(navigator.plans),
        "repairs": [dataclasses.asdict(r) for r in navigator.repairs],
        #: the goal was refused before the wheels were ever commanded (the reason says why)
        "refused_before_driving": navigator.refused,
        "warnings": list(navigator.warnings),
        "recoveries": [dataclasses.asdict(r) for r in navigator.recoveries],
        "camera_frames": frames, "robot_sightings": sightings,
        "calibration": {"fx": calibration.fx, "fy": calibration.fy, "cx": calibration.cx,
                        "cy": calibration.cy, "rms_px": calibration.rms},
    }


def plot_navigation(world: Scene, base: MobileBase, navigator: NavigatorNode,
                    occupancy: np.ndarray | None, grid: FloorGrid, path: Path) -> Path:
    """The map the camera last gave, every plan (the first solid, repairs dashed), the pose
    the navigator drove on, and the truth."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle, Rectangle

    from ...sim.scene import BoxObstacle, CircleObstacle

    figure, ax = plt.subplots(figsize=(8, 6))
    x0, y0 = grid.origin
    if occupancy is not None:
        rows, cols = occupancy.shape
        ax.imshow(np.where(occupancy, 0.35, 1.0), cmap="gray", vmin=0, vmax=1, origin="lower",
                  extent=(x0, x0 + cols * grid.resolution, y0, y0 + rows * grid.resolution),
                  interpolation="nearest")
    for obstacle in world.obstacles:
        late = obstacle.appear_at is not None
        colour, line = ("tab:red", "--") if late else ("black", "-")
        if isinstance(obstacle, CircleObstacle):
            ax.add_patch(Circle((obstacle.x, obstacle.y), obstacle.radius, fill=False,
                                edgecolor=colour, linestyle=line, linewidth=1.5))
        elif isinstance(obstacle, BoxObstacle):
            ax.add_patch(Rectangle((obstacle.x, obstacle.y), obstacle.width, obstacle.depth,
                                   fill=False, edgecolor=colour, linestyle=line,
                                   linewidth=1.5))
        if late:
            ax.annotate(f"appears at {obstacle.appear_at:g} s", (obstacle.x, obstacle.y),
                        color="tab:red", fontsize=8)
    for k, (t, plan) in enumerate(navigator.plans):
        first = k == 0
        if first or any(abs(r.t - t) < 1e-9 for r in navigator.repairs):
            ax.plot(plan[:, 0], plan[:, 1], color="tab:blue" if first else "tab:purple",
                    linestyle="-" if first else "--", linewidth=1,
                    label="first plan" if first else None)
    if navigator.repairs:
        ax.plot([], [], color="tab:purple", linestyle="--", linewidth=1,
                label="plans repaired after a map change")
    cycles = np.array([c[1:3] for c in navigator.cycles], dtype=np.float64).reshape(-1, 2)
    if len(cycles):
        ax.plot(cycles[:, 0], cycles[:, 1], color="tab:orange", linewidth=3, alpha=0.7,
                label="pose driven on (fused)")
    track = np.array(base.track, dtype=np.float64).reshape(-1, 7)
    if len(track):
        ax.plot(track[:, 4], track[:, 5], color="tab:green", linewidth=1, linestyle="--",
                label="truth (simulated floor)")
    ax.plot(*world.start[:2], "o", color="black", label="start")
    if navigator.goal is not None:
        ax.plot(*navigator.goal, "*", color="tab:red", markersize=12, label="goal")
    ax.set_xlim(x0, x0 + world.width + 2 * MAP_MARGIN)
    ax.set_ylim(y0, y0 + world.depth + 2 * MAP_MARGIN)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(loc="best", fontsize=8)
    ax.set_title(f"navigate: {navigator.status.value}, {len(navigator.repairs)} repair(s)")
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)
    return path
