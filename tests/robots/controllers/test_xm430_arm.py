"""The dynamixel_motor manager and joint position controllers on five emulated XM430-W350
(Protocol 2.0, 1 Mbps, IDs 11..15), configured as a user writes dynamixel_controllers' YAML:
the same manager that drives Armstrong's RX-28, speaking registers by role.

Facts checked, and where they come from:

- ROBOTIS e-Manual, docs/en/dxl/x/xm430-w350.md (ROBOTIS-GIT/emanual), Control Table of RAM
  Area: Goal PWM(100, 2 bytes, -PWM Limit ~ PWM Limit, 885 = 100 %), Profile Velocity(112, 4,
  0.229 rpm), Goal Position(116, 4), Moving(122, 1), Present Current(126, 2, 2.69 mA),
  Present Velocity(128, 4, 0.229 rpm), Present Position(132, 4), Present Input Voltage(144,
  2, 0.1 V), Present Temperature(146, 1); EEPROM: Current Limit(38, 2, 0 ~ 1,193, 2.69 mA).
  The state roles therefore lie in 100..146: one READ of 47 bytes.
- The same page: no Compliance Margin/Slope or Punch (the X-series has Position PID gains,
  80..84): the compliance services are refused with one line naming the model and register.
- dynamixel_driver's ``MotorState.load`` is a signed ratio of the maximum (dynamixel_io.py
  ``get_feedback``); servolab gives an XM430's as Present Current over the top of Current
  Limit(38)'s range, 1,193 x 2.69 mA = 3.21 A (see robots/controllers/motor_state.py), and
  ``speed`` as the raw signed Present Velocity, 0.229 rpm a unit.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from servolab.dynamixel.bus import Bus
from servolab.dynamixel.plant import ServoCommand
from servolab.middleware.context import Context
from servolab.middleware.errors import ServiceError
from servolab.middleware.node import Node
from servolab.robots.controllers.config import RobotConfig, load
from servolab.robots.controllers.manager import DynamixelManager
from servolab.sim.emulated import emulated_port
from servolab.sim.simulation import Simulation

from ...simproc import sim_process

FLOAT64 = "std_msgs/msg/Float64"
SRV = "dynamixel_controllers/srv/"
IDS = [11, 12, 13, 14, 15]
XM430_CURRENT_UNIT_A = 0.00269      # e-Manual xm430-w350.md, Present Current(126)
XM430_CURRENT_LIMIT_TOP = 1193      # e-Manual xm430-w350.md, Current Limit(38): 0 ~ 1,193
XM430_VELOCITY_UNIT_RPM = 0.229     # e-Manual xm430-w350.md, Present Velocity(128)
XM430_TICK = 2 * math.pi / 4096     # 4096 pulses a turn (e-Manual, Specifications)
RPM = 2 * math.pi / 60


def controller(name: str, motor_id: int, init: int, low: int, high: int,
               extra: str = "") -> str:
    return f"""\
{name}:
  controller:
    package: dynamixel_controllers
    module: joint_position_controller
    type: JointPositionController
  joint_name: {name.replace("_controller", "")}
  joint_speed: 2.0
  motor: {{id: {motor_id}, init: {init}, min: {low}, max: {high}}}
{extra}"""


# An OpenMANIPULATOR-X-like arm as a lab writes it: a manager and five joint controllers; the
# wrist is mounted the other way round (min > max).
MANAGER = """\
dynamixel_manager:
  namespace: dxl_manager
  serial_ports:
    arm_port:
      port_name: /dev/ttyUSB0
      baud_rate: 1000000
      min_motor_id: 10
      max_motor_id: 16
      update_rate: 50
"""
JOINTS = [("joint1_controller", 11, 2048, 0, 4095), ("joint2_controller", 12, 2048, 1024, 3072),
          ("joint3_controller", 13, 2048, 1024, 3072), ("joint4_controller", 14, 2048, 3072, 1024),
          ("gripper_controller", 15, 2048, 1500, 2600)]
CONFIG = MANAGER + "\n".join(controller(*joint) for joint in JOINTS)


def write_config(tmp_path: Path, text: str = CONFIG) -> RobotConfig:
    path = tmp_path / "arm_controllers.yaml"
    path.write_text(text)
    return load(path)


class FixedPlant:
    """A joint whose state the test sets (the ServoPlant interface)."""

    def __init__(self, velocity: float, effort: float) -> None:
        self.command = ServoCommand()
        self.position = 0.0
        self.velocity = velocity
        self.effort = effort
        self.temperature = 31.0

    def step(self, dt: float) -> None:
        pass


class Arm:
    """The five emulated XM430-W350, the manager and a probe node on one simulation."""

    def __init__(self, config: RobotConfig) -> None:
        self.sim = Simulation()
        port = config.manager.serial_ports[0]
        self.bus = Bus(emulated_port("xm430-w350:11-15", port.baud_rate, simulation=self.sim))
        self.context = Context.open(clock=self.sim)
        self.config, self.port = config, port
        self.probe = Node(self.context, "probe")
        self.manager = DynamixelManager(self.context, self.bus, port, config.controllers)

    def command(self, name: str, angle: float) -> None:
        pub = self.probe.create_publisher(FLOAT64, f"/{name}/command")
        pub.publish(self.probe.message(FLOAT64, data=angle))

    def close(self) -> None:
        self.context.close()
        self.bus.close()


@pytest.fixture
def arm(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> Iterator[Arm]:
    caplog.set_level(logging.INFO)
    a = Arm(write_config(tmp_path))
    try:
        yield a
    finally:
        a.close()


def test_the_manager_finds_five_xm430_and_starts_five_controllers(
        arm: Arm, caplog: pytest.LogCaptureFixture) -> None:
    assert arm.manager.motors == dict.fromkeys(IDS, "XM430-W350")
    said = "\n".join(r.getMessage() for r in caplog.get_records("setup"))
    assert ("arm_port: Found 5 motors - 5 XM430-W350 [11, 12, 13, 14, 15], initialization "
            "complete.") in said
    assert sorted(arm.manager.controllers) == sorted(j[0] for j in JOINTS)
    assert arm.manager.failed == []


def test_each_motors_state_is_one_read_of_47_bytes_from_goal_pwm(arm: Arm) -> None:
    """Goal PWM(100) .. Present Temperature(146): one READ per motor per update."""
    assert [plan.spans() for plan in arm.manager.plans.values()] == [[(100, 47)]] * 5
    arm.manager.update()
    before = arm.bus.stats.transactions
    arm.manager.update()
    assert arm.bus.stats.transactions - before == 5
    # 2.0 READ: 14-byte instruction, 11 + 47 status bytes; return delay 250 x 2 us
    per_motor = (14 + 11 + 47) * 10 / 1_000_000 + 500e-6
    sync = (14 + 5 * 5) * 10 / 1_000_000   # SYNC_WRITE of 5 four-byte goals
    assert arm.manager.wire_time() == pytest.approx(5 * per_motor + sync, rel=1e-9)


def test_joints_reach_the_positions_commanded_on_their_topics(arm: Arm) -> None:
    goals = {"joint1_controller": 0.8, "joint2_controller": -0.5, "joint3_controller": 0.3,
             "joint4_controller": 0.4, "gripper_controller": -0.2}
    states: dict[str, list[Any]] = {name: [] for name in goals}
    for name, got in states.items():
        arm.probe.create_subscription("dynamixel_msgs/msg/JointState", f"/{name}/state",
                                      got.append)
    for name, angle in goals.items():
        arm.command(name, angle)

    def there() -> bool:
        return all(got and abs(got[-1].current_pos - goals[name]) < 2 * XM430_TICK
                   for name, got in states.items())

    assert arm.context.spin_until(there, timeout=10.0), {
        n: g[-1].current_pos for n, g in states.items() if g}
    for name, angle in goals.items():
        c = arm.manager.controllers[name]
        motor = float(arm.bus.read(c.motor_id, "present_position"))
        expected = c.geometry.init - angle if c.geometry.flipped else c.geometry.init + angle
        assert motor == pytest.approx(expected, abs=2 * XM430_TICK)
    assert arm.manager.controllers["joint4_controller"].geometry.flipped


@pytest.mark.parametrize("sign", [1, -1])
def test_motor_states_carry_present_current_as_a_ratio_of_the_current_limits_top(
        arm: Arm, sign: int) -> None:
    for motor_id in IDS:
        arm.bus.emulator.motor(motor_id).attach_plant(
            FixedPlant(velocity=sign * 50 * XM430_VELOCITY_UNIT_RPM * RPM, effort=sign * 0.3))
    got: list[Any] = []
    arm.probe.create_subscription("dynamixel_msgs/msg/MotorStateList",
                                  "/motor_states/arm_port", got.append)
    assert arm.context.spin_until(lambda: len(got) >= 2, timeout=5.0)
    states = {m.id: m for m in got[-1].motor_states}
    assert sorted(states) == IDS
    for motor_id in IDS:
        raw = arm.bus.read(motor_id, ["present_current", "present_velocity"], raw=True)
        current = int(raw["present_current"])
        assert current * sign > 0
        amps = current * XM430_CURRENT_UNIT_A
        assert states[motor_id].load == pytest.approx(
            amps / (XM430_CURRENT_LIMIT_TOP * XM430_CURRENT_UNIT_A), abs=1e-12)
        assert abs(states[motor_id].load) <= 1.0
        assert states[motor_id].speed == int(raw["present_velocity"]) == sign * 50


def test_compliance_services_are_refused_with_one_line_and_the_controller_runs_on(
        arm: Arm) -> None:
    for which, kind, field, register in (
            ("slope", "SetComplianceSlope", "slope", "cw_compliance_slope"),
            ("margin", "SetComplianceMargin", "margin", "cw_compliance_margin"),
            ("punch", "SetCompliancePunch", "punch", "punch")):
        client = arm.probe.create_client(SRV + kind, f"/joint2_controller/set_compliance_{which}")
        with pytest.raises(ServiceError) as refused:
            client.call(client.request(**{field: 32}))
        text = str(refused.value)
        assert "\n" not in text
        assert f"XM430-W350 has no {register} register" in text, text
    speed = arm.probe.create_client(SRV + "SetSpeed", "/joint2_controller/set_speed")
    speed.call(speed.request(speed=2.0))
    assert float(arm.bus.read(12, "profile_velocity")) == pytest.approx(2.0, rel=0.01)
    assert arm.bus.read(12, "profile_velocity", raw=True) == round(
        2.0 / (XM430_VELOCITY_UNIT_RPM * RPM))


def test_torque_limit_is_goal_pwm_and_torque_enable_the_register(arm: Arm) -> None:
    limit = arm.probe.create_client(SRV + "SetTorqueLimit", "/joint3_controller/set_torque_limit")
    limit.call(limit.request(torque_limit=0.4))
    assert arm.bus.read(13, "goal_pwm", raw=True) == round(0.4 * 885)
    torque = arm.probe.create_client(SRV + "TorqueEnable", "/joint3_controller/torque_enable")
    torque.call(torque.request(torque_enable=True))
    assert arm.bus.read(13, "torque_enable") == 1


def test_compliance_in_the_configuration_keeps_only_that_controller_from_starting(
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO)
    text = CONFIG.replace("  motor: {id: 13, init: 2048, min: 1024, max: 3072}\n",
                          "  motor: {id: 13, init: 2048, min: 1024, max: 3072}\n"
                          "  joint_compliance_slope: 32\n")
    a = Arm(write_config(tmp_path, text))
    try:
        assert a.manager.failed == ["joint3_controller"]
        assert len(a.manager.controllers) == 4
        line = next(r.getMessage() for r in caplog.records
                    if "Unable to start controller joint3_controller" in r.getMessage())
        assert "XM430-W350" in line and "cw_compliance_slope" in line
        assert not [e for e in a.context.transport.graph()
                    if e.name.startswith("/joint3_controller/")]
    finally:
        a.close()


@pytest.mark.slow
@pytest.mark.realtime
def test_the_same_arm_over_a_pty_served_by_servolab_sim(tmp_path: Path) -> None:
    """``servolab sim --motors xm430-w350:11-15 --pty --baud 1000000`` in its own process,
    in real time; the manager opens the device as a serial port."""
    config = write_config(tmp_path)
    with sim_process("--motors", "xm430-w350:11-15", "--baud", "1000000",
                     out_dir=tmp_path / "sim") as (device, _):
        bus = Bus.open(device, protocol=2, baudrate=1_000_000)
        context = Context.open()
        try:
            manager = DynamixelManager(context, bus, config.manager.serial_ports[0],
                                       config.controllers)
            assert manager.motors == dict.fromkeys(IDS, "XM430-W350")
            assert len(manager.controllers) == 5
            probe = Node(context, "probe")
            got: list[Any] = []
            probe.create_subscription("dynamixel_msgs/msg/JointState",
                                      "/joint2_controller/state", got.append)
            pub = probe.create_publisher(FLOAT64, "/joint2_controller/command")
            pub.publish(probe.message(FLOAT64, data=0.5))
            assert context.spin_until(
                lambda: bool(got) and abs(got[-1].current_pos - 0.5) < 2 * XM430_TICK,
                timeout=20.0), got[-1].current_pos if got else None
            states: list[Any] = []
            probe.create_subscription("dynamixel_msgs/msg/MotorStateList",
                                      "/motor_states/arm_port", states.append)
            assert context.spin_until(lambda: bool(states), timeout=10.0)
            assert sorted(m.id for m in states[-1].motor_states) == IDS
            slope = probe.create_client(SRV + "SetComplianceSlope",
                                        "/joint2_controller/set_compliance_slope")
            with pytest.raises(ServiceError, match="XM430-W350 has no cw_compliance_slope"):
                slope.call(slope.request(slope=32))
        finally:
            context.close()
            bus.close()
