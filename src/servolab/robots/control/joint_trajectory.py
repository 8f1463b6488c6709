"""``joint_trajectory_controller/JointTrajectoryController``, as ros2_controllers' (Jazzy)
behaves (``src/joint_trajectory_controller.cpp``; its parameter names and defaults are
``src/joint_trajectory_controller_parameters.yaml``'s).

- A trajectory comes as a ``FollowJointTrajectory`` goal on ``~/follow_joint_trajectory`` (what
  MoveIt sends) or as a message on ``~/joint_trajectory``; it is checked
  (:func:`servolab.trajectories.validate_trajectory`) before anything moves, missing joints
  held where they are commanded (``allow_partial_joints_goal``), and sampled each update with
  ``interpolation_method`` (``splines``: linear, cubic or quintic by what the points give)
  starting from where the joints were when it arrived.
- The command sent is the sample one update ahead, as the original sends ``command_next_``;
  a position command interface takes the positions, a velocity one the velocities (with a
  PID on the position error, ``gains.<joint>.p/i/d`` and ``ff_velocity_scale``, when the
  joints have no position command interface).
- Tolerances: ``constraints.<joint>.trajectory`` while moving (violated: the goal is aborted
  with ``PATH_TOLERANCE_VIOLATED``, "Aborted due to path tolerance violation", and the joints
  hold), ``constraints.<joint>.goal`` and ``constraints.stopped_velocity_tolerance`` at the
  end, ``constraints.goal_time`` after it (exceeded: ``GOAL_TOLERANCE_VIOLATED``); a goal's own
  ``path_tolerance``, ``goal_tolerance`` and ``goal_time_tolerance`` override them (0 keeps a
  default, -1 lifts it). Reached: ``SUCCESSFUL``, "Goal successfully reached!".
- A new goal preempts the active one (aborted, ``INVALID_GOAL``, "Current goal preempted by
  new incoming action."); a cancelled goal ends canceled and the joints hold where they are;
  deactivating the controller aborts its goal (``INVALID_GOAL``) and leaves the position
  commands where they are.
- ``~/controller_state`` (control_msgs/JointTrajectoryControllerState) every update:
  reference, feedback, error and output.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ...rclpy.action import ActionServer, CancelResponse, GoalResponse, ServerGoalHandle
from ...rclpy.task import Future
from ...trajectories import (
    Constraints,
    JointArrays,
    JointTolerance,
    PointState,
    SegmentTolerances,
    Trajectory,
    TrajectoryError,
    ValidationConfig,
    check_state_tolerance_per_joint,
    default_segment_tolerances,
    fill_partial_goal,
    segment_tolerances_from_goal,
    sort_to_local_joint_order,
    validate_trajectory,
)
from .controller import INDIVIDUAL, ControllerError, ControllerInterface, InterfaceConfiguration
from .goals import end_goal
from .hardware import ACCELERATION, EFFORT, POSITION, VELOCITY

ACTION = "control_msgs/action/FollowJointTrajectory"
#: a trajectory taken in: its values by joint, its points' times and its start stamp (s)
Pending = tuple[JointArrays, np.ndarray, float]
#: command interface sets the original accepts (``check_valid_interface_combination``)
COMMAND_SETS = ({POSITION}, {POSITION, VELOCITY}, {POSITION, VELOCITY, ACCELERATION},
                {VELOCITY}, {EFFORT}, {POSITION, VELOCITY, ACCELERATION, EFFORT})
#: FollowJointTrajectory result codes
SUCCESSFUL, INVALID_GOAL, PATH_TOLERANCE_VIOLATED, GOAL_TOLERANCE_VIOLATED = 0, -1, -4, -5


def _seconds(duration: Any) -> float:
    return int(duration.sec) + int(duration.nanosec) * 1e-9


class _Goal:
    """An accepted goal: its handle and the future its execute callback returned."""

    def __init__(self, handle: ServerGoalHandle, future: Future) -> None:
        self.handle = handle
        self.future = future


class JointTrajectoryController(ControllerInterface):
    TYPE = "joint_trajectory_controller/JointTrajectoryController"

    def on_init(self) -> None:
        self.joints = self.strings("joints", required=False)
        self.command_names = self.strings("command_interfaces", required=False)
        self.state_names = self.strings("state_interfaces", required=False)
        self.allow_partial = bool(self.parameter("allow_partial_joints_goal", False))
        self.allow_nonzero_end = bool(self.parameter(
            "allow_nonzero_velocity_at_trajectory_end", False))
        self.open_loop = bool(self.parameter("open_loop_control", False))
        self.interpolation = str(self.parameter("interpolation_method", "splines"))
        self.action_monitor_rate = float(self.parameter("action_monitor_rate", 20.0))
        self.stopped_velocity = float(self.parameter(
            "constraints.stopped_velocity_tolerance", 0.01))
        self.goal_time = float(self.parameter("constraints.goal_time", 0.0))
        self.joint_constraints = {
            j: {k: float(self.parameter(f"constraints.{j}.{k}", 0.0))
                for k in ("trajectory", "goal")} for j in self.joints}
        self.gains = {j: {k: float(self.parameter(f"gains.{j}.{k}", d)) for k, d in
                          (("p", 0.0), ("i", 0.0), ("d", 0.0), ("i_clamp", 0.0),
                           ("ff_velocity_scale", 0.0))} for j in self.joints}

    def _check(self) -> None:
        name = self.name
        if not self.joints:
            raise ControllerError(f"{name}: 'joints' parameter is empty.")
        if not self.command_names:
            raise ControllerError(f"{name}: 'command_interfaces' parameter is empty.")
        if set(self.command_names) not in COMMAND_SETS:
            raise ControllerError(f"{name}: command_interfaces {list(self.command_names)} is "
                                  "not a combination joint_trajectory_controller takes "
                                  "(position; position, velocity; velocity; effort; ...)")
        if not self.state_names:
            raise ControllerError(f"{name}: 'state_interfaces' parameter is empty.")
        if POSITION not in self.state_names:
            raise ControllerError(f"{name}: state_interfaces must include position")
        if POSITION not in self.command_names and VELOCITY not in self.state_names:
            raise ControllerError(f"{name}: a velocity or effort command needs the position "
                                  "and velocity state interfaces (for its PID)")
        if self.interpolation not in ("splines", "none"):
            raise ControllerError(f"{name}: interpolation_method {self.interpolation!r} is "
                                  "one of splines, none")
        try:
            self.tolerances = default_segment_tolerances(self.joints, Constraints.from_parameters(
                {"stopped_velocity_tolerance": self.stopped_velocity, "goal_time":
                 self.goal_time, **self.joint_constraints}))
        except TrajectoryError as exc:
            raise ControllerError(f"{name}: {exc}") from None

    def command_interface_configuration(self) -> InterfaceConfiguration:
        return InterfaceConfiguration(INDIVIDUAL, tuple(f"{j}/{i}" for i in self.command_names
                                                        for j in self.joints))

    def state_interface_configuration(self) -> InterfaceConfiguration:
        return InterfaceConfiguration(INDIVIDUAL, tuple(f"{j}/{i}" for i in self.state_names
                                                        for j in self.joints))

    def on_configure(self) -> None:
        self._check()
        node = self.node
        self._pending: Pending | None = None
        self._trajectory: Trajectory | None = None
        self._goal: _Goal | None = None
        self._active_tolerances: SegmentTolerances = self.tolerances
        self._holding = True
        self._traj_time = 0.0
        self._last_feedback = -math.inf
        self._integral = np.zeros(len(self.joints))
        node.create_subscription("trajectory_msgs/msg/JointTrajectory", "~/joint_trajectory",
                                 self._on_trajectory_message, 10)
        self.state_publisher = node.create_publisher(
            "control_msgs/msg/JointTrajectoryControllerState", "~/controller_state", 10)
        self.action_server = ActionServer(
            node, ACTION, "~/follow_joint_trajectory", self._execute,
            goal_callback=self._on_goal, handle_accepted_callback=self._on_accepted,
            cancel_callback=self._on_cancel)

    def on_cleanup(self) -> None:
        self.node.destroy()
        from ...middleware.node import Node

        self.node = Node(self.node.context, self.name, self.node.get_namespace())

    # -- activation -------------------------------------------------------------------------

    def on_activate(self) -> None:
        # a command and a state interface share a name (joint1/position): two tables
        commands = {h.name: h for h in self.command_interfaces}
        states = {h.name: h for h in self.state_interfaces}
        self._commands = {i: [commands[f"{j}/{i}"] for j in self.joints]
                          for i in self.command_names}
        self._states = {i: [states[f"{j}/{i}"] for j in self.joints] for i in self.state_names}
        self._trajectory = None
        self._pending = None
        current = self._read_state()
        self._last_command = current
        self._hold(current.positions)
        self._write(current, np.zeros(len(self.joints)), hold=True)

    def on_deactivate(self) -> None:
        """As ros2_controllers' (jazzy, joint_trajectory_controller.cpp ``on_deactivate``):
        a running goal is aborted with INVALID_GOAL, "Current goal cancelled during
        deactivate transition."; the position commands stay where they are (the last point
        commanded, not the measured position: a joint under load does not sag by one
        compliance error), velocity, acceleration and effort commands go to 0."""
        if self._goal is not None:
            self._end(self._goal, "abort", INVALID_GOAL,
                      "Current goal cancelled during deactivate transition.")
        for interface in (VELOCITY, ACCELERATION, EFFORT):
            for handle in self._commands.get(interface, ()):
                handle.set_value(0.0)
        self._trajectory = None

    # -- what comes in ----------------------------------------------------------------------

    def _arrays(self, msg: Any) -> Pending | str:
        """The message's trajectory checked and in the controller's joint order, with its
        points' times and its start stamp (s), or the line the original logs when it
        refuses it."""
        points = list(msg.points)
        rows = [list(p.positions) for p in points]
        velocities = [list(p.velocities) for p in points]
        accelerations = [list(p.accelerations) for p in points]
        efforts = [list(p.effort) for p in points]
        stamp = int(msg.header.stamp.sec) + int(msg.header.stamp.nanosec) * 1e-9
        error = validate_trajectory(
            list(msg.joint_names), [_seconds(p.time_from_start) for p in points], rows,
            velocities if any(velocities) else None,
            accelerations if any(accelerations) else None, efforts if any(efforts) else None,
            config=ValidationConfig(self.joints, self.allow_partial, self.allow_nonzero_end),
            now=self.node.context.ros_time(), start_time=stamp)
        if error is not None:
            return error
        try:
            arrays = JointArrays(list(msg.joint_names), rows,
                                 velocities if any(velocities) else None,
                                 accelerations if any(accelerations) else None)
            if len(arrays.joint_names) < len(self.joints):
                hold = self._last_command.positions if self.is_active else \
                    np.zeros(len(self.joints))
                arrays = fill_partial_goal(arrays, self.joints, hold)
            arrays = sort_to_local_joint_order(arrays, self.joints)
        except TrajectoryError as exc:
            return str(exc)
        return arrays, np.array([_seconds(p.time_from_start) for p in points]), stamp

    def _on_trajectory_message(self, msg: Any) -> None:
        if not self.is_active:
            return
        checked = self._arrays(msg)
        if isinstance(checked, str):
            self.node.get_logger().error(checked)
            return
        self._pending = checked
        self._holding = False

    def _on_goal(self, goal: Any) -> GoalResponse:
        log = self.node.get_logger()
        log.info("Received new action goal")
        if not self.is_active:
            log.error("Can't accept new action goals. Controller is not running.")
            return GoalResponse.REJECT
        checked = self._arrays(goal.trajectory)
        if isinstance(checked, str):
            log.error(checked)
            return GoalResponse.REJECT
        log.info("Accepted new action goal")
        return GoalResponse.ACCEPT

    def _on_accepted(self, handle: ServerGoalHandle) -> None:
        if self._goal is not None:
            self._end(self._goal, "abort", INVALID_GOAL,
                      "Current goal preempted by new incoming action.")
        goal = handle.request
        checked = self._arrays(goal.trajectory)
        if isinstance(checked, str):  # the joints' hold changed since: refuse it now
            future = Future(executor=self.node.context.executor)
            handle.execute(lambda _h: future)
            self._end(_Goal(handle, future), "abort", INVALID_GOAL, checked)
            return
        self._pending = checked
        self._holding = False
        tolerances = segment_tolerances_from_goal(
            self.tolerances, self.joints,
            [JointTolerance(t.name, t.position, t.velocity, t.acceleration)
             for t in goal.path_tolerance],
            [JointTolerance(t.name, t.position, t.velocity, t.acceleration)
             for t in goal.goal_tolerance], _seconds(goal.goal_time_tolerance))
        if tolerances.error:
            self.node.get_logger().error(tolerances.error)
        self._active_tolerances = tolerances.tolerances
        future = Future(executor=self.node.context.executor)
        self._goal = _Goal(handle, future)
        handle.execute(lambda _h: future)

    def _execute(self, handle: ServerGoalHandle) -> Any:  # replaced per goal in _on_accepted
        return None

    def _on_cancel(self, handle: ServerGoalHandle) -> CancelResponse:
        self.node.get_logger().info("Got request to cancel goal")
        return CancelResponse.ACCEPT

    def _end(self, goal: _Goal, how: str, code: int, text: str) -> None:
        handle = goal.handle
        end_goal(handle, how)
        goal.future.set_result(self.node.message(f"{ACTION}_Result", error_code=code,
                                                 error_string=text))
        if self._goal is goal:
            self._goal = None
            self._active_tolerances = self.tolerances

    # -- the update -------------------------------------------------------------------------

    def _read_state(self) -> PointState:
        def values(interface: str) -> np.ndarray | None:
            handles = self._states.get(interface)
            return None if handles is None else np.array([h.get_value() for h in handles])

        position = values(POSITION)
        assert position is not None
        return PointState(position, values(VELOCITY), values(ACCELERATION))

    def _hold(self, positions: np.ndarray) -> None:
        """A trajectory of one point at the present position, now: hold there."""
        self._pending = (JointArrays(self.joints, [positions], [np.zeros(len(self.joints))]),
                         np.zeros(1), 0.0)
        self._holding = True

    def update(self, time: float, period: float) -> bool:
        """One step, on the trajectories' time line: ROS time, as their header stamps
        (``reading`` keeps the clock's, which the node stamps messages from)."""
        reading, time = time, self.node.context.ros_time(time)
        goal = self._goal
        if goal is not None and goal.handle.is_cancel_requested:
            self.node.get_logger().info("Canceling active action goal because cancel "
                                        "callback received.")
            self._end(goal, "canceled", SUCCESSFUL, "")
            self._hold(self._read_state().positions)
            goal = None
        current = self._read_state()
        first = False
        if self._pending is not None:
            arrays, times, stamp = self._pending
            self._pending = None
            self._trajectory = Trajectory(times, arrays.positions, arrays.velocities,
                                          arrays.accelerations, start_time=stamp)
        trajectory = self._trajectory
        if trajectory is None:
            self._publish(reading, None, current)
            return True
        if not trajectory.is_sampled_already:
            first = True
            before = self._last_command if self.open_loop else current
            trajectory.set_point_before_trajectory(time, before)
            self._traj_time = time
        else:
            self._traj_time += period
        desired = trajectory.sample(self._traj_time, self.interpolation)
        ahead = trajectory.sample(self._traj_time + 1.0 / self.update_rate, self.interpolation,
                                  search_monotonically_increasing=False)
        if desired.state is None or ahead.state is None or desired.end_index is None \
                or desired.start_index is None:
            self._publish(reading, None, current)
            return True
        wanted, next_command = desired.state, ahead.state
        count = len(trajectory.points)
        before_last = desired.end_index < count
        segment_start = trajectory.start_time + trajectory.time_of_point(
            min(desired.start_index, count - 1))
        since_segment = self._traj_time - segment_start
        tolerances = self._active_tolerances
        error_p = wanted.positions - current.positions
        error_v = (wanted.velocities - current.velocities
                   if current.velocities is not None and wanted.velocities is not None
                   else None)
        violated_moving = outside_goal = False
        within_goal_time = True
        for index in range(len(self.joints)):
            if (before_last or first) and not self._holding and not \
                    check_state_tolerance_per_joint(error_p, index,
                                                    tolerances.state_tolerance[index], error_v):
                violated_moving = True
            if not before_last and not self._holding and not check_state_tolerance_per_joint(
                    error_p, index, tolerances.goal_state_tolerance[index], error_v):
                outside_goal = True
                if tolerances.goal_time_tolerance != 0.0 and \
                        since_segment > tolerances.goal_time_tolerance:
                    within_goal_time = False
        if not violated_moving and within_goal_time:
            self._write(next_command, error_p, period=period)
            self._last_command = next_command
        log = self.node.get_logger()
        if goal is not None:
            self._feedback(goal, reading, current, wanted, error_p, error_v)
            if violated_moving:
                self._end(goal, "abort", PATH_TOLERANCE_VIOLATED,
                          "Aborted due to path tolerance violation")
                log.warning("Aborted due to state tolerance violation")
                self._hold(current.positions)
            elif not before_last:
                if not outside_goal:
                    self._end(goal, "succeed", SUCCESSFUL, "Goal successfully reached!")
                    log.info("Goal reached, success!")
                    self._hold(trajectory.points[-1].positions)
                elif not within_goal_time:
                    text = (f"Aborted due to goal_time_tolerance exceeding by "
                            f"{since_segment:f} seconds")
                    self._end(goal, "abort", GOAL_TOLERANCE_VIOLATED, text)
                    log.warning(text)
                    self._hold(current.positions)
        elif violated_moving:
            log.error("Holding position due to state tolerance violation")
            self._hold(current.positions)
        elif not before_last and not within_goal_time:
            log.error("Exceeded goal_time_tolerance: holding position...")
            self._hold(current.positions)
        self._publish(reading, wanted, current, error_p, error_v)
        return True

    def _write(self, point: PointState, error: np.ndarray, *, hold: bool = False,
               period: float = 0.0) -> None:
        commands = self._commands
        if POSITION in commands:
            for handle, value in zip(commands[POSITION], point.positions, strict=True):
                handle.set_value(float(value))
        if VELOCITY in commands:
            velocities = point.velocities if point.velocities is not None else \
                np.zeros(len(self.joints))
            if POSITION not in commands and not hold:  # the PID adapter
                velocities = self._pid(velocities, error, period)
            for handle, value in zip(commands[VELOCITY], velocities, strict=True):
                handle.set_value(0.0 if hold else float(value))
        if ACCELERATION in commands:
            accelerations = point.accelerations if point.accelerations is not None else \
                np.zeros(len(self.joints))
            for handle, value in zip(commands[ACCELERATION], accelerations, strict=True):
                handle.set_value(0.0 if hold else float(value))
        if EFFORT in commands:
            efforts = self._pid(np.zeros(len(self.joints)), error, period)
            for handle, value in zip(commands[EFFORT], efforts, strict=True):
                handle.set_value(0.0 if hold else float(value))

    def _pid(self, feedforward: np.ndarray, error: np.ndarray, period: float) -> np.ndarray:
        """ff_velocity_scale x desired velocity + P x error + I x its integral (clamped)."""
        out = np.empty(len(self.joints))
        for k, joint in enumerate(self.joints):
            gains = self.gains[joint]
            if period > 0:
                self._integral[k] += gains["i"] * error[k] * period
                if gains["i_clamp"] > 0:
                    self._integral[k] = min(max(self._integral[k], -gains["i_clamp"]),
                                            gains["i_clamp"])
            out[k] = (gains["ff_velocity_scale"] * feedforward[k] + gains["p"] * error[k]
                      + self._integral[k])
        return out

    def _point(self, state: PointState | None, error: bool = False) -> Any:
        message = self.node.message
        if state is None:
            return message("trajectory_msgs/msg/JointTrajectoryPoint")
        return message("trajectory_msgs/msg/JointTrajectoryPoint",
                       positions=[float(v) for v in state.positions],
                       velocities=[] if state.velocities is None else
                       [float(v) for v in state.velocities],
                       accelerations=[] if state.accelerations is None else
                       [float(v) for v in state.accelerations])

    def _feedback(self, goal: _Goal, time: float, current: PointState, desired: PointState,
                  error_p: np.ndarray, error_v: np.ndarray | None) -> None:
        if time - self._last_feedback < 1.0 / self.action_monitor_rate:
            return
        self._last_feedback = time
        node = self.node
        goal.handle.publish_feedback(node.message(
            f"{ACTION}_Feedback", header={"stamp": node.stamp(time)},
            joint_names=list(self.joints), desired=self._point(desired),
            actual=self._point(current),
            error=self._point(PointState(error_p, error_v))))

    def _publish(self, time: float, desired: PointState | None, current: PointState,
                 error_p: np.ndarray | None = None, error_v: np.ndarray | None = None) -> None:
        node = self.node
        output = PointState(np.array([h.get_value() for h in self._commands[POSITION]])) \
            if POSITION in self._commands else None
        self.state_publisher.publish(node.message(
            "control_msgs/msg/JointTrajectoryControllerState",
            header={"stamp": node.stamp(time)}, joint_names=list(self.joints),
            reference=self._point(desired), feedback=self._point(current),
            error=self._point(None if error_p is None else PointState(error_p, error_v)),
            output=self._point(output)))
