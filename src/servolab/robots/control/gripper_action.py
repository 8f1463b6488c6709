"""The gripper action controllers of ros2_controllers (Jazzy), as they behave:

- ``position_controllers/GripperActionController`` and
  ``effort_controllers/GripperActionController`` (``gripper_controllers``:
  ``include/gripper_controllers/gripper_action_controller_impl.hpp``,
  ``hardware_interface_adapter.hpp``; parameters ``src/gripper_action_controller_parameters
  .yaml``), serving ``control_msgs/action/GripperCommand`` on ``~/gripper_cmd`` for one
  ``joint``. Jazzy marks both deprecated in favour of the parallel one (its ``on_init`` warns).
- ``parallel_gripper_action_controller/GripperActionController`` (``parallel_gripper_controller``:
  ``include/parallel_gripper_controller/parallel_gripper_action_controller_impl.hpp``; parameters
  ``src/gripper_action_controller_parameters.yaml``), serving
  ``control_msgs/action/ParallelGripperCommand`` (a ``sensor_msgs/JointState`` command of one
  position, optional velocity and effort limits) on ``~/gripper_cmd``.

What they do, alike:

- A goal is accepted and preempts the goal running (which ends canceled, with an empty
  result); its position is the position command from the next update on.
- Each update, before the command is written, the goal is checked: within ``goal_tolerance``
  of the command it succeeds (``reached_goal``); otherwise, the joint's velocity state at or
  below ``stall_velocity_threshold`` for more than ``stall_timeout`` s since it last moved is
  a stall (``stalled``): aborted, or succeeded with ``allow_stalling``. The result carries the
  joint's position then and an effort. A stall is told by the velocity only: neither
  controller reads an effort state to decide it.
- The end is delivered by a timer at ``action_monitor_rate`` Hz (realtime_tools'
  ``RealtimeServerGoalHandle``), not in the update itself.
- A cancel of the running goal holds the joint where it is (the position command becomes the
  position state, the effort the parameter's ``max_effort``) and ends the goal canceled.
- No feedback is published (neither sets one on its goal handle).

The effort in a result: ``GripperActionController`` gives its last computed command (the
position variant: the goal's ``max_effort``, which it passes through; the effort variant: the
PID's clamped output). The parallel controller reports a ``computed_command_`` it never sets
(undefined in the original); here it is the ``effort`` state when ``state_interfaces`` claims
one (what the joint exerts: an XM430's present current times its torque constant), else the
effort limit in force.

Where servolab differs, because the original leaves a goal with no end: the action server is
made when the controller is configured and refuses goals while the controller is not active
(the original makes it on activation and accepts goals that no update will ever end), and
deactivating the controller ends its goal canceled and holds the joint where it is (the
original writes nothing and leaves the goal running). A goal whose end was decided but not
yet delivered when a new one comes is delivered then (the original drops the timer that
would have delivered it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

from ...middleware.node import Node
from ...middleware.parameters import STRING_ARRAY
from ...rclpy.action import ActionServer, CancelResponse, GoalResponse, ServerGoalHandle
from ...rclpy.task import Future
from .controller import INDIVIDUAL, ControllerError, ControllerInterface, InterfaceConfiguration
from .goals import end_goal
from .hardware import EFFORT, POSITION, VELOCITY
from .resources import Handle

GRIPPER_COMMAND = "control_msgs/action/GripperCommand"
PARALLEL_GRIPPER_COMMAND = "control_msgs/action/ParallelGripperCommand"


class _Goal:
    """An accepted goal as realtime_tools' ``RealtimeServerGoalHandle`` keeps it: the update
    asks for its end (:meth:`request`), the goal's timer delivers it (:meth:`run`)."""

    def __init__(self, handle: ServerGoalHandle, future: Future) -> None:
        self.handle = handle
        self.future = future
        self.requested: tuple[str, Any] | None = None
        self.delivered = False

    def request(self, how: str, result: Any) -> None:
        self.requested = (how, result)

    def run(self) -> None:
        if self.requested is None or self.delivered:
            return
        how, result = self.requested
        handle = self.handle
        end_goal(handle, how)
        self.delivered = True
        self.future.set_result(result)


def _at_least(controller: ControllerInterface, name: str, value: float,
              limit: float) -> float:
    """generate_parameter_library's ``gt_eq`` validation: refused at load."""
    if not value >= limit:
        raise ControllerError(f"{controller.name}: parameter '{name}' is {value!r}; it must "
                              f"be greater than or equal to {limit!r}")
    return value


class _GripperAction(ControllerInterface):
    """What both kinds share: the goal's life, its check each update, the result."""

    ACTION: ClassVar[str] = GRIPPER_COMMAND
    #: the max_effort parameter's default (gripper_controllers 0.0, parallel 10.0)
    MAX_EFFORT: ClassVar[float] = 0.0

    def on_init(self) -> None:
        self.action_monitor_rate = _at_least(self, "action_monitor_rate", float(
            self.parameter("action_monitor_rate", 20.0)), 0.1)
        self.joint = str(self.parameter("joint", ""))
        self.goal_tolerance = _at_least(self, "goal_tolerance", float(
            self.parameter("goal_tolerance", 0.01)), 0.0)
        self.max_effort = _at_least(self, "max_effort", float(
            self.parameter("max_effort", self.MAX_EFFORT)), 0.0)
        self.allow_stalling = bool(self.parameter("allow_stalling", False))
        self.stall_velocity_threshold = float(self.parameter("stall_velocity_threshold",
                                                             0.001))
        self.stall_timeout = float(self.parameter("stall_timeout", 1.0))

    def on_configure(self) -> None:
        log = self.node.get_logger()
        log.info(f"Action status changes will be monitored at "
                 f"{self.action_monitor_rate:f} Hz.")
        if not self.joint:
            log.error("Joint name cannot be empty")
            raise ControllerError(f"{self.name}: Joint name cannot be empty (parameter "
                                  "'joint')")
        self._goal: _Goal | None = None
        self._timer: Any = None
        self._last_movement = 0.0
        self.action_server = ActionServer(
            self.node, self.ACTION, "~/gripper_cmd", self._execute,
            goal_callback=self._on_goal, handle_accepted_callback=self._on_accepted,
            cancel_callback=self._on_cancel)

    def on_cleanup(self) -> None:
        context, namespace = self.node.context, self.node.get_namespace()
        self.node.destroy()
        self.node = Node(context, self.name, namespace)

    # -- interfaces ---------------------------------------------------------------------

    def _find(self, handles: list[Handle], interface: str, what: str, kind: str) -> Handle:
        """The loaned ``interface`` of the joint, or the original's refusal."""
        found = next((h for h in handles if h.get_interface_name() == interface), None)
        if found is None:
            raise ControllerError(f"{self.name}: Expected 1 {interface} {kind} interface")
        if found.get_prefix_name() != self.joint:
            raise ControllerError(f"{self.name}: {what} is different than joint name "
                                  f"`{found.get_prefix_name()}` != `{self.joint}`")
        return found

    def _state_handles(self) -> None:
        self._position = self._find(self.state_interfaces, POSITION,
                                    "Position state interface", "state")
        # (the original's words: it calls the velocity state interface a command one)
        self._velocity = self._find(self.state_interfaces, VELOCITY,
                                    "Velocity command interface", "state")

    # -- goals ----------------------------------------------------------------------------

    def _on_goal(self, goal: Any) -> GoalResponse:
        log = self.node.get_logger()
        if not self.is_active:
            log.error("Can't accept new action goals. Controller is not running.")
            return GoalResponse.REJECT
        refusal = self._refuse(goal)
        if refusal:
            log.error(refusal)
            return GoalResponse.REJECT
        log.info("Received & accepted new action goal")
        return GoalResponse.ACCEPT

    def _refuse(self, goal: Any) -> str | None:
        """Why the goal is rejected, if it is."""
        return None

    def _on_accepted(self, handle: ServerGoalHandle) -> None:
        self._preempt()
        if self._timer is not None:
            self._end_timer()  # the last goal's end, if still undelivered, goes now
        self._take(handle.request)
        future = Future(executor=self.node.context.executor)
        goal = _Goal(handle, future)
        self._last_movement = self.node.now()
        handle.execute(lambda _h: future)
        self._goal = goal
        self._timer = (goal, self.node.create_timer(1.0 / self.action_monitor_rate, goal.run))

    def _execute(self, handle: ServerGoalHandle) -> Any:  # replaced per goal in _on_accepted
        return None

    def _end_timer(self) -> None:
        goal, timer = self._timer
        goal.run()
        timer.cancel()
        self.node.destroy_entity(timer)
        self._timer = None

    def _preempt(self) -> None:
        """The running goal ends canceled, with an empty result."""
        goal = self._goal
        if goal is not None:
            goal.request("canceled", self.node.message(f"{self.ACTION}_Result"))
            self._goal = None
            self._end_timer()

    def _on_cancel(self, handle: ServerGoalHandle) -> CancelResponse:
        log = self.node.get_logger()
        log.info("Got request to cancel goal")
        goal = self._goal
        if goal is not None and goal.handle is handle:
            self._hold()
            log.info("Canceling active action goal because cancel callback received.")
            goal.request("canceled", self.node.message(f"{self.ACTION}_Result"))
            self._goal = None
        return CancelResponse.ACCEPT

    def _check_for_success(self, time: float, error_position: float, position: float,
                           velocity: float) -> None:
        goal = self._goal
        if goal is None:
            return
        if abs(error_position) < self.goal_tolerance:
            goal.request("succeed", self._result(position, reached=True, stalled=False))
            self._goal = None
        elif abs(velocity) > self.stall_velocity_threshold:
            self._last_movement = time
        elif time - self._last_movement > self.stall_timeout:
            goal.request("succeed" if self.allow_stalling else "abort",
                         self._result(position, reached=False, stalled=True))
            self._goal = None

    def on_deactivate(self) -> None:
        goal = self._goal
        if goal is not None:
            goal.request("canceled", self.node.message(f"{self.ACTION}_Result"))
            self._goal = None
        if self._timer is not None:
            self._end_timer()
        self._hold()
        self._write_hold()

    # -- what each kind gives ---------------------------------------------------------------

    def _take(self, goal: Any) -> None:
        """The accepted goal's command becomes the command."""
        raise NotImplementedError

    def _hold(self) -> None:
        """The command becomes the present position (at the default effort limit)."""
        raise NotImplementedError

    def _write_hold(self) -> None:
        """Write the hold command once (at deactivation)."""
        raise NotImplementedError

    def _result(self, position: float, *, reached: bool, stalled: bool) -> Any:
        raise NotImplementedError


@dataclass
class _Command:
    position: float
    max_effort: float


class GripperActionController(_GripperAction):
    """``position_controllers/GripperActionController``: the position command is the goal's
    position; the result's effort is the goal's ``max_effort`` (passed through)."""

    TYPE = "position_controllers/GripperActionController"
    INTERFACE: ClassVar[str] = POSITION

    def on_init(self) -> None:
        self.node.get_logger().warning(
            "[Deprecated]: the `position_controllers/GripperActionController` and "
            "`effort_controllers::GripperActionController` controllers are replaced by "
            "'parallel_gripper_controllers/GripperActionController' controller")
        super().on_init()

    def command_interface_configuration(self) -> InterfaceConfiguration:
        return InterfaceConfiguration(INDIVIDUAL, (f"{self.joint}/{self.INTERFACE}",))

    def state_interface_configuration(self) -> InterfaceConfiguration:
        return InterfaceConfiguration(INDIVIDUAL, (f"{self.joint}/{POSITION}",
                                                   f"{self.joint}/{VELOCITY}"))

    def on_activate(self) -> None:
        self._command_handle = self._find(self.command_interfaces, self.INTERFACE,
                                          "Command interface", "command")
        self._state_handles()
        self._init_adapter()
        self._command = _Command(self._position.get_value(), self.max_effort)
        self._computed = 0.0

    def _init_adapter(self) -> None:
        """The position adapter needs nothing."""

    def _adapt(self, command: _Command, error_position: float, error_velocity: float,
               period: float) -> float:
        """Send the command; what it returns is the result's effort."""
        self._command_handle.set_value(command.position)
        return command.max_effort

    def update(self, time: float, period: float) -> bool:
        command = self._command
        position = self._position.get_value()
        velocity = self._velocity.get_value()
        error_position = command.position - position
        self._check_for_success(time, error_position, position, velocity)
        self._computed = self._adapt(command, error_position, -velocity, period)
        return True

    def _take(self, goal: Any) -> None:
        self._command = _Command(float(goal.command.position), float(goal.command.max_effort))

    def _hold(self) -> None:
        self._command = _Command(self._position.get_value(), self.max_effort)

    def _write_hold(self) -> None:
        self._command_handle.set_value(self._command.position)

    def _result(self, position: float, *, reached: bool, stalled: bool) -> Any:
        return self.node.message(f"{self.ACTION}_Result", position=float(position),
                                 effort=float(self._computed), stalled=stalled,
                                 reached_goal=reached)


class EffortGripperActionController(GripperActionController):
    """``effort_controllers/GripperActionController``: a PID on the position error (with
    the velocity state's negative as its derivative), ``gains.<joint>.p/i/d/i_clamp``,
    clamped to the goal's ``max_effort``, is the effort command and the result's effort."""

    TYPE = "effort_controllers/GripperActionController"
    INTERFACE = EFFORT

    def _init_adapter(self) -> None:
        prefix = f"gains.{self.joint}"
        self._gains = {k: float(self.parameter(f"{prefix}.{k}", 0.0))
                       for k in ("p", "i", "d", "i_clamp")}
        self._i_term = 0.0

    def _adapt(self, command: _Command, error_position: float, error_velocity: float,
               period: float) -> float:
        gains = self._gains
        if period <= 0:
            return self._computed
        if not (math.isfinite(error_position) and math.isfinite(error_velocity)):
            value = math.nan
        else:
            # control_toolbox's Pid (legacy anti-windup off): the integral accumulates
            # freely and counts clamped to +-i_clamp
            self._i_term += gains["i"] * period * error_position
            clamp = abs(gains["i_clamp"])
            value = (gains["p"] * error_position + min(max(self._i_term, -clamp), clamp)
                     + gains["d"] * error_velocity)
            limit = abs(command.max_effort)
            value = min(max(value, -limit), limit)
        self._command_handle.set_value(value)
        return value

    def _write_hold(self) -> None:
        self._command_handle.set_value(0.0)


@dataclass
class _ParallelCommand:
    position: float
    velocity: float
    effort: float


class ParallelGripperActionController(_GripperAction):
    """``parallel_gripper_action_controller/GripperActionController``: see the module
    docstring."""

    TYPE = "parallel_gripper_action_controller/GripperActionController"
    ACTION = PARALLEL_GRIPPER_COMMAND
    MAX_EFFORT = 10.0

    def on_init(self) -> None:
        super().on_init()
        if not self.joint:  # no default and not_empty<> in its parameters file
            raise ControllerError(f"{self.name}: parameter 'joint' cannot be empty")
        names = self.parameter("state_interfaces", [POSITION, VELOCITY], STRING_ARRAY)
        if not isinstance(names, (list, tuple)) or not all(isinstance(n, str) for n in names):
            raise ControllerError(f"{self.name}: parameter 'state_interfaces' is a list of "
                                  f"interface names, not {names!r}")
        self.state_names = tuple(names)
        self.stall_timeout = _at_least(self, "stall_timeout", self.stall_timeout, 0.0)
        self.max_effort_interface = str(self.parameter("max_effort_interface", ""))
        self.max_velocity_interface = str(self.parameter("max_velocity_interface", ""))
        self.max_velocity = _at_least(self, "max_velocity", float(
            self.parameter("max_velocity", 0.1)), 0.0)

    def on_configure(self) -> None:
        super().on_configure()
        self.node.get_logger().info(f"Joint name is : {self.joint}")

    def command_interface_configuration(self) -> InterfaceConfiguration:
        names = [f"{self.joint}/{POSITION}"]
        names += [n for n in (self.max_effort_interface, self.max_velocity_interface) if n]
        return InterfaceConfiguration(INDIVIDUAL, tuple(names))

    def state_interface_configuration(self) -> InterfaceConfiguration:
        return InterfaceConfiguration(INDIVIDUAL, tuple(f"{self.joint}/{i}"
                                                        for i in self.state_names))

    def on_activate(self) -> None:
        self._command_handle = self._find(self.command_interfaces, POSITION,
                                          "Command interface", "command")
        self._state_handles()
        by_name = {h.get_name(): h for h in self.command_interfaces}
        self._effort_handle = by_name.get(self.max_effort_interface) \
            if self.max_effort_interface else None
        self._speed_handle = by_name.get(self.max_velocity_interface) \
            if self.max_velocity_interface else None
        for wanted, found, what in ((self.max_effort_interface, self._effort_handle, "effort"),
                                    (self.max_velocity_interface, self._speed_handle,
                                     "velocity")):
            if wanted and found is None:
                raise ControllerError(f"{self.name}: Expected max {what} command interface "
                                      f"`{wanted}` not found")
        self._effort_state = next((h for h in self.state_interfaces
                                   if h.get_name() == f"{self.joint}/{EFFORT}"), None)
        self._command = _ParallelCommand(self._position.get_value(), self.max_velocity,
                                         self.max_effort)

    def _refuse(self, goal: Any) -> str | None:
        count = len(goal.command.position)
        if count != 1:
            return ("Received action goal with wrong number of position values, expects 1, "
                    f"got {count}")
        return None

    def update(self, time: float, period: float) -> bool:
        command = self._command
        position = self._position.get_value()
        velocity = self._velocity.get_value()
        self._check_for_success(time, command.position - position, position, velocity)
        self._command_handle.set_value(command.position)
        if self._speed_handle is not None:
            self._speed_handle.set_value(command.velocity)
        if self._effort_handle is not None:
            self._effort_handle.set_value(command.effort)
        return True

    def _take(self, goal: Any) -> None:
        command = goal.command
        velocity = float(command.velocity[0]) if self.max_velocity_interface and \
            len(command.velocity) else self.max_velocity
        effort = float(command.effort[0]) if self.max_effort_interface and \
            len(command.effort) else self.max_effort
        self._command = _ParallelCommand(float(command.position[0]), velocity, effort)

    def _hold(self) -> None:
        self._command = _ParallelCommand(self._position.get_value(), self.max_velocity,
                                         self.max_effort)

    def _write_hold(self) -> None:
        self._command_handle.set_value(self._command.position)

    def _result(self, position: float, *, reached: bool, stalled: bool) -> Any:
        effort = self._effort_state.get_value() if self._effort_state is not None else \
            self._command.effort
        return self.node.message(f"{self.ACTION}_Result", state={
            "position": [float(position)], "effort": [float(effort)]},
            stalled=stalled, reached_goal=reached)


#: the controllers of this module, for :func:`.types.standard_types`
CONTROLLERS: tuple[type[ControllerInterface], ...] = (
    GripperActionController, EffortGripperActionController, ParallelGripperActionController)
