"""Launch arguments and groups of instances (the fleets issue: ``servolab launch`` starts N
instances of a robot from one file), as ROS 2 launch has them: ``arguments`` with defaults
(``DeclareLaunchArgument``), ``NAME:=VALUE`` on the command line (``ros2 launch``'s syntax),
``$(var NAME)`` substituted (ROS 2's ``var`` substitution), and a group's namespace pushed onto
its node entries (``<group>`` with ``<push_ros_namespace>``: a relative node namespace goes
under it, an absolute one does not). Facts from the ROS 2 launch documentation ("Using
substitutions", "Launch file different formats": ``push_ros_namespace``)."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from servolab.errors import UsageError
from servolab.middleware.errors import LaunchError
from servolab.middleware.launch import child_command, run_launch
from servolab.middleware.launch_arguments import command_line_arguments
from servolab.middleware.launch_file import load_launch
from servolab.middleware.transport import TransportOptions
from tests.clirun import SERVOLAB, one_line, servolab
from tests.middleware.test_launch import DEMO, started_pids
from tests.processes import started
from tests.waiting import alive, wait_for_line

GROUPS = f"""\
arguments:
  robots: 2
  rate: 20.0
transport: zenoh
groups:
  - namespace: /robot$(var instance)
    instances: $(var robots)
    nodes:
      - name: talker
        node: {DEMO}:Talker
        parameters: {{rate: $(var rate), count: 5}}
        process: robot$(var instance)
      - name: listener
        node: {DEMO}:Listener
        namespace: ears
        process: robot$(var instance)
      - name: watcher$(var instance)
        node: {DEMO}:Listener
        namespace: /everyone
        process: watchers$(var instance)
"""


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "fleet.launch.yaml"
    path.write_text(textwrap.dedent(text))
    return path


def test_a_group_is_started_once_an_instance_with_its_namespace_pushed(tmp_path: Path) -> None:
    launch = load_launch(_write(tmp_path, GROUPS), arguments={"robots": "3", "rate": "4.5"})
    assert [(e.fully_qualified_name, e.process) for e in launch.nodes] == [
        entry for n in (1, 2, 3) for entry in (
            (f"/robot{n}/talker", f"robot{n}"),
            # a relative namespace goes under the group's; an absolute one does not
            (f"/robot{n}/ears/listener", f"robot{n}"),
            (f"/everyone/watcher{n}", f"watchers{n}"))]
    # a text that is one substitution takes its value's type, as ROS 2 launch reads it
    assert launch.nodes[0].parameters == {"rate": 4.5, "count": 5}
    # the children are given the same arguments
    argv = child_command(launch, "robot2", TransportOptions("zenoh"))
    assert argv[argv.index("launch") + 2:argv.index("--process")] == ["robots:=3", "rate:=4.5"]


def test_the_defaults_hold_when_the_command_line_gives_nothing(tmp_path: Path) -> None:
    launch = load_launch(_write(tmp_path, GROUPS))
    assert len([e for e in launch.nodes if e.name == "talker"]) == 2
    assert launch.nodes[0].parameters["rate"] == 20.0


@pytest.mark.parametrize(("text", "arguments", "says"), [
    (GROUPS, {"robot": "3"}, "'robot' is not declared by the file (its arguments: robots, "
     "rate); did you mean 'robots'?"),
    (GROUPS.replace("robots: 2", "robots: null"), {}, "robots have no default: give "
     "robots:=VALUE"),
])
def test_an_argument_the_file_does_not_take_or_needs_is_refused(
        tmp_path: Path, text: str, arguments: dict[str, str], says: str) -> None:
    with pytest.raises(UsageError, match=says.replace("(", r"\(").replace(")", r"\)")):
        load_launch(_write(tmp_path, text), arguments=arguments)


@pytest.mark.parametrize(("text", "line", "says"), [
    (GROUPS.replace("$(var rate)", "$(var speed)"), 11, "$(var speed): no launch argument "
     "'speed'"),
    (GROUPS.replace("instances: $(var robots)", "instances: 0"), 7, "key 'instances': 0 is "
     "not 1 to 100"),
    (GROUPS.replace("instances: $(var robots)", "instances: many"), 7, "instances"),
    (GROUPS.replace("/robot$(var instance)", "/robot-$(var instance)"), 6, "key 'namespace'"),
    (f"transport: zenoh\nnodes:\n  - {{name: t$(var instance), node: {DEMO}:Talker}}\n", 3,
     "'instance' only in a group of instances"),
    (GROUPS.replace("  robots: 2", "  instance: 2"), 2, "'instance' is the number of a group's "
     "instance"),
    (GROUPS.replace("  rate: 20.0", "  rate: 20.0\n  key: rate").replace("count: 5",
                                                                       "$(var key): 5"), 12,
     "key '$(var key)' is 'rate' once its arguments are substituted, as another key of this "
     "mapping is"),
])
def test_a_bad_group_or_substitution_is_one_line_naming_its_line(
        tmp_path: Path, text: str, line: int, says: str) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(LaunchError) as caught:
        load_launch(path)
    assert one_line(caught, says).startswith(f"{path}:{line}: "), caught.value


def test_command_line_arguments_are_name_colon_equals_value() -> None:
    assert command_line_arguments(["robots:=3", "map:=a:=b"]) == {"robots": "3",
                                                                  "map": "a:=b"}
    with pytest.raises(UsageError, match="'robots=3' is not NAME:=VALUE"):
        command_line_arguments(["robots=3"])


@pytest.mark.slow
def test_n_instances_run_each_in_its_process_and_namespace(tmp_path: Path) -> None:
    talkers = GROUPS[:GROUPS.index("      - name: listener")]   # they end by themselves
    lines: list[str] = []
    launch = load_launch(_write(tmp_path, talkers), arguments={"robots": "3"})
    assert run_launch(launch, out=lines.append, stop_timeout=10) == 0, lines
    for n in (1, 2, 3):
        # labelled as ROS 2 launch labels processes of one name: talker, talker#2, ...
        assert any(line.endswith(f"[/robot{n}/talker] INFO sent cmd_vel 5") for line in lines)
    assert not any(alive(pid) for pid in started_pids(lines).values())


@pytest.mark.slow
def test_the_shipped_fleet_launch_starts_as_many_waffles_as_asked() -> None:
    fleet = Path(__file__).resolve().parents[2] / "configs" / "fleet.launch.yaml"
    with started([*SERVOLAB, "launch", str(fleet), "robots:=2"], stderr_to_stdout=True) as proc:
        said = wait_for_line(proc, "other tools: --connect", timeout=60)[-1]
        endpoint = said.split("--connect ")[1].split(")")[0]
        for _ in (1, 2):   # each Waffle says so once its controllers are active
            wait_for_line(proc, "running; Ctrl-C stops it", timeout=90)
        listed = servolab("topic", "list", "--connect", endpoint)
        assert listed.returncode == 0, listed.stderr
        topics = listed.stdout.split()
        for n in (1, 2):
            assert f"/robot{n}/joint_states" in topics, topics
            assert f"/robot{n}/diff_drive_controller/cmd_vel" in topics, topics
        assert "/robot3/joint_states" not in topics
