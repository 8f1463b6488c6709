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


DEFAULTS = """float64 gain 1.5   # a gain
int8 mode -1
uint8 flags 0x10
bool enabled true
string label 'a b'
string word plain
int32[3] offsets [1, -2, 3]
float32[] weights [0.5, 1.5]
string[] names ["x,y", z]
int32 plain
int8 LIMIT=7
"""

ROSIDL_DEFAULTS = """
import json, sys
from rosidl_adapter.parser import parse_message_string
spec = parse_message_string("lab_msgs", "Defaults", sys.stdin.read())
print(json.dumps({f.name: f.default_value for f in spec.fields}))
"""


def test_a_fields_default_value_is_rosidls(tmp_path: Path) -> None:
    """``type name default`` lines (rosbags' parser drops the default): a message built
    without the field has the value rosidl_adapter's own parser (Jazzy, the oracle venv)
    reads from the same file, in a message, a service's parts and an action's."""
    files = {"msg/Defaults.msg": DEFAULTS,
             "srv/Tune.srv": "float64 gain 2.5\n---\nstring answer 'ok'\n",
             "action/Reach.action": "float64 speed 0.25\n---\nint8 code -3\n---\n"
                                    "float64 left 1.0\n"}
    types = MessageTypes(interface_path=[_package(tmp_path, files=files)])
    rosidl = json.loads(subprocess.run([str(ros_python()), "-c", ROSIDL_DEFAULTS],
                                       input=DEFAULTS, capture_output=True, text=True,
                                       check=True, timeout=60).stdout)
    built = types.to_value(types.default("lab_msgs/msg/Defaults"))
    assert built == {field: 0 if value is None else value for field, value in rosidl.items()}
    assert built["label"] == "a b" and built["names"] == ["x,y", "z"]  # not merely None == 0
    given = types.from_value("lab_msgs/msg/Defaults", {"gain": 3.0})
    assert given.gain == 3.0 and given.mode == -1       # the rest keep their defaults
    assert types.default("lab_msgs/srv/Tune_Request").gain == 2.5
    assert types.default("lab_msgs/srv/Tune_Response").answer == "ok"
    assert types.default("lab_msgs/action/Reach_Goal").speed == 0.25
    assert types.default("lab_msgs/action/Reach_Result").code == -3
    assert types.default("lab_msgs/action/Reach_Feedback").left == 1.0
    # each message its own array, as rosidl's classes build one per instance
    first, second = (types.default("lab_msgs/msg/Defaults") for _ in range(2))
    first.offsets[0] = 99
    assert second.offsets[0] == 1


@pytest.mark.parametrize(("line", "words"), [
    ("int8 mode 300", "lab_msgs/msg/Bad.mode"),
    ("bool on maybe", "a bool's default is true, false, 1 or 0"),
    ("int32[2] pair [1, 2, 3]", "needs exactly 2 values"),
    ("geometry_msgs/Point p 1", "allowed on a number, bool or string field"),
])
def test_a_bad_default_is_one_line_naming_the_file_and_field(tmp_path: Path, line: str,
                                                               words: str) -> None:
    with pytest.raises(MessageError) as error:
        MessageTypes(interface_path=[_package(tmp_path, files={"msg/Bad.msg": line + "\n"})])
    text = str(error.value)
    assert "\n" not in text and "Bad.msg" in text and words in text


def test_shipped_packages_read_from_many_threads_at_once() -> None:
    """A shipped package is read on whichever thread first asks (an executor's, the DDS
    dispatcher's, the view's): eight threads asking at once for its types each get them."""
    from concurrent.futures import ThreadPoolExecutor

    types = MessageTypes()
    names = ["control_msgs/msg/JointJog", "control_msgs/msg/JointTolerance",
             "control_msgs/action/FollowJointTrajectory_Goal",
             "controller_manager_msgs/msg/ControllerState"] * 2
    with ThreadPoolExecutor(8) as pool:
        assert list(pool.map(types.check, names)) == names
    assert types.is_action("control_msgs/action/GripperCommand")
    assert not types.is_action("control_msgs/msg/JointJog")


def test_an_extra_message_naming_an_unknown_type_is_one_line() -> None:
    with pytest.raises(MessageError, match="lab_msgs/msg/Odd: field 'x' uses"):
        MessageTypes(extra_msgs={"lab_msgs/msg/Odd": "no_such_msgs/Thing x\n"})
    # one that names a shipped package's type reads it first
    types = MessageTypes(extra_msgs={"lab_msgs/msg/Jog": "control_msgs/JointJog jog\n"})
    assert types.default("lab_msgs/msg/Jog").jog.joint_names == []


def test_tabs_separate_as_spaces_do(tmp_path: Path) -> None:
    """rosidl_adapter turns a line's tabs into spaces before it splits it."""
    files = {"msg/Tabbed.msg": "float64\tgain\t1.5\nuint8[]\tdata [1, 2]\nstring[] s [a , b]\n"}
    types = MessageTypes(interface_path=[_package(tmp_path, files=files)])
    assert types.to_value(types.default("lab_msgs/msg/Tabbed")) == {
        "gain": 1.5, "data": [1, 2], "s": ["a", "b"]}
