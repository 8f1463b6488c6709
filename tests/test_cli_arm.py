"""``servolab arm`` on the command line: what it refuses, in one line and before anything is
brought up or moved (exit 2, no run folder; a pick out of reach leaves the run folder whose
summary names the failure), and its help."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from servolab.cli import main
from tests.clirun import refusal
from tests.robots.arm.conftest import two_joint  # noqa: F401 (a fixture)


@pytest.mark.parametrize(("args", "message"), [
    (["move", "--pose", "0.5", "0.05", "0.1"],
     "servolab arm move: error: position (0.500, 0.050, 0.100) m is out of reach of link1 -> "
     "end_effector_link within its joint limits: the nearest of 16 starts is"),
    (["move", "--pose", "0.1", "0", "0.1", "--pitch", "-3"],
     "servolab arm move: error: position (0.100, 0.000, 0.100) m, pitch -171.9° is out of "
     "reach"),
    (["move", "--joints", "0", "2", "0", "0"],
     "servolab arm move: error: move --joints: joint2 2 rad is outside its limits [-1.5, 1.5]"),
    (["move", "--joints", "0", "0"],
     "servolab arm move: error: move --joints: 4 joint positions (joint1, joint2, joint3, "
     "joint4), got 2"),
    (["home", "--speed", "2"],
     "servolab arm home: error: --speed 2: a fraction of the joints' speed limits, in (0, 1]"),
    (["gripper", "close", "--effort", "-1"],
     "servolab arm gripper: error: --effort -1: a force (N) or torque (N m) >= 0"),
    (["pick", "0.2", "0", "--place", "0.15", "0.1", "--world", "emulated"],
     "servolab arm pick: error: pick is judged from the object's pose in MuJoCo, so it runs "
     "the arm in MuJoCo here"),
    (["home", "--port", "/dev/null", "--connect", "tcp/127.0.0.1:1"],
     "servolab arm home: error: --connect joins an arm already running: --port is that run's "
     "to give, not this one's"),
    (["home", "--robot", "nosuch"], "servolab arm home: error: no robot 'nosuch'; there are"),
    (["home", "--robot", "armstrong"], "servolab arm home: error: armstrong.urdf: "
     "legs_controller's joints are not one serial chain ("),
])
def test_bad_input_is_one_line_and_nothing_is_made(args: list[str], message: str,
                                                   tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "run"
    status, line = refusal(["arm", *args, "--out", str(out)], capsys)
    assert (status, line[:len(message)]) == (2, message), line
    assert not out.exists()


def test_a_gripperless_arm_has_no_gripper_action(two_joint: Path,  # noqa: F811
                                                 tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    status, line = refusal(["arm", "gripper", "open", "--robot", "two_joint", "--out",
                            str(tmp_path / "run")], capsys)
    assert (status, line) == (2, "servolab arm gripper: error: robot two_joint has no gripper "
                              "controller in controllers.yaml")


def test_a_pick_out_of_reach_names_the_failure_in_its_summary(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "run"
    status, line = refusal(["arm", "pick", "0.42", "0", "--place", "0.15", "0.1", "--out",
                            str(out)], capsys)
    assert status == 2
    assert line.startswith("servolab arm pick: error: the pick point (0.420, 0.000) m: "
                           "position (0.420, 0.000, 0.072) m, pitch 45.0° is out of reach")
    summary = json.loads((out / "summary.json").read_text())
    assert (summary["placed"], summary["failure"]) == (False, "unreachable")
    assert summary["failure_reason"] == line.removeprefix("servolab arm pick: error: ")


def test_a_place_off_the_table_is_refused_before_anything_moves(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "run"
    status, line = refusal(["arm", "pick", "0.15", "0.1", "--place", "-0.16", "-0.1", "--out",
                            str(out)], capsys)
    assert (status, line) == (2, "servolab arm pick: error: the place point (-0.160, -0.100) m "
                              "is off the table: nothing under it, where the object must rest "
                              "at z = 0")
    summary = json.loads((out / "summary.json").read_text())
    assert (summary["placed"], summary["failure"]) == (False, "off_table")


def test_the_help_shows_every_action(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_:
        main(["arm", "--help"])
    assert exit_.value.code == 0
    out = capsys.readouterr().out
    for action in ("home", "move", "gripper", "pick"):
        assert f"\n    {action} " in out
    assert "servolab arm pick 0.2 0.0 --place 0.15 0.12" in out
