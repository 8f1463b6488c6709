"""Armstrong shown to a 3D viewer (robots/armstrong/state_publisher.py, on
robots/state_publisher.py), as ROS's
robot_state_publisher shows a robot: ``/robot_description`` latched, ``/joint_states`` from the
joint controllers' states, ``/tf`` and ``/tf_static``.

Facts and oracles, none of them servolab's:

- the joint transform convention is the URDF specification's (wiki.ros.org/urdf/XML/joint):
  ``<origin>`` is the transform from the parent link to the child link, its ``rpy`` "the
  rotation around fixed axis: first roll around x, then pitch around y and finally yaw
  around z"; ``<axis>`` is "specified in the joint frame", the child frame, about which a
  revolute joint turns (along which a prismatic one slides): child = origin x motion(axis, q),
  as kdl_parser builds robot_state_publisher's chain. Frames are REP 103's (right-handed);
  REP 105 names the tree's frames (the robot's links hang from its base link);
- the forward kinematics the published transforms are checked against are computed here from
  the URDF as ``urdf-parser-py`` (ROS's reader) reads it, with rotations as the spec's matrices
  (Rz Ry Rx) and ``scipy.linalg.expm`` of the axis' skew matrix: not the module's scipy
  ``Rotation`` calls;
- the recordings are read with ``mcap`` + ``mcap-ros2-support``, not servolab's bag reader.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from scipy.spatial.transform import Rotation
from urdf_parser_py.urdf import URDF

from servolab.clock import VirtualClock
from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.middleware.qos import qos_profile_latched
from servolab.robots.armstrong.description import model_file
from servolab.robots.armstrong.motions import load_motion
from servolab.robots.armstrong.poses import MOTORS
from servolab.robots.armstrong.run import run_walk
from servolab.robots.armstrong.state_publisher import (
    ArmstrongStatePublisher,
    StatePublisherConfig,
)
from servolab.robots.errors import RobotValueError
from servolab.robots.state_publisher import joint_transforms, rpy_quaternions
from servolab.runs import RunFolder
from tests.robots.urdf_oracle import axis_turn as _axis_turn
from tests.robots.urdf_oracle import homogeneous as _homogeneous
from tests.robots.urdf_oracle import spec_rpy as _spec_rpy
from tests.robots.urdf_oracle import tf_chain, urdf_fk

RNG_SEED = 105
#: motor 62 (the camera) is absent from the seed's bus: its controller does not run
RUNNING = tuple(f"controller_{m}" for m in MOTORS if m != "m62")
TIPS = ("left_sole", "right_sole", "head", "left_forearm", "right_forearm")


@pytest.fixture(scope="module")
def urdf_text() -> str:
    return model_file("urdf")


@pytest.fixture(scope="module")
def robot(urdf_text: str) -> Any:
    return URDF.from_xml_string(urdf_text)


def _reductions(robot: Any) -> dict[str, tuple[str, float]]:
    """controller -> (joint, mechanicalReduction), from the URDF's transmissions."""
    return {f"controller_{t.actuators[0].name}": (t.joints[0].name,
                                                   float(t.actuators[0].mechanicalReduction))
            for t in robot.transmissions}


# -- the pure kinematics ----------------------------------------------------------------------

def test_rpy_is_roll_pitch_yaw_about_the_fixed_axes() -> None:
    rng = np.random.default_rng(RNG_SEED)
    rpy = rng.uniform(-math.pi, math.pi, (20, 3))
    quaternions = rpy_quaternions(rpy)
    assert quaternions.shape == (20, 4)
    for angles, quaternion in zip(rpy, quaternions, strict=True):
        np.testing.assert_allclose(Rotation.from_quat(quaternion).as_matrix(),
                                   _spec_rpy(angles), atol=1e-12)
    # (x, y, z, w): a quarter turn of yaw is (0, 0, sin 45°, cos 45°)
    np.testing.assert_allclose(rpy_quaternions([0.0, 0.0, math.pi / 2]),
                               [0, 0, math.sqrt(0.5), math.sqrt(0.5)], atol=1e-12)
    with pytest.raises(RobotValueError, match="3 angles"):
        rpy_quaternions([0.0, 1.0])


def test_a_joint_moves_its_child_about_or_along_its_axis_in_the_child_frame() -> None:
    rng = np.random.default_rng(RNG_SEED + 1)
    n = 12
    xyz, rpy = rng.normal(size=(n, 3)), rng.uniform(-math.pi, math.pi, (n, 3))
    axis, q = rng.normal(size=(n, 3)), rng.uniform(-3, 3, n)
    prismatic = np.arange(n) % 3 == 0
    translations, rotations = joint_transforms(xyz, rpy, axis, q, prismatic)
    for i in range(n):
        placed = _spec_rpy(rpy[i])
        unit = axis[i] / np.linalg.norm(axis[i])
        if prismatic[i]:
            expected = _homogeneous(placed, xyz[i]) @ _homogeneous(np.eye(3), unit * q[i])
        else:
            expected = _homogeneous(placed, xyz[i]) @ _homogeneous(_axis_turn(unit, q[i]),
                                                                   (0, 0, 0))
        got = _homogeneous(Rotation.from_quat(rotations[i]).as_matrix(), translations[i])
        np.testing.assert_allclose(got, expected, atol=1e-12)
    with pytest.raises(RobotValueError, match="non-zero"):
        joint_transforms([[0, 0, 0]], [[0, 0, 0]], [[0, 0, 0]], [1.0])
    with pytest.raises(RobotValueError, match="shape"):
        joint_transforms([[0, 0, 0]], [[0, 0, 0]], [[0, 0, 1]], [1.0, 2.0])


# -- the node, fed controller states by hand --------------------------------------------------

class Viewer(Node):
    """What a 3D viewer hears, and the joint controllers' state topics to feed."""

    def __init__(self, context: Context, controllers: tuple[str, ...]) -> None:
        super().__init__(context, "viewer")
        self.descriptions: list[Any] = []
        self.statics: list[Any] = []
        self.tf: list[Any] = []
        self.joint_states: list[Any] = []
        self.create_subscription("std_msgs/msg/String", "/robot_description",
                                 self.descriptions.append, qos_profile_latched)
        self.create_subscription("tf2_msgs/msg/TFMessage", "/tf_static", self.statics.append,
                                 qos_profile_latched)
        self.create_subscription("tf2_msgs/msg/TFMessage", "/tf", self.tf.append, 100)
        self.create_subscription("sensor_msgs/msg/JointState", "/joint_states",
                                 self.joint_states.append, 100)
        self.states = {c: self.create_publisher("dynamixel_msgs/msg/JointState",
                                                f"/{c}/state", 10) for c in controllers}

    def report(self, controller: str, position: float) -> None:
        self.states[controller].publish(self.message(
            "dynamixel_msgs/msg/JointState", name=controller, current_pos=position))


@pytest.fixture
def fed() -> Any:
    with Context.open(clock=VirtualClock()) as context:
        publisher = ArmstrongStatePublisher(context, StatePublisherConfig.armstrong(RUNNING))
        viewer = Viewer(context, RUNNING)  # joins late: the latched topics still reach it
        yield context, publisher, viewer


def _spin(context: Context, done: Callable[[], bool]) -> None:
    assert context.spin_until(done, timeout=5.0), "nothing came"


def test_the_description_and_the_fixed_joints_are_latched(fed: Any, urdf_text: str,
                                                         robot: Any) -> None:
    context, _, viewer = fed
    _spin(context, lambda: viewer.descriptions and viewer.statics)
    assert [m.data for m in viewer.descriptions] == [urdf_text]
    (static,) = viewer.statics
    fixed = {(j.parent, j.child) for j in robot.joints if j.type == "fixed"}
    assert {(t.header.frame_id, t.child_frame_id) for t in static.transforms} == fixed
    assert fixed == {("left_foot", "left_sole"), ("right_foot", "right_sole")}


@pytest.mark.parametrize("trial", range(4))
def test_the_tf_chain_is_the_urdfs_forward_kinematics(fed: Any, robot: Any,
                                                      trial: int) -> None:
    context, _, viewer = fed
    rng = np.random.default_rng(RNG_SEED + 10 + trial)
    joints = _reductions(robot)
    q = {}
    for controller in RUNNING:
        joint, reduction = joints[controller]
        limit = robot.joint_map[joint].limit
        q[joint] = float(rng.uniform(limit.lower, limit.upper))
        viewer.report(controller, reduction * q[joint])  # the motor's angle
    _spin(context, lambda: viewer.joint_states and viewer.tf and viewer.statics)
    (state,) = viewer.joint_states
    (tf,) = viewer.tf
    movable = [j.name for j in robot.joints if j.type != "fixed"]
    assert list(state.name) == movable and len(movable) == 21
    assert dict(zip(state.name, state.position, strict=True)) == pytest.approx(
        {**q, "camera": 0.0}, abs=1e-12)   # motor 62 absent: its joint at its zero
    assert len(tf.transforms) == 21
    assert all(t.header.stamp == state.header.stamp for t in tf.transforms)
    transforms = [*tf.transforms, *viewer.statics[0].transforms]
    for tip in TIPS:
        np.testing.assert_allclose(tf_chain(transforms, robot.get_root(), tip),
                                   urdf_fk(robot, tip, q), atol=1e-12)


def test_one_joint_states_a_sweep_and_a_silent_controller_does_not_stop_them(
        fed: Any) -> None:
    context, publisher, viewer = fed
    for controller in RUNNING[:-1]:
        viewer.report(controller, 0.1)
    assert not context.spin_until(lambda: viewer.joint_states, timeout=0.5)
    viewer.report(RUNNING[-1], 0.1)    # the set is complete
    _spin(context, lambda: len(viewer.joint_states) == 1)
    for controller in RUNNING[:-1]:    # the last one falls silent
        viewer.report(controller, 0.2)
    viewer.report(RUNNING[0], 0.3)     # a second report: what is known goes out
    _spin(context, lambda: len(viewer.joint_states) == 2)
    _spin(context, lambda: len(viewer.tf) == 2)
    assert publisher.published == 2


def test_a_controller_silent_from_the_start_delays_the_first_joint_states(fed: Any) -> None:
    context, _, viewer = fed
    for value in (0.1, 0.2):            # the last controller is never heard
        for controller in RUNNING[:-1]:
            viewer.report(controller, value)
    assert not context.spin_until(lambda: viewer.joint_states, timeout=0.5)
    viewer.report(RUNNING[0], 0.3)      # STARTUP_REPORTS (3) reports of one: out they go
    _spin(context, lambda: len(viewer.joint_states) == 1)
    (state,) = viewer.joint_states
    assert sorted(set(state.position)) == [-0.2, 0.0, 0.2]   # the silent joint at 0


def test_a_controller_without_a_transmission_is_refused() -> None:
    with Context.open(clock=VirtualClock()) as context:
        with pytest.raises(RobotValueError, match="no transmission whose actuator is 'm99'"):
            ArmstrongStatePublisher(context, StatePublisherConfig.armstrong(["controller_m99"]))
        with pytest.raises(RobotValueError, match="not XML"):
            ArmstrongStatePublisher(context, StatePublisherConfig("<robot"))


# -- servolab walk: what the bag holds ---------------------------------------------------------

def _read(bag: Path) -> dict[str, list[tuple[int, Any]]]:
    """topic -> [(log time ns, decoded message)], by mcap + mcap-ros2-support."""
    (path,) = bag.glob("*.mcap")
    out: dict[str, list[tuple[int, Any]]] = {}
    with path.open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        for _, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True):
            out.setdefault(channel.topic, []).append((message.log_time, decoded))
    return out


def _ns(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


@pytest.fixture(scope="module", params=["kinematic", "mujoco"])
def walked(request: pytest.FixtureRequest,
           tmp_path_factory: pytest.TempPathFactory) -> dict[str, list[tuple[int, Any]]]:
    """One step of the seed's gait, each world: the shortest walk there is."""
    run = RunFolder.create("walk", tmp_path_factory.mktemp("walk"))
    summary = run_walk(run, load_motion(None), steps=1, say=lambda s: None,
                       show_progress=False, world=request.param)
    return _read(Path(summary["bag"]))


@pytest.mark.slow
def test_a_walk_records_the_robot_description_once(
        walked: dict[str, list[tuple[int, Any]]], urdf_text: str) -> None:
    ((_, description),) = walked["/robot_description"]
    assert description.data == urdf_text
    robot = URDF.from_xml_string(description.data)
    assert robot.get_root() == "pelvis" and len(robot.joints) == 23
    ((_, static),) = walked["/tf_static"]
    assert sorted(t.child_frame_id for t in static.transforms) == ["left_sole", "right_sole"]


def test_a_walks_joint_states_are_what_the_controllers_reported(
        walked: dict[str, list[tuple[int, Any]]], robot: Any) -> None:
    joint_states = walked["/joint_states"]
    joints = _reductions(robot)
    # each controller's states, by when they were heard (a state's stamp is when its motor
    # was read; the manager publishes a sweep's states together, at its end)
    states = {c: ([t for t, _ in walked[f"/{c}/state"]],
                  [m.current_pos for _, m in walked[f"/{c}/state"]]) for c in RUNNING}
    # one /joint_states a sweep of the manager, as many as each controller's states
    assert abs(len(joint_states) - len(states[RUNNING[0]][0])) <= 1
    assert len(joint_states) > 30
    for heard, message in joint_states:
        assert _ns(message.header.stamp) == heard   # stamped when published (virtual time)
        position = dict(zip(message.name, message.position, strict=True))
        assert position["camera"] == 0.0            # motor 62 absent
        for controller in RUNNING:
            stamps, values = states[controller]
            k = int(np.searchsorted(stamps, heard, side="right")) - 1
            joint, reduction = joints[controller]
            assert k >= 0 and position[joint] == pytest.approx(values[k] / reduction,
                                                               abs=1e-12)
    # they follow the gait: the knees bend and straighten by tens of degrees
    for knee in ("left_knee", "right_knee"):
        index = list(joint_states[0][1].name).index(knee)
        angles = np.degrees([m.position[index] for _, m in joint_states])
        assert np.ptp(angles) > 20


def test_a_walks_tf_places_the_feet_where_its_joint_states_put_them(
        walked: dict[str, list[tuple[int, Any]]], robot: Any) -> None:
    joint_states = walked["/joint_states"]
    # the joints' transforms; in MuJoCo the ground truth also places the pelvis in the world
    # on /tf (sim/mujoco_truth.py), one transform world -> pelvis a sample
    tf = [(t, m) for t, m in walked["/tf"] if m.transforms[0].header.frame_id != "world"]
    placed = [m for _, m in walked["/tf"] if m.transforms[0].header.frame_id == "world"]
    assert all([t.child_frame_id for t in m.transforms] == ["pelvis"] for m in placed)
    assert len(tf) == len(joint_states)
    ((_, static),) = walked["/tf_static"]
    for (_, state), (_, transforms) in zip(joint_states[::7], tf[::7], strict=True):
        assert {_ns(t.header.stamp) for t in transforms.transforms} == {
            _ns(state.header.stamp)}
        q = dict(zip(state.name, state.position, strict=True))
        chain = [*transforms.transforms, *static.transforms]
        for tip in TIPS:
            np.testing.assert_allclose(tf_chain(chain, "pelvis", tip),
                                       urdf_fk(robot, tip, q), atol=1e-9)
