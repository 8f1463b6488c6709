"""Message types: lookup, YAML values as ``rostopic pub`` takes them, CDR through rosbags."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servolab.middleware.errors import MessageError
from servolab.middleware.messages import MessageTypes

TYPES = MessageTypes()


def test_twist_from_rostopic_style_yaml() -> None:
    msg = TYPES.from_yaml("geometry_msgs/msg/Twist", "{linear: {x: 0.1}, angular: {z: 0.5}}")
    assert TYPES.to_value(msg) == {"linear": {"x": 0.1, "y": 0.0, "z": 0.0},
                                   "angular": {"x": 0.0, "y": 0.0, "z": 0.5}}


def test_ros1_spelling_bare_value_and_positional_list() -> None:
    assert TYPES.from_yaml("std_msgs/Float64", "1.5").data == 1.5
    vec = TYPES.from_yaml("geometry_msgs/msg/Vector3", "[1, 2, 3]")
    assert (vec.x, vec.y, vec.z) == (1.0, 2.0, 3.0)


@pytest.mark.parametrize(("type_name", "text", "names"), [
    ("std_msgs/msg/Float64", "abc", ["std_msgs/msg/Float64", "data", "'abc'", "float64"]),
    ("std_msgs/msg/UInt8", "300", ["data", "300", "uint8"]),
    ("std_msgs/msg/Int32", "1.5", ["data", "1.5", "int32"]),
    ("std_msgs/msg/String", "42", ["data", "42", "string"]),
    ("std_msgs/msg/Bool", "2", ["data", "bool"]),
    ("geometry_msgs/msg/Twist", "{linear: {q: 1}}", ["linear.q", "'q'", "x, y, z"]),
    ("geometry_msgs/msg/Twist", "{linear: [1, 2]}", ["linear", "Vector3"]),
    ("geometry_msgs/msg/PoseWithCovariance", "{covariance: [1, 2]}",
     ["covariance", "36", "2"]),
    ("std_msgs/msg/Float64", "{data: [1", ["not YAML", "line 1"]),
    ("no_msgs/msg/Nothing", "{}", ["unknown message type", "no_msgs/msg/Nothing"]),
    ("Twist", "{}", ["unknown message type", "did you mean geometry_msgs/msg/Twist"]),
])
def test_bad_values_name_the_type_field_and_value(type_name: str, text: str,
                                                  names: list[str]) -> None:
    with pytest.raises(MessageError) as info:
        TYPES.from_yaml(type_name, text)
    message = str(info.value)
    assert "\n" not in message
    for part in names:
        assert part in message


def test_defaults_are_rosidl_defaults() -> None:
    js = TYPES.default("sensor_msgs/msg/JointState")
    assert js.name == [] and js.position.dtype == np.float64 and len(js.position) == 0
    assert TYPES.default("geometry_msgs/msg/PoseWithCovariance").covariance.shape == (36,)
    assert TYPES.default("geometry_msgs/msg/Quaternion").w == 0.0  # rosbags: all zero


def test_image_pixels_as_an_array_are_checked_whole() -> None:
    pixels = np.arange(640 * 376, dtype=np.int64) % 256
    img = TYPES.from_value("sensor_msgs/msg/Image", {"height": 376, "width": 640,
                                                     "encoding": "mono8", "step": 640,
                                                     "data": pixels})
    assert img.data.dtype == np.uint8 and np.array_equal(img.data, pixels)
    with pytest.raises(MessageError, match="data: values outside uint8"):
        TYPES.from_value("sensor_msgs/msg/Image", {"data": np.array([0, 256])})


def test_dynamixel_msgs_as_the_ros_package_defines_them() -> None:
    state = TYPES.from_value("dynamixel_msgs/msg/MotorState",
                             {"timestamp": 1.5, "id": 14, "goal": 512, "position": 500,
                              "error": -12, "speed": 0, "load": -0.15625, "voltage": 12.1,
                              "temperature": 56, "moving": False})
    states = TYPES.from_value("dynamixel_msgs/msg/MotorStateList", {"motor_states": [state]})
    back = TYPES.deserialize(TYPES.serialize(states), "dynamixel_msgs/msg/MotorStateList")
    assert TYPES.to_value(back) == TYPES.to_value(states)
    joint = TYPES.from_yaml("dynamixel_msgs/msg/JointState",
                            "{name: pan_joint_14, motor_ids: [14], motor_temps: [56], "
                            "goal_pos: -0.751650586064, current_pos: -0.787443471115, "
                            "error: -0.0357928850507, velocity: 0.0, load: -0.15625, "
                            "is_moving: false}")
    assert joint.motor_ids.tolist() == [14] and joint.goal_pos == -0.751650586064
    assert "MSG: dynamixel_msgs/MotorState" in TYPES.msgdef("dynamixel_msgs/msg/MotorStateList")


def test_cdr_is_rosbags_and_little_endian_with_encapsulation_header() -> None:
    twist = TYPES.from_value("geometry_msgs/msg/Twist", {"linear": {"x": 1.0}})
    data = TYPES.serialize(twist)
    assert data[:4] == b"\x00\x01\x00\x00"  # CDR_LE
    assert len(data) == 4 + 6 * 8
    assert data == bytes(TYPES.store.serialize_cdr(twist, "geometry_msgs/msg/Twist"))
    with pytest.raises(MessageError, match="not a CDR geometry_msgs/msg/Twist"):
        TYPES.deserialize(data[:20], "geometry_msgs/msg/Twist")


def test_type_hashes_and_dds_names_follow_rosidl() -> None:
    # The anchors are rmw_zenoh's design document examples, computed there by rosidl.
    assert TYPES.rihs01("std_msgs/msg/String") == (
        "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18")
    assert TYPES.rihs01("example_interfaces/srv/AddTwoInts") == (
        "RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a")
    assert TYPES.dds_name("geometry_msgs/msg/Twist") == "geometry_msgs::msg::dds_::Twist_"


def test_services_have_request_and_response_types() -> None:
    srv = TYPES.service("dynamixel_controllers/srv/SetSpeed")
    assert TYPES.from_value(srv.request, {"speed": 1.2}).speed == 1.2
    TYPES.default(srv.response)
    with pytest.raises(MessageError, match="unknown service type 'x/srv/Y'"):
        TYPES.service("x/srv/Y")


@settings(max_examples=60, deadline=None)
@given(x=st.floats(allow_nan=False), n=st.integers(-(2**31), 2**31 - 1),
       names=st.lists(st.text(max_size=8), max_size=4))
def test_values_round_trip_through_cdr(x: float, n: int, names: list[str]) -> None:
    value = {"header": {"stamp": {"sec": n, "nanosec": 7}, "frame_id": "base"},
             "name": names, "position": [x] * len(names), "velocity": [], "effort": []}
    msg = TYPES.from_value("sensor_msgs/msg/JointState", value)
    back = TYPES.deserialize(TYPES.serialize(msg), "sensor_msgs/msg/JointState")
    assert TYPES.to_value(back) == value


def test_the_package_re_exports_its_public_api_lazily() -> None:
    """``from servolab.middleware import Node, Context, ...`` works for every name in
    ``__all__``, each the class its module defines, without importing them all up front."""
    import subprocess
    import sys

    import servolab.middleware as middleware

    assert set(middleware.__all__) == set(middleware._EXPORTS)
    for name in middleware.__all__:
        value = getattr(middleware, name)
        assert value.__module__.startswith("servolab.middleware."), name
    code = ("import sys, servolab.middleware.errors\n"
            "print(any(m == 'servolab.middleware.bag' or m.startswith('servolab.middleware.bag.')"
            " for m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=60, check=True).stdout
    assert out.strip() == "False"
