"""The gripper action controllers: GripperCommand and ParallelGripperCommand goals end as
ros2_controllers' (Jazzy branch) end them. Each test names the lines of the reference it
checks:

- GAC: gripper_controllers/include/gripper_controllers/gripper_action_controller_impl.hpp
- ADAPTER: gripper_controllers/include/gripper_controllers/hardware_interface_adapter.hpp
- GAC_PARAMS: gripper_controllers/src/gripper_action_controller_parameters.yaml
- PGC: parallel_gripper_controller/include/parallel_gripper_controller/
  parallel_gripper_action_controller_impl.hpp
- PGC_PARAMS: parallel_gripper_controller/src/gripper_action_controller_parameters.yaml

A finger an object blocks is a test hardware component here (:class:`BlockedFinger`, its
position stopping short of the goal), and an XM430 closing on an object on the emulated bus,
where the object is a world that pushes back on the horn once it touches it.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import pytest

from servolab.clock import VirtualClock
from servolab.dynamixel.emulator import VirtualMotor
from servolab.dynamixel.plant import KinematicServo
from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.middleware.parameters import ParameterOverrides
from servolab.rclpy.action import ActionClient
from servolab.rclpy.action.server import STATUS_ABORTED, STATUS_CANCELED, STATUS_SUCCEEDED
from servolab.robots.control.bringup import BringUpOptions, ControlSystem
from servolab.robots.control.hardware import SystemInterface
from servolab.robots.control.manager import STRICT, ControllerManager
from servolab.robots.control.types import standard_types
from servolab.robots.hardware_info import HardwareInfo, parse_control_resources
from servolab.sim.simulation import Simulation
from servolab.sim.world import World

from .conftest import DATA

GRIPPER = "control_msgs/action/GripperCommand"
PARALLEL = "control_msgs/action/ParallelGripperCommand"
#: one XM430 closing a finger, on the emulated bus
GRIPPER_URDF = DATA / "gripper.urdf"

FINGER_URDF = """<robot name="finger"><link name="base"/><link name="tip"/>
  <joint name="finger" type="revolute"><parent link="base"/><child link="tip"/>
    <limit lower="-1" upper="1" effort="5" velocity="2"/></joint>
  <ros2_control name="Finger" type="system">
    <hardware><plugin>test/BlockedFinger</plugin></hardware>
    <joint name="finger">
      <command_interface name="position"/><command_interface name="velocity"/>
      <command_interface name="effort"/>
      <state_interface name="position"><param name="initial_value">0.0</param></state_interface>
      <state_interface name="velocity"><param name="initial_value">0.0</param></state_interface>
      <state_interface name="effort"><param name="initial_value">0.0</param></state_interface>
    </joint>
  </ros2_control></robot>"""


class BlockedFinger(SystemInterface):
    """A finger closing toward negative positions until an object at ``contact`` stops it.

    Commanded in position it moves toward the command at the velocity command (a limit, as a
    gripper's max velocity interface) or ``speed`` rad/s; commanded in effort it moves at
    effort / ``damping``. The object stops it at ``contact`` whatever it is told: its
    position then stays short of the goal and its velocity is 0. The effort state is the
    effort command, or, pushed against the object in position, ``stiffness`` x the position
    it is short by."""

    stiffness = 5.0

    def __init__(self, info: HardwareInfo, contact: float = -math.inf, speed: float = 1.0,
                 damping: float = 2.0) -> None:
        super().__init__(info)
        self.contact, self.speed, self.damping = contact, speed, damping

    def read(self, time: float, period: float) -> bool:
        states, commands = self.states, self.commands
        at = states["finger/position"]
        position = commands.get("finger/position", math.nan)
        speed = commands.get("finger/velocity", math.nan)
        effort = commands.get("finger/effort", math.nan)
        speed = abs(speed) if math.isfinite(speed) else self.speed
        if math.isfinite(position):
            to = at + max(-speed * period, min(speed * period, position - at))
        elif math.isfinite(effort):
            to = at + effort / self.damping * period
        else:
            to = at
        blocked = to < self.contact
        to = max(to, self.contact)
        states["finger/position"] = to
        states["finger/velocity"] = (to - at) / period if period > 0 else 0.0
        if math.isfinite(effort):
            states["finger/effort"] = effort
        elif blocked and math.isfinite(position):
            states["finger/effort"] = self.stiffness * (position - to)
        else:
            states["finger/effort"] = 0.0
        return True

    def write(self, time: float, period: float) -> bool:
        return True


class Rig:
    """A controller manager (100 Hz, virtual time) and a client of ``gripper_controller``."""

    def __init__(self, context: Context, manager: ControllerManager, action: str,
                 close: Any) -> None:
        self.context, self.manager, self.action = context, manager, action
        self.probe = Node(context, "probe")
        self.client = ActionClient(self.probe, action, "/gripper_controller/gripper_cmd")
        self._close = close

    @property
    def controller(self) -> Any:
        return self.manager.controllers["gripper_controller"]

    def goal(self, **command: Any) -> Any:
        return self.probe.message(f"{self.action}_Goal", command=command)

    def send(self, goal: Any) -> tuple[Any, Any]:
        """The goal's handle (once answered) and the future of its result."""
        sent = self.client.send_goal_async(goal)
        self.context.spin_for(0.005)
        handle = sent.result()
        return handle, handle.get_result_async() if handle.accepted else None

    def until(self, ended: Any, limit: float) -> float:
        """Spin in 10 ms steps until ``ended`` is done (at most ``limit`` s): the time then."""
        deadline = self.context.clock.now() + limit
        while not ended.done() and self.context.clock.now() < deadline:
            self.context.spin_for(0.01)
        assert ended.done(), f"no result within {limit} s"
        return self.context.clock.now()

    def value(self, name: str, kind: str = "states") -> float:
        return float(getattr(self.manager.interfaces, kind)[name])

    def close(self) -> None:
        self._close()


def controllers_file(kind: str, parameters: str) -> ParameterOverrides:
    body = "".join(f"    {line}\n" for line in parameters.strip().splitlines())
    return ParameterOverrides.from_text(
        "controller_manager:\n  ros__parameters:\n    update_rate: 100\n"
        f"    gripper_controller:\n      type: {kind}\n"
        f"gripper_controller:\n  ros__parameters:\n{body}")


def finger_rig(kind: str, parameters: str, *, contact: float = -math.inf,
               speed: float = 1.0, activate: bool = True) -> Rig:
    """``kind`` on a :class:`BlockedFinger`, loaded, configured and (``activate``) active."""
    context = Context.open(clock=VirtualClock(), parameter_overrides=controllers_file(
        kind, parameters))
    (info,) = parse_control_resources(FINGER_URDF, "finger.urdf")
    manager = ControllerManager(context, [BlockedFinger(info, contact, speed)])

    def close() -> None:
        manager.close()
        context.close()

    try:
        assert manager.load_controller("gripper_controller")[0]
        assert manager.configure_controller("gripper_controller")[0]
        if activate:
            ok, message = manager.switch_controller(["gripper_controller"], [], STRICT)
            assert ok, message
    except BaseException:
        close()
        raise
    action = PARALLEL if kind.startswith("parallel") else GRIPPER
    return Rig(context, manager, action, close)


@pytest.fixture
def position_gripper() -> Iterator[Rig]:
    """position_controllers/GripperActionController; an object at -0.3 rad."""
    rig = finger_rig("position_controllers/GripperActionController",
                     "joint: finger\nstall_timeout: 0.2", contact=-0.3)
    try:
        yield rig
    finally:
        rig.close()


# -- types and parameters -----------------------------------------------------------------


def test_the_types_and_their_parameters_defaults() -> None:
    # gripper_controllers/ros_control_plugins.xml 3-15, parallel_gripper_controller/
    # ros_control_plugins.xml 3-8: the three plugin names
    types = standard_types()
    assert {"position_controllers/GripperActionController",
            "effort_controllers/GripperActionController",
            "parallel_gripper_action_controller/GripperActionController"} <= set(types)
    rig = finger_rig("position_controllers/GripperActionController", "joint: finger",
                     activate=False)
    try:
        params = rig.controller.node.parameters()
        # GAC_PARAMS 1-43: the defaults
        assert {k: params[k] for k in ("action_monitor_rate", "goal_tolerance", "max_effort",
                                       "allow_stalling", "stall_velocity_threshold",
                                       "stall_timeout")} == {
            "action_monitor_rate": 20.0, "goal_tolerance": 0.01, "max_effort": 0.0,
            "allow_stalling": False, "stall_velocity_threshold": 0.001, "stall_timeout": 1.0}
        # GAC 322-337: joint/<HardwareInterface> commanded, position and velocity read
        assert rig.controller.command_interface_configuration().names == ("finger/position",)
        assert rig.controller.state_interface_configuration().names == (
            "finger/position", "finger/velocity")
    finally:
        rig.close()
    rig = finger_rig("parallel_gripper_action_controller/GripperActionController",
                     "joint: finger\nmax_effort_interface: finger/effort", activate=False)
    try:
        params = rig.controller.node.parameters()
        # PGC_PARAMS 1-72: the defaults (max_effort 10, max_velocity 0.1)
        assert {k: params[k] for k in ("action_monitor_rate", "state_interfaces",
                                       "goal_tolerance", "allow_stalling",
                                       "stall_velocity_threshold", "stall_timeout",
                                       "max_velocity_interface", "max_effort",
                                       "max_velocity")} == {
            "action_monitor_rate": 20.0, "state_interfaces": ["position", "velocity"],
            "goal_tolerance": 0.01, "allow_stalling": False,
            "stall_velocity_threshold": 0.001, "stall_timeout": 1.0,
            "max_velocity_interface": "", "max_effort": 10.0, "max_velocity": 0.1}
        # PGC 421-446: position plus the max interfaces named; the state_interfaces
        assert rig.controller.command_interface_configuration().names == (
            "finger/position", "finger/effort")
        assert rig.controller.state_interface_configuration().names == (
            "finger/position", "finger/velocity")
    finally:
        rig.close()


def test_what_is_refused_at_load_configure_and_activate() -> None:
    # GAC 217-221: "Joint name cannot be empty" at configure
    context = Context.open(clock=VirtualClock(), parameter_overrides=controllers_file(
        "position_controllers/GripperActionController", "goal_tolerance: 0.02"))
    (info,) = parse_control_resources(FINGER_URDF, "finger.urdf")
    manager = ControllerManager(context, [BlockedFinger(info)])
    try:
        assert manager.load_controller("gripper_controller")[0]
        ok, message = manager.configure_controller("gripper_controller")
        assert not ok and "Joint name cannot be empty" in message
    finally:
        manager.close()
        context.close()
    # GAC_PARAMS 5-8 (action_monitor_rate gt_eq 0.1); PGC_PARAMS 11-17 (joint not_empty):
    # the parameter library refuses them when the controller is initialized (GAC 48-57)
    for kind, parameters in (
            ("position_controllers/GripperActionController",
             "joint: finger\naction_monitor_rate: 0.05"),
            ("parallel_gripper_action_controller/GripperActionController", "goal_tolerance: 0.1")):
        context = Context.open(clock=VirtualClock(),
                               parameter_overrides=controllers_file(kind, parameters))
        manager = ControllerManager(context, [BlockedFinger(info)])
        try:
            ok, message = manager.load_controller("gripper_controller")
            assert not ok and "Could not initialize the controller" in message
        finally:
            manager.close()
            context.close()
    # PGC 362-368 (and the parallel test's 242-247): a max effort interface the hardware
    # does not have is not activated; here the controller manager refuses the claim
    # ("... is not available") before the controller's own check is reached
    rig = finger_rig("parallel_gripper_action_controller/GripperActionController",
                     "joint: finger\nmax_effort_interface: finger/grip_force", activate=False)
    try:
        ok, message = rig.manager.switch_controller(["gripper_controller"], [], STRICT)
        assert not ok and "finger/grip_force" in message
        assert not rig.controller.is_active
    finally:
        rig.close()


# -- GripperCommand on a blocked finger ---------------------------------------------------------


def test_a_finger_closing_on_an_object_stalls_and_aborts(position_gripper: Rig) -> None:
    rig = position_gripper
    handle, ended = rig.send(rig.goal(position=-0.5, max_effort=3.0))
    assert handle.accepted  # GAC 84-89: every goal is accepted
    start = rig.context.clock.now()
    rig.context.spin_for(0.4)  # at 1 rad/s it touches the object at -0.3 after 0.3 s
    assert rig.value("finger/position") == pytest.approx(-0.3)
    assert not ended.done()  # not stalled yet: stall_timeout 0.2 s from its last movement
    end = rig.until(ended, 1.0)
    # GAC 178-200: no movement above stall_velocity_threshold for stall_timeout -> stalled;
    # aborted as allow_stalling is false; the end comes with the next action_monitor_rate
    # (20 Hz) tick of realtime_tools' goal handle (GAC 116-119)
    assert 0.3 + 0.2 < end - start <= 0.3 + 0.2 + 0.05 + 0.03
    result = ended.result()
    assert result.status == STATUS_ABORTED
    assert (result.result.stalled, result.result.reached_goal) == (True, False)
    assert result.result.position == pytest.approx(-0.3)
    # GAC 184 and ADAPTER 81-88: the effort reported is the computed command, which the
    # position adapter returns as the goal's max_effort
    assert result.result.effort == 3.0
    # still commanded to the goal: the finger keeps pushing on the object
    assert rig.value("finger/position", "commands") == -0.5


def test_a_stall_succeeds_when_stalling_is_allowed() -> None:
    rig = finger_rig("position_controllers/GripperActionController",
                     "joint: finger\nstall_timeout: 0.2\nallow_stalling: true", contact=-0.3)
    try:
        _handle, ended = rig.send(rig.goal(position=-0.5, max_effort=1.0))
        rig.until(ended, 1.5)
        # GAC 189-193: allow_stalling -> setSucceeded with stalled
        result = ended.result()
        assert result.status == STATUS_SUCCEEDED
        assert (result.result.stalled, result.result.reached_goal) == (True, False)
    finally:
        rig.close()


def test_a_goal_in_reach_succeeds(position_gripper: Rig) -> None:
    rig = position_gripper
    _handle, ended = rig.send(rig.goal(position=-0.2, max_effort=0.5))
    rig.until(ended, 1.0)
    result = ended.result()
    # GAC 166-174: |goal - position| < goal_tolerance -> reached_goal, succeeded
    assert result.status == STATUS_SUCCEEDED
    assert (result.result.reached_goal, result.result.stalled) == (True, False)
    assert abs(result.result.position + 0.2) < 0.01
    assert result.result.effort == 0.5


def test_a_new_goal_preempts_and_a_cancel_holds(position_gripper: Rig) -> None:
    rig = position_gripper
    _first, first_end = rig.send(rig.goal(position=0.8, max_effort=1.0))
    rig.context.spin_for(0.2)
    second, second_end = rig.send(rig.goal(position=-0.25, max_effort=1.0))
    rig.context.spin_for(0.01)
    # GAC 92-98 and 28-38: the goal running is canceled, with an empty result
    result = first_end.result()
    assert result.status == STATUS_CANCELED
    assert (result.result.reached_goal, result.result.position) == (False, 0.0)
    rig.context.spin_for(0.2)
    at = rig.value("finger/position")
    assert 0.0 < at < 0.2  # on its way back from ~0.2 toward -0.25
    second.cancel_goal_async()
    rig.context.spin_for(0.1)
    # GAC 123-145 and 148-153: the command becomes the present position, the goal canceled
    assert second_end.result().status == STATUS_CANCELED
    held = rig.value("finger/position")
    assert held == pytest.approx(at, abs=0.015)
    assert rig.value("finger/position", "commands") == pytest.approx(held, abs=0.015)
    rig.context.spin_for(0.5)
    assert rig.value("finger/position") == pytest.approx(held, abs=1e-9)


def test_deactivating_ends_the_goal_and_holds(position_gripper: Rig) -> None:
    rig = position_gripper
    _handle, ended = rig.send(rig.goal(position=0.8, max_effort=1.0))
    rig.context.spin_for(0.2)
    ok, message = rig.manager.switch_controller([], ["gripper_controller"], STRICT)
    assert ok, message
    rig.context.spin_for(0.01)  # the result's way back to the client
    # servolab's choice where GAC 310-318 leaves the goal running with no update to end it:
    # canceled, and the position command is where the finger is (it holds)
    assert ended.result().status == STATUS_CANCELED
    held = rig.value("finger/position")
    assert rig.value("finger/position", "commands") == held
    rig.context.spin_for(0.3)
    assert rig.value("finger/position") == held
    handle, _ = rig.send(rig.goal(position=0.5, max_effort=1.0))
    assert not handle.accepted  # refused while inactive (no update would ever end it)


def test_the_effort_variant_closes_by_a_clamped_pid_and_stalls_at_max_effort() -> None:
    rig = finger_rig("effort_controllers/GripperActionController",
                     "joint: finger\nstall_timeout: 0.2\ngains:\n  finger: {p: 20.0, d: 0.5}",
                     contact=-0.3)
    try:
        assert rig.controller.command_interface_configuration().names == ("finger/effort",)
        _handle, ended = rig.send(rig.goal(position=-0.2, max_effort=1.5))
        rig.context.spin_for(0.02)
        # ADAPTER 156-173: p x error + d x (-velocity), clamped to +-max_effort:
        # 20 x -0.2 = -4 N.m asked, -1.5 given
        assert rig.value("finger/effort", "commands") == -1.5
        rig.until(ended, 3.0)
        result = ended.result()
        assert result.status == STATUS_SUCCEEDED and result.result.reached_goal
        assert abs(result.result.position + 0.2) < 0.01
        # the effort reported is the PID's last output (GAC 168 + 77-79)
        assert abs(result.result.effort) <= 1.5
        assert result.result.effort == pytest.approx(
            20.0 * (-0.2 - result.result.position) - 0.5 * rig.value("finger/velocity"),
            abs=0.5)
        # behind the object: the PID saturates at max_effort and the finger stalls
        _handle, ended = rig.send(rig.goal(position=-0.6, max_effort=1.5))
        rig.until(ended, 3.0)
        result = ended.result()
        assert result.status == STATUS_ABORTED and result.result.stalled
        assert result.result.position == pytest.approx(-0.3)
        assert result.result.effort == -1.5
    finally:
        rig.close()


# -- ParallelGripperCommand --------------------------------------------------------------------


def test_parallel_goals_take_one_position_and_the_max_interfaces_their_limits() -> None:
    rig = finger_rig("parallel_gripper_action_controller/GripperActionController",
                     "joint: finger\nmax_effort_interface: finger/effort\n"
                     "max_velocity_interface: finger/velocity\nstate_interfaces: "
                     "[position, velocity, effort]", contact=-0.3)
    try:
        # PGC 111-124: not exactly one position -> rejected
        handle, _ = rig.send(rig.goal(name=["finger", "finger2"], position=[-0.1, 0.1]))
        assert not handle.accepted
        # PGC 387-389: before any goal the limits are the parameters' defaults
        rig.context.spin_for(0.02)
        assert rig.value("finger/velocity", "commands") == 0.1
        assert rig.value("finger/effort", "commands") == 10.0
        # PGC 141-156 and 92-106: a goal's velocity and effort are the limits written
        _handle, ended = rig.send(rig.goal(name=["finger"], position=[-0.2], velocity=[0.5],
                                           effort=[2.0]))
        rig.context.spin_for(0.1)
        assert rig.value("finger/velocity", "commands") == 0.5
        assert rig.value("finger/effort", "commands") == 2.0
        assert rig.value("finger/velocity") == pytest.approx(-0.5)  # moves at its limit
        rig.until(ended, 1.0)
        result = ended.result()
        assert result.status == STATUS_SUCCEEDED and result.result.reached_goal
        assert abs(result.result.state.position[0] + 0.2) < 0.01
        # PGC 227: the effort reported (an unset computed_command_ in the original) is the
        # effort state claimed
        assert list(result.result.state.effort) == [rig.value("finger/effort")]
        # without them in the goal: the parameters' max_velocity and max_effort
        handle, ended = rig.send(rig.goal(name=["finger"], position=[-0.25]))
        rig.context.spin_for(0.02)
        assert rig.value("finger/velocity", "commands") == 0.1
        assert rig.value("finger/effort", "commands") == 10.0
        # PGC 175-212: cancel -> hold the present position at the default limits
        rig.context.spin_for(0.1)
        handle.cancel_goal_async()
        rig.context.spin_for(0.1)
        assert ended.result().status == STATUS_CANCELED
        held = rig.value("finger/position")
        assert rig.value("finger/position", "commands") == pytest.approx(held, abs=0.002)
        assert (rig.value("finger/velocity", "commands"),
                rig.value("finger/effort", "commands")) == (0.1, 10.0)
    finally:
        rig.close()


# -- on emulated Dynamixel ------------------------------------------------------------------


class ObjectInTheWay(World):
    """An object the finger touches at ``contact`` rad: from there it pushes back on the horn
    with ``load`` x stall torque, more than the motor can beat, so the horn stops there."""

    name = "object_in_the_way"

    def __init__(self, motor: VirtualMotor, contact: float, load: float = 1.5) -> None:
        self.contact, self.load = contact, load
        self.plant = KinematicServo(motor.model.no_load_speed, motor.plant.position)
        self.attach(motor, self.plant)

    def step(self, dt: float) -> None:
        self.plant.step(dt)
        self.plant.external_load = self.load if self.plant.position <= self.contact else 0.0

    def ground_truth(self) -> dict[str, float]:
        return {"position": self.plant.position}

    @classmethod
    def example(cls, simulation: Simulation) -> World:
        raise NotImplementedError


def emulated(kind: str, parameters: str) -> ControlSystem:
    return ControlSystem(GRIPPER_URDF.read_text(), GRIPPER_URDF.name,
                         controllers_file(kind, parameters),
                         BringUpOptions(spawn=("gripper_controller",), real_time=False))


def emulated_rig(system: ControlSystem, action: str) -> Rig:
    return Rig(system.context, system.manager, action, system.close)


def test_an_emulated_xm430_closing_in_open_space_reaches_its_goal() -> None:
    system = emulated("position_controllers/GripperActionController", "joint: gripper")
    rig = emulated_rig(system, GRIPPER)
    try:
        _handle, ended = rig.send(rig.goal(position=-0.5, max_effort=2.0))
        rig.until(ended, 1.0)
        result = ended.result()
        # GAC 166-174 on the motor itself
        assert result.status == STATUS_SUCCEEDED
        assert (result.result.reached_goal, result.result.stalled) == (True, False)
        assert abs(result.result.position + 0.5) < 0.01
        assert result.result.effort == 2.0  # ADAPTER 87: max_effort passed through
        assert float(system.buses[0].read(1, "present_position")) == pytest.approx(-0.5,
                                                                                 abs=0.01)
    finally:
        rig.close()


def test_an_emulated_xm430_closing_on_an_object_stalls_at_its_max_effort() -> None:
    """The parallel controller claims the effort command as its max effort interface: the
    XM430 runs in current-based position mode with the goal's effort as its goal current,
    and squeezes the object with that much (its present current x torque constant)."""
    system = emulated("parallel_gripper_action_controller/GripperActionController",
                      "joint: gripper\nstall_timeout: 0.3\nmax_effort_interface: "
                      "gripper/effort\nstate_interfaces: [position, velocity, effort]")
    rig = emulated_rig(system, PARALLEL)
    try:
        assert system.emulator is not None and system.simulation is not None
        system.simulation.add(ObjectInTheWay(system.emulator.motor(1), contact=-0.3))
        _handle, ended = rig.send(rig.goal(name=["gripper"], position=[-0.5], effort=[1.0]))
        rig.until(ended, 1.5)
        bus = system.buses[0]
        assert int(bus.read(1, "operating_mode")) == 5  # current-based position
        result = ended.result()
        # PGC 238-258: stalled short of the goal, aborted
        assert result.status == STATUS_ABORTED
        assert (result.result.stalled, result.result.reached_goal) == (True, False)
        assert result.result.state.position[0] == pytest.approx(-0.3, abs=0.01)
        # the squeeze: the effort state (present current x torque constant), 1 N.m closing
        assert result.result.state.effort[0] == pytest.approx(-1.0, abs=0.05)
    finally:
        rig.close()
