"""``/motor_states/<port>`` and each joint's ``/<controller>/state``, field by field and sign
by sign, on a straight joint and on a reversed one (``min > max`` in the controller YAML).

Facts checked, and where they come from:

- ROS dynamixel_motor (arebgun/dynamixel_motor, commit 3d84232),
  ``dynamixel_driver/dynamixel_io.py`` ``get_feedback``: the MotorState a driver publishes is
  the motor's own, whatever joint it drives: ``goal`` and ``position`` raw, ``error =
  position - goal`` raw, ``speed`` the raw Present Speed with bit 10 (clockwise) as a minus
  sign, ``load`` the Present Load's ratio with bit 10 as a minus sign, ``voltage`` the raw
  value / 10, ``temperature`` the raw value (deg C), ``moving`` the Moving byte;
  ``dynamixel_msgs/msg/MotorState.msg``: speed in 0.111 rpm units, load a ratio of the
  maximum torque, voltage in V, temperature in deg C (int32).
- The same repository's ``dynamixel_controllers/joint_position_controller.py``
  ``process_motor_states``: the JointState's ``velocity`` is ``state.speed *
  VELOCITY_PER_TICK`` (rad/s), its ``load`` is ``state.load`` and ``motor_temps`` is
  ``[state.temperature]``. ROS does *not* flip velocity or load for a reversed joint (nor
  error): servolab gives the joint's state in the joint's own sense (see the controller's
  module docstring), so on a reversed joint ``current_pos``, ``error``, ``velocity`` and
  ``load`` all have the opposite sign of a straight joint's, and ``velocity`` has the sign of
  ``current_pos``'s change.
- ROBOTIS e-Manual, Protocol 1.0 control table (RX-28 and MX-28 pages): Present Speed(38)
  0..2047, 0..1023 counter-clockwise, 1024..2047 clockwise ("the 10th bit becomes the
  direction bit"), about 0.111 rpm a unit on the RX-28; Present Load(40) the same with bit 10
  ("CW Load: Load Direction = 1"), about 0.1 % a unit ("512 ... about 50 % of the maximum
  torque"); Present Voltage(42) 10 times the voltage; Present Temperature(43) deg C.

Two differences from the ROS driver's arithmetic are kept on purpose and pinned here: a
clockwise speed of magnitude k is -k (the e-Manual's bit 10), where ``get_feedback``'s
``1023 - speed`` gives -(k + 1); and the load is the e-Manual's 0.1 % a unit (raw 250 ->
0.25), where ``get_feedback`` divides by 1024 (-> 0.244).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from servolab.dynamixel.plant import ServoCommand
from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.robots.armstrong import hardware as armstrong
from servolab.robots.controllers.config import load
from servolab.robots.controllers.manager import DynamixelManager
from servolab.sim.simulation import Simulation

INIT = 512
# Two RX-28 controllers written as dynamixel_controllers' YAML has them (seed 001 Listing
# 3.1): motor 1 straight, motor 2 reversed (min > max: dynamixel_controllers' "flipped").
CONFIG = f"""\
dynamixel_manager:
  namespace: dxl_manager
  serial_ports:
    test_port: {{port_name: /dev/null, baud_rate: 1000000.0, min_motor_id: 1,
                max_motor_id: 3, update_rate: 20}}
straight:
  controller: {{package: dynamixel_controllers, module: joint_position_controller,
               type: JointPositionController}}
  joint_name: straight_joint
  joint_speed: 1.0
  motor: {{id: 1, init: {INIT}, min: 0, max: 1023}}
reversed:
  controller: {{package: dynamixel_controllers, module: joint_position_controller,
               type: JointPositionController}}
  joint_name: reversed_joint
  joint_speed: 1.0
  motor: {{id: 2, init: {INIT}, min: 1023, max: 0}}
"""
RX28_SPEED_UNIT_RPM = 0.111  # e-Manual, RX-28 Present Speed
RPM = 2 * math.pi / 60


class FixedPlant:
    """A joint whose state the test sets: what the firmware shows in present_* (the
    ServoPlant interface of servolab.dynamixel.plant)."""

    def __init__(self, position: float, velocity: float, effort: float,
                 temperature: float) -> None:
        self.command = ServoCommand()
        self.position = position
        self.velocity = velocity
        self.effort = effort
        self.temperature = temperature

    def step(self, dt: float) -> None:
        pass


class Robot:
    """The two-joint robot on emulated RX-28, its manager, and a probe that listens."""

    def __init__(self, tmp_path: Path) -> None:
        path = tmp_path / "controllers.yaml"
        path.write_text(CONFIG)
        config = load(path)
        self.sim = Simulation()
        self.bus, self.port = armstrong.open_bus(config, simulation=self.sim, absent=())
        self.config = config
        self.context = Context.open(clock=self.sim)
        self.manager: DynamixelManager | None = None
        self.probe = Node(self.context, "probe")
        self.motor_states: list[Any] = []
        self.joint_states: dict[str, list[Any]] = {"straight": [], "reversed": []}

    def start(self) -> DynamixelManager:
        self.manager = DynamixelManager(self.context, self.bus, self.port,
                                        self.config.controllers)
        self.probe.create_subscription("dynamixel_msgs/msg/MotorStateList",
                                       "/motor_states/test_port", self.motor_states.append)
        for name, got in self.joint_states.items():
            self.probe.create_subscription("dynamixel_msgs/msg/JointState", f"/{name}/state",
                                           got.append)
        return self.manager

    def hold(self, *, ticks_from_init: int, speed_units: int, load: float,
             temperature: float, supply: float) -> None:
        """Both motors show the same state: at INIT + ``ticks_from_init``, turning at
        ``speed_units`` (signed, 0.111 rpm), loaded ``load`` (signed fraction)."""
        unit = RX28_SPEED_UNIT_RPM * RPM
        for motor_id in (1, 2):
            position = float(self.bus.to_si(motor_id, "present_position",
                                            INIT + ticks_from_init))
            motor = self.bus.emulator.motor(motor_id)
            motor.attach_plant(FixedPlant(position, speed_units * unit, load, temperature))
            motor.supply_voltage = supply

    def next_update(self) -> tuple[dict[int, Any], dict[str, Any]]:
        """The motor states and joint states of the next whole update."""
        before = len(self.motor_states)
        lengths = {n: len(s) for n, s in self.joint_states.items()}
        ok = self.context.spin_until(
            lambda: len(self.motor_states) > before
            and all(len(s) > lengths[n] for n, s in self.joint_states.items()), timeout=5.0)
        assert ok, "no update of /motor_states and both joints' /state"
        motors = {m.id: m for m in self.motor_states[-1].motor_states}
        return motors, {n: s[-1] for n, s in self.joint_states.items()}

    def close(self) -> None:
        self.context.close()
        self.bus.close()


@pytest.fixture
def robot(tmp_path: Path) -> Iterator[Robot]:
    r = Robot(tmp_path)
    try:
        yield r
    finally:
        r.close()


# The emulated RX-28 shows supply - 0.3 |load| as its Present Voltage: 14.875 - 0.075 = 14.8.
SUPPLY, VOLTS = 14.875, 14.8


@pytest.mark.parametrize("sign", [1, -1], ids=["ccw", "cw"])
def test_motor_states_carry_the_motors_raw_values_whatever_the_joint(robot: Robot,
                                                                     sign: int) -> None:
    """get_feedback (dynamixel_io.py): the MotorState is the motor's, raw, signed by bit 10;
    a reversed joint's motor reports exactly as a straight one's."""
    robot.hold(ticks_from_init=10 * sign, speed_units=100 * sign, load=0.25 * sign,
               temperature=47.0, supply=SUPPLY)
    robot.start()
    # the registers as the e-Manual lays them out: bit 10 is the clockwise direction
    raw = robot.bus.read(2, ["present_speed", "present_load", "present_voltage",
                             "present_temperature"], raw=True)
    assert raw == {"present_speed": 100 if sign > 0 else 1024 + 100,
                   "present_load": 250 if sign > 0 else 1024 + 250,
                   "present_voltage": 148, "present_temperature": 47}
    motors, _ = robot.next_update()
    assert sorted(motors) == [1, 2]
    for motor_id in (1, 2):
        m = motors[motor_id]
        assert m.goal == INIT                         # raw, read back from the motor
        assert m.position == INIT + 10 * sign         # raw encoder units
        assert m.error == 10 * sign                   # position - goal, raw
        assert m.speed == 100 * sign                  # 0.111 rpm units, CW negative
        assert m.load == pytest.approx(0.25 * sign, abs=1e-12)  # 0.1 % a unit, CW negative
        assert m.voltage == pytest.approx(VOLTS, abs=1e-9)      # raw / 10
        assert m.temperature == 47                    # deg C
        assert m.moving is True


@pytest.mark.parametrize("sign", [1, -1], ids=["ccw", "cw"])
def test_joint_state_of_a_reversed_joint_has_velocity_and_load_inverted(robot: Robot,
                                                                        sign: int) -> None:
    """process_motor_states (joint_position_controller.py): velocity = speed x rad/s per
    unit, load = the MotorState's, motor_temps = [temperature]; servolab states a reversed
    joint in its own sense, so position, error, velocity and load all change sign."""
    robot.hold(ticks_from_init=10 * sign, speed_units=100 * sign, load=0.25 * sign,
               temperature=47.0, supply=SUPPLY)
    manager = robot.start()
    rad_per_tick = float(robot.bus.to_si(1, "present_position", INIT + 1)) - float(
        robot.bus.to_si(1, "present_position", INIT))
    speed = 100 * RX28_SPEED_UNIT_RPM * RPM        # rad/s of 100 units
    assert manager.controllers["reversed"].geometry.flipped
    assert not manager.controllers["straight"].geometry.flipped
    _, joints = robot.next_update()
    for name, joint_sign in (("straight", sign), ("reversed", -sign)):
        j = joints[name]
        assert list(j.motor_ids) == [1 if name == "straight" else 2]
        assert list(j.motor_temps) == [47]
        assert j.goal_pos == pytest.approx(0.0, abs=1e-12)
        assert j.current_pos == pytest.approx(joint_sign * 10 * rad_per_tick, rel=1e-9)
        assert j.error == pytest.approx(j.current_pos - j.goal_pos, abs=1e-12)
        assert j.velocity == pytest.approx(joint_sign * speed, rel=1e-3)
        assert j.load == pytest.approx(joint_sign * 0.25, abs=1e-12)
        assert j.is_moving is True


def test_velocity_has_the_sign_of_the_joints_motion(robot: Robot) -> None:
    """On the emulated motors' own plant: a command of +0.3 rad turns the straight motor
    counter-clockwise (MotorState speed > 0) and the reversed one clockwise (speed < 0, the
    motor's raw sign, as get_feedback gives it); both joints' velocity is positive, the way
    their current_pos goes (the JointState in the joint's own sense)."""
    manager = robot.start()
    for controller in manager.controllers.values():
        controller.set_speed(0.5)   # slow enough to be seen moving for several updates
        controller.command(0.3)
    moving: list[tuple[dict[int, Any], dict[str, Any]]] = []
    for _ in range(50):
        motors, joints = robot.next_update()
        if all(j.is_moving for j in joints.values()):
            moving.append((motors, joints))
        if len(moving) >= 3:
            break
    assert len(moving) >= 3, "the joints were never seen moving"
    (_, first), (motors, last) = moving[0], moving[-1]
    assert motors[1].speed > 0 and motors[2].speed < 0
    assert motors[1].position > INIT and motors[2].position < INIT
    for name in ("straight", "reversed"):
        assert last[name].current_pos > first[name].current_pos >= 0.0
        assert last[name].velocity == pytest.approx(0.5, rel=0.05)
