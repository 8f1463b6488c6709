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

**In a namespace** (``namespace``, ``servolab navigate --namespace /robot1``) every node of the
run is in it and every topic above but ``/tf`` and ``/clock`` is the robot's
(``/robot1/cmd_vel``, ``/robot1/map``; the bag records them so), and the robot's frames take
the namespace as a prefix (``map -> robot1/odom -> robot1/base_footprint``), as ROS 2
multi-robot setups run a fleet (:mod:`servolab.middleware.names`).

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
import time
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ...harness import interruption
from ...middleware.names import in_namespace, node_namespace
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
from ..lifecycle import Step, Task, replaced, run_task
from .navigator import NavigationStatus, NavigatorNode, Patience
from .params import CostmapParams, MoveBaseParams, load_nav_scene, load_planning
from .session import (
    BOARD,
    BOARD_AT,
    MAP_MARGIN,
    POSE_TIMEOUT_FRAMES,
    VIEWS,
    GoalNotReached,
    NavigationError,
    calibrate_synthetic,
    fusion_for,
    map_grid,
)

if TYPE_CHECKING:
    from ...middleware.context import Context
    from ...middleware.view.run_view import ViewRequest
    from ...runs import RunFolder

Say = Callable[[str], None]
#: what the bag records, named as a robot alone has them (:func:`recorded` in a namespace)
RECORDED = ("/odom", "/ground_truth", "/cmd_vel", "/tracker/pose", "/fused_pose", "/plan",
            "/map", "/odometry/filtered", "/tf", "/clock", "/navigate_to_pose/_action/status",
            # what the navigator thinks, as Nav2 publishes it (navigator.py, display.py)
            "/global_costmap/costmap", "/local_plan", "/path", "/goal_pose")


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
    #: where the run's nodes are (``/``: a robot alone)
    namespace: str = "/"


def prepare(goal: tuple[float, float], *, goal_yaw: float | None = None,
            scene: str | Path | None = None, calib: str | Path | None = None,
            board_at: tuple[float, float, float] | None = None,
            costmap: str | Path | None = None, dwa: str | Path | None = None,
            move_base: str | Path | None = None, namespace: str = "/") -> Navigation:
    """Read and check everything a run needs, before anything is made or moves: the scene,
    the three parameter files, the goal (on the floor), the calibration file if any and the
    namespace.
    ``goal_yaw`` None: arrive facing the way from the start to the goal. ``board_at`` (m, m,
    rad) goes with ``calib`` only; without it, the file's own ``board_at`` (a run's
    ``calibration.yaml`` has one), else the map's origin."""
    namespace = node_namespace(namespace)
    world = load_nav_scene(scene)
    planning = load_planning(costmap, dwa, move_base)
    costmap_params, dwa_config, move_base_params, ignored = (
        planning.costmap, planning.dwa, planning.move_base, planning.ignored)
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
        loaded = _calibration_file(calib, world)
        board_at = board_at or loaded[1].board_at or (0.0, 0.0, 0.0)
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
                      loaded, board_at or BOARD_AT, ignored, namespace)


def _calibration_file(calib: str | Path,
                      world: Scene) -> tuple[CameraCalibration, FloorExtrinsics]:
    """A calibration file's camera and floor board, checked against the scene's camera."""
    calibration, board = load_calibration(calib)
    if board is None:
        raise NavigationError(f"{calib}: has no floor extrinsics; calibrate with "
                              "--floor IMAGE (a board lying on the floor)")
    if tuple(calibration.image_size) != world.camera.pinhole().image_size:
        raise NavigationError(f"{calib}: is for {calibration.image_size[0]}x"
                              f"{calibration.image_size[1]} images, the scene's camera "
                              f"gives {world.camera.width}x{world.camera.height}")
    return calibration, board


def run_navigate(run_folder: RunFolder, navigation: Navigation, *, timeout: float = 180.0,
                 seed: int = 0, say: Say = print, show_progress: bool = True,
                 view: ViewRequest | None = None) -> dict[str, Any]:
    """Drive to the goal (see the module docstring); writes the summary and returns it, or
    raises :class:`GoalNotReached` when the goal is not reached. Stopped by a signal or an
    error, the wheels stop, the bag closes, and the summary and plot are written with
    ``interrupted`` before the stop goes on to the caller. ``timeout`` is in the floor's
    simulated seconds."""
    task = NavigateTask(run_folder, navigation, timeout=timeout, seed=seed, say=say,
                        show_progress=show_progress)
    return run_task(run_folder, task, view=view, say=say)


class NavigateTask(Task):
    """A navigation's part of the run (:func:`~servolab.robots.lifecycle.run_task`): the
    camera calibrated and the base on its floor, the nodes, the drive to the goal; the
    wheels stopped, the figures measured against the truth, the map saved and plotted."""

    name = "navigate"

    def __init__(self, run_folder: RunFolder, navigation: Navigation, *, timeout: float,
                 seed: int, say: Say, show_progress: bool) -> None:
        self.run_folder, self.navigation, self.timeout = run_folder, navigation, timeout
        self.seed, self.say, self.show_progress = seed, say, show_progress
        self.summary = {"motors_on_stop": BASE_ON_STOP, "namespace": navigation.namespace}

    def open(self, opened: ExitStack) -> None:
        from ...middleware.clock_node import start_clock
        from ...middleware.context import Context

        navigation, folder = self.navigation, self.run_folder
        for line in navigation.ignored:
            self.say(line)
        if navigation.calibration is not None:
            self.calibration, board = navigation.calibration
        else:
            self.say(f"calibrating the overhead camera: {VIEWS} views of a {BOARD[0]}x"
                     f"{BOARD[1]} board")
            self.calibration, board = calibrate_synthetic(
                navigation.world, np.random.default_rng(self.seed))
        board_at = navigation.board_at
        save_calibration(self.calibration, dataclasses.replace(board, board_at=board_at),
                         folder.file("calibration.yaml"))
        self.extrinsics = in_map(board, (board_at[0] * 1000.0, board_at[1] * 1000.0,
                                         board_at[2]))
        self.grid = map_grid(navigation.world, navigation.costmap.resolution)
        self.base = MobileBase.emulated(load_base(navigation.world.base),
                                        start=navigation.world.start, seed=self.seed)
        opened.callback(self.base.bus.close)
        self.bag = replaced(folder.file("navigate_bag"))
        self.context = opened.enter_context(Context.open(clock=self.base.clock))
        self.opened = opened
        start_clock(self.context)  # /clock in the floor's simulated time, as Gazebo's
        self.wall = time.perf_counter()
        self.summary.update(bag=str(self.bag), calibration_file=str(
            folder.file("calibration.yaml")), board_at=list(board_at))

    def start(self) -> None:
        from ...middleware.recorder import Recorder
        from ...sim.overhead_camera import OverheadCameraNode
        from ...sim.truth_node import GroundTruthNode
        from ..base.fusion_node import FusionNode
        from ..base.node import BaseNode
        from .tracker_node import OverheadTrackerNode

        context, base, world = self.context, self.base, self.navigation.world
        here = self.navigation.namespace
        assert base.floor is not None
        BaseNode(context, base, namespace=here)
        GroundTruthNode(context, base.floor, namespace=here)
        self.camera = OverheadCameraNode(context, world, base.floor, namespace=here,
                                         seed=self.seed)
        self.tracker = OverheadTrackerNode(context, self.calibration, self.extrinsics,
                                           self.grid, namespace=here)
        FusionNode(context, namespace=here, pose_filter=fusion_for(world))
        self.navigator = navigator_for(context, self.navigation)
        Recorder(context, str(self.bag), recorded(here))
        self.started = base.clock.now()  # before the wait for a viewer, which a stop may end

    def served(self) -> Context:
        return self.context

    def graph(self) -> Context:
        return self.context

    def run(self) -> None:
        world, (gx, gy, _) = self.navigation.world, self.navigation.goal
        self.say(f"navigating from ({world.start[0]:g}, {world.start[1]:g}) to ({gx:g}, "
                 f"{gy:g}) on {world.path}")
        _drive(self.context, self.navigator, self.base, self.started, self.timeout,
               self.show_progress, self.say)

    def stop(self, ended: BaseException | None) -> list[Step]:
        def wheels() -> None:
            self.base.stop()  # the wheels first, whatever else fails
            self.summary["wheels_after_stop"] = self.base.wheel_commands()

        return [Step("stopping the wheels", wheels)]

    def way_out(self, ended: BaseException | None) -> list[Step]:
        return [Step("closing the bag and the bus", self.opened.close),  # the recorder ends
                Step("measuring", self._measure), Step("saving the map", self._save_map),
                Step("plotting", self._plot)]

    def _measure(self) -> None:
        navigation, base = self.navigation, self.base
        self.summary.update(summarise(
            navigation.world, base, self.navigator, goal=navigation.goal,
            elapsed=base.clock.now() - self.started, calibration=self.calibration,
            frames=self.camera.frames, sightings=self.tracker.sightings, dwa=navigation.dwa,
            start=self.camera.start, body_radius=max(
                navigation.world.robot_radius, navigation.costmap.circumscribed_radius)))
        self.summary["wall_seconds"] = round(time.perf_counter() - self.wall, 2)
        #: the simulated time the run started at (the camera's first frame; obstacles
        #: appear at their ``appear_at`` after it): the bag's and the repairs' times count
        #: from the clock's 0
        self.summary["start_time_s"] = self.camera.start

    def _save_map(self) -> None:
        from ...vision.map_file import save_map

        if self.tracker.occupancy is not None:
            yaml_path, _ = save_map(self.run_folder.file("map"), self.tracker.occupancy,
                                    self.grid.resolution, self.grid.origin)
            self.summary["map"] = str(yaml_path)

    def _plot(self) -> None:
        self.summary["plot"] = str(plot_navigation(
            self.navigation.world, self.base, self.navigator, self.tracker.occupancy,
            self.grid, self.run_folder.file("navigate.png")))

    def verdict(self, ended: BaseException | None) -> None:
        if ended is not None:
            self.summary["status"] = "INTERRUPTED"
            self.summary["reason"] = f"interrupted: {interruption(ended)}"
        elif self.navigator.status is not NavigationStatus.SUCCEEDED:
            self.summary["reason"] = (self.navigator.reason
                                      or f"not at the goal after {self.timeout:g} s")

    def report(self, ended: BaseException | None) -> None:
        if ended is not None:
            return
        summary, navigator = self.summary, self.navigator
        if navigator.status is not NavigationStatus.SUCCEEDED:
            raise GoalNotReached(f"navigation failed: {summary['reason']} (run folder: "
                                 f"{self.run_folder.path})", summary)
        self.say(f"goal reached in {summary['seconds']:.1f} s: "
                 f"{summary['goal_distance_m'] * 1000:.0f} mm and "
                 f"{math.degrees(summary['goal_yaw_error_rad']):.1f}° from the goal (truth), "
                 f"nearest obstacle {summary['min_clearance_m'] * 1000:.0f} mm from the "
                 f"robot's edge, {len(navigator.repairs)} plan repair(s); bag {self.bag}, "
                 f"plot {summary['plot']}")


def navigator_for(context: Context, navigation: Navigation) -> NavigatorNode:
    """The navigator with the navigation's parameters: move_base's patience, recovery and
    planner frequency, and a pose older than :data:`POSE_TIMEOUT_FRAMES` camera frames
    counted stale."""
    costmap, move_base = navigation.costmap, navigation.move_base
    gx, gy, goal_yaw = navigation.goal
    return NavigatorNode(
        context, (gx, gy), costmap=costmap, dwa=navigation.dwa, goal_yaw=goal_yaw,
        patience=Patience(move_base.planner_patience, move_base.controller_patience,
                          move_base.oscillation_timeout, move_base.oscillation_distance),
        recovery=move_base.behaviors(costmap.circumscribed_radius),
        planner_frequency=move_base.planner_frequency,
        pose_timeout=POSE_TIMEOUT_FRAMES / navigation.world.camera.rate,
        namespace=navigation.namespace)


def recorded(namespace: str = "/") -> list[str]:
    """The topics the bag records for a robot in ``namespace``: :data:`RECORDED`, each the
    robot's own there (``/robot1/odom``) but ``/tf`` and ``/clock``, every robot's."""
    return [in_namespace(topic, namespace) for topic in RECORDED]


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

    figure, ax = plt.subplots(figsize=(8, 6))
    x0, y0 = grid.origin
    if occupancy is not None:
        rows, cols = occupancy.shape
        ax.imshow(np.where(occupancy, 0.35, 1.0), cmap="gray", vmin=0, vmax=1, origin="lower",
                  extent=(x0, x0 + cols * grid.resolution, y0, y0 + rows * grid.resolution),
                  interpolation="nearest")
    _draw_obstacles(ax, world)
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


def _draw_obstacles(ax: Any, world: Scene) -> None:
    """The scene's obstacles, those appearing mid-run dashed red with their time."""
    from matplotlib.patches import Circle, Rectangle

    from ...sim.scene import BoxObstacle, CircleObstacle

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
