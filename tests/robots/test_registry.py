"""servolab.robots.load and `servolab robots`: every shipped robot opens on emulated motors,
and the files `servolab robots show` prints are the ones the commands load by default."""

from __future__ import annotations

from pathlib import Path

import pytest

import servolab
from servolab.cli import main
from servolab.robots import load, robots
from servolab.robots.registry import UnknownRobotError, layouts, shipped_files


@pytest.mark.parametrize("name", sorted(robots()))
def test_every_robot_loads_on_emulated_motors_and_its_motors_answer(name: str) -> None:
    entry = robots()[name]
    bus_summary = entry.bus()
    robot = load(name)
    try:
        bus = robot.bus
        for motor_id in bus_summary.ids:  # every motor the listing names is on the bus
            found = bus.ping(motor_id)
            assert found.model is not None
            assert found.model.name == bus_summary.model_of(motor_id)
        assert bus.protocol.version == bus_summary.protocol
    finally:
        robot.close()


def test_an_unknown_robot_names_the_known_ones() -> None:
    with pytest.raises(UnknownRobotError, match="no robot 'armstong'; there are armstrong"):
        load("armstong")


def test_the_listing_names_every_robot_its_bus_and_file(capsys: pytest.CaptureFixture[str]
                                                       ) -> None:
    assert main(["robots"]) == 0
    out = capsys.readouterr().out
    for name, entry in robots().items():
        assert f"{name}: {entry.summary}" in out
        assert str(entry.bus()) in out
    assert "20 x RX-28 (IDs 11-16,21-26,31-33,41-43,51,61), Protocol 1.0, 57142 bps" in out


@pytest.mark.parametrize("name", sorted(shipped_files()))
def test_show_prints_the_shipped_file(name: str, capsys: pytest.CaptureFixture[str],
                                      tmp_path: Path) -> None:
    """What is printed is the file itself, byte for byte, from the installed package's own
    folder, and a YAML file is a mapping that PyYAML reads."""
    import yaml

    assert main(["robots", "show", name]) == 0
    printed = capsys.readouterr().out
    assert printed.strip()
    shown = shipped_files()[name]
    if not isinstance(shown, Path):  # written from a description: its own test is below
        assert printed == shown()
        return
    package = Path(servolab.__file__).parent
    assert shown.is_relative_to(package) and printed == shown.read_bytes().decode()
    if shown.suffix == ".yaml":
        assert isinstance(yaml.safe_load(printed), dict)


@pytest.mark.parametrize(("name", "root"), [("armstrong.urdf", "robot"),
                                            ("armstrong.mjcf", "mujoco")])
def test_show_prints_the_biped_description(name: str, root: str,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    """The URDF and the MJCF, written from the one description (robots/armstrong/
    description.py): the text the module writes, an XML document of the right kind. The
    URDF is the one ``servolab control run armstrong`` runs: the description with the
    ``<ros2_control>`` block of the biped's bus (robots/armstrong/ros2_control.py) added."""
    import xml.etree.ElementTree as ET

    from servolab.robots.armstrong.description import model_file

    assert main(["robots", "show", name]) == 0
    printed = capsys.readouterr().out
    shown = ET.fromstring(printed)
    assert shown.tag == root
    if root == "robot":
        blocks = shown.findall("ros2_control")
        assert [b.get("name") for b in blocks] == ["armstrong"], "one <ros2_control> block"
        shown.remove(blocks[0])
        assert ET.canonicalize(ET.tostring(shown), strip_text=True) == ET.canonicalize(
            model_file("urdf").split("?>", 1)[-1], strip_text=True)
    else:
        assert printed == model_file(name.split(".")[1])


def test_show_of_something_not_shipped_is_one_line_and_exit_2(
        capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["robots", "show", "navigation"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "navigation has no configuration file" in err


@pytest.mark.slow
def test_a_copied_file_drives_the_command(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    """What a student does: print the Waffle's file, edit it, drive with it."""
    assert main(["robots", "show", "turtlebot3_waffle"]) == 0
    mine = tmp_path / "my_waffle.yaml"
    mine.write_text(capsys.readouterr().out.replace("name: turtlebot3_waffle", "name: mine"))
    assert main(["drive", "rotate", "--angle", "90", "--base", str(mine), "--no-progress",
                 "--out", str(tmp_path / "run")]) == 0
    import json

    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["base"] == "mine" and summary["interrupted"] is None


def test_a_base_is_named_or_a_file_and_a_typo_gets_a_suggestion(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from tests.clirun import refusal

    status, line = refusal(["drive", "rotate", "--angle", "10", "--base", "turtlebot",
                            "--out", str(tmp_path / "run")], capsys)
    assert status == 2
    assert line == ("servolab drive: error: turtlebot: no such file, nor a shipped base; "
                    "did you mean turtlebot3_waffle?")
    assert not (tmp_path / "run").exists()  # refused before a run folder was made


@pytest.mark.parametrize("name", sorted(n for n, p in robots().items() if p.origin == "servolab"))
def test_every_shipped_robot_names_its_files_and_makes_its_layout(name: str) -> None:
    """A shipped robot whose files or layout fail is servolab's bug, raised rather than left
    out of 'servolab robots show' and the view (only a user's robot is skipped)."""
    plugin = robots()[name]
    files = plugin.shown_files()
    if plugin.config() is not None:
        assert files[name] == plugin.config()
    if plugin.layout is not None:
        assert plugin.layout().name in layouts()


def test_the_shipped_bases_are_the_base_files_beside_them() -> None:
    """robots/base SHIPPED names exactly the ``base_<name>.yaml`` files the package ships, and
    each is a robot (so 'servolab drive --base NAME' and 'servolab robots' agree)."""
    from servolab.robots import base
    from servolab.robots.base import DEFAULT_BASE, SHIPPED

    on_disk = {p.stem.removeprefix("base_") for p in Path(base.__file__).parent.glob("base_*.yaml")}
    assert set(SHIPPED) == on_disk and DEFAULT_BASE in SHIPPED
    assert {n: robots()[n].summary for n in SHIPPED} == dict(SHIPPED)
