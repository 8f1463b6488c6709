"""The navigator: seed 000's planning loop as one node, doing move_base's job for one goal.

In: ``/map`` (``nav_msgs/msg/OccupancyGrid``, the overhead camera's), the robot's pose on
``pose_topic`` (``geometry_msgs/msg/PoseStamped`` in the map frame, ``/fused_pose`` by default:
odometry and camera fused) and ``/odom`` for the robot's current velocity. Out: ``/cmd_vel``
(``geometry_msgs/msg/Twist``) every controller period and ``/plan`` (``nav_msgs/msg/Path``)
whenever the plan changes.

Each map is inflated as costmap_2d does (:func:`~servolab.planning.costmap.inflate`, the D.2
parameters) and turned into navfn's traversal costs. The first map and pose start D* Lite
(:class:`~servolab.planning.dstar_lite.DStarLite`) from the robot's cell to the goal's; later
maps change only the cells that differ (``update_cells``), and the robot's new cell moves the
planner's start (``move_to``), so each plan is a repair, not a new search. Each controller
cycle (``controller_frequency``, move_base's) hands the plan to DWA
(:func:`~servolab.planning.dwa.compute_velocity`, the D.3 parameters), which also stops the
robot and turns it to the goal's heading within the goal tolerances. DWA's oscillation flags
are kept here and cleared every ``1 / planner_frequency`` s, when move_base would hand DWA a
new global plan (``DWAPlanner::setPlan`` clears them; 0: only at the start).

It gives up (``ABORTED``, the wheels stopped, the reason in :attr:`NavigatorNode.reason`) as
move_base does: the goal outside the map or inside an obstacle as soon as the first map shows
it, no plan for ``planner_patience`` s, no valid trajectory for ``controller_patience`` s. While
the robot's own cell is within the inscribed radius of an obstacle (the controller cut a
corner), the plan keeps starting from the last cell it could stand in, as navfn clears the
robot's cell. A pose older than ``pose_timeout`` (the camera lost the robot) stops the wheels
until a new one comes, and after ``controller_patience`` s gives the goal up.
"""

from __future__ import annotations

import enum
import math
import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from ...middleware.context import Context
from ...middleware.messages import time_of
from ...middleware.node import Node
from ...planning.costmap import inflate, traversal_costs
from ...planning.dstar_lite import DStarLite
from ...planning.dwa import DwaConfig, DwaStatus, OscillationFlags, compute_velocity
from ...planning.errors import NoPath
from ..errors import RobotValueError
from .params import CostmapParams
from .tracker_node import LATCHED, MAP_FRAME, OCCUPANCY_GRID, occupancy_of

POSE = "geometry_msgs/msg/PoseStamped"
ODOMETRY = "nav_msgs/msg/Odometry"
TWIST = "geometry_msgs/msg/Twist"
PATH = "nav_msgs/msg/Path"
FloatArray = npt.NDArray[np.float64]


class NavigationStatus(enum.Enum):
    """Where the goal stands, as move_base's action reports it."""

    WAITING = "waiting for a map and a pose"
    ACTIVE = "driving"
    SUCCEEDED = "goal reached"
    ABORTED = "aborted"


@dataclass(frozen=True)
class Repair:
    """One map change the planner repaired: when (s), how many cells changed, and the host
    seconds the repair took (``update_cells`` and the next plan after the change)."""

    t: float
    cells: int
    seconds: float


@dataclass(frozen=True)
class Patience:
    """move_base's patience: ``planner`` s without a plan, ``controller`` s without a valid
    command, or ``oscillation_timeout`` s (0: never) without moving ``oscillation_distance``
    m, before the goal is given up (move_base would first try its recovery behaviours;
    turtlebot's configuration has none)."""

    planner: float = 5.0
    controller: float = 15.0
    oscillation_timeout: float = 0.0
    oscillation_distance: float = 0.5


class NavigatorNode(Node):
    """See the module docstring. ``goal`` is ``(x, y)`` in the map frame (m), ``goal_yaw``
    the heading to end with (rad; None: any)."""

    def __init__(self, context: Context, goal: tuple[float, float], *,
                 costmap: CostmapParams, dwa: DwaConfig, goal_yaw: float | None = None,
                 patience: Patience = Patience(), planner_frequency: float = 0.0,
                 pose_timeout: float = 0.5, pose_topic: str = "/fused_pose",
                 name: str = "navigator", namespace: str = "/",
                 parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        gx, gy = (float(v) for v in goal)
        if not (math.isfinite(gx) and math.isfinite(gy)) or (
                goal_yaw is not None and not math.isfinite(goal_yaw)):
            raise RobotValueError(f"goal ({gx!r}, {gy!r}, yaw {goal_yaw!r}) must be finite numbers")
        self.goal = (gx, gy)
        self.goal_yaw = goal_yaw
        self.params, self.dwa, self.patience = costmap, dwa, patience
        if not (math.isfinite(planner_frequency) and planner_frequency >= 0):
            raise RobotValueError(f"planner_frequency {planner_frequency!r} must be >= 0 Hz")
        self.planner_frequency = planner_frequency
        if not (math.isfinite(pose_timeout) and pose_timeout > 0):
            raise RobotValueError(f"pose_timeout {pose_timeout!r} must be > 0 s")
        self.pose_timeout = pose_timeout
        self._pose_at = -math.inf
        self._stale_since: float | None = None
        #: controller cycles skipped, the wheels stopped, because the pose was too old
        self.stale_cycles = 0
        #: DWA's oscillation critic; cleared whenever move_base would hand over a new plan
        self.oscillation = OscillationFlags()
        self._handed_over: float | None = None
        self.status = NavigationStatus.WAITING
        self.reason = ""
        self.pose: tuple[float, float, float] | None = None
        self.velocity = (0.0, 0.0)
        self.costmap: npt.NDArray[np.uint8] | None = None
        self.costs: FloatArray | None = None
        self.resolution = 0.0
        self.origin = (0.0, 0.0)
        self.planner: DStarLite | None = None
        #: every plan (t, (N, 2) map points), the first and each one that differed
        self.plans: list[tuple[float, FloatArray]] = []
        self.repairs: list[Repair] = []
        #: (t, x, y, yaw, v, omega, DWA status) of every controller cycle that drove
        self.cycles: list[tuple[float, float, float, float, float, float, str]] = []
        self._pending_change = 0
        self._pending_seconds = 0.0
        self._stuck_since: float | None = None
        self._no_plan_since: float | None = None
        #: (t, x, y) where the robot last had moved oscillation_distance
        self._moved: tuple[float, float, float] | None = None
        self.cmd_vel = self.create_publisher(TWIST, "/cmd_vel", 10)
        self.plan_publisher = self.create_publisher(PATH, "/plan", LATCHED)
        self.create_subscription(OCCUPANCY_GRID, "/map", self._on_map, LATCHED)
        self.create_subscription(POSE, pose_topic, self._on_pose, 10)
        self.create_subscription(ODOMETRY, "/odom", self._on_odom, 10)
        self.timer = self.create_timer(1.0 / dwa.controller_frequency, self._cycle)

    @property
    def done(self) -> bool:
        return self.status in (NavigationStatus.SUCCEEDED, NavigationStatus.ABORTED)

    # -- inputs ------------------------------------------------------------------------------

    def _on_map(self, msg: Any) -> None:
        try:
            occupied, resolution, origin = occupancy_of(msg)
        except RobotValueError as error:
            self.get_logger().error(str(error))
            return
        p = self.params
        costmap = inflate(occupied, resolution, p.inflation_radius, p.cost_scaling_factor,
                          p.inscribed_radius)
        costs = traversal_costs(costmap)
        if self.costs is not None and self.planner is not None:
            if costs.shape != self.costs.shape or resolution != self.resolution \
                    or origin != self.origin:
                self._abort("the map changed its size or frame mid-run")
                return
            changed = np.argwhere(costs != self.costs)
            if len(changed):
                started = time.perf_counter()
                self.planner.update_cells(changed, costs[changed[:, 0], changed[:, 1]])
                self._pending_seconds += time.perf_counter() - started
                self._pending_change += len(changed)
        self.costmap, self.costs = costmap, costs
        self.resolution, self.origin = resolution, origin

    def _on_pose(self, msg: Any) -> None:
        p, q = msg.pose.position, msg.pose.orientation
        pose = (float(p.x), float(p.y), 2.0 * math.atan2(float(q.z), float(q.w)))
        if not all(math.isfinite(v) for v in pose):
            self.get_logger().error(f"pose refused: {pose} is not finite")
            return
        self.pose = pose
        self._pose_at = self.now()

    def _on_odom(self, msg: Any) -> None:
        v, omega = float(msg.twist.twist.linear.x), float(msg.twist.twist.angular.z)
        if math.isfinite(v) and math.isfinite(omega):
            self.velocity = (v, omega)

    # -- the loop ------------------------------------------------------------------------------

    def cell_of(self, x: float, y: float) -> tuple[int, int] | None:
        """The ``(row, col)`` of a map point, None outside the map."""
        if self.costs is None:
            return None
        col = math.floor((x - self.origin[0]) / self.resolution)
        row = math.floor((y - self.origin[1]) / self.resolution)
        rows, cols = self.costs.shape
        return (row, col) if 0 <= row < rows and 0 <= col < cols else None

    def points_of(self, cells: npt.NDArray[np.int64]) -> FloatArray:
        """Map points (cell centres) of ``(row, col)`` cells, ``(N, 2)`` as ``(x, y)``."""
        return np.asarray(np.asarray(self.origin) + (cells[:, ::-1] + 0.5) * self.resolution,
                          dtype=np.float64)

    def _stop(self) -> None:
        self.cmd_vel.publish(self.message(TWIST))

    def _abort(self, reason: str) -> None:
        self.status, self.reason = NavigationStatus.ABORTED, reason
        self.get_logger().error(f"goal aborted: {reason}")
        self._stop()

    def _start_planner(self, start: tuple[int, int]) -> bool:
        assert self.costs is not None and self.costmap is not None
        gx, gy = self.goal
        goal = self.cell_of(gx, gy)
        if goal is None:
            rows, cols = self.costs.shape
            x0, y0 = self.origin
            x1, y1 = x0 + cols * self.resolution, y0 + rows * self.resolution
            self._abort(f"goal ({gx:g}, {gy:g}) is outside the map (x {x0:g}..{x1:g}, "
                        f"y {y0:g}..{y1:g} m)")
            return False
        if not math.isfinite(self.costs[goal]):
            self._abort(f"goal ({gx:g}, {gy:g}) is inside an obstacle or within the robot's "
                        f"inscribed radius of one (costmap {int(self.costmap[goal])})")
            return False
        if not math.isfinite(self.costs[start]):
            self._abort(f"the robot at cell {start} stands within its inscribed radius of an "
                        f"obstacle (costmap {int(self.costmap[start])}): it cannot start")
            return False
        self.planner = DStarLite(self.costs, start, goal)
        self.status = NavigationStatus.ACTIVE
        return True

    def _plan(self, now: float) -> FloatArray | None:
        """The plan from the robot's cell, repaired for what changed; None if there is none."""
        assert self.planner is not None
        started = time.perf_counter()
        try:
            cells = self.planner.path()
        except NoPath:
            self._no_plan_since = self._no_plan_since if self._no_plan_since is not None \
                else now
            if now - self._no_plan_since >= self.patience.planner:
                self._abort(f"no path to the goal for {self.patience.planner:g} s")
            return None
        self._no_plan_since = None
        if self._pending_change:
            self.repairs.append(Repair(now, self._pending_change, self._pending_seconds
                                       + time.perf_counter() - started))
            self._pending_change, self._pending_seconds = 0, 0.0
        plan = self.points_of(cells)
        if not self.plans or not np.array_equal(self.plans[-1][1], plan):
            self.plans.append((now, plan))
            stamp = time_of(now)
            self.plan_publisher.publish(self.message(
                PATH, header={"stamp": stamp, "frame_id": MAP_FRAME},
                poses=[{"header": {"stamp": stamp, "frame_id": MAP_FRAME},
                        "pose": {"position": {"x": float(x), "y": float(y)},
                                 "orientation": {"w": 1.0}}} for x, y in plan]))
        return plan

    def _oscillating(self, now: float, x: float, y: float) -> bool:
        """move_base's oscillation check; True (and aborted) when it fires."""
        p = self.patience
        if self._moved is None or math.hypot(x - self._moved[1], y - self._moved[2]) \
                >= p.oscillation_distance:
            self._moved = (now, x, y)
            return False
        if p.oscillation_timeout > 0 and now - self._moved[0] >= p.oscillation_timeout:
            self._abort(f"oscillating: moved less than {p.oscillation_distance:g} m in "
                        f"{p.oscillation_timeout:g} s")
            return True
        return False

    def _stale(self, now: float) -> bool:
        """True (the wheels stopped) while the pose is older than ``pose_timeout``, as a ROS
        controller refuses a transform that old; aborted after ``controller_patience``."""
        if now - self._pose_at <= self.pose_timeout:
            self._stale_since = None
            return False
        self.stale_cycles += 1
        self._stale_since = self._stale_since if self._stale_since is not None else now
        if now - self._stale_since >= self.patience.controller:
            self._abort(f"no pose newer than {self.pose_timeout:g} s for "
                        f"{self.patience.controller:g} s")
        else:
            self._stop()
        return True

    def _cycle(self) -> None:
        if self.done or self.pose is None or self.costs is None:
            return
        now = self.now()
        if self._stale(now):
            return
        x, y, yaw = self.pose
        cell = self.cell_of(x, y)
        if cell is None:
            self._abort(f"the robot at ({x:.3f}, {y:.3f}) is outside the map")
            return
        if self.planner is None and not self._start_planner(cell):
            return
        if self._oscillating(now, x, y):
            return
        assert self.planner is not None and self.costmap is not None and self.costs is not None
        if cell != self.planner.start and math.isfinite(self.costs[cell]):
            self.planner.move_to(cell)
        plan = self._plan(now)
        if plan is None:
            self._stop()
            return
        if self._handed_over is None or (
                self.planner_frequency > 0
                and now - self._handed_over >= 1.0 / self.planner_frequency - 1e-9):
            self.oscillation.reset()  # DWAPlanner::setPlan, at move_base's planner_frequency
            self._handed_over = now
        result = compute_velocity((x, y, yaw), self.velocity, self.costmap, plan, self.dwa,
                                  resolution=self.resolution, origin=self.origin,
                                  goal_yaw=self.goal_yaw, oscillation=self.oscillation)
        self.cycles.append((now, x, y, yaw, result.v, result.omega, result.status.name))
        if result.status is DwaStatus.GOAL_REACHED:
            self.status, self.reason = NavigationStatus.SUCCEEDED, "goal reached"
            self._stop()
            return
        if result.status is DwaStatus.NO_VALID_TRAJECTORY:
            self._stuck_since = self._stuck_since if self._stuck_since is not None else now
            if now - self._stuck_since >= self.patience.controller:
                self._abort(f"no valid trajectory for {self.patience.controller:g} s")
                return
        else:
            self._stuck_since = None
        self.cmd_vel.publish(self.message(TWIST, linear={"x": result.v},
                                          angular={"z": result.omega}))

    def destroy(self) -> None:
        try:
            if self.context.ok():
                self._stop()
        finally:
            super().destroy()
