"""A lab's own two-joint arm as a robot folder (pure data: a URDF with its <ros2_control>
block and a controllers file, as tests/robots/control/data has them), with a tool link fixed
below its last link, for the arm's generic paths: no SRDF, no joint_limits file, no gripper."""

from __future__ import annotations

from pathlib import Path

import pytest

DATA = Path(__file__).resolve().parents[1] / "control" / "data"
#: the tool link the folder's URDF adds, 0.1 m out along link2's x
TOOL = ('<link name="tool0"/><joint name="tool_joint" type="fixed"><parent link="link2"/>'
        '<child link="tool0"/><origin xyz="0.1 0 0"/></joint>')


def two_joint_folder(root: Path, controllers: str | None = None) -> Path:
    """``root/two_joint``: the two-joint URDF with ``tool0``, and its controllers file (or
    ``controllers``' text)."""
    folder = root / "two_joint"
    folder.mkdir(parents=True)
    urdf = (DATA / "two_joint.urdf").read_text().replace("<ros2_control", TOOL + "<ros2_control",
                                                          1)
    (folder / "two_joint.urdf").write_text(urdf)
    (folder / "controllers.yaml").write_text(
        controllers if controllers is not None
        else (DATA / "two_joint_controllers.yaml").read_text())
    return folder


@pytest.fixture
def two_joint(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The two-joint arm found by its name, ``two_joint`` (SERVOLAB_ROBOT_PATH)."""
    folder = two_joint_folder(tmp_path / "robots")
    monkeypatch.setenv("SERVOLAB_ROBOT_PATH", str(tmp_path / "robots"))
    return folder
