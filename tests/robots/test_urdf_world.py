"""A robot folder whose URDF gives its links' masses is served in MuJoCo: its emulated
Dynamixels, named by its <ros2_control> block, move its description there; one without masses
(docs/layout.md's pan_tilt) has its motors served alone.

Facts from sources other than this code: XM430-W350, 4096 ticks a turn (ROBOTIS e-Manual,
Goal Position(116)); a URDF <inertial> gives a link's mass in kg (the URDF specification)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from servolab.dynamixel.bus import Bus
from servolab.dynamixel.emulator import build_emulator
from servolab.robots.registry import discover
from servolab.sim.emulated import port_to
from tests.robots.adding_a_robot import write_files

pytest.importorskip("mujoco")

XM430_TICK = 2 * math.pi / 4096

INERTIAL = ('<link name="{name}"><inertial><origin xyz="0 0 0.02"/><mass value="{mass}"/>'
            '<inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/></inertial>'
            '</link>')


@pytest.fixture
def robot_path(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    write_files(tmp_path, "robots/")
    monkeypatch.setenv("SERVOLAB_ROBOT_PATH", str(tmp_path / "robots"))
    return tmp_path / "robots"


def test_a_urdf_without_masses_has_its_motors_served_alone(robot_path: Path) -> None:
    served = discover().entry("pan_tilt").serve()
    assert served.place is None and served.what == ""
    assert [(m.id, m.model.name) for m in served.spec.motors] == [(1, "XM430-W350"),
                                                                   (2, "XM430-W350")]
    assert served.spec.baudrate == 1_000_000


def test_a_urdf_with_masses_moves_in_mujoco_under_its_servos(robot_path: Path) -> None:
    urdf = robot_path / "pan_tilt" / "pan_tilt.urdf"
    text = urdf.read_text()
    for name, mass in (("pan_link", 0.082), ("tilt_link", 0.082)):   # an XM430-W350: 82 g
        text = text.replace(f'<link name="{name}"/>', INERTIAL.format(name=name, mass=mass))
    urdf.write_text(text)
    served = discover().entry("pan_tilt").serve()
    assert served.place is not None and served.what == "moving its URDF in MuJoCo"
    simulation, emulator, world = served.place(build_emulator(served.spec))
    bus = Bus(port_to(emulator, simulation, 1_000_000), 2)
    goals = {1: 0.6, 2: -0.3}                      # pan, tilt (rad)
    for motor_id, goal in goals.items():
        bus.write(motor_id, "torque_enable", 1)
        bus.write(motor_id, "goal_position", goal)
    simulation.advance(2.0)
    for name, motor_id in (("pan", 1), ("tilt", 2)):
        qpos = float(world.data.qpos[world.model.joint(name).qposadr[0]])
        # the horn reads the joint, in whole ticks
        assert bus.read(motor_id, "present_position") == pytest.approx(qpos, abs=XM430_TICK)
        assert qpos == pytest.approx(goals[motor_id], abs=4 * XM430_TICK)
