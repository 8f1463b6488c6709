"""The controller manager and joint controllers on the emulated Armstrong.

Facts checked, and where they come from:
- seed 001 Figure 3.1: "pan_tilt_port: Found 20 motors - 20 RX-28 [11, 12, 13, 14, 15, 16, 21,
  22, 23, 24, 25, 26, 31, 32, 33, 41, 42, 43, 51, 61], initialization complete.";
- seed 001 Figure 3.4: controller_m62 fails to start, the other 20 start;
- dynamixel_controllers' joint_position_controller.py: a command of 0 rad is ``init``, the
  joint's range is min..max seen from init, ``min > max`` flips the joint, commands outside the
  range are clamped; topics /<controller>/command and /state, services /<controller>/set_speed
  and /<controller>/torque_enable;
- the wire (issue 16): one READ of an RX-28's addresses 30..46 (dynamixel_io's get_feedback
  reads these 17 bytes) is an 8-byte instruction and a 23-byte status, 31 bytes of 10 bits; at
  57142 bps with the factory return delay (250 x 2 us, RX-28 e-Manual) 20 of them take
  118.5 ms.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from servolab.dynamixel.wire import wire_time
from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.robots.armstrong import hardware as armstrong
from servolab.robots.controllers.config import RobotConfig, load
from servolab.robots.controllers.manager import DynamixelManager
from servolab.sim.simulation import Simulation

FLOAT64 = "std_msgs/msg/Float64"
FIGURE_3_1_IDS = [11, 12, 13, 14, 15, 16, 21, 22, 23, 24, 25, 26, 31, 32, 33, 41, 42, 43, 51, 61]


class Robot:
    """The emulated Armstrong, its manager and a probe node, on one simulation's time."""

    def __init__(self, config: RobotConfig, baudrate: int | None = None) -> None:
        self.sim = Simulation()
        self.bus, port = armstrong.open_bus(config, simulation=self.sim, baudrate=baudrate)
        self.context = Context.open(clock=self.sim)
        self.manager = DynamixelManager(self.context, self.bus, port, config.controllers)
        self.probe = Node(self.context, "probe")
        self.states: dict[str, list[Any]] = {}

    def watch(self, controller: str) -> list[Any]:
        got = self.states.setdefault(controller, [])
        self.probe.create_subscription("dynamixel_msgs/msg/JointState", f"/{controller}/state",
                                       got.append)
        return got

    def command(self, controller: str, angle: float) -> None:
        pub = self.probe.create_publisher(FLOAT64, f"/{controller}/command")
        pub.publish(self.probe.message(FLOAT64, data=angle))

    def motor_angle(self, motor_id: int) -> float:
        return float(self.bus.read(motor_id, "present_position"))

    def close(self) -> None:
        self.context.close()
        self.bus.close()


def said(caplog: pytest.LogCaptureFixture) -> str:
    """Everything logged, also while the fixture built the robot."""
    return "\n".join(r.getMessage() for when in ("setup", "call")
                     for r in caplog.get_records(when))


@pytest.fixture
def robot(caplog: pytest.LogCaptureFixture) -> Iterator[Robot]:
    caplog.set_level(logging.INFO)
    r = Robot(armstrong.load_config())
    try:
        yield r
    finally:
        r.close()


def test_found_motors_and_started_controllers_as_figures_3_1_and_3_4(
        robot: Robot, caplog: pytest.LogCaptureFixture) -> None:
    assert list(robot.manager.motors) == FIGURE_3_1_IDS
    assert set(robot.manager.motors.values()) == {"RX-28"}
    text = said(caplog)
    assert ("pan_tilt_port: Found 20 motors - 20 RX-28 [11, 12, 13, 14, 15, 16, 21, 22, 23, "
            "24, 25, 26, 31, 32, 33, 41, 42, 43, 51, 61], initialization complete.") in text
    assert robot.manager.failed == ["controller_m62"]
    assert "Unable to start controller controller_m62" in text
    assert sorted(robot.manager.controllers) == sorted(f"controller_m{i}" for i in FIGURE_3_1_IDS)


def test_the_emulated_robot_stands_at_its_init_positions(robot: Robot) -> None:
    """Every motor starts at its configured init (Table 2.2): joint angle 0."""
    for controller in robot.manager.controllers.values():
        assert robot.motor_angle(controller.motor_id) == pytest.approx(
            controller.geometry.init, abs=1e-9)
        assert controller.goal_angle == pytest.approx(0.0, abs=1e-9)


def test_a_command_moves_the_joint_and_the_state_follows(robot: Robot) -> None:
    states = robot.watch("controller_m14")
    robot.command("controller_m14", 0.5)
    robot.context.spin_until(lambda: bool(states) and abs(states[-1].current_pos - 0.5) < 0.006,
                             timeout=5.0)
    last = states[-1]
    assert last.name == "pan_joint_14" and list(last.motor_ids) == [14]
    assert last.goal_pos == pytest.approx(0.5)
    assert last.current_pos == pytest.approx(0.5, abs=0.006)  # within one RX-28 tick
    assert last.error == pytest.approx(last.current_pos - last.goal_pos)
    init = robot.manager.controllers["controller_m14"].geometry.init
    assert robot.motor_angle(14) == pytest.approx(init + 0.5, abs=0.006)


def test_out_of_range_is_clamped_with_a_warning_and_nan_refused(
        robot: Robot, caplog: pytest.LogCaptureFixture) -> None:
    controller = robot.manager.controllers["controller_m16"]  # init 338: an asymmetric range
    g = controller.geometry
    assert g.min_angle < 0 < g.max_angle and g.max_angle > -g.min_angle
    assert controller.command(10.0) == pytest.approx(g.max_angle)
    assert "clamped" in caplog.text
    states = robot.watch("controller_m16")
    robot.context.spin_until(lambda: bool(states) and states[-1].goal_pos == g.max_angle,
                             timeout=5.0)
    robot.command("controller_m16", math.nan)
    robot.context.spin_for(0.5)
    assert "not a finite angle" in caplog.text
    assert controller.goal_angle == pytest.approx(g.max_angle)


def test_a_flipped_joint_turns_the_other_way(tmp_path: Path) -> None:
    text = armstrong.CONFIG.read_text().replace(
        "motor: {id: 14, init: 512, min: 0, max: 1023}",
        "motor: {id: 14, init: 512, min: 1023, max: 0}")
    path = tmp_path / "flipped.yaml"
    path.write_text(text)
    r = Robot(load(path))
    try:
        states = r.watch("controller_m14")
        r.command("controller_m14", 0.3)
        r.context.spin_until(lambda: bool(states) and abs(states[-1].current_pos - 0.3) < 0.006,
                             timeout=5.0)
        init = r.manager.controllers["controller_m14"].geometry.init
        assert r.motor_angle(14) == pytest.approx(init - 0.3, abs=0.006)
        assert states[-1].current_pos == pytest.approx(0.3, abs=0.006)
    finally:
        r.close()


def test_each_update_is_one_read_per_motor_and_one_sync_write(robot: Robot) -> None:
    robot.manager.update()  # nothing pending: reads only
    before = robot.bus.stats.transactions
    robot.manager.update()
    assert robot.bus.stats.transactions - before == 20
    for name in ("controller_m12", "controller_m13", "controller_m14"):
        robot.manager.controllers[name].command(0.1)
    robot.manager.update()  # torque on for 3 motors once, one SYNC_WRITE, 20 READs
    before = robot.bus.stats.transactions
    for name in ("controller_m12", "controller_m13", "controller_m14"):
        robot.manager.controllers[name].command(0.2)
    robot.manager.update()
    assert robot.bus.stats.transactions - before == 20 + 1


def test_motor_states_list_every_motor(robot: Robot) -> None:
    got: list[Any] = []
    robot.probe.create_subscription("dynamixel_msgs/msg/MotorStateList",
                                    "/motor_states/pan_tilt_port", got.append)
    robot.context.spin_until(lambda: bool(got), timeout=5.0)
    states = got[-1].motor_states
    assert [s.id for s in states] == FIGURE_3_1_IDS
    assert {s.id: s.position for s in states}[12] == 444  # Table 2.2
    assert all(s.error == s.position - s.goal and not s.moving for s in states)


def test_the_wire_sets_the_rate(robot: Robot, caplog: pytest.LogCaptureFixture) -> None:
    """At 57142 bps 20 READs of the 17 bytes from goal_position (8-byte instruction, 23-byte
    status) take 119 ms with the factory return delay: update_rate 20 Hz cannot be met, and
    the manager says so and updates as fast as the wire allows."""
    manager, bus, proto = robot.manager, robot.bus, robot.bus.proto
    read = proto.encode_instruction(proto.read(11, 30, 17))  # get_feedback's READ of 30..46
    assert (len(read), proto.status_size(17)) == (8, 23)
    delay = float(bus.read(11, "return_delay_time"))
    assert delay == pytest.approx(250 * 2e-6)  # the factory return delay (RX-28 e-Manual)
    reads = 20 * (wire_time(len(read) + proto.status_size(17), bus.baudrate) + delay)
    assert reads == pytest.approx(0.1185, abs=1e-4)
    sync = manager.update_time - reads  # the SYNC_WRITE of 20 goals: 8 + 20 x 3 bytes
    assert sync == pytest.approx((8 + 20 * 3) * 10 / 57142, abs=1e-9)
    assert manager.rate == pytest.approx(1 / manager.update_time)
    assert "update_rate 20 Hz cannot be met" in said(caplog)
    start, updates = robot.sim.now(), manager.updates
    robot.context.spin_for(5.0)
    achieved = (manager.updates - updates) / (robot.sim.now() - start)
    assert 0.8 * manager.rate <= achieved <= manager.rate * 1.01


def test_at_one_megabit_and_return_delay_0_the_rate_is_met(tmp_path: Path) -> None:
    config = armstrong.load_config()
    r = Robot(config, baudrate=1_000_000)
    try:
        for motor_id in r.manager.motors:
            r.bus.write(motor_id, "return_delay_time", 0)
        assert r.manager.wire_time() < 0.0075  # 20 x 31 bytes + the SYNC_WRITE: 6.9 ms
    finally:
        r.close()


def test_set_speed_and_torque_enable_services(robot: Robot) -> None:
    speed = robot.probe.create_client("dynamixel_controllers/srv/SetSpeed",
                                      "/controller_m14/set_speed")
    torque = robot.probe.create_client("dynamixel_controllers/srv/TorqueEnable",
                                       "/controller_m14/torque_enable")
    speed.call(speed.request(speed=2.0))
    assert float(robot.bus.read(14, "moving_speed")) == pytest.approx(2.0, rel=0.01)
    speed.call(speed.request(speed=0.0))  # 0 would be full speed on an RX-28: never
    assert float(robot.bus.read(14, "moving_speed")) > 0
    torque.call(torque.request(torque_enable=True))
    assert robot.bus.read(14, "torque_enable") == 1
    torque.call(torque.request(torque_enable=False))
    assert robot.bus.read(14, "torque_enable") == 0


def test_compliance_and_torque_limit_services(robot: Robot) -> None:
    """dynamixel_controllers' set_compliance_slope/_margin/_punch write both directions of
    the motor's raw register (punch has one), clamped to its range (servolab's RX-28 table,
    checked against the e-Manual in tests/dynamixel/test_tables_emanual.py: slope 0..254);
    set_torque_limit a fraction of the maximum torque."""
    srv = "dynamixel_controllers/srv/"
    clients = {name: robot.probe.create_client(srv + kind, f"/controller_m14/{name}")
               for name, kind in (("set_compliance_slope", "SetComplianceSlope"),
                                  ("set_compliance_margin", "SetComplianceMargin"),
                                  ("set_compliance_punch", "SetCompliancePunch"),
                                  ("set_torque_limit", "SetTorqueLimit"))}
    clients["set_compliance_slope"].call(clients["set_compliance_slope"].request(slope=64))
    clients["set_compliance_margin"].call(clients["set_compliance_margin"].request(margin=3))
    clients["set_compliance_punch"].call(clients["set_compliance_punch"].request(punch=50))
    clients["set_torque_limit"].call(clients["set_torque_limit"].request(torque_limit=0.4))
    assert robot.bus.read(14, ["cw_compliance_slope", "ccw_compliance_slope",
                               "cw_compliance_margin", "ccw_compliance_margin", "punch"],
                          raw=True) == {"cw_compliance_slope": 64, "ccw_compliance_slope": 64,
                                        "cw_compliance_margin": 3, "ccw_compliance_margin": 3,
                                        "punch": 50}
    assert float(robot.bus.read(14, "torque_limit")) == pytest.approx(0.4, abs=0.001)
    clients["set_compliance_slope"].call(clients["set_compliance_slope"].request(slope=255))
    assert robot.bus.read(14, "ccw_compliance_slope", raw=True) == 254  # clamped
    assert robot.bus.read(13, "cw_compliance_slope", raw=True) == 32  # another motor: untouched


def test_stop_start_and_restart_controller_services(robot: Robot) -> None:
    """controller_manager.py's services under /<namespace>/<port>/: a stopped controller's
    topics and services leave the graph and its motor keeps its goal; start brings it back;
    a controller not in the configuration is refused with a reason."""
    srv, base = "dynamixel_controllers/srv/", "/dxl_manager/pan_tilt_port"
    stop = robot.probe.create_client(srv + "StopController", f"{base}/stop_controller")
    start = robot.probe.create_client(srv + "StartController", f"{base}/start_controller")
    restart = robot.probe.create_client(srv + "RestartController",
                                        f"{base}/restart_controller")
    assert stop.call(stop.request(controller_name="controller_m14")).success
    assert "controller_m14" not in robot.manager.controllers
    assert not stop.call(stop.request(controller_name="controller_m14")).success
    graph = robot.context.transport.graph()
    assert not [e for e in graph if e.name.startswith("/controller_m14/")]
    assert [e for e in graph if e.name == "/controller_m13/command"]
    answer = start.call(start.request(controller_name="controller_m14"))
    assert answer.success and "controller_m14" in robot.manager.controllers
    assert restart.call(restart.request(controller_name="controller_m14")).success
    refused = start.call(start.request(controller_name="controller_m99"))
    assert not refused.success and "no controller 'controller_m99'" in refused.reason
    wrong = start.call(start.request(controller_name="controller_m14", package_path="x",
                                     module_name="y", class_name="Z"))
    assert not wrong.success and "x/y/Z is not supported" in wrong.reason


def test_tuning_from_the_configuration_is_written(tmp_path: Path) -> None:
    text = armstrong.CONFIG.read_text().replace(
        "controller_m14:\n", "controller_m14:\n  joint_compliance_slope: 64\n"
        "  joint_torque_limit: 0.5\n")
    path = tmp_path / "tuned.yaml"
    path.write_text(text)
    r = Robot(load(path))
    try:
        assert r.bus.read(14, ["cw_compliance_slope", "ccw_compliance_slope"], raw=True) == {
            "cw_compliance_slope": 64, "ccw_compliance_slope": 64}
        assert float(r.bus.read(14, "torque_limit")) == pytest.approx(0.5, abs=0.001)
        assert r.bus.read(13, "cw_compliance_slope", raw=True) == 32  # untouched: default
    finally:
        r.close()


def test_motor_state_goal_is_what_was_written(robot: Robot) -> None:
    robot.manager.controllers["controller_m14"].command(0.5)
    readings = {r.id: r for r in robot.manager.update()}
    assert readings[14].goal == robot.bus.read(14, "goal_position", raw=True)
    assert readings[14].goal != readings[13].goal or robot.bus.read(13, "goal_position",
                                                                    raw=True) == readings[13].goal
