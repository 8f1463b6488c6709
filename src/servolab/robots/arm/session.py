"""An arm reached through its controllers, as MoveIt reaches one: a ``FollowJointTrajectory``
goal for each move of the arm, a ``GripperCommand`` (or ``ParallelGripperCommand``) goal for
each move of the gripper, ``/joint_states`` heard all along.

:class:`ArmLink` works on any context: the one of an arm brought up in this process (its
controller manager's, on simulated time or the wall clock) or one joined to a running
``servolab control run`` over Zenoh. It waits by spinning that context, so in simulated time
a move takes no longer than the computer needs.

Each move is timed by ruckig (:func:`servolab.trajectories.timing.time_optimal`) from where
the joints are to the target, and sent as points every :data:`SAMPLE_PERIOD` s with their
positions and velocities: joint_trajectory_controller interpolates cubic splines between
them. Every goal sent is also published on this node's own topics (``/servolab_arm/
trajectory``, ``/servolab_arm/gripper_command``), so the run's bag holds what was asked
beside what the joints did.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import RobotError
from .spec import PARALLEL_GRIPPER_COMMAND, ArmSpec

if TYPE_CHECKING:
    from ...middleware.context import Context
    from ...trajectories.timing import MoveLimits, TimedMove

TRAJECTORY_ACTION = "control_msgs/action/FollowJointTrajectory"
JOINT_STATE = "sensor_msgs/msg/JointState"
JOINT_TRAJECTORY = "trajectory_msgs/msg/JointTrajectory"
CONTROLLER_STATE = "control_msgs/msg/JointTrajectoryControllerState"
GRIPPER_MESSAGE = "control_msgs/msg/GripperCommand"
#: the node's name: its topics are /servolab_arm/trajectory and /servolab_arm/gripper_command
NODE = "servolab_arm"
#: s between the points of a goal (ruckig's profile sampled with positions and velocities)
SAMPLE_PERIOD = 0.05
#: how much longer than planned a goal may take before it is cancelled (s)
GOAL_MARGIN = 5.0
#: how long a gripper goal may take (s): its controller ends it reached or stalled
GRIPPER_TIMEOUT = 10.0
#: a gripper controller ends its goal within its goal_tolerance (ROBOTIS's: 1 cm) while the
#: motor goes on: the gripper is still once it moved less than this (m or rad) over
#: GRIPPER_STILL_S s, waited for at most GRIPPER_SETTLE_S s
GRIPPER_STILL = 2e-4
GRIPPER_STILL_S = 0.2
GRIPPER_SETTLE_S = 3.0
#: GoalStatus numbers (action_msgs/msg/GoalStatus) and their names
STATUS_NAMES = {0: "UNKNOWN", 1: "ACCEPTED", 2: "EXECUTING", 3: "CANCELING", 4: "SUCCEEDED",
                5: "CANCELED", 6: "ABORTED"}
SUCCEEDED = 4
#: FollowJointTrajectory's error codes (control_msgs/action/FollowJointTrajectory)
ERROR_CODES = {0: "SUCCESSFUL", -1: "INVALID_GOAL", -2: "INVALID_JOINTS",
               -3: "OLD_HEADER_TIMESTAMP", -4: "PATH_TOLERANCE_VIOLATED",
               -5: "GOAL_TOLERANCE_VIOLATED"}


def _stamp(seconds: float) -> dict[str, int]:
    sec = math.floor(seconds)
    return {"sec": int(sec), "nanosec": min(round((seconds - sec) * 1e9), 999_999_999)}


def _seconds(stamp: Any) -> float:
    return int(stamp.sec) + int(stamp.nanosec) * 1e-9


@dataclass
class MoveResult:
    """How one arm move ended: what was asked (``target``, rad), how long ruckig timed it
    (s), the goal's status and the controller's error code and string, when it started and
    ended (s, ROS time), and the joints' error at the end (target - measured, rad)."""

    what: str
    target: tuple[float, ...]
    planned_s: float
    status: str = "NOT SENT"
    error_code: str = ""
    error_string: str = ""
    started: float = math.nan
    ended: float = math.nan
    final_error: tuple[float, ...] = ()
    points: int = 0

    @property
    def succeeded(self) -> bool:
        return self.status == STATUS_NAMES[SUCCEEDED]

    def figures(self, joints: Sequence[str]) -> dict[str, Any]:
        return {"what": self.what, "target_rad": dict(zip(joints, self.target, strict=True)),
                "planned_s": round(self.planned_s, 4), "points": self.points,
                "status": self.status, "error_code": self.error_code,
                "error_string": self.error_string,
                "took_s": round(self.ended - self.started, 4)
                if math.isfinite(self.ended - self.started) else None,
                "final_error_rad": dict(zip(joints, self.final_error, strict=False)),
                "max_final_error_rad": max((abs(e) for e in self.final_error), default=None)}


@dataclass
class GripResult:
    """How one gripper move ended: the goal (position, m or rad; effort), its status, and
    what the controller's result says (position, reached the goal, stalled)."""

    what: str
    position: float
    effort: float
    status: str = "NOT SENT"
    reached_goal: bool = False
    stalled: bool = False
    final_position: float = math.nan
    started: float = math.nan
    ended: float = math.nan
    #: where the gripper came to rest after the goal ended (/joint_states), and when (s)
    settled_position: float = math.nan
    settled_s: float = math.nan

    def figures(self) -> dict[str, Any]:
        return {"what": self.what, "position": self.position, "max_effort": self.effort,
                "status": self.status, "reached_goal": self.reached_goal,
                "stalled": self.stalled, "result_position": self.final_position,
                "settled_position": self.settled_position,
                "settled_after_s": round(self.settled_s, 3)
                if math.isfinite(self.settled_s) else None}


@dataclass
class Heard:
    """What the node heard: /joint_states (times, positions by joint) and the arm
    controller's reference (times, positions of the arm's joints)."""

    state_times: list[float] = field(default_factory=list)
    states: list[dict[str, float]] = field(default_factory=list)
    reference_times: list[float] = field(default_factory=list)
    references: list[tuple[float, ...]] = field(default_factory=list)
    #: each goal sent: (ROS time it was sent, its points' times from start, positions)
    sent: list[tuple[float, np.ndarray, np.ndarray]] = field(default_factory=list)


class ArmLink:
    """The arm ``spec`` through its controllers on ``context`` (see the module docstring)."""

    def __init__(self, context: Context, spec: ArmSpec,
                 say: Callable[[str], None] | None = None) -> None:
        from ...middleware.node import Node
        from ...rclpy.action import ActionClient

        self.context, self.spec = context, spec
        #: told when a goal is accepted, so that a slow move shows it has begun
        self.say = say
        self.node = node = Node(context, NODE)
        self.heard = Heard()
        self.trajectory = ActionClient(node, TRAJECTORY_ACTION, spec.action)
        self.gripper = None
        if spec.gripper is not None:
            self.gripper = ActionClient(node, spec.gripper.action,
                                        f"/{spec.gripper.controller}/gripper_cmd")
        self.trajectory_out = node.create_publisher(JOINT_TRAJECTORY, "~/trajectory", 10)
        self.gripper_out = node.create_publisher(GRIPPER_MESSAGE, "~/gripper_command", 10)
        node.create_subscription(JOINT_STATE, "/joint_states", self._on_joint_states, 100)
        node.create_subscription(CONTROLLER_STATE, f"/{spec.controller}/controller_state",
                                 self._on_reference, 100)
        self._active: Any = None

    #: the topics a run records, with their types
    def topics(self) -> dict[str, str]:
        return {"/joint_states": JOINT_STATE, f"/{NODE}/trajectory": JOINT_TRAJECTORY,
                f"/{NODE}/gripper_command": GRIPPER_MESSAGE,
                f"/{self.spec.controller}/controller_state": CONTROLLER_STATE}

    def _on_joint_states(self, message: Any) -> None:
        self.heard.state_times.append(_seconds(message.header.stamp))
        self.heard.states.append(dict(zip(message.name, (float(p) for p in message.position),
                                          strict=False)))

    def _on_reference(self, message: Any) -> None:
        names = list(message.joint_names)
        positions = list(message.reference.positions)
        if len(positions) != len(names):
            return
        by_name = dict(zip(names, positions, strict=True))
        if all(j in by_name for j in self.spec.joints):
            self.heard.reference_times.append(_seconds(message.header.stamp))
            self.heard.references.append(tuple(float(by_name[j]) for j in self.spec.joints))

    # -- waiting --------------------------------------------------------------------------

    def wait(self, done: Any, timeout: float) -> bool:
        return bool(self.context.spin_until(done, timeout))

    def wait_ready(self, timeout: float = 10.0) -> None:
        """Wait until the controllers' actions are served and the joints are heard; one
        line saying what is missing if they are not within ``timeout`` s."""
        clients = [self.trajectory] + ([self.gripper] if self.gripper is not None else [])

        def ready() -> bool:
            return all(c.server_is_ready() for c in clients) and self._arm_known()

        if not self.wait(ready, timeout):
            missing = [c.name for c in clients if not c.server_is_ready()]
            if not self._arm_known():
                missing.append("/joint_states with " + ", ".join(self.spec.joints))
            raise RobotError(f"the arm did not answer within {timeout:g} s: no "
                             f"{'; no '.join(missing)} (are its controllers active? servolab "
                             f"control run {self.spec.robot} --spawn joint_state_broadcaster "
                             f"{self.spec.controller}"
                             + (f" {self.spec.gripper.controller}" if self.spec.gripper else "")
                             + ")")

    def _arm_known(self) -> bool:
        return bool(self.heard.states) and all(j in self.heard.states[-1]
                                               for j in self.spec.joints)

    def joints(self) -> np.ndarray:
        """The arm's joints now (rad, as /joint_states last said)."""
        for state in reversed(self.heard.states):
            if all(j in state for j in self.spec.joints):
                return np.array([state[j] for j in self.spec.joints])
        raise RobotError("no /joint_states heard with the arm's joints")

    def gripper_position(self) -> float:
        gripper = self.spec.gripper
        for state in reversed(self.heard.states):
            if gripper is not None and gripper.joint in state:
                return state[gripper.joint]
        return math.nan

    # -- the arm --------------------------------------------------------------------------

    def plan(self, target: Sequence[float], limits: MoveLimits) -> TimedMove:
        from ...trajectories.timing import time_optimal

        return time_optimal(self.joints(), np.asarray(target, dtype=np.float64), limits)

    def move(self, what: str, target: Sequence[float], limits: MoveLimits) -> MoveResult:
        """One FollowJointTrajectory goal from where the joints are to ``target``, timed by
        ruckig within ``limits``; waits for its end (cancelled :data:`GOAL_MARGIN` s after
        its planned duration)."""
        timed = self.plan(target, limits)
        result = MoveResult(what, tuple(float(v) for v in target), timed.duration)
        times, positions, velocities, _ = timed.sample(SAMPLE_PERIOD)
        if timed.duration <= 0:   # already there: a single point now
            times = np.array([SAMPLE_PERIOD])
        result.points = len(times)
        trajectory = {"joint_names": list(self.spec.joints), "points": [
            {"positions": p.tolist(), "velocities": v.tolist(),
             "time_from_start": _stamp(float(t))}
            for t, p, v in zip(times, positions, velocities, strict=True)]}
        now = self.context.ros_time()
        self.heard.sent.append((now, np.asarray(times), np.asarray(positions)))
        self.trajectory_out.publish(self.node.message(
            JOINT_TRAJECTORY, header={"stamp": _stamp(now)}, **trajectory))
        goal = self.node.message(f"{TRAJECTORY_ACTION}_Goal", trajectory=trajectory)
        response = self._send(self.trajectory, goal, float(times[-1]) + GOAL_MARGIN, result)
        if response is not None:
            result.error_code = ERROR_CODES.get(int(response.result.error_code),
                                                str(response.result.error_code))
            result.error_string = str(response.result.error_string)
        self.wait(lambda: False, 0.05)   # the last /joint_states of the move
        result.final_error = tuple(float(e) for e in np.asarray(target) - self.joints())
        return result

    def _send(self, client: Any, goal: Any, timeout: float, result: Any) -> Any:
        """Send ``goal`` and wait for its end; the result response, or None (rejected, or
        cancelled after ``timeout`` s: ``result.status`` says which)."""
        result.started = self.context.ros_time()
        sent = client.send_goal_async(goal)
        if not self.wait(sent.done, 5.0):
            result.status = "NOT ANSWERED"
            return None
        handle = sent.result()
        if not handle.accepted:
            result.status = "REJECTED"
            return None
        self._active = handle   # until it ends: a stop signal while waiting cancels it
        if self.say is not None:
            self.say(f"{result.what}: goal accepted, moving")
        ended = handle.get_result_async()
        if not self.wait(ended.done, timeout):
            self.cancel()
            self.wait(ended.done, 2.0)
            result.status = f"TIMED OUT after {timeout:.1f} s (cancelled)"
            result.ended = self.context.ros_time()
            return ended.result() if ended.done() else None
        self._active = None
        response = ended.result()
        result.status = STATUS_NAMES.get(int(response.status), str(response.status))
        result.ended = self.context.ros_time()
        return response

    def cancel(self) -> None:
        """Cancel the goal running (on the way out of a stopped run: the joints hold)."""
        handle = self._active
        if handle is not None:
            self._active = None
            cancel = handle.cancel_goal_async()
            self.wait(cancel.done, 2.0)

    # -- the gripper ----------------------------------------------------------------------

    def grip(self, what: str, position: float, effort: float) -> GripResult:
        """One gripper goal: the gripper's joint to ``position`` at most ``effort``; waits
        for its end (reached, or stalled on what it holds)."""
        gripper = self.spec.gripper
        if gripper is None or self.gripper is None:
            raise RobotError(f"robot {self.spec.robot} has no gripper controller")
        result = GripResult(what, position, effort)
        self.gripper_out.publish(self.node.message(GRIPPER_MESSAGE, position=position,
                                                   max_effort=effort))
        if gripper.action == PARALLEL_GRIPPER_COMMAND:
            goal = self.node.message(f"{gripper.action}_Goal", command={
                "name": [gripper.joint], "position": [position], "effort": [effort]})
        else:
            goal = self.node.message(f"{gripper.action}_Goal",
                                     command={"position": position, "max_effort": effort})
        response = self._send(self.gripper, goal, GRIPPER_TIMEOUT, result)
        if response is not None:
            answer = response.result
            result.reached_goal = bool(answer.reached_goal)
            result.stalled = bool(answer.stalled)
            if gripper.action == PARALLEL_GRIPPER_COMMAND:
                positions = list(answer.state.position)
                result.final_position = float(positions[0]) if positions else math.nan
            else:
                result.final_position = float(answer.position)
        self._settle(result)
        return result

    def _settle(self, result: GripResult) -> None:
        """Wait for the gripper to come to rest (see :data:`GRIPPER_STILL`)."""
        gripper = self.spec.gripper
        assert gripper is not None
        began = self.context.ros_time()
        times, states = self.heard.state_times, self.heard.states

        def still() -> bool:
            now = times[-1] if times else -math.inf
            if now - began < GRIPPER_STILL_S:
                return False
            window = [s[gripper.joint] for t, s in zip(reversed(times), reversed(states),
                                                        strict=True)
                      if t >= now - GRIPPER_STILL_S and gripper.joint in s]
            return len(window) > 1 and max(window) - min(window) < GRIPPER_STILL

        self.wait(still, GRIPPER_SETTLE_S)
        result.settled_position = self.gripper_position()
        result.settled_s = self.context.ros_time() - began

    def close(self) -> None:
        self.node.destroy()
