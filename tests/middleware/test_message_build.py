"""from_value's fast path (servolab.middleware.message_build) builds exactly what its walk
builds: random plain values for every type the robots use, built both ways, serialize to the
same CDR bytes (the oracle is the walk, which the rest of the suite checks against rosbags,
rclpy and the e-Manual's units), and what the fast path declines still builds or fails as
before."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from rosbags.interfaces import Nodetype

from servolab.middleware.errors import MessageError
from servolab.middleware.message_build import Slow
from servolab.middleware.messages import MessageTypes
from tests.fuzzing import fuzzing
from tests.middleware.test_malformed import ROBOT_TYPES

TYPES = MessageTypes()
_INTS = {"int8": 7, "uint8": 8, "byte": 8, "char": 8, "int16": 15, "uint16": 16, "int32": 31,
         "uint32": 32, "int64": 63, "uint64": 64}


@contextmanager
def walk_only(types: MessageTypes) -> Iterator[None]:
    """from_value with its fast path declining everything: the walk alone."""
    def declines(name: str) -> Any:
        def build(value: Any) -> Any:
            raise Slow
        return build
    types.builder = declines  # type: ignore[method-assign]
    try:
        yield
    finally:
        del types.builder


def _value(data: st.DataObject, desc: Any, depth: int = 0) -> Any:
    """A plain value a user might give a field of ``desc`` (or leave out: see _message)."""
    kind = desc[0]
    if kind == Nodetype.BASE:
        base, bound = desc[1]
        if base in ("float32", "float64"):
            return data.draw(st.one_of(st.floats(-1e6, 1e6, width=32), st.integers(-9, 9)))
        if base in _INTS:
            bits = _INTS[base]
            low, high = (0, 2**bits - 1) if base.startswith("u") or base in (
                "byte", "char") else (-(2**bits), 2**bits - 1)
            return data.draw(st.integers(low, high))
        if base == "bool":
            return data.draw(st.booleans())
        return data.draw(st.text(max_size=bound or 8))
    if kind == Nodetype.NAME:
        return _message(data, desc[1], depth + 1)
    sub, count = desc[1]
    n = count if kind == Nodetype.ARRAY else data.draw(st.integers(0, min(count or 3, 3)))
    return [_value(data, sub, depth + 1) for _ in range(n)]


def _message(data: st.DataObject, name: str, depth: int = 0) -> dict[str, Any]:
    _, fields = TYPES.store.fielddefs[name]
    return {field: _value(data, desc, depth) for field, desc in fields
            if depth > 4 or data.draw(st.booleans())}


@pytest.mark.fuzz
@fuzzing(150)
@given(name=st.sampled_from(ROBOT_TYPES), data=st.data())
def test_the_fast_path_builds_what_the_walk_builds(name: str, data: st.DataObject) -> None:
    value = _message(data, name)
    fast = TYPES.from_value(name, value)
    with walk_only(TYPES):
        walked = TYPES.from_value(name, value)
    assert TYPES.serialize(fast, name) == TYPES.serialize(walked, name)
    assert repr(fast) == repr(walked)


@pytest.mark.parametrize(("value", "error"), [
    ({"linear": {"x": "fast"}}, "linear.x: 'fast' is not a float64"),
    ({"linear": {"x": True}}, "linear.x: True is not a float64"),
    ({"angular": {"w": 1.0}}, "angular.w: geometry_msgs/msg/Vector3 has no field 'w'"),
    ({"linear": [1.0, 2.0]}, "linear: [1.0, 2.0] is not a mapping"),
])
def test_what_the_fast_path_declines_fails_as_the_walk_says(value: Any, error: str) -> None:
    with pytest.raises(MessageError, match=error.replace("[", r"\[").replace("]", r"\]")):
        TYPES.from_value("geometry_msgs/msg/Twist", value)


def test_what_only_the_walk_takes_still_builds() -> None:
    """numpy numbers and arrays, a bare value for a one-field type, a message for a field, a
    fixed array's default: the walk's, the same as before."""
    joint = TYPES.from_value("sensor_msgs/msg/JointState", {
        "position": np.array([0.5, 1.5]), "velocity": [np.float64(1.0)],
        "header": {"stamp": {"sec": np.int32(3)}}})
    assert joint.position.tolist() == [0.5, 1.5] and joint.velocity.tolist() == [1.0]
    assert joint.header.stamp.sec == 3
    assert TYPES.from_value("std_msgs/msg/Float64", 2.5).data == 2.5
    odometry = TYPES.from_value("nav_msgs/msg/Odometry", {})
    assert odometry.pose.covariance.shape == (36,) and not odometry.pose.covariance.any()
    other = TYPES.from_value("nav_msgs/msg/Odometry", {})
    other.pose.covariance[0] = 1.0  # defaults are never shared between messages
    assert odometry.pose.covariance[0] == 0.0
    header = TYPES.from_value("std_msgs/msg/Header", {"frame_id": "map"})
    assert TYPES.from_value("geometry_msgs/msg/PoseStamped", {"header": header}).header is header


def test_a_byte_above_127_is_held_as_the_byte_reads_back() -> None:
    """ROS 2's ``byte`` is an octet (0..255: the ROS 2 interface docs, "Field types"); rosbags
    reads and packs it signed (struct code ``b``). Found by the fuzzer above: a level of 128
    was accepted and then failed to serialize (struct.error). Built, assigned or received, a
    byte of 200 is now -56, and its CDR is the byte 0xC8, as rosbags' own serializer writes."""
    status = TYPES.from_value("diagnostic_msgs/msg/DiagnosticStatus", {"level": 200})
    assert status.level == -56
    data = TYPES.serialize(status)
    assert data == bytes(TYPES.store.serialize_cdr(status, "diagnostic_msgs/msg/DiagnosticStatus"))
    assert data[4] == 0xC8
    assert TYPES.deserialize(data, "diagnostic_msgs/msg/DiagnosticStatus").level == -56
    status.level = 255
    assert status.level == -1


def test_a_byte_field_reads_as_ros_writes_it_and_goes_back() -> None:
    """What echo prints (to_value) is 0..255, as ROS shows a byte, and goes back through
    from_value (echo's output fed to pub); repr (what `servolab service call` prints) shows
    rosidl's bytes of length 1."""
    status = TYPES.from_value("diagnostic_msgs/msg/DiagnosticStatus", {"level": 200})
    assert TYPES.to_value(status)["level"] == 200
    again = TYPES.from_value("diagnostic_msgs/msg/DiagnosticStatus", TYPES.to_value(status))
    assert TYPES.serialize(again) == TYPES.serialize(status)
    assert "level=b'\\xc8'" in TYPES.repr_of(status)
    assert TYPES.from_value("diagnostic_msgs/msg/DiagnosticStatus", {"level": -56}).level == -56
