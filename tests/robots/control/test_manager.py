"""The controller manager: its update loop, lifecycle, claims and switch rules, on emulated
XM430s. The words checked are ros2_control's own (controller_manager.cpp, Jazzy branch), as
``ros2 control`` and the spawner print them."""

from __future__ import annotations

import math
from typing import Any

import pytest

from servolab.middleware.node import Node
from servolab.robots.control.bringup import ControlSystem
from servolab.robots.control.manager import BEST_EFFORT, STRICT
from servolab.robots.control.resources import ACTIVE, INACTIVE, UNCONFIGURED
from servolab.robots.errors import RobotValueError

from .conftest import bring_up


def joint_states(system: ControlSystem) -> list[Any]:
    got: list[Any] = []
    node = Node(system.context, "probe")
    node.create_subscription("sensor_msgs/msg/JointState", "/joint_states", got.append, 10)
    return got


def command(system: ControlSystem, controller: str, values: list[float]) -> None:
    node = Node(system.context, f"commander_{controller}")
    node.create_publisher("std_msgs/msg/Float64MultiArray", f"/{controller}/commands",
                          10).publish(node.message("std_msgs/msg/Float64MultiArray",
                                                   data=values))


def motor_positions(system: ControlSystem) -> list[float]:
    bus = system.buses[0]
    return [float(bus.read(i, "present_position")) for i in (1, 2)]


def test_the_loop_keeps_its_rate_and_broadcasts_every_state_interface(two_joint: ControlSystem
                                                                      ) -> None:
    got = joint_states(two_joint)
    two_joint.context.spin_for(0.5)
    manager = two_joint.manager
    # update_rate: 100 (the controllers file), in the emulated motors' time
    assert manager.achieved_rate == pytest.approx(100, rel=1e-6)
    assert manager.overruns == 0
    assert 48 <= len(got) <= 51
    assert list(got[-1].name) == ["joint1", "joint2"]
    # every joint has position, velocity and effort state interfaces in the URDF
    assert len(got[-1].velocity) == 2 and len(got[-1].effort) == 2


def test_a_position_group_command_moves_the_motors(two_joint: ControlSystem) -> None:
    got = joint_states(two_joint)
    command(two_joint, "forward_position_controller", [0.5, -0.3])
    two_joint.context.spin_for(2.0)
    assert motor_positions(two_joint) == pytest.approx([0.5, -0.3], abs=0.01)
    assert list(got[-1].position) == pytest.approx([0.5, -0.3], abs=0.01)


def test_a_command_of_the_wrong_length_is_written_nowhere(two_joint: ControlSystem) -> None:
    # forward_command_controller.cpp: "command size (%zu) does not match number of
    # interfaces (%zu)" and the update returns ERROR
    command(two_joint, "forward_position_controller", [0.5])
    two_joint.context.spin_for(0.5)
    assert motor_positions(two_joint) == pytest.approx([0.0, 0.0], abs=0.01)


def test_a_claimed_command_interface_is_refused_with_ros2_controls_words(
        two_joint: ControlSystem) -> None:
    manager = two_joint.manager
    ok, message = manager.load_controller("second_position")[0], ""
    assert not ok  # no type given for it in the controllers file
    two_joint.close()
    system = bring_up(spawn=("joint_state_broadcaster", "forward_position_controller"),
                      params="controller_manager:\n  ros__parameters:\n    second_position:\n"
                             "      type: position_controllers/JointGroupPositionController\n"
                             "second_position:\n  ros__parameters:\n    joints: [joint2]\n")
    try:
        system.spawn("second_position", activate=False)
        ok, message = system.manager.switch_controller(["second_position"], [], STRICT)
        assert not ok
        # check_for_interfaces_availability_to_activate
        assert message == ("Unable to activate controller 'second_position' since the command "
                           "interface 'joint2/position' is currently claimed by another "
                           "controller.")
        # deactivating the holder in the same switch frees it
        ok, message = system.manager.switch_controller(
            ["second_position"], ["forward_position_controller"], STRICT)
        assert ok and message == "Successfully switched controllers!"
        assert system.manager.interfaces.claimed == {"joint2/position": "second_position"}
    finally:
        system.close()


def test_switch_rules(two_joint: ControlSystem) -> None:
    manager = two_joint.manager
    ok, message = manager.switch_controller(["nope"], [], STRICT)
    assert not ok and message == ("Could not activate controller with name 'nope' because no "
                                  "controller with this name exists")
    # BEST_EFFORT leaves out what cannot be switched, and says nothing needs switching
    assert manager.switch_controller(["nope"], [], BEST_EFFORT) == (
        True, "After checking the controllers, no controllers need to be activated or "
              "deactivated.")
    ok, message = manager.switch_controller(["forward_position_controller"], [], STRICT)
    assert not ok and message == ("Controller with name 'forward_position_controller' is "
                                  "already active.")
    ok, message = manager.switch_controller([], ["forward_velocity_controller"], STRICT)
    assert not ok and message == ("Controller with name 'forward_velocity_controller' can not "
                                  "be deactivated since it is not active.")
    manager.load_controller("joint_trajectory_controller")
    ok, message = manager.switch_controller(["joint_trajectory_controller"], [], STRICT)
    assert not ok and "is in 'unconfigured' state" in message
    ok, message = manager.unload_controller("forward_position_controller")
    assert not ok and message.endswith("because it is still active")


def test_velocity_mode_follows_the_claimed_interfaces(two_joint: ControlSystem) -> None:
    manager, bus = two_joint.manager, two_joint.buses[0]
    # a joint cannot obey position and velocity at once: the hardware refuses the switch
    ok, message = manager.switch_controller(["forward_velocity_controller"], [], STRICT)
    assert not ok and message == ("Could not switch controllers since prepare command mode "
                                  "switch was rejected.")
    ok, _ = manager.switch_controller(["forward_velocity_controller"],
                                      ["forward_position_controller"], STRICT)
    assert ok
    # e-Manual control_table_operating_mode: 1 is velocity control
    assert [bus.read(i, "operating_mode") for i in (1, 2)] == [1, 1]
    command(two_joint, "forward_velocity_controller", [0.4, -0.2])
    start = motor_positions(two_joint)
    two_joint.context.spin_for(1.0)
    moved = [b - a for a, b in zip(start, motor_positions(two_joint), strict=True)]
    assert moved == pytest.approx([0.4, -0.2], abs=0.06)  # less the acceleration at start
    ok, _ = manager.switch_controller(["forward_position_controller"],
                                      ["forward_velocity_controller"], STRICT)
    assert ok and [bus.read(i, "operating_mode") for i in (1, 2)] == [3, 3]
    held = motor_positions(two_joint)
    two_joint.context.spin_for(0.5)  # position mode from where it was: no jump, no drift
    assert motor_positions(two_joint) == pytest.approx(held, abs=0.01)


def test_a_failed_read_deactivates_the_controllers_and_the_joints_hold(
        two_joint: ControlSystem, caplog: pytest.LogCaptureFixture) -> None:
    manager = two_joint.manager
    command(two_joint, "forward_position_controller", [0.3, 0.2])
    two_joint.context.spin_for(1.5)
    assert two_joint.emulator is not None
    motor = two_joint.emulator.unplug(2)
    with caplog.at_level("ERROR"):
        two_joint.context.spin_for(0.3)
    text = caplog.text
    assert ("Deactivating following hardware components as their read cycle resulted in an "
            "error: [ TwoJoint ]") in text
    assert ("Deactivating following controllers as their hardware components read cycle "
            "resulted in an error: [ joint_state_broadcaster forward_position_controller ]"
            ) in text
    assert manager.components.by_name["TwoJoint"].state == UNCONFIGURED
    assert {c.name: c.state for c in manager.controllers.values()} == {
        "joint_state_broadcaster": INACTIVE, "forward_position_controller": INACTIVE,
        "forward_velocity_controller": INACTIVE}
    assert not manager.interfaces.available_commands
    bus = two_joint.buses[0]
    assert float(bus.read(1, "present_position")) == pytest.approx(0.3, abs=0.01)
    assert float(bus.read(1, "goal_position")) == pytest.approx(0.3, abs=0.01)
    # the cable back in: set_hardware_component_state active configures and activates the
    # component again (hardware_component lifecycle: unconfigured -> inactive -> active)
    two_joint.emulator.add(motor)
    ok, message = manager.set_hardware_component_state("TwoJoint", ACTIVE)
    assert ok, message
    assert manager.components.by_name["TwoJoint"].state == ACTIVE
    assert "joint1/position" in manager.interfaces.available_commands


def test_a_failed_read_stops_the_velocity_joints_that_still_answer(
        two_joint: ControlSystem) -> None:
    """A wheel whose neighbour's cable is pulled must not keep turning: the failed component
    gets no more writes, so before it is let go the motors that still answer are stopped
    (servolab's rule; ros2_control writes nothing more to a failed component)."""
    manager = two_joint.manager
    assert manager.switch_controller(["forward_velocity_controller"],
                                     ["forward_position_controller"], STRICT)[0]
    command(two_joint, "forward_velocity_controller", [0.4, -0.2])
    two_joint.context.spin_for(0.5)
    bus = two_joint.buses[0]
    assert float(bus.read(1, "present_velocity")) == pytest.approx(0.4, abs=0.05)
    assert two_joint.emulator is not None
    two_joint.emulator.unplug(2)
    two_joint.context.spin_for(0.3)
    assert manager.components.by_name["TwoJoint"].state == UNCONFIGURED
    assert int(bus.read(1, "goal_velocity", raw=True)) == 0
    two_joint.context.spin_for(0.3)
    assert float(bus.read(1, "present_velocity")) == pytest.approx(0.0, abs=0.02)
    assert bus.read(1, "torque_enable") == 1


def test_hardware_component_states(two_joint: ControlSystem) -> None:
    manager = two_joint.manager
    ok, _ = manager.set_hardware_component_state("TwoJoint", INACTIVE)
    assert ok
    # command interfaces go with the active state, state interfaces stay (resource_manager)
    assert not manager.interfaces.available_commands
    assert "joint1/position" in manager.interfaces.available_states
    assert manager.set_hardware_component_state("TwoJoint", ACTIVE)[0]
    assert "joint1/position" in manager.interfaces.available_commands


@pytest.mark.slow
def test_mock_generic_system_mirrors_commands_to_states() -> None:
    urdf = (TWO_MOCK := """<robot name="m"><link name="a"/><link name="b"/>
      <joint name="j" type="revolute"><parent link="a"/><child link="b"/>
        <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      <ros2_control name="Mock" type="system">
        <hardware><plugin>mock_components/GenericSystem</plugin>
          <param name="calculate_dynamics">true</param></hardware>
        <joint name="j"><command_interface name="velocity"/>
          <state_interface name="position"><param name="initial_value">0.2</param>
          </state_interface><state_interface name="velocity"/></joint>
      </ros2_control></robot>""")
    from servolab.middleware.parameters import ParameterOverrides
    from servolab.robots.control.bringup import BringUpOptions

    params = ParameterOverrides.from_text(
        "controller_manager:\n  ros__parameters:\n    update_rate: 50\n    vel:\n"
        "      type: velocity_controllers/JointGroupVelocityController\n"
        "vel:\n  ros__parameters:\n    joints: [j]\n")
    with ControlSystem(urdf, "mock.urdf", params,
                       BringUpOptions(spawn=("vel",), real_time=False)) as system:
        assert system.manager.interfaces.states["j/position"] == 0.2  # initial_value
        assert math.isnan(system.manager.interfaces.states["j/velocity"])
        command(system, "vel", [0.5])
        system.context.spin_for(1.0)
        # generic_system.cpp: velocity command -> velocity state; position by backward Euler
        assert system.manager.interfaces.states["j/velocity"] == 0.5
        assert system.manager.interfaces.states["j/position"] == pytest.approx(0.7, abs=0.02)
    assert TWO_MOCK


def test_an_unknown_type_and_a_missing_type_are_refused(two_joint: ControlSystem) -> None:
    manager = two_joint.manager
    ok, message = manager.load_controller("nothing_here")
    assert not ok and message == "The 'type' param was not defined for 'nothing_here'."
    with pytest.raises(RobotValueError, match="spawner nothing_here: The 'type' param"):
        two_joint.spawn("nothing_here")
