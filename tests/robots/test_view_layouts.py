"""The robots' Foxglove layouts: well-formed files whose panels show topics the robots publish."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from servolab.cli import main
from servolab.errors import UsageError
from servolab.robots.navigation.run import RECORDED as NAVIGATION_RECORDED
from servolab.robots.registry import layout_named, layouts
from servolab.robots.treadmill.node import FICTRAC_TOPIC, OVERLAY_TOPIC
from servolab.robots.treadmill.rig import RECORDED as TREADMILL_RECORDED

LAYOUTS = layouts()

#: what each robot's run publishes, from the robots' own modules (walk: the state publisher's
#: four topics and the manager's diagnostics, tests/robots/armstrong/test_state_publisher.py)
PUBLISHED = {
    "armstrong": {"/robot_description", "/joint_states", "/tf", "/tf_static", "/diagnostics"},
    "navigation": set(NAVIGATION_RECORDED),
    "base": {"/odom", "/tf", "/cmd_vel", "/joint_states"},
    "treadmill": {*TREADMILL_RECORDED, OVERLAY_TOPIC, FICTRAC_TOPIC},
    # under servolab control run: joint_state_broadcaster's two topics and the state
    # publisher's three (robots/control/bringup.py, joint_state_broadcaster.py)
    "open_manipulator_x": {"/joint_states", "/dynamic_joint_states", "/robot_description",
                           "/tf", "/tf_static"},
}


def _leaves(mosaic: Any) -> list[str]:
    if isinstance(mosaic, str):
        return [mosaic]
    assert set(mosaic) == {"direction", "first", "second", "splitPercentage"}
    assert mosaic["direction"] in ("row", "column")
    return _leaves(mosaic["first"]) + _leaves(mosaic["second"])


@pytest.mark.parametrize("name", sorted(LAYOUTS))
def test_a_layout_is_a_foxglove_layout_file(name: str) -> None:
    data = json.loads(json.dumps(LAYOUTS[name].to_json()))
    assert set(data) >= {"configById", "globalVariables", "userNodes", "layout"}
    assert sorted(_leaves(data["layout"])) == sorted(data["configById"])
    for key in data["configById"]:
        assert key.split("!")[0] in {"3D", "Plot", "Image", "RawMessages"}


@pytest.mark.parametrize("name", sorted(LAYOUTS))
def test_a_layout_shows_only_what_its_robot_publishes(name: str) -> None:
    assert LAYOUTS[name].topics() <= PUBLISHED[name]


def test_the_biped_layout_draws_the_urdf_from_its_topic() -> None:
    config = LAYOUTS["armstrong"].to_json()["configById"]["3D!robot"]
    urdf = [layer for layer in config["layers"].values() if layer["layerId"] == "foxglove.Urdf"]
    assert urdf == [{"layerId": "foxglove.Urdf", "sourceType": "topic",
                     "topic": "/robot_description", "visible": True, "label": "robot"}]


def test_view_layout_writes_the_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "armstrong.json"
    assert main(["view", "--layout", "armstrong", "-o", str(out)]) == 0
    assert json.loads(out.read_text()) == LAYOUTS["armstrong"].to_json()
    assert "Import" in capsys.readouterr().out


def test_an_unknown_layout_names_the_ones_there_are() -> None:
    with pytest.raises(UsageError, match="no layout 'walk'; there are: armstrong, base"):
        layout_named("walk")
