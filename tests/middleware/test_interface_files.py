"""Interfaces read from their own files (servolab.middleware.interface_files and
MessageTypes.register_package): a lab's .msg/.srv/.action in folders laid out as ROS
packages, found through SERVOLAB_INTERFACE_PATH, imported as rclpy code imports them.

The oracle for the type hashes is rosidl itself: every ROS 2 Jazzy interface package
installed from the index into the oracle venv (.venv-ros, ``make ros-oracle``) ships
``share/<pkg>/<msg|srv|action>/<Name>.json``, rosidl_generator_type_description's output, with
the RIHS01 hash of the type and of every type it refers to (REP 2016). servolab reads the same
packages' .msg/.srv/.action files and must compute the same hashes. The action layout
(_Goal, _Result, _Feedback, _SendGoal, _GetResult, _FeedbackMessage and the action type's six
fields) is checked by those hashes too (test_msgs/action/Fibonacci.json).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from servolab.middleware.errors import MessageError
from servolab.middleware.interface_files import find_packages, read_package, split_parts
from servolab.middleware.messages import MessageTypes
from tests.rosoracle import ros_python, ros_venv

LAB = {
    "msg/Reading.msg": "# a sensor reading\nfloat64 value\nstring unit\n",
    "msg/Readings.msg": "Reading[] readings\nstd_msgs/Header header\n",
    "srv/Calibrate.srv": "Reading reference\nuint8 samples\n---\nbool ok\nReading offset\n",
    "action/Sweep.action": "float64 start\nfloat64 stop\n---\nReadings all\n---\n"
                           "float32 progress\nReading last\n",
}


def _package(root: Path, name: str = "lab_msgs", files: dict[str, str] = LAB) -> Path:
    folder = root / name
    for relative, text in files.items():
        path = folder / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return folder


def test_a_labs_package_registers_its_messages_services_and_action(tmp_path: Path) -> None:
    _package(tmp_path)
    types = MessageTypes(interface_path=[tmp_path])
    readings = types.from_value("lab_msgs/msg/Readings",
                                {"readings": [{"value": 1.5, "unit": "m"}],
                                 "header": {"frame_id": "a"}})
    data = types.serialize(readings)
    assert types.deserialize(data, "lab_msgs/msg/Readings").readings[0].value == 1.5
    # a type named relative to the package, in a service or an action, is the package's msg
    service = types.service("lab_msgs/srv/Calibrate")
    request = types.from_value(service.request, {"reference": {"value": 2.0}, "samples": 3})
    assert types.type_of(request.reference) == "lab_msgs/msg/Reading"
    assert "lab_msgs/action/Sweep" in types.action_names()
    assert "lab_msgs/action/Sweep" not in MessageTypes().action_names()
    feedback = types.from_value("lab_msgs/action/Sweep_FeedbackMessage",
                                {"feedback": {"progress": 0.5, "last": {"value": 1.0}}})
    assert types.type_of(feedback.feedback.last) == "lab_msgs/msg/Reading"
    assert len(feedback.goal_id.uuid) == 16
    request_fields = types.store.fielddefs["lab_msgs/action/Sweep_SendGoal_Request"][1]
    assert [name for name, _ in request_fields] == ["goal_id", "goal"]    # rosidl's order
    assert types.rihs01("lab_msgs/action/Sweep").startswith("RIHS01_")


def test_the_environment_names_the_folders_and_rclpy_style_imports_work(
        tmp_path: Path) -> None:
    """In a fresh process with SERVOLAB_INTERFACE_PATH set, ``servolab.interfaces`` imports
    a lab's message and action as rclpy code imports generated ones."""
    _package(tmp_path / "ws" / "src")
    code = (
        "from servolab.interfaces.lab_msgs.msg import Reading\n"
        "from servolab.interfaces.lab_msgs.action import Sweep\n"
        "r = Reading(value=2.0, unit='m')\n"
        "g = Sweep.Goal(start=0.0, stop=1.0)\n"
        "req = Sweep.Impl.SendGoalService.Request(goal=g)\n"
        "print(r.unit, req.goal.stop, Sweep.Impl.FeedbackMessage.__msgtype__)\n")
    env = {**os.environ, "SERVOLAB_INTERFACE_PATH": str(tmp_path / "ws" / "src")}
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["m", "1.0", "lab_msgs/action/Sweep_FeedbackMessage"]


@pytest.mark.parametrize(("relative", "text", "said"), [
    ("srv/Bad.srv", "int32 a\n---\nint32 b\n---\nint32 c\n", "Bad.srv: a service has 2 parts"),
    ("action/Bad.action", "int32 a\n---\nint32 b\n", "Bad.action: an action has 3 parts"),
    ("msg/Bad.msg", "wstring name\n", "Bad.msg: lab_msgs/msg/Bad: field 'name' uses"),
    ("msg/Bad.msg", "Missing thing\n", "Bad.msg: lab_msgs/msg/Bad: field 'thing' uses "
                                       "lab_msgs/msg/Missing, which is not a known type"),
    ("msg/bad.msg", "int32 a\n", "'bad' is not an interface name"),
])
def test_a_bad_file_is_one_line_naming_it(tmp_path: Path, relative: str, text: str,
                                          said: str) -> None:
    _package(tmp_path, files={relative: text})
    with pytest.raises(MessageError) as caught:
        MessageTypes(interface_path=[tmp_path])
    message = str(caught.value)
    assert said in message and "\n" not in message
    assert relative.split("/")[-1] in message


def test_a_missing_folder_or_a_bad_package_name_is_refused(tmp_path: Path) -> None:
    with pytest.raises(MessageError, match="does not exist"):
        list(find_packages([tmp_path / "nowhere"]))
    with pytest.raises(MessageError, match="not a ROS package name"):
        read_package(_package(tmp_path, "Lab-Msgs"))
    assert split_parts("a\n---\n", 2) == ("a\n", "")


def test_type_hashes_equal_rosidls_for_every_installed_interface(tmp_path: Path) -> None:
    """Every package installed in the oracle venv, read from its own .msg/.srv/.action
    files, hashes as rosidl hashed it (its .json files): messages, services and actions.
    test_msgs' WStrings is left out (rosbags' .msg parser has no wstring; refused with its
    own message, see above)."""
    ros_python()            # skips, saying why, where the oracle is not installed
    share = ros_venv() / "share"
    if not (share / "test_msgs" / "action" / "Fibonacci.json").exists():
        pytest.skip("ros-jazzy-test-msgs is not in the oracle venv (make ros-oracle)")
    copy = tmp_path / "share"
    for package in find_packages([share]):
        for kind in ("msg", "srv", "action"):
            if (package / kind).is_dir():
                shutil.copytree(package / kind, copy / package.name / kind,
                                ignore=shutil.ignore_patterns("WStrings.msg", "*.json",
                                                              "*.idl"))
    types = MessageTypes(interface_path=[copy])
    expected: dict[str, str] = {}
    for described in share.glob("*/*/*.json"):
        document = json.loads(described.read_text())
        for entry in document.get("type_hashes", []):
            expected[entry["type_name"]] = entry["hash_string"]
    expected.pop("test_msgs/msg/WStrings")
    kinds = {name.split("/")[1] for name in expected}
    assert kinds == {"msg", "srv", "action"} and len(expected) > 200
    wrong = {name: (types.rihs01(name), want) for name, want in expected.items()
             if types.rihs01(name) != want}
    assert wrong == {}


def test_a_shipped_package_is_read_when_first_used(tmp_path: Path) -> None:
    """The shipped packages are read on first use (every servolab process builds a
    MessageTypes; most use none of control_msgs' 32 types): a type of one is there when asked
    for by name, listed by ``names()``, and usable from a lab's own package that names it."""
    types = MessageTypes()
    assert "control_msgs/msg/JointTolerance" not in types.store.fielddefs   # not read yet
    assert types.has_package("control_msgs") and not types.has_package("no_such_msgs")
    assert types.check("control_msgs/msg/JointTolerance") == "control_msgs/msg/JointTolerance"
    assert types.default("control_msgs/msg/JointTolerance").name == ""
    assert "controller_manager_msgs/srv/ListControllers" in MessageTypes().service_names()
    lab = tmp_path / "arm_msgs" / "msg"
    lab.mkdir(parents=True)
    (lab / "Limits.msg").write_text("control_msgs/JointTolerance[] per_joint\n")
    labs = MessageTypes(interface_path=[tmp_path])
    assert labs.rihs01("arm_msgs/msg/Limits").startswith("RIHS01_")
