"""The generic robot_state_publisher (robots/state_publisher.py) on a small arm written in
tests/robots/test_description.py: a prismatic lift, a continuous wrist about a slanted axis, a
revolute finger and its mirror, a mimic joint, a fixed camera.

Facts and oracles, none of them servolab's:

- ROS 2's robot_state_publisher: ``/robot_description`` latched (transient local), fixed
  joints once on latched ``/tf_static``, movable joints on ``/tf`` for every
  ``sensor_msgs/JointState`` on ``/joint_states``, stamped as the message, for the joints it
  names (github.com/ros/robot_state_publisher, README "Published Topics", "Subscribed
  Topics");
- URDF ``<mimic>`` (wiki.ros.org/urdf/XML/joint): "value = multiplier * other_joint_value +
  offset"; robot_state_publisher places a mimic joint from its leader's position that way;
- the transforms are checked against the forward kinematics of ``urdf-parser-py``'s parse
  with the URDF specification's matrices (tests/robots/urdf_oracle.py), the mimic's value
  computed from urdf-parser-py's ``mimic`` element.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from urdf_parser_py.urdf import URDF

from servolab.clock import VirtualClock
from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.middleware.qos import qos_profile_latched
from servolab.robots.errors import RobotValueError
from servolab.robots.state_publisher import (
    ControllerStates,
    RobotStatePublisher,
    follow_mimics,
)
from tests.robots.test_description import ARM
from tests.robots.urdf_oracle import tf_chain, urdf_fk

TIPS = ("left_finger", "right_finger", "camera")
LEADERS = ("lift", "wrist_roll", "left_finger_joint")


class Driver(Node):
    """A robot's driver publishing /joint_states, and a viewer hearing what is shown."""

    def __init__(self, context: Context) -> None:
        super().__init__(context, "driver")
        self.descriptions: list[Any] = []
        self.statics: list[Any] = []
        self.tf: list[Any] = []
        self.create_subscription("std_msgs/msg/String", "/robot_description",
                                 self.descriptions.append, qos_profile_latched)
        self.create_subscription("tf2_msgs/msg/TFMessage", "/tf_static", self.statics.append,
                                 qos_profile_latched)
        self.create_subscription("tf2_msgs/msg/TFMessage", "/tf", self.tf.append, 100)
        self.states = self.create_publisher("sensor_msgs/msg/JointState", "/joint_states", 10)

    def send(self, positions: dict[str, float], sec: int = 7, nanosec: int = 25) -> None:
        self.states.publish(self.message(
            "sensor_msgs/msg/JointState",
            header={"stamp": {"sec": sec, "nanosec": nanosec}},
            name=list(positions), position=list(positions.values())))


@pytest.fixture
def shown() -> Any:
    with Context.open(clock=VirtualClock()) as context:
        publisher = RobotStatePublisher(context, ARM)
        driver = Driver(context)      # joins late: the latched topics still reach it
        yield context, publisher, driver


@pytest.fixture(scope="module")
def robot() -> Any:
    return URDF.from_xml_string(ARM)


def _spin(context: Context, done: Callable[[], bool]) -> None:
    assert context.spin_until(done, timeout=5.0), "nothing came"


def _with_mimics(robot: Any, q: dict[str, float]) -> dict[str, float]:
    """The oracle's mimic: value = multiplier * other_joint_value + offset (URDF spec)."""
    out = dict(q)
    for joint in robot.joints:
        if joint.mimic is not None:
            out[joint.name] = (joint.mimic.multiplier * q[joint.mimic.joint]
                               + joint.mimic.offset)
    return out


def test_the_description_and_the_fixed_joints_are_latched(shown: Any) -> None:
    context, publisher, driver = shown
    _spin(context, lambda: driver.descriptions and driver.statics)
    assert [m.data for m in driver.descriptions] == [ARM]
    (static,) = driver.statics
    (camera,) = static.transforms
    assert (camera.header.frame_id, camera.child_frame_id) == ("carriage", "camera")
    assert publisher.topics == {"/robot_description": "std_msgs/msg/String",
                                "/tf": "tf2_msgs/msg/TFMessage",
                                "/tf_static": "tf2_msgs/msg/TFMessage"}


@pytest.mark.parametrize("trial", range(3))
def test_tf_follows_joint_states_with_the_mimic_from_its_leader(shown: Any, robot: Any,
                                                               trial: int) -> None:
    context, _, driver = shown
    rng = np.random.default_rng(42 + trial)
    q = {"lift": float(rng.uniform(0, 0.2)), "wrist_roll": float(rng.uniform(-6, 6)),
         "left_finger_joint": float(rng.uniform(-0.5, 0.8))}
    driver.send(q, sec=7 + trial)
    _spin(context, lambda: driver.tf and driver.statics)
    (tf,) = driver.tf
    assert {t.child_frame_id for t in tf.transforms} == {
        "carriage", "wrist", "left_finger", "right_finger"}     # the mimic goes with them
    assert all((t.header.stamp.sec, t.header.stamp.nanosec) == (7 + trial, 25)
               for t in tf.transforms)                          # the message's stamp
    transforms = [*tf.transforms, *driver.statics[0].transforms]
    full = _with_mimics(robot, q)
    for tip in TIPS:
        np.testing.assert_allclose(tf_chain(transforms, robot.get_root(), tip),
                                   urdf_fk(robot, tip, full), atol=1e-12)


def test_only_the_joints_a_message_names_and_their_mimics_are_sent(shown: Any,
                                                                   robot: Any) -> None:
    context, _, driver = shown
    driver.send({"lift": 0.1, "unknown_joint": 3.0})
    _spin(context, lambda: len(driver.tf) == 1)
    assert [t.child_frame_id for t in driver.tf[0].transforms] == ["carriage"]
    # a value for the mimic itself is not the mimic's: its leader's makes it
    driver.send({"left_finger_joint": 0.4, "right_finger_joint": 9.0})
    _spin(context, lambda: len(driver.tf) == 2)
    by_child = {t.child_frame_id: t for t in driver.tf[1].transforms}
    assert set(by_child) == {"left_finger", "right_finger"}
    _spin(context, lambda: driver.statics)
    transforms = [*driver.tf[1].transforms, *driver.tf[0].transforms]
    # the wrist never named: the chain from the carriage to the fingers at wrist_roll = 0
    got = tf_chain([*transforms, *driver.statics[0].transforms], "wrist", "right_finger")
    full = _with_mimics(robot, {"lift": 0.1, "wrist_roll": 0.0, "left_finger_joint": 0.4})
    expected = np.linalg.inv(urdf_fk(robot, "wrist", full)) @ urdf_fk(robot, "right_finger",
                                                                       full)
    np.testing.assert_allclose(got, expected, atol=1e-12)


def test_a_message_whose_names_and_positions_differ_is_dropped(shown: Any) -> None:
    context, publisher, driver = shown
    driver.states.publish(driver.message("sensor_msgs/msg/JointState",
                                         name=["lift", "wrist_roll"], position=[0.1]))
    driver.send({"lift": 0.05})
    _spin(context, lambda: driver.tf)
    assert publisher.published == 1 and len(driver.tf) == 1
    assert publisher.positions.tolist()[:2] == [0.05, 0.0]


def test_follow_mimics_is_multiplier_times_leader_plus_offset() -> None:
    q = np.array([0.3, 2.0, -1.0, 5.0])
    out = follow_mimics(q, [-1, -1, 0, 1], [1.0, 1.0, -2.0, 0.5], [0.0, 0.0, 0.1, -0.2])
    np.testing.assert_allclose(out, [0.3, 2.0, -2.0 * 0.3 + 0.1, 0.5 * 2.0 - 0.2])
    assert q[2] == -1.0                     # arrays in, arrays out: the input untouched


def test_a_bad_description_is_refused_in_one_line() -> None:
    with Context.open(clock=VirtualClock()) as context:
        bad = ARM.replace('multiplier="-1.5"', 'multiplier="lots"')
        assert bad != ARM
        with pytest.raises(RobotValueError) as caught:
            RobotStatePublisher(context, bad)
        message = str(caught.value)
        assert "\n" not in message
        assert "right_finger_joint" in message and "<mimic>" in message and "lots" in message


def test_with_controllers_it_publishes_joint_states_and_the_mimic_follows() -> None:
    """The option Armstrong uses: dynamixel_msgs controller states in, /joint_states out;
    the arm's <transmission> names actuator m1 on the lift, reduction 1."""
    with Context.open(clock=VirtualClock()) as context:
        publisher = RobotStatePublisher(context, ARM,
                                        controllers=ControllerStates(("controller_m1",)))
        driver = Driver(context)
        heard: list[Any] = []
        driver.create_subscription("sensor_msgs/msg/JointState", "/joint_states",
                                   heard.append, 10)
        report = driver.create_publisher("dynamixel_msgs/msg/JointState",
                                         "/controller_m1/state", 10)
        report.publish(driver.message("dynamixel_msgs/msg/JointState", name="controller_m1",
                                      current_pos=0.12, velocity=0.01))
        _spin(context, lambda: heard and driver.tf)
        (state,) = heard
        positions = dict(zip(state.name, state.position, strict=True))
        # the lift where its controller says; the mimic at -1.5 x 0 + 0.1 from its leader at 0
        assert positions == pytest.approx({"lift": 0.12, "wrist_roll": 0.0,
                                           "left_finger_joint": 0.0,
                                           "right_finger_joint": 0.1})
        assert "/joint_states" in publisher.topics
        with pytest.raises(RobotValueError, match="no transmission whose actuator is 'm9'"):
            RobotStatePublisher(context, ARM, name="other",
                                controllers=ControllerStates(("controller_m9",)))
