"""The dynamixel_motor manager and a joint position controller on every model servolab ships:
the controllers ask for registers by role (servolab.dynamixel.models.ROLES), so a model
whose table has the roles is driven without a line of code for it. Checked on each: the
manager starts the controller, a command on ``/<controller>/command`` moves the joint there
(within two of the model's position ticks) and ``/motor_states`` reports the motor; the
compliance services work where the model has compliance registers and are refused, one line
naming the model and the register, where it has PID gains instead."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

from servolab.dynamixel import MODELS, models, register_model
from servolab.dynamixel.bus import Bus
from servolab.middleware.context import Context
from servolab.middleware.errors import ServiceError
from servolab.middleware.node import Node
from servolab.robots.controllers.config import load
from servolab.robots.controllers.manager import DynamixelManager
from servolab.sim.emulated import emulated_port
from servolab.sim.simulation import Simulation

FLOAT64 = "std_msgs/msg/Float64"


def config_text(center: int, span: int) -> str:
    return f"""\
dynamixel_manager:
  serial_ports:
    port: {{port_name: /dev/ttyUSB0, baud_rate: 1000000, min_motor_id: 1, max_motor_id: 2,
           update_rate: 50}}
joint_controller:
  controller: {{package: dynamixel_controllers, module: joint_position_controller,
               type: JointPositionController}}
  joint_name: joint
  joint_speed: 2.0
  motor: {{id: 1, init: {center}, min: {center - span}, max: {center + span}}}
"""


@pytest.mark.parametrize("name", sorted(MODELS))
def test_the_manager_drives_every_shipped_model(name: str, tmp_path: Path) -> None:
    m = MODELS[name]
    path = tmp_path / "controllers.yaml"
    path.write_text(config_text(m.position_center, m.resolution // 5))
    config = load(path)
    sim = Simulation()
    bus = Bus(emulated_port(f"{name}:1", 1_000_000, simulation=sim))
    context = Context.open(clock=sim)
    try:
        manager = DynamixelManager(context, bus, config.manager.serial_ports[0],
                                   config.controllers)
        assert manager.motors == {1: name} and list(manager.controllers) == ["joint_controller"]
        probe = Node(context, "probe")
        joints: list[Any] = []
        motors: list[Any] = []
        probe.create_subscription("dynamixel_msgs/msg/JointState", "/joint_controller/state",
                                  joints.append)
        probe.create_subscription("dynamixel_msgs/msg/MotorStateList", "/motor_states/port",
                                  motors.append)
        pub = probe.create_publisher(FLOAT64, "/joint_controller/command")
        pub.publish(probe.message(FLOAT64, data=0.3))
        tick = m.rad_per_tick
        assert context.spin_until(
            lambda: bool(joints) and abs(joints[-1].current_pos - 0.3) < 2 * tick,
            timeout=10.0), joints[-1].current_pos if joints else None
        assert motors and [s.id for s in motors[-1].motor_states] == [1]
        assert motors[-1].motor_states[0].goal == bus.read(1, "goal_position", raw=True)
        slope = probe.create_client("dynamixel_controllers/srv/SetComplianceSlope",
                                    "/joint_controller/set_compliance_slope")
        if m.has_role("cw_compliance_slope"):
            slope.call(slope.request(slope=64))
            assert bus.read(1, "ccw_compliance_slope", raw=True) == 64
        else:
            with pytest.raises(ServiceError, match=re.escape(f"{name} has no "
                                                             "cw_compliance_slope register")):
                slope.call(slope.request(slope=64))
    finally:
        context.close()
        bus.close()


def test_a_model_without_a_state_role_is_left_out_with_one_line(
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """A lab's own model file whose table has no Goal PWM (no torque limit role): the manager
    says which register it lacks, and the motor's controller does not start for that
    reason (not "did not answer")."""
    text = Path(MODELS["XM430-W350"].path).read_text()
    lab = tmp_path / "lab-x.yaml"
    lab.write_text(text.replace("name: XM430-W350", "name: LAB-X")
                   .replace("number: 1020", "number: 64999")
                   .replace("default: 1020}", "default: 64999}")
                   .replace("  goal_pwm:", "  # goal_pwm:"))
    register_model(lab)
    path = tmp_path / "controllers.yaml"
    path.write_text(config_text(2048, 800))
    config = load(path)
    sim = Simulation()
    bus = Bus(emulated_port("LAB-X:1", 1_000_000, simulation=sim))
    context = Context.open(clock=sim)
    try:
        manager = DynamixelManager(context, bus, config.manager.serial_ports[0],
                                   config.controllers)
        assert manager.motors == {} and manager.failed == ["joint_controller"]
        lines = [r.getMessage() for r in caplog.records if r.levelname == "ERROR"]
        lacking = "LAB-X has no torque_limit or goal_pwm register (torque or output limit)"
        assert any("motor 1 cannot be read" in line and lacking in line for line in lines)
        assert any("Unable to start controller joint_controller: " + lacking in line
                   for line in lines), lines
    finally:
        context.close()
        bus.close()
        models._REGISTRY.forget("LAB-X")
