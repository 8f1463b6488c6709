"""The interface packages servolab ships (``servolab/interfaces/packages``) are ROS 2 Jazzy's:
every type each defines — a service's request, response and event, an action's goal,
result, feedback, ``_SendGoal``, ``_GetResult``, ``_FeedbackMessage`` and the action itself —
has the RIHS01 type hash the real ROS 2 tools compute for it.

Where the facts come from:

- the definitions: control_msgs from ros-controls/control_msgs, branch ``jazzy`` (5.8.0,
  commit f901df2662f2; its motion primitive types are left out, see the packages' README);
  controller_manager_msgs from ros-controls/ros2_control, branch ``jazzy``, folder
  controller_manager_msgs (last changed in 4.46.0, commit 6e50df38c97a); nav2_msgs'
  NavigateToPose from ros-navigation/navigation2's ``jazzy`` branch (1.3.x). Each file
  restates the fields and constants in the upstream order; the packages' README says where
  each package comes from.
- the hashes: the real rosidl, run in the oracle venv (``tests/rosoracle.py``; the Makefile's
  ``ROS_PACKAGES``). Once per module, one subprocess turns every shipped ``.msg``, ``.srv`` and
  ``.action`` file into ``.idl`` with rosidl_adapter 4.6.6 (``convert_to_idl``, as
  ``rosidl_generate_interfaces`` does) and hashes them with rosidl_generator_type_description
  4.6.6 (``generate_type_hash``, the function its CMake step and ``rosidl hash`` call), the
  types they use from other packages read from the installed packages' own type descriptions
  (``.venv-ros/share/<pkg>/<kind>/*.json``: builtin_interfaces, std_msgs, geometry_msgs,
  sensor_msgs, trajectory_msgs, lifecycle_msgs, unique_identifier_msgs, service_msgs, ...).
  This checks every shipped type, also of the packages the package index has no wheel of
  (control_msgs, controller_manager_msgs, nav2_msgs, example_interfaces).
- for the packages the index has (action_msgs, test_msgs) rosidl's hashes are also read from
  their real build's ``share/<pkg>/<kind>/<Name>.json``, and the hashes computed here from
  servolab's files must equal those: the check of the check.

The hash check holds servolab's reading of a file to rosidl's reading of the same file; that
control_msgs' and controller_manager_msgs' files say what upstream's say (the same fields,
types, bounds, constants and default values, in the same order) was checked when they were
written, by rosidl_adapter's parser on both (the upstream sources are not at hand in a test).
"""

from __future__ import annotations

import json
import os
import subprocess

import pytest

from servolab.cli import main
from servolab.interfaces import action_class
from servolab.middleware.interface_files import find_packages, read_package, split_parts
from servolab.middleware.messages import SHIPPED_INTERFACES, MessageTypes
from tests.rosoracle import ros_python, ros_venv

TYPES = MessageTypes()
TYPES.load_all()  # read on first use otherwise; every test here sees every shipped type
PACKAGES = [read_package(folder) for folder in find_packages([SHIPPED_INTERFACES])]
SHIPPED = sorted(name for package in PACKAGES
                 for name in (*package.msgs, *package.srvs, *package.actions))
#: the shipped packages the package index has a ROS 2 Jazzy wheel of, whose real build's
#: type descriptions the oracle venv installs (Makefile: ros-jazzy-test-msgs; action_msgs
#: comes with rclpy)
ON_THE_INDEX = ("action_msgs", "test_msgs")
IN_ORACLE = [name for name in SHIPPED if name.split("/")[0] in ON_THE_INDEX]
#: how many types rosidl makes of one interface: a message is itself; a service is itself,
#: its _Request, _Response and _Event; an action is itself, its _Goal, _Result, _Feedback
#: and _FeedbackMessage, and its _SendGoal and _GetResult services (four types each)
TYPES_PER_KIND = {"msg": 1, "srv": 4, "action": 13}

#: Run by the oracle venv's Python with one argument, a JSON job: ``packages`` (name ->
#: folder), ``share`` (the installed packages' share folder), ``out`` (a scratch folder).
#: Prints a JSON object: every type rosidl made of those files -> its RIHS01 hash.
ROSIDL_HASHES = r"""
import contextlib, json, pathlib, sys
from rosidl_adapter import convert_to_idl
from rosidl_generator_type_description import generate_type_hash

job = json.loads(sys.argv[1])
share = pathlib.Path(job["share"])
out = pathlib.Path(job["out"])
installed = [p for p in sorted(share.iterdir())
             if any((p / kind).is_dir() for kind in ("msg", "srv", "action"))]
hashes = {}
for name, folder in job["packages"].items():
    folder = pathlib.Path(folder)
    idl = out / name / "idl"
    tuples = []
    with contextlib.redirect_stdout(sys.stderr):  # the adapter says what it reads and writes
        for kind in ("msg", "srv", "action"):
            for file in sorted((folder / kind).glob(f"*.{kind}")):
                written = convert_to_idl(folder, name, file.relative_to(folder), idl)
                tuples.append(f"{idl}:{written.relative_to(idl).as_posix()}")
    # the types of other packages come from the installed packages' type descriptions (a
    # shipped package using another shipped package's would be an error naming it)
    arguments = out / name / "arguments.json"
    arguments.write_text(json.dumps({
        "package_name": name, "output_dir": str(out / name / "json"), "idl_tuples": tuples,
        "include_paths": [f"{p.name}:{p}" for p in installed]}))
    try:
        written_files = generate_type_hash(str(arguments))
    except (KeyError, FileNotFoundError) as exc:
        sys.exit(f"{name}: rosidl found no type description for {exc} among the packages "
                 f"installed in {share}")
    for written in written_files:  # one per type made here: its own hash comes first
        top = json.loads(pathlib.Path(written).read_text())["type_hashes"][0]
        hashes[top["type_name"]] = top["hash_string"]
print(json.dumps(hashes))
"""


@pytest.fixture(scope="module")
def rosidl_hashes(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """Every shipped type's RIHS01 hash as the real rosidl computes it from servolab's files
    (one subprocess for all of them)."""
    python = ros_python()  # skips, saying why, where the oracle is not installed
    job = {"packages": {package.name: str(package.path) for package in PACKAGES},
           "share": str(ros_venv() / "share"), "out": str(tmp_path_factory.mktemp("rosidl"))}
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    done = subprocess.run([str(python), "-c", ROSIDL_HASHES, json.dumps(job)], env=env,
                          capture_output=True, text=True, timeout=100, check=False)
    if done.returncode != 0:
        said = done.stderr.strip().splitlines()
        pytest.fail(f"rosidl could not hash the shipped interfaces: {said[-1] if said else ''} "
                    "(a package they use missing from the oracle venv? it installs the "
                    "Makefile's ROS_PACKAGES: rm .venv-ros/.installed; make ros-oracle)")
    hashes: dict[str, str] = json.loads(done.stdout)
    return hashes


def test_the_shipped_packages_are_there() -> None:
    assert {"action_msgs/srv/CancelGoal", "test_msgs/action/Fibonacci",
            "example_interfaces/action/Fibonacci", "nav2_msgs/action/NavigateToPose",
            "control_msgs/action/FollowJointTrajectory", "control_msgs/action/GripperCommand",
            "control_msgs/action/ParallelGripperCommand",
            "control_msgs/msg/JointTrajectoryControllerState",
            "control_msgs/msg/DynamicJointState", "control_msgs/msg/InterfaceValue",
            "controller_manager_msgs/srv/ListControllers",
            "controller_manager_msgs/srv/ListControllerTypes",
            "controller_manager_msgs/srv/ListHardwareInterfaces",
            "controller_manager_msgs/srv/ListHardwareComponents",
            "controller_manager_msgs/srv/LoadController",
            "controller_manager_msgs/srv/ConfigureController",
            "controller_manager_msgs/srv/SwitchController",
            "controller_manager_msgs/srv/UnloadController",
            "controller_manager_msgs/srv/SetHardwareComponentState"} <= set(SHIPPED)


@pytest.mark.parametrize("name", SHIPPED)
@pytest.mark.slow
def test_each_type_hash_is_what_rosidl_computes_from_the_shipped_file(
        name: str, rosidl_hashes: dict[str, str]) -> None:
    kind = name.split("/")[1]
    theirs = {n: h for n, h in rosidl_hashes.items() if n == name or n.startswith(f"{name}_")}
    assert len(theirs) == TYPES_PER_KIND[kind]
    assert {n: TYPES.rihs01(n) for n in theirs} == theirs


def test_rosidl_makes_no_type_servolab_lacks(rosidl_hashes: dict[str, str]) -> None:
    assert set(rosidl_hashes) - set(TYPES.store.fielddefs) == set()
    assert len(rosidl_hashes) == sum(TYPES_PER_KIND[n.split("/")[1]] for n in SHIPPED)


def test_rosidl_run_here_hashes_as_the_real_builds_did(rosidl_hashes: dict[str, str]) -> None:
    """The hashes computed from servolab's files for action_msgs and test_msgs are those in
    the type descriptions their real builds installed (what makes the computation here
    stand for a build of control_msgs and the rest)."""
    checked = 0
    for name, computed in rosidl_hashes.items():
        if name.split("/")[0] not in ON_THE_INDEX:
            continue
        package, kind, short = name.split("/")
        top = f"{package}/{kind}/{short.split('_')[0]}"
        description = json.loads((ros_venv() / "share" / f"{top}.json").read_text())
        built = {h["type_name"]: h["hash_string"] for h in description["type_hashes"]}
        assert built[name] == computed
        checked += 1
    assert checked == sum(TYPES_PER_KIND[n.split("/")[1]] for n in IN_ORACLE)


@pytest.mark.parametrize("name", IN_ORACLE)
def test_each_type_hash_is_the_real_builds(name: str) -> None:
    ros_python()  # skips, saying why, where the oracle is not installed
    description = ros_venv() / "share" / f"{name}.json"
    hashes = {h["type_name"]: h["hash_string"]
              for h in json.loads(description.read_text())["type_hashes"]}
    package = name.split("/")[0]
    own = {n: h for n, h in hashes.items() if n.startswith(f"{package}/")}
    assert len(own) >= 4  # the type and its parts
    assert {n: TYPES.rihs01(n) for n in own} == own


def test_an_action_imports_as_rclpy_imports_it() -> None:
    fibonacci = action_class("test_msgs/action/Fibonacci")
    from servolab.interfaces.test_msgs.action import Fibonacci
    assert Fibonacci.__actiontype__ == fibonacci.__actiontype__
    goal = Fibonacci.Goal(order=5)
    assert goal.order == 5
    assert Fibonacci.Impl.CancelGoalService.Response.ERROR_GOAL_TERMINATED == 3


def test_the_ros2_control_interfaces_import_as_rclpy_imports_them() -> None:
    """As a ros2_control node's Python imports them: the classes, their constants (rosidl
    makes a constant a class attribute) and their parts."""
    from servolab.interfaces.control_msgs.action import FollowJointTrajectory, GripperCommand
    from servolab.interfaces.control_msgs.msg import (
        DynamicJointState,
        JointComponentTolerance,
        JointTrajectoryControllerState,
    )
    from servolab.interfaces.controller_manager_msgs.msg import ControllerState
    from servolab.interfaces.controller_manager_msgs.srv import (
        ListControllers,
        SetHardwareComponentState,
        SwitchController,
    )
    from servolab.interfaces.lifecycle_msgs.msg import State

    assert FollowJointTrajectory.__actiontype__ == "control_msgs/action/FollowJointTrajectory"
    assert FollowJointTrajectory.Result.GOAL_TOLERANCE_VIOLATED == -5
    assert FollowJointTrajectory.Result().error_code == FollowJointTrajectory.Result.SUCCESSFUL
    assert GripperCommand.Goal().command.max_effort == 0.0
    assert JointComponentTolerance.ROTATION == 5
    assert JointTrajectoryControllerState().speed_scaling_factor == 0.0
    assert DynamicJointState(joint_names=["a"]).interface_values == []
    assert ListControllers.__srvtype__ == "controller_manager_msgs/srv/ListControllers"
    state = ControllerState(name="jtc", state="active", update_rate=100)
    assert ListControllers.Response(controller=[state]).controller[0].update_rate == 100
    assert SwitchController.Request.STRICT == 2
    assert SwitchController.Request.FORCE_AUTO == 4
    request = SetHardwareComponentState.Request(
        name="arm", target_state=State(id=State.PRIMARY_STATE_ACTIVE, label="active"))
    assert request.target_state.id == 3


def test_a_follow_joint_trajectory_goal_round_trips_through_cdr() -> None:
    """Two joints, three points, tolerances and a goal time tolerance: servolab's CDR bytes
    are rosbags' (servolab's reference for CDR, ``test_fast_cdr``) and read back to the same
    goal."""
    from servolab.interfaces.builtin_interfaces.msg import Duration
    from servolab.interfaces.control_msgs.action import FollowJointTrajectory
    from servolab.interfaces.control_msgs.msg import JointComponentTolerance, JointTolerance
    from servolab.interfaces.trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    points = [JointTrajectoryPoint(positions=[0.1 * i, -0.2 * i], velocities=[0.5, -0.5],
                                   accelerations=[], effort=[1.0 + i, 2.0],
                                   time_from_start=Duration(sec=i, nanosec=250_000_000))
              for i in range(1, 4)]
    goal = FollowJointTrajectory.Goal(
        trajectory=JointTrajectory(joint_names=["shoulder", "elbow"], points=points),
        path_tolerance=[JointTolerance(name="shoulder", position=0.05, velocity=-1.0)],
        component_goal_tolerance=[JointComponentTolerance(
            joint_name="base", component=JointComponentTolerance.ROTATION, position=0.01)],
        goal_time_tolerance=Duration(sec=0, nanosec=500_000_000))
    name = "control_msgs/action/FollowJointTrajectory_Goal"
    data = TYPES.serialize(goal, name)
    assert data == TYPES.store.serialize_cdr(goal, name)
    back = TYPES.deserialize(data, name)
    assert TYPES.to_value(back) == TYPES.to_value(goal)
    assert TYPES.to_value(back)["trajectory"]["points"][2]["positions"] == [0.1 * 3, -0.2 * 3]
    assert len(TYPES.to_value(back)["trajectory"]["points"]) == 3


def _definition_lines(text: str) -> list[str]:
    """A part of a shipped file as ``interface show`` prints it at the top level: comments
    and blank lines left out, whitespace made single, constants (``TYPE NAME=VALUE``) first
    — servolab keeps a type's constants apart from its fields (rosbags does), where ros2's
    ``interface show`` keeps the file's order — then the fields in the file's order."""
    constants, fields = [], []
    for raw in text.splitlines():
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        if "=" in line:
            left, value = line.split("=", 1)
            constants.append(f"{' '.join(left.split())}={value.strip()}")
        else:
            fields.append(" ".join(line.split()[:2]))
    return constants + fields


def test_interface_show_prints_follow_joint_trajectory(
        capsys: pytest.CaptureFixture[str]) -> None:
    """``servolab interface show control_msgs/action/FollowJointTrajectory``: the goal,
    result and feedback of the shipped file between ``---`` lines, each field of a message
    type followed by that type's fields one tab further in."""
    assert main(["interface", "show", "control_msgs/action/FollowJointTrajectory"]) == 0
    printed = capsys.readouterr().out.splitlines()
    package = SHIPPED_INTERFACES / "control_msgs"
    file = package / "action" / "FollowJointTrajectory.action"
    parts = split_parts(file.read_text(), 3, file)
    top = [line for line in printed if not line.startswith("\t")]
    assert top == [*_definition_lines(parts[0]), "---", *_definition_lines(parts[1]), "---",
                   *_definition_lines(parts[2])]
    tolerance = printed.index("JointTolerance[] path_tolerance")
    fields = _definition_lines((package / "msg" / "JointTolerance.msg").read_text())
    assert printed[tolerance + 1:tolerance + 1 + len(fields)] == [f"\t{f}" for f in fields]
    assert "\t\tbuiltin_interfaces/Duration time_from_start" in printed  # two levels down


def test_the_packages_readme_names_each_shipped_packages_source() -> None:
    readme = (SHIPPED_INTERFACES / "README.md").read_text()
    for package in PACKAGES:
        assert f"`{package.name}`" in readme
