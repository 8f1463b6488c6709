"""The navigator's decisions about its goal, as a state machine with no middleware in it.

The goal's life is what nav2's bt_navigator serves for ``NavigateToPose`` (one goal at a time; a
new goal preempts the one being driven to, which ends ABORTED as nav2's SimpleActionServer aborts
it; a cancel stops the wheels and ends the goal CANCELED), with move_base's troubles and recovery
behaviours (move_base.cpp ``executeCycle``) and a goal checker in nav2's shape:

========== =============================================== =====================================
state      what holds                                      leaves for
========== =============================================== =====================================
IDLE       no goal yet                                     PLANNING (a goal)
PLANNING   a goal, waiting for a map and a fresh pose,     DRIVING (the checks passed, the first
           then the checks before driving and D* Lite's    plan made); ABORTED (refused, or no
           first plan (move_base starts a goal planning)   map / pose within ``start_timeout``)
DRIVING    a plan each cycle, DWA's command sent           SUCCEEDED (the goal checker);
           (move_base's CONTROLLING)                       RECOVERING (a turn); ABORTED
RECOVERING a rotate recovery turns the robot on the spot   DRIVING (the turn is done)
           (move_base's CLEARING)
SUCCEEDED, ABORTED, CANCELED: the goal has ended           PLANNING (a new goal)
========== =============================================== =====================================

From every live state (PLANNING, DRIVING, RECOVERING) a new goal preempts (the old one ABORTED,
the new one PLANNING) and a cancel ends CANCELED. An old pose (``pose_timeout``) while driving
stops the wheels until a new one comes, ABORTED after ``controller_patience``; while planning
the goal waits for a fresh one, ABORTED after ``start_timeout``.

A trouble -- no plan for ``planner_patience``, no valid command for ``controller_patience``, less
than ``oscillation_distance`` in ``oscillation_timeout`` -- runs the next recovery behaviour, the
wheels stopped first; with none left the goal is given up (ABORTED, the reason naming the trouble,
the behaviours run and, when the latest map covers the goal, that). A trouble's behaviour index
goes back to the first when the trouble ends, as in move_base.

The machine reads no clock and publishes nothing: :class:`~.navigator.NavigatorNode` reads the
clock, plans and runs DWA, hands the machine what it saw (:class:`Sensed` and the outcomes) and
carries out what comes back -- :class:`Drive`, :class:`Stop`, :class:`Wait`, :class:`End`,
:class:`Recover`, :class:`TurnTimedOut`, :class:`Feedback` -- in that order, one controller cycle
at a time:

1. :meth:`GoalStateMachine.begin_cycle` (cancel, start timeout, old pose);
2. the node's checks before driving, then :meth:`~GoalStateMachine.start_driving` or
   :meth:`~GoalStateMachine.abort`;
3. :meth:`~GoalStateMachine.feedback`, :meth:`~GoalStateMachine.turn` (a rotate recovery),
   :meth:`~GoalStateMachine.watch_oscillation`;
4. the node's plan, then :meth:`~GoalStateMachine.planned`;
5. DWA's command, then :meth:`~GoalStateMachine.controlled` (the goal checker).

A ``None`` from a step means "go on with the cycle".
"""

from __future__ import annotations

import enum
import math
from collections.abc import Sequence
from dataclasses import dataclass

from ...planning.dwa import DwaConfig, DwaStatus, GoalLatch, OscillationFlags, angle_diff
from ..errors import RobotValueError
from .params import RecoveryBehavior
from .recovery import ROTATE_TIMEOUT, RotateRecovery

Pose = tuple[float, float, float]


class NavigationStatus(enum.Enum):
    """Where the goal stands, as move_base's action reports it."""

    WAITING = "waiting for a goal, a map and a pose"
    ACTIVE = "driving"
    SUCCEEDED = "goal reached"
    ABORTED = "aborted"
    CANCELED = "canceled"


class GoalState(enum.Enum):
    """The machine's states (module docstring); :attr:`status` is what the action reports."""

    IDLE = "no goal"
    PLANNING = "waiting for a map and a pose, then the first plan"
    DRIVING = "driving"
    RECOVERING = "turning on the spot"
    SUCCEEDED = "goal reached"
    ABORTED = "aborted"
    CANCELED = "canceled"

    @property
    def status(self) -> NavigationStatus:
        return _STATUS[self]

    @property
    def live(self) -> bool:
        return self in (GoalState.PLANNING, GoalState.DRIVING, GoalState.RECOVERING)


_STATUS = {GoalState.IDLE: NavigationStatus.WAITING,
           GoalState.PLANNING: NavigationStatus.WAITING,
           GoalState.DRIVING: NavigationStatus.ACTIVE,
           GoalState.RECOVERING: NavigationStatus.ACTIVE,
           GoalState.SUCCEEDED: NavigationStatus.SUCCEEDED,
           GoalState.ABORTED: NavigationStatus.ABORTED,
           GoalState.CANCELED: NavigationStatus.CANCELED}

#: move_base's recovery triggers, and what it says when every behaviour has run in vain
GIVEN_UP = {"planning": "no plan to the goal", "controlling": "no valid trajectory",
            "oscillation": "oscillating"}


@dataclass(frozen=True)
class Patience:
    """move_base's patience: ``planner`` s without a plan, ``controller`` s without a valid
    command, or ``oscillation_timeout`` s (0: never) without moving ``oscillation_distance``
    m, before the next recovery behaviour runs (and the goal is given up after the last)."""

    planner: float = 5.0
    controller: float = 15.0
    oscillation_timeout: float = 0.0
    oscillation_distance: float = 0.5


#: move_base's own defaults (oscillation_timeout 0: no oscillation check)
MOVE_BASE_PATIENCE = Patience()


@dataclass(frozen=True)
class GoalChecker:
    """Whether the robot has arrived, judged on the goal as it was *asked for* (never on its
    cell's centre: issue 44 measured "successes" 154-167 mm away with a 150 mm tolerance).

    nav2's StoppedGoalChecker (SimpleGoalChecker's position and heading, then stopped), with
    base_local_planner's comparisons (``<=``, as ``LatchedStopRotateController`` and so DWA
    decide), so the goal ends exactly when DWA's own goal handling has stopped the robot there.
    ``latch_xy_goal_tolerance`` is SimpleGoalChecker's ``stateful``: once within
    ``xy_goal_tolerance``, a localisation jump out of it while turning does not undo it."""

    xy_goal_tolerance: float
    yaw_goal_tolerance: float
    trans_stopped_vel: float
    rot_stopped_vel: float
    latch_xy_goal_tolerance: bool = False

    @classmethod
    def of(cls, dwa: DwaConfig) -> GoalChecker:
        """The checker with DWA's own tolerances (one set of numbers for both, as D.3 has)."""
        return cls(dwa.xy_goal_tolerance, dwa.yaw_goal_tolerance, dwa.trans_stopped_vel,
                   dwa.rot_stopped_vel, dwa.latch_xy_goal_tolerance)

    def reached(self, pose: Pose, velocity: tuple[float, float], goal: tuple[float, float],
                goal_yaw: float | None, latch: GoalLatch) -> bool:
        x, y, yaw = pose
        within = math.hypot(x - goal[0], y - goal[1]) <= self.xy_goal_tolerance
        if not within and not (self.latch_xy_goal_tolerance and latch.xy_tolerance):
            return False
        error = 0.0 if goal_yaw is None else angle_diff(goal_yaw, yaw)
        v, omega = velocity
        return (abs(error) <= self.yaw_goal_tolerance and abs(v) <= self.trans_stopped_vel
                and abs(omega) <= self.rot_stopped_vel)


@dataclass(frozen=True)
class GoalRules:
    """The machine's configuration: move_base's ``patience`` and recovery ``behaviors`` (in
    order; none: give up at once), its ``planner_frequency`` (Hz; DWA's latches and oscillation
    flags are cleared at each new plan handed over, 0: only at the start), the age
    ``pose_timeout`` (s) past which a pose is too old to drive on, ``start_timeout`` (s; None:
    ``patience.controller``) for the first map and pose, and the goal ``checker``."""

    checker: GoalChecker
    patience: Patience = MOVE_BASE_PATIENCE
    behaviors: tuple[RecoveryBehavior, ...] = ()
    planner_frequency: float = 0.0
    pose_timeout: float = 0.5
    start_timeout: float | None = None
    #: why a pose may be missing, said when a goal is aborted for the lack of one: the
    #: overhead camera's, or the odometry topic a navigator beside the robot localises on
    no_pose: str = "the camera does not see it"

    def __post_init__(self) -> None:
        if not (math.isfinite(self.planner_frequency) and self.planner_frequency >= 0):
            raise RobotValueError(f"planner_frequency {self.planner_frequency!r} must be >= 0 Hz")
        if not (math.isfinite(self.pose_timeout) and self.pose_timeout > 0):
            raise RobotValueError(f"pose_timeout {self.pose_timeout!r} must be > 0 s")
        if not (math.isfinite(self.start_wait) and self.start_wait > 0):
            raise RobotValueError(f"start_timeout {self.start_timeout!r} must be > 0 s")

    @property
    def start_wait(self) -> float:
        return self.patience.controller if self.start_timeout is None else self.start_timeout


@dataclass(frozen=True)
class Recovery:
    """One recovery behaviour that ran: when (s), which, and why (move_base's trigger)."""

    t: float
    name: str
    type: str
    trigger: str


# -- what goes in ----------------------------------------------------------------------------


@dataclass(frozen=True)
class Sensed:
    """What the node knows at the start of a controller cycle: the time ``now`` (s), the robot's
    latest ``pose`` and when it came (``pose_at``, the node's clock; None: no pose yet), its
    ``velocity`` (v, omega) from odometry, whether a map has come, whether the goal's client
    asked to cancel, and why the latest map covers the goal ("" if it does not), which a goal
    given up says."""

    now: float
    pose: Pose | None = None
    pose_at: float | None = None
    velocity: tuple[float, float] = (0.0, 0.0)
    have_map: bool = False
    cancel_requested: bool = False
    goal_covered: str = ""


# -- what comes out --------------------------------------------------------------------------


@dataclass(frozen=True)
class Drive:
    """Send this command on ``/cmd_vel`` (m/s, rad/s)."""

    v: float
    omega: float


@dataclass(frozen=True)
class Stop:
    """Send a zero command and wait for the next cycle."""


@dataclass(frozen=True)
class Wait:
    """Send nothing this cycle (no goal input to act on yet)."""


@dataclass(frozen=True)
class End:
    """Stop the wheels and end the goal: its action goal succeeds, aborts (``reason`` is the
    result's ``error_msg``) or is canceled. ``refused``: it ended before the wheels were ever
    commanded."""

    status: NavigationStatus
    reason: str
    refused: bool = False


@dataclass(frozen=True)
class Recover:
    """move_base's CLEARING: stop the wheels, then run ``behavior`` (number ``number`` of
    ``of``) because of ``trigger``; ``give_up`` instead when none is left."""

    trigger: str
    why: str
    behavior: RecoveryBehavior | None
    number: int
    of: int
    give_up: End | None = None

    @property
    def message(self) -> str:
        assert self.behavior is not None
        return (f"recovery {self.number} of {self.of}: {self.behavior.name} "
                f"({self.behavior.type}) because of {GIVEN_UP[self.trigger]} ({self.why})")


@dataclass(frozen=True)
class TurnTimedOut:
    """A rotate recovery's turn took over :data:`~.recovery.ROTATE_TIMEOUT` s (a wheel that
    does not turn): it was ended; say so and go on with the cycle."""

    @property
    def message(self) -> str:
        return f"rotate recovery: the turn took over {ROTATE_TIMEOUT:g} s; ended"


@dataclass(frozen=True)
class Feedback:
    """NavigateToPose's feedback: the robot's pose, the time since the goal came (s), this
    goal's recoveries and the straight-line distance left (m)."""

    pose: Pose
    navigation_time: float
    number_of_recoveries: int
    distance_remaining: float


Decision = Drive | Stop | Wait | End | Recover


# -- the machine -----------------------------------------------------------------------------


@dataclass
class _Timers:
    """When each of move_base's troubles began, for this goal (s; None: not now)."""

    goal_at: float
    handed_over: float | None = None
    stuck_since: float | None = None
    no_plan_since: float | None = None
    #: (t, x, y) where the robot last had moved oscillation_distance
    moved: tuple[float, float, float] | None = None


@dataclass
class _Recovering:
    """Where the goal is in its recovery behaviours: the next one's index, the trouble that
    ran the last, and a turn in progress with when it began."""

    index: int = 0
    trigger: str = ""
    rotation: RotateRecovery | None = None
    rotation_since: float = 0.0


class GoalStateMachine:
    """See the module docstring. The goal's record -- :attr:`goal`, :attr:`goal_yaw`,
    :attr:`state`, :attr:`reason`, :attr:`refused`, :attr:`warnings` -- is the current goal's;
    :attr:`recoveries`, :attr:`stale_cycles` and :attr:`goal_count` count every goal's."""

    def __init__(self, rules: GoalRules) -> None:
        self.rules = rules
        self.state = GoalState.IDLE
        self.goal: tuple[float, float] | None = None
        self.goal_yaw: float | None = None
        self.reason = ""
        #: the goal ended before the wheels were ever commanded
        self.refused = False
        #: warnings about the goal given before driving (a goal in the inflated band)
        self.warnings: list[str] = []
        #: how many goals the machine has taken (each preempting the one before)
        self.goal_count = 0
        #: every recovery behaviour that ran
        self.recoveries: list[Recovery] = []
        #: controller cycles skipped, the wheels stopped, because the pose was too old
        self.stale_cycles = 0
        #: DWA's oscillation critic; cleared whenever move_base would hand over a new plan
        self.oscillation = OscillationFlags()
        #: LatchedStopRotateController's latches; cleared with the oscillation flags
        self.latch = GoalLatch()
        self._stale_since: float | None = None
        self._reset(0.0)
        self._sensed = Sensed(0.0)

    def _reset(self, now: float) -> None:
        self.oscillation.reset()
        self.latch.reset()
        self._timers = _Timers(goal_at=now)
        self._recovering = _Recovering(rotation_since=now)
        self._driven = False
        #: recoveries of earlier goals: this goal's are the ones after them
        self._recoveries_before = len(self.recoveries)

    @property
    def status(self) -> NavigationStatus:
        return self.state.status

    @property
    def live(self) -> bool:
        """A goal is being driven to (or waited for): the controller's cycles are its."""
        return self.state.live

    @property
    def done(self) -> bool:
        return self.state in (GoalState.SUCCEEDED, GoalState.ABORTED, GoalState.CANCELED)

    # -- goals ---------------------------------------------------------------------------------

    def take_goal(self, now: float, goal: tuple[float, float],
                  goal_yaw: float | None) -> End | None:
        """A new goal (``goal_yaw`` None: any heading); the :class:`End` of the goal it
        preempts, if one was live (nav2's SimpleActionServer aborts it)."""
        preempted = End(NavigationStatus.ABORTED, "preempted by a new goal") if self.live \
            else None
        self.goal_count += 1
        self.goal, self.goal_yaw = goal, goal_yaw
        self.state, self.reason, self.refused = GoalState.PLANNING, "", False
        self.warnings = []
        self._reset(now)
        return preempted

    def abort(self, reason: str) -> End:
        """The node found the goal cannot be driven to (refused before driving, the robot off
        the map, the map changed its frame)."""
        return self._end(GoalState.ABORTED, reason)

    def start_driving(self, warnings: Sequence[str] = ()) -> None:
        """The checks before driving passed and the first plan is made, with ``warnings``."""
        self.warnings.extend(warnings)
        self.state = GoalState.DRIVING

    def _end(self, state: GoalState, reason: str) -> End:
        self.state, self.reason = state, reason
        if state is GoalState.ABORTED:
            self.refused = not self._driven
        return End(state.status, reason, self.refused)

    # -- a controller cycle --------------------------------------------------------------------

    def begin_cycle(self, sensed: Sensed) -> Decision | None:
        """A cancel, a goal still without its map or a fresh pose, or a pose gone old."""
        self._sensed = s = sensed
        if s.cancel_requested:
            return self._end(GoalState.CANCELED, "canceled by its client")
        r = self.rules
        if s.pose_at is None or not s.have_map or (
                self.state is GoalState.PLANNING and s.now - s.pose_at > r.pose_timeout):
            if s.now - self._timers.goal_at < r.start_wait:
                return Wait()
            missing = "map" if not s.have_map else f"pose of the robot ({r.no_pose})"
            return self.abort(f"no {missing} for {r.start_wait:g} s after the goal")
        if s.now - s.pose_at <= r.pose_timeout:
            self._stale_since = None
            return None
        # as a ROS controller refuses a transform that old
        self.stale_cycles += 1
        self._stale_since = self._stale_since if self._stale_since is not None else s.now
        if s.now - self._stale_since >= r.patience.controller:
            return self.abort(f"no pose newer than {r.pose_timeout:g} s for "
                              f"{r.patience.controller:g} s")
        return Stop()

    def feedback(self) -> Feedback:
        s = self._sensed
        assert s.pose is not None and self.goal is not None
        x, y, _ = s.pose
        return Feedback(s.pose, s.now - self._timers.goal_at,
                        len(self.recoveries) - self._recoveries_before,
                        math.hypot(self.goal[0] - x, self.goal[1] - y))

    def turn(self) -> Drive | TurnTimedOut | None:
        """The rotate recovery's command while it turns; when it is done (or timed out) the
        goal drives on."""
        rec, s = self._recovering, self._sensed
        if rec.rotation is None:
            return None
        assert s.pose is not None
        x, y, yaw = s.pose
        rate = rec.rotation.command(yaw)
        timed_out = rate is not None and s.now - rec.rotation_since > ROTATE_TIMEOUT
        if rate is not None and not timed_out:
            self._driven = True
            return Drive(0.0, rate)
        rec.rotation = None
        self.state = GoalState.DRIVING
        self._timers.moved = (s.now, x, y)
        return TurnTimedOut() if timed_out else None

    def start_turn(self) -> None:
        """The node found the robot free to turn on the spot: the rotate recovery begins."""
        s = self._sensed
        assert s.pose is not None
        self._recovering.rotation = RotateRecovery(s.pose[2])
        self._recovering.rotation_since = s.now
        self.state = GoalState.RECOVERING

    def watch_oscillation(self) -> Recover | None:
        """move_base's oscillation check: a recovery when the robot has not moved
        ``oscillation_distance`` for ``oscillation_timeout``."""
        p, s, t = self.rules.patience, self._sensed, self._timers
        assert s.pose is not None
        x, y, _ = s.pose
        if t.moved is None or math.hypot(x - t.moved[1], y - t.moved[2]) \
                >= p.oscillation_distance:
            t.moved = (s.now, x, y)
            self._trouble_over("oscillation")
            return None
        if p.oscillation_timeout > 0 and s.now - t.moved[0] >= p.oscillation_timeout:
            return self._trouble("oscillation", f"moved less than {p.oscillation_distance:g} m "
                                 f"in {p.oscillation_timeout:g} s")
        return None

    def planned(self, found: bool) -> Recover | None:
        """Whether the planner found a plan this cycle: a recovery after ``planner_patience``
        without one. With one, DWA is handed it (its latches and oscillation flags cleared) at
        ``planner_frequency``, as ``DWAPlanner::setPlan`` is."""
        s, t = self._sensed, self._timers
        if not found:
            t.no_plan_since = t.no_plan_since if t.no_plan_since is not None else s.now
            if s.now - t.no_plan_since >= self.rules.patience.planner:
                return self._trouble("planning", f"no path to the goal for "
                                     f"{self.rules.patience.planner:g} s")
            return None
        t.no_plan_since = None
        self._trouble_over("planning")
        f = self.rules.planner_frequency
        if t.handed_over is None or (f > 0 and s.now - t.handed_over >= 1.0 / f - 1e-9):
            self.oscillation.reset()
            self.latch.reset()
            t.handed_over = s.now
        return None

    def controlled(self, status: DwaStatus, v: float, omega: float) -> Drive | End | Recover:
        """DWA's command for this cycle (``status`` its verdict): the goal ends when the goal
        checker says it is reached; no valid command for ``controller_patience`` is a
        trouble; else the command is sent."""
        s, t = self._sensed, self._timers
        assert s.pose is not None and self.goal is not None
        if self.rules.checker.reached(s.pose, s.velocity, self.goal, self.goal_yaw, self.latch):
            return self._end(GoalState.SUCCEEDED, "goal reached")
        if status is DwaStatus.NO_VALID_TRAJECTORY:
            t.stuck_since = t.stuck_since if t.stuck_since is not None else s.now
            if s.now - t.stuck_since >= self.rules.patience.controller:
                return self._trouble("controlling",
                                     f"none for {self.rules.patience.controller:g} s")
        else:
            t.stuck_since = None
            self._trouble_over("controlling")
        self._driven = self._driven or v != 0.0 or omega != 0.0
        return Drive(v, omega)

    # -- move_base's troubles ------------------------------------------------------------------

    def _trouble_over(self, trigger: str) -> None:
        if self._recovering.trigger == trigger:
            self._recovering.index = 0

    def _trouble(self, trigger: str, why: str) -> Recover:
        """move_base's CLEARING state: the next recovery behaviour, or give up."""
        behaviors, rec, s = self.rules.behaviors, self._recovering, self._sensed
        if rec.index >= len(behaviors):
            after = (f", even after {len(behaviors)} recovery behaviour(s)" if behaviors
                     else "")
            covered = f"; {s.goal_covered}" if s.goal_covered else ""
            return Recover(trigger, why, None, rec.index, len(behaviors),
                           give_up=self._end(GoalState.ABORTED,
                                             f"{GIVEN_UP[trigger]}: {why}{after}{covered}"))
        behavior = behaviors[rec.index]
        rec.index += 1
        rec.trigger = trigger
        self.recoveries.append(Recovery(s.now, behavior.name, behavior.type, trigger))
        assert s.pose is not None
        # what move_base resets on leaving CLEARING: the oscillation timer only (a planner or
        # controller still failing starts the next behaviour at once)
        self._timers.moved = (s.now, s.pose[0], s.pose[1])
        return Recover(trigger, why, behavior, rec.index, len(behaviors))
