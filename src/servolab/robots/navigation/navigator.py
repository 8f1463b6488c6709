"""The navigator: seed 000's planning loop as one node, doing move_base's job.

In: ``/map`` (``nav_msgs/msg/OccupancyGrid``, the overhead camera's), the robot's pose on
``pose_topic`` (``geometry_msgs/msg/PoseStamped`` in the map frame, ``/fused_pose`` by default:
odometry and camera fused), ``/odom`` for the robot's current velocity, and goals: nav2's
``navigate_to_pose`` action (``nav2_msgs/action/NavigateToPose``), served here, and
``geometry_msgs/msg/PoseStamped`` goals in the map frame on ``/goal_pose`` (nav2's) and
``/move_base_simple/goal`` (move_base's), which become goals of the same server as nav2's
bt_navigator sends them to itself, besides the one it may be built with. A new goal replaces
the one being driven to (it ends ABORTED, as nav2 preempts); a cancel stops the wheels and ends
the goal CANCELED. Out: ``/cmd_vel`` (``geometry_msgs/msg/Twist``; ``TwistStamped`` with
``stamped_cmd_vel``, Nav2's ``enable_stamped_cmd_vel``) every controller period,
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
latches are kept by the goal's state machine and cleared every ``1 / planner_frequency`` s,
when move_base would hand DWA a new global plan (``DWAPlanner::setPlan``; 0: only at the
start).

**Who decides**: what becomes of the goal -- waiting, driving, recovering, reached, aborted,
canceled, preempted, and the goal checker on the requested pose -- is decided by
:class:`~.goal_state.GoalStateMachine`, which reads no clock and publishes nothing. This node
subscribes, reads the clock, keeps the costmap and D* Lite, runs DWA, hands the machine what it
saw each controller cycle and carries out what it decides (``/cmd_vel``, the feedback, the
action goal's succeed, abort or canceled).

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

**In a namespace** (``/robot1``) every name above is the robot's (``/robot1/cmd_vel``,
``/robot1/navigate_to_pose``): the node names them relative, as Nav2's nodes do. Goals and
plans stay in the ``map`` frame, which every robot shares.
"""

from __future__ import annotations

import functools
import math
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, TypeVar

import numpy as np
import numpy.typing as npt

from ...middleware.context import Context
from ...middleware.messages import time_of
from ...middleware.names import BASE_FRAME, frame_prefix
from ...middleware.node import Node
from ...middleware.publisher import Publisher
from ...planning.approach import dry_run
from ...planning.costmap import inflate, traversal_costs
from ...planning.dstar_lite import DStarLite
from ...planning.dwa import DwaConfig, compute_velocity
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
from .goal_state import (
    MOVE_BASE_PATIENCE,
    Decision,
    Drive,
    End,
    Feedback,
    GoalChecker,
    GoalRules,
    GoalStateMachine,
    NavigationStatus,
    Patience,
    Pose,
    Recover,
    Recovery,
    Sensed,
    Stop,
    TurnTimedOut,
    Wait,
)
from .params import CLEAR_COSTMAP_RECOVERY, CostmapParams, RecoveryBehavior
from .recovery import can_rotate_in_place
from .tracker_node import LATCHED, MAP_FRAME, OCCUPANCY_GRID, occupancy_of

#: NavigationStatus, Patience and Recovery are the goal state machine's, named from here too
__all__ = ["ACTION_NAME", "FEEDBACK_TOPIC", "NAVIGATE_TO_POSE", "ODOMETRY", "PATH", "POSE",
           "STATUS_TOPIC", "TWIST", "CostGrid", "DrivenPath", "NavigationStatus", "NavigatorNode",
           "Patience", "Recovery", "Repair"]
POSE = "geometry_msgs/msg/PoseStamped"
ODOMETRY = "nav_msgs/msg/Odometry"
TWIST = "geometry_msgs/msg/Twist"
#: what ``cmd_vel`` carries with ``stamped_cmd_vel`` (Nav2's ``enable_stamped_cmd_vel``):
#: jazzy's diff_drive_controller takes nothing else
TWIST_STAMPED = "geometry_msgs/msg/TwistStamped"
PATH = "nav_msgs/msg/Path"
#: nav2's action (nav2_msgs/action/NavigateToPose, Jazzy's: servolab ships its definition)
NAVIGATE_TO_POSE = "nav2_msgs/action/NavigateToPose"
ACTION_NAME = "navigate_to_pose"
#: the topics nav2's NavigateToPose action server publishes on (relative, as every name the
#: navigator uses: in a namespace they are the robot's, ``/robot1/navigate_to_pose/...``)
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


@dataclass(frozen=True)
class Repair:
    """One map change the planner repaired: when (s), how many cells changed, and the host
    seconds the repair took (``update_cells`` and the next plan after the change)."""

    t: float
    cells: int
    seconds: float


@dataclass(frozen=True)
class CostGrid:
    """One map as the planner sees it, ``[row, col]``: the camera's ``occupied`` cells,
    costmap_2d's inflated ``costmap`` and navfn's traversal ``costs`` (inf: not to be entered),
    with the map's ``resolution`` (m) and ``origin`` (the first cell's corner, m)."""

    occupied: npt.NDArray[np.bool_]
    costmap: npt.NDArray[np.uint8]
    costs: FloatArray
    resolution: float
    origin: tuple[float, float]

    def cell_of(self, x: float, y: float) -> tuple[int, int] | None:
        """The ``(row, col)`` of a map point, None outside the map."""
        col = math.floor((x - self.origin[0]) / self.resolution)
        row = math.floor((y - self.origin[1]) / self.resolution)
        rows, cols = self.costs.shape
        return (row, col) if 0 <= row < rows and 0 <= col < cols else None

    def points_of(self, cells: npt.NDArray[np.int64]) -> FloatArray:
        """Map points (cell centres) of ``(row, col)`` cells, ``(N, 2)`` as ``(x, y)``."""
        return np.asarray(np.asarray(self.origin) + (cells[:, ::-1] + 0.5) * self.resolution,
                          dtype=np.float64)

    def plan_points(self, cells: npt.NDArray[np.int64], goal: tuple[float, float]) -> FloatArray:
        """The plan through ``cells`` as map points, ending at the goal as it was asked for:
        navfn appends the exact goal to the cell centres it found (``NavFn::makePlan``), and
        DWA brakes and turns within xy_goal_tolerance of the plan's last pose, so it settles
        where the goal checker looks: at the requested goal, never at its cell's centre."""
        return np.vstack([self.points_of(cells), np.asarray([goal], dtype=np.float64)])

    def obstacle_distance(self, cell: tuple[int, int]) -> float:
        """The distance (m) from a cell's centre to the nearest occupied cell's centre."""
        occupied = np.argwhere(self.occupied)
        if not len(occupied):
            return math.inf
        return float(np.min(np.hypot(*(occupied - np.asarray(cell)).T)) * self.resolution)


@dataclass
class _Planning:
    """D* Lite for the goal being driven to, the map changes it repaired that no plan has
    followed yet (their cells and host seconds, which the next plan's :class:`Repair` counts),
    and the plan last published."""

    planner: DStarLite
    changed: int = 0
    seconds: float = 0.0
    last_plan: FloatArray | None = None


@dataclass
class _Robot:
    """The robot as last heard of: its pose (x, y, yaw in the map frame), when it came (the
    node's clock, which the pose's age is measured on) and its stamp, and its velocity from
    odometry."""

    pose: Pose | None = None
    at: float | None = None
    stamp: Any = None
    velocity: tuple[float, float] = (0.0, 0.0)


@dataclass
class DrivenPath:
    """The robot's poses so far as ``/path`` shows them, each with its stamp: a pose is kept
    once it is :data:`~.display.PATH_SPACING` m from the last."""

    poses: list[Pose] = field(default_factory=list)
    stamps: list[Any] = field(default_factory=list)

    def add(self, pose: Pose, stamp: Any) -> bool:
        """Keep ``pose`` if it is far enough from the last; whether it was kept."""
        if self.poses and math.hypot(pose[0] - self.poses[-1][0],
                                     pose[1] - self.poses[-1][1]) < PATH_SPACING:
            return False
        self.poses.append(pose)
        self.stamps.append(stamp)
        return True


@dataclass(frozen=True)
class _ActionGoal:
    """The goal being driven to as nav2's action server holds it: its handle, the future its
    execution ends with, and its stamp (``/goal_pose`` echoes it)."""

    handle: ServerGoalHandle
    ending: Future
    stamp: dict[str, int]


@dataclass(frozen=True)
class _Topics:
    """What the node publishes besides its action (module docstring)."""

    cmd_vel: Publisher
    plan: Publisher
    costmap: Publisher
    local_plan: Publisher
    driven_path: Publisher
    goal: Publisher


class NavigatorNode(Node):
    """See the module docstring. ``goal`` is ``(x, y)`` in the map frame (m), ``goal_yaw``
    the heading to end with (rad; None: any); without a goal the node waits for one on its
    goal topics. ``recovery``: the behaviours to run, in order (``MoveBaseParams.behaviors``;
    none: give up at once, as before move_base had them). DWA checks each trajectory with the
    costmap file's ``footprint`` polygon, or a round robot's centre cell. What the goal's
    state machine keeps -- :attr:`status`, :attr:`reason`, :attr:`refused`,
    :attr:`warnings`, :attr:`recoveries`, ... -- reads as the node's own."""

    def __init__(self, context: Context, goal: tuple[float, float] | None = None, *,
                 costmap: CostmapParams, dwa: DwaConfig, goal_yaw: float | None = None,
                 patience: Patience = MOVE_BASE_PATIENCE,
                 recovery: Sequence[RecoveryBehavior] = (),
                 planner_frequency: float = 0.0, pose_timeout: float = 0.5,
                 start_timeout: float | None = None, pose_topic: str = "fused_pose",
                 no_pose: str = "the camera does not see it",
                 stamped_cmd_vel: bool = False, name: str = "navigator", namespace: str = "/",
                 parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        self._lock = threading.RLock()
        self.params, self.dwa = costmap, dwa
        #: the polygon DWA checks each trajectory pose with (base_local_planner's
        #: footprintCost); a round robot (robot_radius) has its centre cell checked instead,
        #: which the inflation's inscribed band already makes exact
        self.footprint = None if costmap.footprint is None else \
            np.asarray(costmap.footprint_polygon, dtype=np.float64)
        self.goal_state = GoalStateMachine(GoalRules(
            GoalChecker.of(dwa), patience, tuple(recovery), planner_frequency, pose_timeout,
            start_timeout, no_pose))
        self.robot = _Robot()
        self.grid: CostGrid | None = None
        self._planning: _Planning | None = None
        #: every plan (t, (N, 2) map points), the first and each one that differed
        self.plans: list[tuple[float, FloatArray]] = []
        self.repairs: list[Repair] = []
        #: (t, x, y, yaw, v, omega, DWA status) of every controller cycle that drove
        self.cycles: list[tuple[float, float, float, float, float, float, str]] = []
        self.driven = DrivenPath()
        self._goal: _ActionGoal | None = None
        #: the goal message this node published last, to know its echo on /goal_pose
        self._goal_echo: tuple[Any, ...] | None = None
        self.stamped_cmd_vel = stamped_cmd_vel
        #: the frame a stamped command is in: the robot's base (robot1/base_footprint)
        self.base_frame = frame_prefix(self.get_namespace()) + BASE_FRAME
        cmd_vel = self.create_publisher(TWIST_STAMPED if stamped_cmd_vel else TWIST,
                                        "cmd_vel", 10)
        plan = self.create_publisher(PATH, "plan", LATCHED)
        self.action_server = ActionServer(
            self, NAVIGATE_TO_POSE, ACTION_NAME, self._execute,
            goal_callback=self._check_goal, handle_accepted_callback=self._accepted,
            cancel_callback=lambda _goal: CancelResponse.ACCEPT)
        self.topics = _Topics(
            cmd_vel, plan, self.create_publisher(OCCUPANCY_GRID, COSTMAP_TOPIC, LATCHED),
            self.create_publisher(PATH, LOCAL_PLAN_TOPIC, 10),
            self.create_publisher(PATH, DRIVEN_PATH_TOPIC, 10),
            self.create_publisher(POSE, GOAL_TOPIC, LATCHED))
        self.create_subscription(OCCUPANCY_GRID, "map", self._on_map, LATCHED)
        self.create_subscription(POSE, pose_topic, self._on_pose, 10)
        self.create_subscription(ODOMETRY, "odom", self._on_odom, 10)
        self.create_subscription(POSE, GOAL_TOPIC, self._on_goal, 10)
        self.create_subscription(POSE, "move_base_simple/goal", self._on_goal, 10)
        self.timer = self.create_timer(1.0 / dwa.controller_frequency, self._cycle)
        if goal is not None:
            self.set_goal(*goal, goal_yaw)

    # -- the goal's record, as its state machine keeps it --------------------------------------

    @property
    def status(self) -> NavigationStatus:
        return self.goal_state.status

    @property
    def done(self) -> bool:
        return self.goal_state.done

    @property
    def goal(self) -> tuple[float, float] | None:
        return self.goal_state.goal

    @property
    def goal_yaw(self) -> float | None:
        return self.goal_state.goal_yaw

    @property
    def reason(self) -> str:
        return self.goal_state.reason

    @property
    def refused(self) -> bool:
        return self.goal_state.refused

    @property
    def warnings(self) -> list[str]:
        return self.goal_state.warnings

    @property
    def recoveries(self) -> list[Recovery]:
        return self.goal_state.recoveries

    @property
    def stale_cycles(self) -> int:
        return self.goal_state.stale_cycles

    @property
    def goal_count(self) -> int:
        return self.goal_state.goal_count

    @property
    def pose(self) -> Pose | None:
        return self.robot.pose

    @property
    def costmap(self) -> npt.NDArray[np.uint8] | None:
        return None if self.grid is None else self.grid.costmap

    # -- goals ---------------------------------------------------------------------------------

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
        preempted = self.goal_state.take_goal(self.now(), goal, yaw)
        if preempted is not None and self._goal is not None and self._goal.handle.is_active:
            # nav2's SimpleActionServer::accept_pending_goal aborts the goal it preempts
            self.get_logger().info("goal preempted by a new one")
            self._stop()
            self._end(self._goal.handle.abort, preempted.reason)
        ending = Future(executor=self.context.executor)
        stamp = handle.goal_info.stamp
        self._goal = _ActionGoal(handle, ending, {"sec": int(stamp.sec),
                                                  "nanosec": int(stamp.nanosec)})
        self._planning = None

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
        if self._goal is None or not self._goal.handle.is_active:
            return
        try:
            terminate()
        except ActionError:  # it ended another way meanwhile (a client's cancel went first)
            return
        self._goal.ending.set_result(self.message(f"{NAVIGATE_TO_POSE}_Result",
                                                  error_msg=message))

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
        assert self.goal is not None and self._goal is not None
        pose = pose_fields(*self.goal, self.goal_yaw or 0.0)
        stamp = self._goal.stamp
        q = pose["orientation"]
        self._goal_echo = (stamp["sec"], stamp["nanosec"], *self.goal, q["z"], q["w"])
        self.topics.goal.publish(self.message(
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
        grid = self.grid
        if grid is not None and self._planning is not None and not self.done and (
                occupied.shape != grid.costs.shape or resolution != grid.resolution
                or origin != grid.origin):
            self._finish(self.goal_state.abort("the map changed its size or frame mid-run"))
            return
        self._take_map(occupied, resolution, origin, stamp=msg.header.stamp)

    def _take_map(self, occupied: npt.NDArray[np.bool_], resolution: float,
                  origin: tuple[float, float], *, stamp: Any = None) -> None:
        p, old = self.params, self.grid
        costmap = inflate(occupied, resolution, p.inflation_radius, p.cost_scaling_factor,
                          p.inscribed_radius)
        if old is None or not np.array_equal(costmap, old.costmap) or (
                resolution, origin) != (old.resolution, old.origin):
            self._publish_costmap(costmap, resolution, origin,
                                  self.stamp() if stamp is None else stamp)
        costs = traversal_costs(costmap)
        if old is not None and self._planning is not None:
            changed = np.argwhere(costs != old.costs)
            if len(changed):
                started = time.perf_counter()
                self._planning.planner.update_cells(changed, costs[changed[:, 0], changed[:, 1]])
                self._planning.seconds += time.perf_counter() - started
                self._planning.changed += len(changed)
        self.grid = CostGrid(occupied, costmap, costs, resolution, origin)

    def _publish_costmap(self, costmap: npt.NDArray[np.uint8], resolution: float,
                         origin: tuple[float, float], stamp: Any) -> None:
        rows, cols = costmap.shape
        self.topics.costmap.publish(self.message(
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
        self.robot.pose, self.robot.at, self.robot.stamp = pose, self.now(), msg.header.stamp
        if self.driven.add(pose, msg.header.stamp):
            self.topics.driven_path.publish(self.message(PATH, **path_fields(
                self.driven.poses, msg.header.stamp, MAP_FRAME, self.driven.stamps)))

    @_one_at_a_time
    def _on_odom(self, msg: Any) -> None:
        v, omega = float(msg.twist.twist.linear.x), float(msg.twist.twist.angular.z)
        if math.isfinite(v) and math.isfinite(omega):
            self.robot.velocity = (v, omega)

    def _goal_covered(self) -> str | None:
        """Why the current map covers the goal (an obstacle put on it after it was given);
        None while it does not."""
        grid, goal = self.grid, self.goal
        cell = None if grid is None or goal is None else grid.cell_of(*goal)
        if grid is None or goal is None or cell is None or math.isfinite(grid.costs[cell]):
            return None
        return (f"goal ({goal[0]:g}, {goal[1]:g}) is inside an obstacle or within the robot's "
                f"inscribed radius {self.params.inscribed_radius:.3g} m of one on the current "
                f"map (costmap {int(grid.costmap[cell])}): the map covered it after the goal "
                "was given")

    # -- carrying out what the goal's state machine decides ------------------------------------

    def _carry_out(self, decision: Decision) -> None:
        match decision:
            case Drive(v, omega):
                self._command(v, omega)
            case Stop():
                self._stop()
            case End():
                self._finish(decision)
            case Recover():
                self._recover(decision)
            case Wait():
                pass  # nothing to act on yet: no command, the wheels as they are

    def _stop(self) -> None:
        self._command(0.0, 0.0)

    def halt(self) -> None:
        """Command the wheels to a stop now, whatever the goal (a run ending)."""
        with self._lock:
            self._command(0.0, 0.0)

    def _command(self, v: float, omega: float) -> None:
        """``(v, omega)`` on ``cmd_vel``: a Twist, or with ``stamped_cmd_vel`` a TwistStamped
        in the robot's frame, stamped now (as Nav2's controller_server stamps it)."""
        twist = {"linear": {"x": v}, "angular": {"z": omega}}
        if self.stamped_cmd_vel:
            self.topics.cmd_vel.publish(self.message(TWIST_STAMPED, header={
                "stamp": self.stamp(), "frame_id": self.base_frame}, twist=twist))
        else:
            self.topics.cmd_vel.publish(self.message(TWIST, **twist))

    def _finish(self, end: End) -> None:
        """The goal ended: the wheels stopped, its action goal ended as ``end`` says (the
        reason is an aborted goal's ``error_msg`` only, as nav2 answers)."""
        self._planning = None
        aborted = end.status is NavigationStatus.ABORTED
        if aborted:
            self.get_logger().error(("goal refused before driving: " if end.refused
                                     else "goal aborted: ") + end.reason)
        self._stop()
        if end.status is NavigationStatus.CANCELED:
            self.get_logger().info("goal canceled")
        if self._goal is not None:
            handle = self._goal.handle
            terminate = {NavigationStatus.ABORTED: handle.abort,
                         NavigationStatus.CANCELED: handle.canceled}.get(end.status,
                                                                         handle.succeed)
            self._end(terminate, end.reason if aborted else "")

    def _recover(self, trouble: Recover) -> None:
        """move_base's CLEARING: the wheels stopped, then the behaviour (or the goal given
        up)."""
        self._stop()
        if trouble.give_up is not None:
            self._finish(trouble.give_up)
            return
        assert trouble.behavior is not None and self.pose is not None and self.grid is not None
        self.get_logger().warning(trouble.message)
        x, y, _ = self.pose
        if trouble.behavior.type == CLEAR_COSTMAP_RECOVERY:
            # what the clearing forgets, the camera re-marks at once (it sees the whole floor
            # every frame): what is left of the behaviour is a search from scratch
            self._restart_planner(x, y)
            return
        grid, cell = self.grid, self.grid.cell_of(x, y)
        if cell is not None and can_rotate_in_place(
                grid.costmap, cell, (x, y), self.footprint, grid.resolution, grid.origin):
            self.goal_state.start_turn()
        else:
            self.get_logger().error("rotate recovery can't rotate in place because there "
                                    "is a potential collision")

    def _restart_planner(self, x: float, y: float) -> None:
        """A new D* Lite search from the robot's cell on the current map, its repairs'
        history dropped (a clearing recovery)."""
        grid, planning, goal = self.grid, self._planning, self.goal
        assert grid is not None and goal is not None and planning is not None
        cell = grid.cell_of(x, y)
        start = cell if cell is not None and math.isfinite(grid.costs[cell]) \
            else planning.planner.start
        covered = self._goal_covered()
        if covered is not None:
            # an obstacle covers the goal now: a search from scratch cannot reach it either
            # (the planner keeps its repairs, and finds the goal again if the obstacle goes)
            self.get_logger().warning(covered)
            return
        goal_cell = grid.cell_of(*goal)
        assert goal_cell is not None
        planning.planner = DStarLite(grid.costs, start, goal_cell)
        planning.changed, planning.seconds = 0, 0.0

    def _publish_feedback(self, now: float, feedback: Feedback) -> None:
        assert self._goal is not None
        stamp = self.stamp(now)
        x, y, yaw = feedback.pose
        self._goal.handle.publish_feedback(self.message(
            f"{NAVIGATE_TO_POSE}_Feedback",
            current_pose={"header": {"stamp": stamp, "frame_id": MAP_FRAME}, "pose": {
                "position": {"x": x, "y": y},
                "orientation": {"z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}}},
            navigation_time=time_of(feedback.navigation_time),  # a duration
            number_of_recoveries=feedback.number_of_recoveries,
            distance_remaining=feedback.distance_remaining))

    # -- before driving ------------------------------------------------------------------------

    def _start_planner(self, grid: CostGrid, start: tuple[int, int], pose: Pose) -> bool:
        """The checks of the module docstring's "before driving", then D* Lite's first plan."""
        assert self.goal is not None

        def refuse(reason: str) -> bool:
            self._finish(self.goal_state.abort(reason))
            return False

        gx, gy = self.goal
        goal = grid.cell_of(gx, gy)
        if goal is None:
            rows, cols = grid.costs.shape
            x0, y0 = grid.origin
            x1, y1 = x0 + cols * grid.resolution, y0 + rows * grid.resolution
            return refuse(f"goal ({gx:g}, {gy:g}) is outside the map (x {x0:g}..{x1:g}, "
                          f"y {y0:g}..{y1:g} m)")
        if not math.isfinite(grid.costs[goal]):
            return refuse(f"goal ({gx:g}, {gy:g}) is inside an obstacle or within the robot's "
                          f"inscribed radius {self.params.inscribed_radius:.3g} m of one "
                          f"(costmap {int(grid.costmap[goal])})")
        if not math.isfinite(grid.costs[start]):
            return refuse(f"the robot at cell {start} stands within its inscribed radius of an "
                          f"obstacle (costmap {int(grid.costmap[start])}): it cannot start")
        planner = DStarLite(grid.costs, start, goal)
        try:
            cells = planner.path()
        except NoPath:
            return refuse(f"no path from the robot to goal ({gx:g}, {gy:g}) on the first map: "
                          "obstacles enclose the goal or the robot")
        warnings: list[str] = []
        cost = int(grid.costmap[goal])
        if cost > 0:
            clear = grid.obstacle_distance(goal) - grid.resolution / 2
            band = (f"goal ({gx:g}, {gy:g}) lies in the inflated band of an obstacle about "
                    f"{clear:.2f} m away: costmap cost {cost} of 252 (inflation_radius "
                    f"{self.params.inflation_radius:g} m)")
            plan = grid.plan_points(cells, self.goal)
            length = float(np.sum(np.hypot(*np.diff(plan, axis=0).T)))
            def rehearse(dwa: DwaConfig) -> Any:
                return dry_run(grid.costmap, plan, dwa, resolution=grid.resolution,
                               origin=grid.origin, goal_yaw=self.goal_yaw, start=pose,
                               footprint=self.footprint,
                               stall_time=self.goal_state.rules.patience.oscillation_timeout
                               or 10.0,
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
                return refuse(f"{band}; a dry run of DWA on this map {where} "
                              f"({check.status}): {self._deciding(rehearse)}")
            warnings.append(band)
            self.get_logger().warning(band + "; DWA's dry run reaches it")
        self._planning = _Planning(planner)
        self.goal_state.start_driving(warnings)
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

    # -- the loop ------------------------------------------------------------------------------

    def _plan(self, now: float) -> FloatArray | None:
        """The plan from the robot's cell, repaired for what changed; None if there is none."""
        planning, grid = self._planning, self.grid
        assert planning is not None and grid is not None and self.goal is not None
        started = time.perf_counter()
        try:
            cells = planning.planner.path()
        except NoPath:
            return None
        if planning.changed:
            self.repairs.append(Repair(now, planning.changed, planning.seconds
                                       + time.perf_counter() - started))
            planning.changed, planning.seconds = 0, 0.0
        plan = grid.plan_points(cells, self.goal)
        if planning.last_plan is None or not np.array_equal(planning.last_plan, plan):
            planning.last_plan = plan
            self.plans.append((now, plan))
            stamp = self.stamp(now)
            self.topics.plan.publish(self.message(
                PATH, header={"stamp": stamp, "frame_id": MAP_FRAME},
                poses=[{"header": {"stamp": stamp, "frame_id": MAP_FRAME},
                        "pose": {"position": {"x": float(x), "y": float(y)},
                                 "orientation": {"w": 1.0}}} for x, y in plan]))
        return plan

    @_one_at_a_time
    def _cycle(self) -> None:
        """One controller cycle: the steps of :mod:`~.goal_state`, in its order."""
        machine, robot, grid = self.goal_state, self.robot, self.grid
        if not machine.live:
            return
        now = self.now()
        decision = machine.begin_cycle(Sensed(
            now, robot.pose, robot.at, robot.velocity, have_map=grid is not None,
            cancel_requested=self._goal is not None and self._goal.handle.is_cancel_requested,
            goal_covered=self._goal_covered() or ""))
        if decision is not None:
            self._carry_out(decision)
            return
        assert robot.pose is not None and grid is not None
        x, y, yaw = robot.pose
        cell = grid.cell_of(x, y)
        if cell is None:
            self._finish(machine.abort(f"the robot at ({x:.3f}, {y:.3f}) is outside the map"))
            return
        if self._planning is None and not self._start_planner(grid, cell, robot.pose):
            return
        assert self._planning is not None
        self._publish_feedback(now, machine.feedback())
        turn = machine.turn()
        if isinstance(turn, Drive):
            self._carry_out(turn)
            return
        if isinstance(turn, TurnTimedOut):
            self.get_logger().error(turn.message)
        trouble = machine.watch_oscillation()
        if trouble is not None:
            self._recover(trouble)
            return
        if cell != self._planning.planner.start and math.isfinite(grid.costs[cell]):
            self._planning.planner.move_to(cell)
        plan = self._plan(now)
        trouble = machine.planned(plan is not None)
        if trouble is not None:
            self._recover(trouble)
        if plan is None:
            self._stop()
            return
        result = compute_velocity((x, y, yaw), robot.velocity, grid.costmap, plan, self.dwa,
                                  resolution=grid.resolution, origin=grid.origin,
                                  goal_yaw=self.goal_yaw, oscillation=machine.oscillation,
                                  latch=machine.latch, footprint=self.footprint)
        self.cycles.append((now, x, y, yaw, result.v, result.omega, result.status.name))
        self._publish_local_plan(result.trajectory if len(result.trajectory)
                                 else np.array([(x, y, yaw)]), now)
        self._carry_out(machine.controlled(result.status, result.v, result.omega))

    def _publish_local_plan(self, poses: FloatArray, now: float) -> None:
        """DWA's chosen trajectory, stamped as the pose it starts from (module docstring)."""
        stamp = self.stamp(now) if self.robot.stamp is None else self.robot.stamp
        self.topics.local_plan.publish(self.message(PATH, **path_fields(
            poses, stamp, MAP_FRAME)))

    def destroy(self) -> None:
        try:
            if self.context.ok():
                self._stop()
                with self._lock:  # a client waiting for the result hears why it ended
                    if self._goal is not None:
                        self._end(self._goal.handle.abort, "the navigator shut down")
        finally:
            super().destroy()
