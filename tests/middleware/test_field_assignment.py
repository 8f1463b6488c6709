"""Assigning a message's field checks and converts the value as rclpy's generated classes do
(rosidl_generator_py's properties), so that a message that publishes in one process publishes
over every transport.

The oracle is the real rclpy (``tests/rosoracle.py``): the same snippet runs under it and
under servolab, and what each says must agree. rclpy checks a value only with
``ROS_PYTHON_CHECK_FIELDS=1`` (Jazzy's generated ``_<type>.py`` reads it; unset, a bad value
is taken and fails later, in the serializer or on the wire); servolab always checks, so the
oracle runs with it set. Where servolab differs on purpose, the test says so: it converts an
int assigned to a float field (rclpy refuses it), and keeps a numpy array assigned to a
numeric sequence (rclpy refuses one; servolab reads and defaults sequences as numpy arrays).
"""

from __future__ import annotations

import array
import subprocess

import numpy as np
import pytest

from servolab.middleware.errors import MessageError
from servolab.middleware.messages import MessageTypes

TYPES = MessageTypes()

SNIPPET = """
{imports}
def attempt(what, action, field=""):
    try:
        result = action()
    except (AssertionError, AttributeError, TypeError, ValueError) as exc:
        # refused; by AttributeError (no such field) or not; naming the field
        print(what, "refused", type(exc).__name__ == "AttributeError", field in str(exc))
    else:
        print(what, result)

def joint_positions():
    msg = JointState()
    msg.position = [0.1, 2.5]
    return type(msg.position).__name__, msg.position.typecode, list(msg.position)

def appended():
    msg = Fibonacci.Feedback()
    msg.sequence = [0, 1]
    msg.sequence.append(1)
    msg.sequence.extend([2, 3])
    return type(msg.sequence).__name__, [int(v) for v in msg.sequence]

def tuple_names():
    msg = JointState()
    msg.name = ("left", "right")
    return list(msg.name)

def set_field(make, field, value):
    def action():
        msg = make()
        setattr(msg, field, value)
        return getattr(msg, field)
    return action

attempt("positions", joint_positions)
attempt("append", appended)
attempt("names", tuple_names)
attempt("uint8 300", set_field(UInt8, "data", 300), "data")
attempt("uint8 -1", set_field(UInt8, "data", -1), "data")
attempt("int8 127", set_field(Int8, "data", 127), "data")
attempt("string 5", set_field(String, "data", 5), "data")
attempt("names str", set_field(JointState, "name", "left"), "name")
attempt("names ints", set_field(JointState, "name", [1, 2]), "name")
attempt("header 5", set_field(JointState, "header", 5), "header")
attempt("header twist", set_field(JointState, "header", Twist()), "header")
attempt("covariance 35", set_field(PoseWithCovariance, "covariance", [0.0] * 35), "covariance")
attempt("no field", set_field(JointState, "positions", [1.0]), "positions")
"""

IMPORTS = {
    "rclpy": """
from geometry_msgs.msg import PoseWithCovariance, Twist
from sensor_msgs.msg import JointState
from std_msgs.msg import Int8, String, UInt8
from test_msgs.action import Fibonacci
""",
    "servolab": """
from servolab.interfaces.geometry_msgs.msg import PoseWithCovariance, Twist
from servolab.interfaces.sensor_msgs.msg import JointState
from servolab.interfaces.std_msgs.msg import Int8, String, UInt8
from servolab.interfaces.test_msgs.action import Fibonacci
""",
}


def transcript(python: str, imports: str, env: dict[str, str] | None = None) -> list[str]:
    code = SNIPPET.format(imports=imports)
    out = subprocess.run([python, "-c", code], env=env, capture_output=True, text=True,
                         timeout=120, check=False)
    assert out.returncode == 0, out.stderr
    return out.stdout.splitlines()


@pytest.mark.slow
def test_assignments_behave_as_in_rclpy() -> None:
    import sys

    from tests.rosoracle import free_domain_id, ros_env, ros_python

    theirs = transcript(str(ros_python()), IMPORTS["rclpy"],
                        ros_env(free_domain_id(), ROS_PYTHON_CHECK_FIELDS="1"))
    ours = transcript(sys.executable, IMPORTS["servolab"])
    assert theirs[:3] == ["positions ('array', 'd', [0.1, 2.5])",
                          "append ('array', [0, 1, 1, 2, 3])", "names ['left', 'right']"]
    assert ours == theirs


def test_a_refusal_names_the_type_and_field() -> None:
    msg = TYPES.default("sensor_msgs/msg/JointState")
    with pytest.raises(MessageError, match=r"^sensor_msgs/msg/JointState\.position\[1\]: "
                                           r"'x' is not a float64"):
        msg.position = [1.0, "x"]
    with pytest.raises(AttributeError, match=r"JointState has no field 'positions' \(it has "
                                             r"effort, header, name, position, velocity"):
        msg.positions = [1.0]
    status = TYPES.default("action_msgs/msg/GoalStatus")
    with pytest.raises(MessageError, match="STATUS_UNKNOWN is a constant"):
        status.STATUS_UNKNOWN = 3


def test_what_an_assignment_makes_publishes_as_the_numpy_message_does() -> None:
    """A list-assigned sequence (array.array) and fixed array (numpy) write the very bytes
    the numpy-built message writes, and read back as servolab reads every message."""
    name = "sensor_msgs/msg/JointState"
    msg = TYPES.default(name)
    msg.name = ["a", "b"]
    msg.position = [0.5, -1.25]
    msg.velocity = (1, 2)  # ints into float64[]: converted
    assert isinstance(msg.position, array.array) and msg.velocity.tolist() == [1.0, 2.0]
    built = TYPES.from_value(name, {"name": ["a", "b"], "position": [0.5, -1.25],
                                    "velocity": [1.0, 2.0]})
    data = TYPES.serialize(msg, name)
    assert data == TYPES.serialize(built, name) == bytes(TYPES.store.serialize_cdr(built, name))
    back = TYPES.deserialize(data, name)
    assert back.position.tolist() == [0.5, -1.25]
    cov = TYPES.default("geometry_msgs/msg/PoseWithCovariance")
    cov.covariance = [float(i) for i in range(36)]
    assert isinstance(cov.covariance, np.ndarray) and cov.covariance.dtype == np.float64
    TYPES.serialize(cov, "geometry_msgs/msg/PoseWithCovariance")


def test_servolabs_own_differences_from_rclpy() -> None:
    """On purpose: an int into a float field becomes a float (rclpy refuses it), and a numpy
    array into a numeric sequence is kept (as servolab's own readers make them)."""
    twist = TYPES.default("geometry_msgs/msg/Twist")
    twist.linear.x = 1
    assert type(twist.linear.x) is float
    msg = TYPES.default("sensor_msgs/msg/JointState")
    positions = np.array([1.0, 2.0])
    msg.position = positions
    assert msg.position is positions
    msg.position = np.array([1, 2], dtype=np.int32)
    assert msg.position.dtype == np.float64
