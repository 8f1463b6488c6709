"""The interface packages servolab ships (``servolab/interfaces/packages``) are ROS 2 Jazzy's:
every type each defines — a service's request, response and event, an action's goal,
result, feedback, ``_SendGoal``, ``_GetResult``, ``_FeedbackMessage`` and the action itself —
has the RIHS01 type hash rosidl computed for the real package, read from its
``share/<pkg>/<kind>/<Name>.json`` in the oracle venv (``tests/rosoracle.py``).
example_interfaces and nav2_msgs are not on the package index (:data:`NOT_ON_THE_INDEX`)."""

from __future__ import annotations

import json

import pytest

from servolab.interfaces import action_class
from servolab.middleware.interface_files import find_packages, read_package
from servolab.middleware.messages import SHIPPED_INTERFACES, MessageTypes
from tests.rosoracle import ros_python, ros_venv

TYPES = MessageTypes()
PACKAGES = [read_package(folder) for folder in find_packages([SHIPPED_INTERFACES])]
SHIPPED = sorted(name for package in PACKAGES
                 for name in (*package.msgs, *package.srvs, *package.actions))
#: the shipped packages the package index has no ROS 2 Jazzy wheel of, so the oracle cannot
#: hash them: example_interfaces (its Fibonacci is checked field for field against
#: test_msgs' below) and nav2_msgs (NavigateToPose restated from ros-navigation/navigation2's
#: jazzy branch, 1.3.0 to 1.3.13 alike; hashed by the same code as every checked type)
NOT_ON_THE_INDEX = ("example_interfaces", "nav2_msgs")
IN_ORACLE = [name for name in SHIPPED if name.split("/")[0] not in NOT_ON_THE_INDEX]


def test_the_shipped_packages_are_there() -> None:
    assert {"action_msgs/srv/CancelGoal", "test_msgs/action/Fibonacci",
            "example_interfaces/action/Fibonacci"} <= set(SHIPPED)


@pytest.mark.parametrize("name", IN_ORACLE)
def test_each_type_hash_is_rosidls(name: str) -> None:
    ros_python()  # skips, saying why, where the oracle is not installed
    description = ros_venv() / "share" / f"{name}.json"
    hashes = {h["type_name"]: h["hash_string"]
              for h in json.loads(description.read_text())["type_hashes"]}
    package = name.split("/")[0]
    own = {n: h for n, h in hashes.items() if n.startswith(f"{package}/")}
    assert len(own) >= 4  # the type and its parts
    assert {n: TYPES.rihs01(n) for n in own} == own


def test_example_interfaces_fibonacci_is_test_msgs_field_for_field() -> None:
    """What the hash check of test_msgs' Fibonacci stands for here: every part has the same
    fields and types, the package's name aside."""
    for part in ("_Goal", "_Result", "_Feedback", "_FeedbackMessage", "_SendGoal_Request",
                 "_SendGoal_Response", "_GetResult_Request", "_GetResult_Response"):
        ours = TYPES.store.fielddefs[f"example_interfaces/action/Fibonacci{part}"]
        theirs = TYPES.store.fielddefs[f"test_msgs/action/Fibonacci{part}"]
        assert repr(ours).replace("example_interfaces/", "test_msgs/") == repr(theirs)


def test_an_action_imports_as_rclpy_imports_it() -> None:
    fibonacci = action_class("test_msgs/action/Fibonacci")
    from servolab.interfaces.test_msgs.action import Fibonacci
    assert Fibonacci.__actiontype__ == fibonacci.__actiontype__
    goal = Fibonacci.Goal(order=5)
    assert goal.order == 5
    assert Fibonacci.Impl.CancelGoalService.Response.ERROR_GOAL_TERMINATED == 3
