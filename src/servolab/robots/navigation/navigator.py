"""The navigator: seed 000's planning loop as one node, doing move_base's job.

In: ``/map`` (``nav_msgs/msg/OccupancyGrid``, the overhead camera's), the robot's pose on
``pose_topic`` (``geometry_msgs/msg/PoseStamped`` in the map frame, ``/fused_pose`` by default:
odometry and camera fused), ``/odom`` for the robot's current velocity, and goals: nav2's
``navigate_to_pose`` action (``nav2_msgs/action/NavigateToPose``), served here, and
``geometry_msgs/msg/PoseStamped`` goals in the map frame on ``/goal_pose`` (nav2's) and
``/move_base_simple/goal`` (move_base's), which become goals of the same server as nav2's
bt_navigator sends them to itself, besides the one it may be built with. A new goal replaces
the one being driven to (it ends ABORTED, as nav2 preempts); a cancel stops the wheels and ends
the goal CANCELED. Out: ``/cmd_vel`` (``geometry_msgs/msg/Twist``) every controller period,
``/plan`` (``nav_msgs/msg/Path``) whenever the plan changes, and the action's status and
feedback (pose, time, recoveries, distance left); the result's ``error_msg`` says why a goal
was aborted.

**What it thinks**, in the types and on the topics Nav2 uses, so rviz2 or Foxglove draw it
(conversions in :mod:`~.display`, frame ``map``, metres and radians):

- ``/global_costmap/costmap`` (``nav_msgs/msg/OccupancyGrid``, TRANSIENT_LOCAL depth 1): the
  inflated grid D* Lite plans on, costmap_2d's costs written 0..100 / -1 as Nav2's
  Costmap2DPublisher writes them (:func:`~.display.costmap_occupancy`), with the map's
  resolution, size and origin; published with the first map and again whenever it changes;
- ``/local_plan`` (``nav_msgs/msg/Path``, depth 10): every controller cycle DWA runs, the poses
  of the chosen (v, w) over DWA's ``sim_time`` from DWA's own rollout
  (:attr:`~servolab.planning.dwa.DwaResult.trajectory`), its first pose the robot's pose of
  that cycle, stamped with that pose's stamp (as DWB stamps its local plan); when DWA chose
  no trajectory (goal handling: braking, turning to the goal's heading, the goal reached; or
  no valid one) the path is that one pose, where the robot stays;
- ``/path`` (``nav_msgs/msg/Path``, depth 10): the robot's poses so far (the pose it drives
  on, each with its own stamp), a new one kept once it is
  :data:`~.display.PATH_SPACING` m from the last, the whole path published each time;
- ``/goal_pose`` (``geometry_msgs/msg/PoseStamped``, TRANSIENT_LOCAL depth 1): the goal being
  driven to, published whenever one is set (its own echo is not taken as a new goal; without
  a goal heading its orientation is the identity).

Each map is inflated as costmap_2d does (:func:`~servolab.planning.costmap.inflate`, the D.2
parameters) and turned into navfn's traversal costs. The first map and pose after a goal start
D* Lite (:class:`~servolab.planning.dstar_lite.DStarLite`) from the robot's cell to the goal's;
later maps change only the cells that differ (``update_cells``), and the robot's new cell
moves the planner's start (``move_to``), so each plan is a repair, not a new search. Each
controller cycle (``controller_frequency``, move_base's) hands the plan to DWA
(:func:`~servolab.planning.dwa.compute_velocity`, the D.3 parameters), which also stops the
robot and turns it to the goal's heading within the goal tolerances, latched as
base_local_planner's ``LatchedStopRotateController`` latches. DWA's oscillation flags and the
latches are kept here and cleared every ``1 / planner_frequency`` s, when move_base would hand
DWA a new global plan (``DWAPlanner::setPlan``; 0: only at the start).

**Before driving**, from the first map and pose, a goal is refused (``ABORTED`` with
:attr:`NavigatorNode.refused` set, the wheels never commanded) when it is outside the map, in
an obstacle or within the robot's inscribed radius of one, when the robot itself stands there,
when the first map shows no path to it (an enclosed goal), or when a goal in the inflated band
of an obstacle is one DWA would not settle on (:func:`~servolab.planning.approach.dry_run`, the
reason and the cost it has in the message). A goal in the band that DWA reaches is driven to
with a warning giving its cost. A goal whose map or robot pose does not come within
``start_timeout`` s is refused too: the camera does not see the robot.

**While driving**, move_base's troubles -- no plan for ``planner_patience`` s, no valid
trajectory for ``controller_patience`` s, no progress of ``oscillation_distance`` m in
``oscillation_timeout`` s -- start its recovery behaviours in turn
(:mod:`~servolab.robots.navigation.recovery`, each logged and kept in
:attr:`NavigatorNode.recoveries`), and the goal is given up only when they have all run. A
behaviour's trouble ends (and the list starts again from the first) as in move_base. While
the robot's own cell is within the inscribed radius of an obstacle (the controller cut a
corner), the plan keeps starting from the last cell it could stand in, as navfn clears the
robot's cell. A pose older than ``pose_timeout`` (the localiser stopped) stops the wheels
until a new one comes, and after ``controller_patience`` s gives the goal up. With
robot_localization's EKF (the fusion node's default) the pose carries on from odometry while
the camera has lost the robot, its covariance growing, for up to the localiser's
``max_dead_reckoning``; with seed 000's D.4 filter it stops with the camera.
"""

from __future__ import annotations

import enum
import functools
import math
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, TypeVar

import numpy as np
import numpy.typing as npt

from ...middleware.context import Context
from ...middleware.messages import time_of
from ...middleware.node import Node
from ...planning.approach import dry_run
from ...planning.costmap import inflate, traversal_costs
from ...planning.dstar_lite import DStarLite
from ...planning.dwa import DwaConfig, DwaStatus, GoalLatch, OscillationFlags, compute_velocity
from ...planning.errors import NoPath
from ...rclpy.action import ActionServer, CancelResponse, GoalResponse, ServerGoalHandle
from ...rclpy.action.server import ActionError
from ...rclpy.task import Future
from ..errors import RobotValueError
from .display import (
    COSTMAP_TOPIC,
    DRIVEN_PATH_TOPIC,
    GOAL_TOPIC,
    LOCAL_PLAN_TOPIC,
    PATH_SPACING,
    costmap_occupancy,
    path_fields,
    pose_fields,
)
from .params import CLEAR_COSTMAP_RECOVERY, CostmapParams, RecoveryBehavior
from .recovery import ROTATE_TIMEOUT, RotateRecovery, can_rotate_in_place
from .tracker_node import LATCHED, MAP_FRAME, OCCUPANCY_GRID, occupancy_of

POSE = "geometry_msgs/msg/PoseStamped"
ODOMETRY = "nav_msgs/msg/Odometry"
TWIST = "geometry_msgs/msg/Twist"
PATH = "nav_msgs/msg/Path"
#: nav2's action (nav2_msgs/action/NavigateToPose, Jazzy's: servolab ships its definition)
NAVIGATE_TO_POSE = "nav2_msgs/action/NavigateToPose"
ACTION_NAME = "/navigate_to_pose"
#: the topics nav2's NavigateToPose action server publishes on
STATUS_TOPIC = f"{ACTION_NAME}/_action/status"
FEEDBACK_TOPIC = f"{ACTION_NAME}/_action/feedback"
FloatArray = npt.NDArray[np.float64]
_Method = TypeVar("_Method", bound=Callable[..., Any])


def _one_at_a_time(method: _Method) -> _Method:
    """Run ``method`` holding the node's lock: the controller's cycle, a new goal (from a
    client, a topic or code on another thread) and the inputs never change the goal's state
    under one another, whatever executor runs the node."""
    @functools.wraps(method)
    def locked(self: NavigatorNode, *args: Any, **kwargs: Any) -> Any:
        with self._lock:
            return method(self, *args, **kwargs)
    return locked  # type: ignore[return-value]


class NavigationStatus(enum.Enum):
    """Where the goal stands, as move_base's action reports it."""

    WAITING = "waiting for a goal, a map and a pose"
    ACTIVE = "driving"
    SUCCEEDED = "goal reached"
    ABORTED = "aborted"
    CANCELED = "canceled"


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
    m, before the next recovery behaviour runs (and the goal is given up after the last)."""

    planner: float = 5.0
    controller: float = 15.0
    oscillation_timeout: float = 0.0
    oscillation_distance: float = 0.5


@dataclass(frozen=True)
class Recovery:
    """One recovery behaviour that ran: when (s), which, and why (move_base's trigger)."""

    t: float
    name: str
    type: str
    trigger: str


#: move_base's recovery triggers, and what it says when every behaviour has run in vain
_GIVEN_UP = {"planning": "no plan to the goal", "controlling": "no valid trajectory",
             "oscillation": "oscillating"}


class NavigatorNode(Node):
    """See the module docstring. ``goal`` is ``(x, y)`` in the map frame (m), ``goal_yaw``
    the heading to end with (rad; None: any); without a goal the node waits for one on its
    goal topics. ``recovery``: the behaviours to run, in order (``MoveBaseParams.behaviors``;
    none: give up at once, as before move_base had them). DWA checks each trajectory with the
    costmap file's ``footprint`` polygon, or a round robot's centre cell."""

    def __init__(self, context: Context, goal: tuple[float, float] | None = None, *,
                 costmap: CostmapParams, dwa: DwaConfig, goal_yaw: float | None = None,
                 patience: Patience = Patience(),
                 recovery: Sequence[RecoveryBehavior] = (),
                 planner_frequency: float = 0.0, pose_timeout: float = 0.5,
                 start_timeout: float | None = None, pose_topic: str = "/fused_pose",
                 name: str = "navigator", namespace: str = "/",
                 parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        self._lock = threading.RLock()
        self.params, self.dwa, self.patience = costmap, dwa, patience
        #: the polygon DWA checks each trajectory pose with (base_local_planner's
        #: footprintCost); a round robot (robot_radius) has its centre cell checked instead,
        #: which the inflation's inscribed band already makes exact
        self.footprint = None if costmap.footprint is None else \
            np.asarray(costmap.footprint_polygon, dtype=np.float64)
        self.behaviors = tuple(recovery)
        if not (math.isfinite(planner_frequency) and planner_frequency >= 0):
            raise RobotValueError(f"planner_frequency {planner_frequency!r} must be >= 0 Hz")
        self.planner_frequency = planner_frequency
        if not (math.isfinite(pose_timeout) and pose_timeout > 0):
            raise RobotValueError(f"pose_timeout {pose_timeout!r} must be > 0 s")
        self.pose_timeout = pose_timeout
        self.start_timeout = patience.controller if start_timeout is None else start_timeout
        if not (math.isfinite(self.start_timeout) and self.start_timeout > 0):
            raise RobotValueError(f"start_timeout {start_timeout!r} must be > 0 s")
        #: the goal being driven to, as nav2's action server holds it, and what its
        #: execution ends with
        self._handle: ServerGoalHandle | None = None
        self._ending: Future | None = None
        #: how many goals the node has taken (each preempting the one before)
        self.goal_count = 0
        self._pose_at = -math.inf
        self._stale_since: float | None = None
        #: controller cycles skipped, the wheels stopped, because the pose was too old
        self.stale_cycles = 0
        #: DWA's oscillation critic; cleared whenever move_base would hand over a new plan
        self.oscillation = OscillationFlags()
        #: LatchedStopRotateController's latches; cleared with the oscillation flags
        self.latch = GoalLatch()
        self.goal: tuple[float, float] | None = None
        self.goal_yaw: float | None = None
        self.status = NavigationStatus.WAITING
        self.reason = ""
        #: the goal was refused before the wheels were ever commanded
        self.refused = False
        #: warnings about the goal given before driving (a goal in the inflated band)
        self.warnings: list[str] = []
        self.pose: tuple[float, float, float] | None = None
        self.velocity = (0.0, 0.0)
        self.occupied: npt.NDArray[np.bool_] | None = None
        self.costmap: npt.NDArray[np.uint8] | None = None
        self.costs: FloatArray | None = None
        self.resolution = 0.0
        self.origin = (0.0, 0.0)
        self.planner: DStarLite | None = None
        #: every plan (t, (N, 2) map points), the first and each one that differed
        self.plans: list[tuple[float, FloatArray]] = []
        self.repairs: list[Repair] = []
        #: every recovery behaviour that ran
        self.recoveries: list[Recovery] = []
        #: (t, x, y, yaw, v, omega, DWA status) of every controller cycle that drove
        self.cycles: list[tuple[float, float, float, float, float, float, str]] = []
        self._pending_change = 0
        self._pending_seconds = 0.0
        #: the stamp of the pose last taken (builtin_interfaces/Time fields)
        self._pose_stamp: Any = None
        #: the driven path: (x, y, yaw) poses and their stamps, as published on /path
        self.driven: list[tuple[float, float, float]] = []
        self._driven_stamps: list[Any] = []
        #: the goal message this node published last, to know its echo on /goal_pose
        self._goal_echo: tuple[Any, ...] | None = None
        self._reset_goal_state(self.now())
        self.cmd_vel = self.create_publisher(TWIST, "/cmd_vel", 10)
        self.plan_publisher = self.create_publisher(PATH, "/plan", LATCHED)
        self.action_server = ActionServer(
            self, NAVIGATE_TO_POSE, ACTION_NAME, self._execute,
            goal_callback=self._check_goal, handle_accepted_callback=self._accepted,
            cancel_callback=lambda _goal: CancelResponse.ACCEPT)
        self.costmap_publisher = self.create_publisher(OCCUPANCY_GRID, COSTMAP_TOPIC, LATCHED)
        self.local_plan_publisher = self.create_publisher(PATH, LOCAL_PLAN_TOPIC, 10)
        self.driven_path_publisher = self.create_publisher(PATH, DRIVEN_PATH_TOPIC, 10)
        self.goal_publisher = self.create_publisher(POSE, GOAL_TOPIC, LATCHED)
        self.create_subscription(OCCUPANCY_GRID, "/map", self._on_map, LATCHED)
        self.create_subscription(POSE, pose_topic, self._on_pose, 10)
        self.create_subscription(ODOMETRY, "/odom", self._on_odom, 10)
        self.create_subscription(POSE, "/goal_pose", self._on_goal, 10)
        self.create_subscription(POSE, "/move_base_simple/goal", self._on_goal, 10)
        self.timer = self.create_timer(1.0 / dwa.controller_frequency, self._cycle)
        if goal is not None:
            self.set_goal(*goal, goal_yaw)

    @property
    def done(self) -> bool:
        return self.status in (NavigationStatus.SUCCEEDED, NavigationStatus.ABORTED,
                               NavigationStatus.CANCELED)

    # -- goals ---------------------------------------------------------------------------------

    def _reset_goal_state(self, now: float) -> None:
        self.planner = None
        self.oscillation.reset()
        self.latch.reset()
        self._handed_over: float | None = None
        self._stuck_since: float | None = None
        self._no_plan_since: float | None = None
        #: (t, x, y) where the robot last had moved oscillation_distance
        self._moved: tuple[float, float, float] | None = None
        self._goal_at = now
        self._driven = False
        self._recovery_index = 0
        self._trigger = ""
        self._rotation: RotateRecovery | None = None
        self._rotation_since = now
        #: recoveries of earlier goals: this goal's are the ones after them
        self._recoveries_before = len(self.recoveries)
        self._pending_change, self._pending_seconds = 0, 0.0
        self._last_plan: FloatArray | None = None

    @_one_at_a_time
    def set_goal(self, x: float, y: float, yaw: float | None = None) -> None:
        """Drive to ``(x, y)`` (map frame, m), ending at ``yaw`` (rad; None: any), replacing
        the goal being driven to: accepted by the node's own NavigateToPose server, as
        nav2's bt_navigator sends a ``/goal_pose`` to itself, so it has an id and a status."""
        gx, gy = float(x), float(y)
        if not (math.isfinite(gx) and math.isfinite(gy)) or (
                yaw is not None and not math.isfinite(yaw)):
            raise RobotValueError(f"goal ({gx!r}, {gy!r}, yaw {yaw!r}) must be finite numbers")
        handle = self.action_server.accept_goal(self.message(
            f"{NAVIGATE_TO_POSE}_Goal", pose={"header": {"stamp": self.stamp(),
                                                         "frame_id": MAP_FRAME},
                                              "pose": pose_fields(gx, gy, yaw or 0.0)}))
        self._take(handle, (gx, gy), yaw)

    def _check_goal(self, goal: Any) -> GoalResponse:
        """A NavigateToPose goal from a client: in the map frame, with a heading."""
        try:
            self._pose_of(goal.pose)
        except RobotValueError as error:
            self.get_logger().error(f"goal refused: {error}")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    @_one_at_a_time
    def _accepted(self, handle: ServerGoalHandle) -> None:
        x, y, yaw = self._pose_of(handle.request.pose)
        self.get_logger().info(f"new goal ({x:g}, {y:g}, {math.degrees(yaw):.0f}°)")
        self._take(handle, (x, y), yaw)

    def _take(self, handle: ServerGoalHandle, goal: tuple[float, float],
              yaw: float | None) -> None:
        """Make ``handle`` the goal driven to, preempting the one driven to before."""
        if self._handle is not None and self._handle.is_active:
            # nav2's SimpleActionServer::accept_pending_goal aborts the goal it preempts
            self.get_logger().info("goal preempted by a new one")
            self._stop()
            self._end(self._handle.abort, "preempted by a new goal")
        self._handle, self._ending = handle, Future(executor=self.context.executor)
        self.goal_count += 1
        self.goal, self.goal_yaw = goal, yaw
        self.status, self.reason, self.refused = NavigationStatus.WAITING, "", False
        self.warnings = []
        self._goal_id = bytes(bytearray(handle.goal_id.uuid))
        stamp = handle.goal_info.stamp
        self._goal_stamp = {"sec": int(stamp.sec), "nanosec": int(stamp.nanosec)}
        self._reset_goal_state(self.now())
        ending = self._ending

        def execution(_handle: ServerGoalHandle) -> Future:
            return ending  # ended by _end, from the controller's loop
        handle.execute(execution)
        self._publish_goal()

    def _execute(self, handle: ServerGoalHandle) -> Any:
        """Never called: every goal is executed by :meth:`_take` with its own ending."""
        raise AssertionError("NavigatorNode executes its goals itself")

    def _end(self, terminate: Callable[[], None], message: str) -> None:
        """End the goal being driven to (``terminate``: its handle's succeed, abort or
        canceled) with nav2's result: no error code but NONE in Jazzy, the reason."""
        handle, ending = self._handle, self._ending
        if handle is None or ending is None or not handle.is_active:
            return
        try:
            terminate()
        except ActionError:  # it ended another way meanwhile (a client's cancel went first)
            return
        ending.set_result(self.message(f"{NAVIGATE_TO_POSE}_Result", error_msg=message))

    def _pose_of(self, pose: Any) -> tuple[float, float, float]:
        """``(x, y, yaw)`` of a PoseStamped goal, or a one-line error saying what is wrong."""
        frame = str(pose.header.frame_id)
        if frame not in ("", MAP_FRAME):
            raise RobotValueError(f"frame {frame!r}; goals are in the {MAP_FRAME!r} frame")
        p, q = pose.pose.position, pose.pose.orientation
        if math.hypot(float(q.x), float(q.y), float(q.z), float(q.w)) < 1e-9:
            # move_base refuses it too ("Empty quaternion received, invalid goal")
            raise RobotValueError("its orientation is all zeros; give the heading to end "
                                  "with, e.g. orientation: {w: 1.0} for 0°")
        x, y = float(p.x), float(p.y)
        yaw = math.remainder(2.0 * math.atan2(float(q.z), float(q.w)), 2.0 * math.pi)
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(yaw)):
            raise RobotValueError(f"goal ({x!r}, {y!r}, yaw {yaw!r}) must be finite numbers")
        return x, y, yaw

    def _publish_goal(self) -> None:
        assert self.goal is not None
        pose = pose_fields(*self.goal, self.goal_yaw or 0.0)
        stamp = self._goal_stamp
        q = pose["orientation"]
        self._goal_echo = (stamp["sec"], stamp["nanosec"], *self.goal, q["z"], q["w"])
        self.goal_publisher.publish(self.message(
            POSE, header={"stamp": stamp, "frame_id": MAP_FRAME}, pose=pose))

    def _is_echo(self, msg: Any) -> bool:
        """Whether ``msg`` is the goal this node published itself on ``/goal_pose``."""
        p, q, stamp = msg.pose.position, msg.pose.orientation, msg.header.stamp
        return self._goal_echo == (int(stamp.sec), int(stamp.nanosec), float(p.x), float(p.y),
                                   float(q.z), float(q.w))

    @_one_at_a_time
    def _on_goal(self, msg: Any) -> None:
        if self._is_echo(msg):
            return
        try:
            x, y, yaw = self._pose_of(msg)
            self.set_goal(x, y, yaw)
        except RobotValueError as error:
            self.get_logger().error(f"goal refused: {error}")
            return
        self.get_logger().info(f"new goal ({x:g}, {y:g}, {math.degrees(yaw):.0f}°)")

    # -- inputs ------------------------------------------------------------------------------

    @_one_at_a_time
    def _on_map(self, msg: Any) -> None:
        try:
            occupied, resolution, origin = occupancy_of(msg)
        except RobotValueError as error:
            self.get_logger().error(str(error))
            return
        if self.costs is not None and self.planner is not None and not self.done and (
                occupied.shape != self.costs.shape or resolution != self.resolution
                or origin != self.origin):
            self._abort("the map changed its size or frame mid-run")
            return
        self._take_map(occupied, resolution, origin, stamp=msg.header.stamp)

    def _take_map(self, occupied: npt.NDArray[np.bool_], resolution: float,
                  origin: tuple[float, float], *, stamp: Any = None) -> None:
        p = self.params
        costmap = inflate(occupied, resolution, p.inflation_radius, p.cost_scaling_factor,
                          p.inscribed_radius)
        if self.costmap is None or not np.array_equal(costmap, self.costmap) or (
                resolution, origin) != (self.resolution, self.origin):
            self._publish_costmap(costmap, resolution, origin,
                                  self.stamp() if stamp is None else stamp)
        costs = traversal_costs(costmap)
        if self.costs is not None and self.planner is not None:
            changed = np.argwhere(costs != self.costs)
            if len(changed):
                started = time.perf_counter()
                self.planner.update_cells(changed, costs[changed[:, 0], changed[:, 1]])
                self._pending_seconds += time.perf_counter() - started
                self._pending_change += len(changed)
        self.occupied, self.costmap, self.costs = occupied, costmap, costs
        self.resolution, self.origin = resolution, origin

    def _publish_costmap(self, costmap: npt.NDArray[np.uint8], resolution: float,
                         origin: tuple[float, float], stamp: Any) -> None:
        rows, cols = costmap.shape
        self.costmap_publisher.publish(self.message(
            OCCUPANCY_GRID, header={"stamp": stamp, "frame_id": MAP_FRAME},
            info={"map_load_time": stamp, "resolution": float(resolution), "width": cols,
                  "height": rows, "origin": pose_fields(*origin)},
            data=costmap_occupancy(costmap)))

    @_one_at_a_time
    def _on_pose(self, msg: Any) -> None:
        p, q = msg.pose.position, msg.pose.orientation
        pose = (float(p.x), float(p.y), 2.0 * math.atan2(float(q.z), float(q.w)))
        if not all(math.isfinite(v) for v in pose):
            self.get_logger().error(f"pose refused: {pose} is not finite")
            return
        self.pose = pose
        self._pose_at = self.now()
        self._pose_stamp = msg.header.stamp
        if not self.driven or math.hypot(pose[0] - self.driven[-1][0],
                                         pose[1] - self.driven[-1][1]) >= PATH_SPACING:
            self.driven.append(pose)
            self._driven_stamps.append(msg.header.stamp)
            self.driven_path_publisher.publish(self.message(PATH, **path_fields(
                self.driven, msg.header.stamp, MAP_FRAME, self._driven_stamps)))

    @_one_at_a_time
    def _on_odom(self, msg: Any) -> None:
        v, omega = float(msg.twist.twist.linear.x), float(msg.twist.twist.angular.z)
        if math.isfinite(v) and math.isfinite(omega):
            self.velocity = (v, omega)

    # -- where things are ----------------------------------------------------------------------

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

    def plan_points(self, cells: npt.NDArray[np.int64]) -> FloatArray:
        """The plan through ``cells`` as map points, ending at the goal as it was asked for:
        navfn appends the exact goal to the cell centres it found (``NavFn::makePlan``), and
        base_local_planner judges "goal reached" on the plan's last pose, so the goal checker
        measures xy_goal_tolerance from the requested goal, never from its cell's centre."""
        assert self.goal is not None
        points = self.points_of(cells)
        return np.vstack([points, np.asarray([self.goal], dtype=np.float64)])

    def obstacle_distance(self, cell: tuple[int, int]) -> float:
        """The distance (m) from a cell's centre to the nearest occupied cell's centre."""
        assert self.occupied is not None
        occupied = np.argwhere(self.occupied)
        if not len(occupied):
            return math.inf
        return float(np.min(np.hypot(*(occupied - np.asarray(cell)).T)) * self.resolution)

    # -- endings -------------------------------------------------------------------------------

    def _stop(self) -> None:
        self.cmd_vel.publish(self.message(TWIST))

    def _abort(self, reason: str) -> None:
        self.status, self.reason = NavigationStatus.ABORTED, reason
        self.planner = None
        self.refused = not self._driven
        self.get_logger().error(("goal refused before driving: " if self.refused
                                 else "goal aborted: ") + reason)
        self._stop()
        if self._handle is not None:
            self._end(self._handle.abort, reason)

    def _succeed(self) -> None:
        self.status, self.reason = NavigationStatus.SUCCEEDED, "goal reached"
        self.planner = None
        self._stop()
        if self._handle is not None:
            self._end(self._handle.succeed, "")

    def _cancel(self) -> None:
        """A client canceled the goal: the wheels stop, the goal ends CANCELED."""
        self.status, self.reason = NavigationStatus.CANCELED, "canceled by its client"
        self.planner = None
        self._stop()
        self.get_logger().info("goal canceled")
        if self._handle is not None:
            self._end(self._handle.canceled, "")

    def _publish_feedback(self, now: float, x: float, y: float, yaw: float) -> None:
        assert self.goal is not None and self._handle is not None
        stamp = self.stamp(now)
        elapsed = time_of(now - self._goal_at)  # a duration
        self._handle.publish_feedback(self.message(
            f"{NAVIGATE_TO_POSE}_Feedback",
            current_pose={"header": {"stamp": stamp, "frame_id": MAP_FRAME}, "pose": {
                "position": {"x": x, "y": y},
                "orientation": {"z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}}},
            navigation_time=elapsed,
            number_of_recoveries=len(self.recoveries) - self._recoveries_before,
            distance_remaining=math.hypot(self.goal[0] - x, self.goal[1] - y)))

    # -- before driving ------------------------------------------------------------------------

    def _start_planner(self, start: tuple[int, int], pose: tuple[float, float, float]) -> bool:
        """The checks of the module docstring's "before driving", then D* Lite's first plan."""
        assert self.costs is not None and self.costmap is not None and self.goal is not None
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
                        f"inscribed radius {self.params.inscribed_radius:.3g} m of one "
                        f"(costmap {int(self.costmap[goal])})")
            return False
        if not math.isfinite(self.costs[start]):
            self._abort(f"the robot at cell {start} stands within its inscribed radius of an "
                        f"obstacle (costmap {int(self.costmap[start])}): it cannot start")
            return False
        planner = DStarLite(self.costs, start, goal)
        try:
            cells = planner.path()
        except NoPath:
            self._abort(f"no path from the robot to goal ({gx:g}, {gy:g}) on the first map: "
                        "obstacles enclose the goal or the robot")
            return False
        cost = int(self.costmap[goal])
        if cost > 0:
            clear = self.obstacle_distance(goal) - self.resolution / 2
            band = (f"goal ({gx:g}, {gy:g}) lies in the inflated band of an obstacle about "
                    f"{clear:.2f} m away: costmap cost {cost} of 252 (inflation_radius "
                    f"{self.params.inflation_radius:g} m)")
            plan = self.plan_points(cells)
            length = float(np.sum(np.hypot(*np.diff(plan, axis=0).T)))
            def rehearse(dwa: DwaConfig) -> Any:
                assert self.costmap is not None
                return dry_run(self.costmap, plan, dwa, resolution=self.resolution,
                               origin=self.origin, goal_yaw=self.goal_yaw, start=pose,
                               footprint=self.footprint,
                               stall_time=self.patience.oscillation_timeout or 10.0,
                               max_time=30.0 + 3.0 * length / max(dwa.max_vel_x, 0.01))

            check = rehearse(self.dwa)
            if not check.reached:
                x, y, _ = check.pose
                where = (f"stops {check.distance:.3f} m from it, beyond xy_goal_tolerance "
                         f"{self.dwa.xy_goal_tolerance:g} m"
                         if check.distance <= self.params.inflation_radius
                         + self.dwa.xy_goal_tolerance else
                         f"stops on the way, at ({x:.2f}, {y:.2f}), {check.distance:.2f} m "
                         f"before it (costmap cost {check.cost} there)")
                self._abort(f"{band}; a dry run of DWA on this map {where} "
                            f"({check.status}): {self._deciding(rehearse)}")
                return False
            self.warnings.append(band)
            self.get_logger().warning(band + "; DWA's dry run reaches it")
        self.planner = planner
        self.status = NavigationStatus.ACTIVE
        return True

    def _deciding(self, rehearse: Callable[[DwaConfig], Any]) -> str:
        """Which DWA parameter keeps the robot off the goal, found by dry runs with each
        suspect set to 0 in turn (the first that lets DWA settle on the goal is named), and
        what to do about it: the message names what decides, not a guess."""
        d = self.dwa
        suspects = (
            ("occdist_scale", f"occdist_scale {d.occdist_scale:g} outweighs "
             f"goal_distance_bias {d.goal_distance_bias:g} and path_distance_bias "
             f"{d.path_distance_bias:g} near obstacles"),
            ("forward_point_distance", f"forward_point_distance {d.forward_point_distance:g} "
             "m puts the robot's nose target past the goal, into the obstacle's cost"),
        )
        for name, why in suspects:
            zeroed: dict[str, Any] = {name: 0.0}
            if getattr(d, name) != 0 and rehearse(replace(d, **zeroed)).reached:
                return (f"{why} (with {name} 0 the dry run reaches it). Move the goal away "
                        f"from the obstacle or lower {name}")
        return ("neither occdist_scale nor forward_point_distance alone decides it (a dry run "
                "with each at 0 does not reach it either). Move the goal away from the "
                "obstacle")

    def _waited_too_long(self, now: float) -> bool:
        """A goal with no map or no pose of the robot for ``start_timeout`` s is refused."""
        if now - self._goal_at < self.start_timeout:
            return False
        missing = "map" if self.costs is None else "pose of the robot (the camera does not " \
            "see it)"
        self._abort(f"no {missing} for {self.start_timeout:g} s after the goal")
        return True

    # -- move_base's troubles and recoveries ---------------------------------------------------

    def _plan(self, now: float) -> FloatArray | None:
        """The plan from the robot's cell, repaired for what changed; None if there is none
        (and after ``planner_patience`` the next recovery)."""
        assert self.planner is not None
        started = time.perf_counter()
        try:
            cells = self.planner.path()
        except NoPath:
            self._no_plan_since = self._no_plan_since if self._no_plan_since is not None \
                else now
            if now - self._no_plan_since >= self.patience.planner:
                self._recover(now, "planning", f"no path to the goal for "
                              f"{self.patience.planner:g} s")
            return None
        self._no_plan_since = None
        if self._trigger == "planning":
            self._recovery_index = 0
        if self._pending_change:
            self.repairs.append(Repair(now, self._pending_change, self._pending_seconds
                                       + time.perf_counter() - started))
            self._pending_change, self._pending_seconds = 0, 0.0
        plan = self.plan_points(cells)
        if self._last_plan is None or not np.array_equal(self._last_plan, plan):
            self._last_plan = plan
            self.plans.append((now, plan))
            stamp = self.stamp(now)
            self.plan_publisher.publish(self.message(
                PATH, header={"stamp": stamp, "frame_id": MAP_FRAME},
                poses=[{"header": {"stamp": stamp, "frame_id": MAP_FRAME},
                        "pose": {"position": {"x": float(x), "y": float(y)},
                                 "orientation": {"w": 1.0}}} for x, y in plan]))
        return plan

    def _oscillating(self, now: float, x: float, y: float) -> bool:
        """move_base's oscillation check; True (and a recovery started) when it fires."""
        p = self.patience
        if self._moved is None or math.hypot(x - self._moved[1], y - self._moved[2]) \
                >= p.oscillation_distance:
            self._moved = (now, x, y)
            if self._trigger == "oscillation":
                self._recovery_index = 0
            return False
        if p.oscillation_timeout > 0 and now - self._moved[0] >= p.oscillation_timeout:
            self._recover(now, "oscillation", f"moved less than {p.oscillation_distance:g} m "
                          f"in {p.oscillation_timeout:g} s")
            return True
        return False

    def _recover(self, now: float, trigger: str, why: str) -> None:
        """move_base's CLEARING state: the next recovery behaviour, or give up."""
        self._stop()
        if self._recovery_index >= len(self.behaviors):
            after = (f", even after {len(self.behaviors)} recovery behaviour(s)"
                     if self.behaviors else "")
            goal = None if self.goal is None else self.cell_of(*self.goal)
            covered = (f"; {self._goal_covered()}" if self.costs is not None
                       and goal is not None and not math.isfinite(self.costs[goal]) else "")
            self._abort(f"{_GIVEN_UP[trigger]}: {why}{after}{covered}")
            return
        behavior = self.behaviors[self._recovery_index]
        self._recovery_index += 1
        self._trigger = trigger
        self.recoveries.append(Recovery(now, behavior.name, behavior.type, trigger))
        self.get_logger().warning(
            f"recovery {self._recovery_index} of {len(self.behaviors)}: {behavior.name} "
            f"({behavior.type}) because of {_GIVEN_UP[trigger]} ({why})")
        assert self.pose is not None
        x, y, yaw = self.pose
        if behavior.type == CLEAR_COSTMAP_RECOVERY:
            # what the clearing forgets, the camera re-marks at once (it sees the whole floor
            # every frame): what is left of the behaviour is a search from scratch
            self._restart_planner(x, y)
        else:
            cell = self.cell_of(x, y)
            assert self.costmap is not None
            if cell is not None and can_rotate_in_place(
                    self.costmap, cell, (x, y), self.footprint, self.resolution, self.origin):
                self._rotation = RotateRecovery(yaw)
                self._rotation_since = now
            else:
                self.get_logger().error("rotate recovery can't rotate in place because there "
                                        "is a potential collision")
        # what move_base resets on leaving CLEARING: the oscillation timer only (a planner or
        # controller still failing starts the next behaviour at once)
        self._moved = (now, x, y)

    def _restart_planner(self, x: float, y: float) -> None:
        """A new D* Lite search from the robot's cell on the current map, its repairs'
        history dropped (a clearing recovery)."""
        assert self.costs is not None and self.goal is not None and self.planner is not None
        cell = self.cell_of(x, y)
        start = cell if cell is not None and math.isfinite(self.costs[cell]) \
            else self.planner.start
        goal = self.cell_of(*self.goal)
        assert goal is not None
        if not math.isfinite(self.costs[goal]):
            # an obstacle covers the goal now: a search from scratch cannot reach it either
            # (the planner keeps its repairs, and finds the goal again if the obstacle goes)
            self.get_logger().warning(self._goal_covered())
            return
        self.planner = DStarLite(self.costs, start, goal)
        self._pending_change, self._pending_seconds = 0, 0.0

    def _goal_covered(self) -> str:
        assert self.goal is not None and self.costmap is not None
        goal = self.cell_of(*self.goal)
        assert goal is not None
        return (f"goal ({self.goal[0]:g}, {self.goal[1]:g}) is inside an obstacle or within "
                f"the robot's inscribed radius {self.params.inscribed_radius:.3g} m of one on "
                f"the current map (costmap {int(self.costmap[goal])}): the map covered it "
                "after the goal was given")

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

    # -- the loop ------------------------------------------------------------------------------

    @_one_at_a_time
    def _cycle(self) -> None:
        if self.done or self.goal is None:
            return
        if self._handle is not None and self._handle.is_cancel_requested:
            self._cancel()
            return
        now = self.now()
        if self.pose is None or self.costs is None or (
                self.planner is None and now - self._pose_at > self.pose_timeout):
            self._waited_too_long(now)
            return
        if self._stale(now):
            return
        x, y, yaw = self.pose
        cell = self.cell_of(x, y)
        if cell is None:
            self._abort(f"the robot at ({x:.3f}, {y:.3f}) is outside the map")
            return
        if self.planner is None and not self._start_planner(cell, (x, y, yaw)):
            return
        assert self.planner is not None and self.costmap is not None and self.costs is not None
        self._publish_feedback(now, x, y, yaw)
        if self._rotation is not None:
            rate = self._rotation.command(yaw)
            if rate is not None and now - self._rotation_since > ROTATE_TIMEOUT:
                self.get_logger().error(f"rotate recovery: the turn took over "
                                        f"{ROTATE_TIMEOUT:g} s; ended")
                rate = None
            if rate is not None:
                self._driven = True
                self.cmd_vel.publish(self.message(TWIST, angular={"z": rate}))
                return
            self._rotation = None
            self._moved = (now, x, y)
        if self._oscillating(now, x, y):
            return
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
            self.latch.reset()
            self._handed_over = now
        result = compute_velocity((x, y, yaw), self.velocity, self.costmap, plan, self.dwa,
                                  resolution=self.resolution, origin=self.origin,
                                  goal_yaw=self.goal_yaw, oscillation=self.oscillation,
                                  latch=self.latch, footprint=self.footprint)
        self.cycles.append((now, x, y, yaw, result.v, result.omega, result.status.name))
        self._publish_local_plan(result.trajectory if len(result.trajectory)
                                 else np.array([(x, y, yaw)]), now)
        if result.status is DwaStatus.GOAL_REACHED:
            self._succeed()
            return
        if result.status is DwaStatus.NO_VALID_TRAJECTORY:
            self._stuck_since = self._stuck_since if self._stuck_since is not None else now
            if now - self._stuck_since >= self.patience.controller:
                self._recover(now, "controlling", f"none for {self.patience.controller:g} s")
                return
        else:
            self._stuck_since = None
            if self._trigger == "controlling":
                self._recovery_index = 0
        self._driven = self._driven or result.v != 0.0 or result.omega != 0.0
        self.cmd_vel.publish(self.message(TWIST, linear={"x": result.v},
                                          angular={"z": result.omega}))

    def _publish_local_plan(self, poses: FloatArray, now: float) -> None:
        """DWA's chosen trajectory, stamped as the pose it starts from (module docstring)."""
        stamp = self.stamp(now) if self._pose_stamp is None else self._pose_stamp
        self.local_plan_publisher.publish(self.message(PATH, **path_fields(
            poses, stamp, MAP_FRAME)))

    def destroy(self) -> None:
        try:
            if self.context.ok():
                self._stop()
                with self._lock:  # a client waiting for the result hears why it ended
                    if self._handle is not None:
                        self._end(self._handle.abort, "the navigator shut down")
        finally:
            super().destroy()
