"""The arm declares its own leader and says it is the default arm, through the public plug-in
API: listed, opened on emulated motors, served by ``servolab sim --robot
open_manipulator_x_leader`` with its horns in the scripted hand about the arm's own
:data:`HAND`; ``servolab arm`` and ``servolab teleop`` name no robot."""

from __future__ import annotations

from pathlib import Path

import pytest

from servolab.dynamixel.bus import Bus
from servolab.dynamixel.emulator import build_emulator
from servolab.errors import UsageError
from servolab.robots.open_manipulator_x import HAND, NAME
from servolab.robots.plugin import RobotPlugin
from servolab.robots.registry import default_robot, discover
from servolab.robots.teleop.hand import HandWorld
from servolab.robots.teleop.leader import SERVED_BEGIN_S, LeaderPlugin, leader_of, leader_plugin
from servolab.sim.emulated import port_to

LEADER = f"{NAME}_leader"


def test_it_is_found_and_is_the_arm_with_its_torque_off() -> None:
    found = discover({})
    leader, arm = found.entry(LEADER), found.entry(NAME)
    assert isinstance(leader, LeaderPlugin) and (leader.arm, leader.hand) == (NAME, HAND)
    assert leader.origin == "servolab" and leader.commands == ("teleop",)
    # declared in the arm's own package, not in teleop's
    assert leader.open.__module__ == "servolab.robots.teleop.leader"
    assert leader_of(NAME) == leader and leader_of(LEADER) == leader
    assert leader.bus() == arm.bus()
    assert leader.description is not None and arm.description is not None
    assert leader.description() == arm.description()
    assert leader.on_stop.startswith("the motors' torque goes off")


def test_served_its_motors_follow_the_hand() -> None:
    served = discover({}).entry(LEADER).serve()
    assert served.place is not None and served.spec.baudrate == 1_000_000
    simulation, emulator, world = served.place(build_emulator(served.spec))
    assert isinstance(world, HandWorld)
    bus = Bus(port_to(emulator, simulation, 1_000_000), 2)
    ids = [11, 12, 13, 14]
    homes = [HAND[f"joint{i}"][0] for i in range(1, 5)]
    simulation.advance_to(SERVED_BEGIN_S - 0.1)   # held at home until the hand begins
    assert list(bus.sync_read("present_position", ids).values()) == pytest.approx(homes,
                                                                                  abs=2e-3)
    simulation.advance_to(SERVED_BEGIN_S + 3.0)
    moved = bus.sync_read("present_position", ids)
    assert max(abs(moved[i] - h) for i, h in zip(ids, homes, strict=True)) > 0.05
    assert [moved[i] for i in ids] == pytest.approx(list(world.joints()[:4]), abs=2e-3)


@pytest.mark.parametrize("command", ["arm", "teleop"])
def test_it_is_the_default_arm_by_its_own_word(command: str) -> None:
    assert discover({}).entry(NAME).default_for == ("arm", "teleop")
    assert default_robot(command, {}) == NAME


def _claims(monkeypatch: pytest.MonkeyPatch, *plugins: RobotPlugin) -> None:
    """Installs ``plugins`` as a lab's entry point would."""
    from servolab.robots import registry

    monkeypatch.setattr(registry, "_entry_points",
                        lambda: [(p.name, f"entry point {p.name}", p) for p in plugins])


def _lab_arm(name: str) -> RobotPlugin:
    arm = discover({}).entry(NAME)
    return RobotPlugin(name, "a lab's arm", bus=arm.bus, open=arm.open, on_stop=arm.on_stop,
                       description=arm.description, default_model=arm.default_model,
                       default_for=("arm",))


def test_a_labs_own_default_wins_and_two_are_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    _claims(monkeypatch, _lab_arm("lab_arm"))
    assert default_robot("arm", {}) == "lab_arm"
    assert default_robot("teleop", {}) == NAME   # it claimed arm only
    _claims(monkeypatch, _lab_arm("lab_arm"), _lab_arm("other_arm"))
    with pytest.raises(UsageError, match="lab_arm and other_arm each say they are its "
                       "default; give --robot NAME"):
        default_robot("arm", {})
    with pytest.raises(UsageError, match="no robot is its default; give --robot NAME"):
        default_robot("walk_backwards", {})


def test_a_labs_arm_declares_its_leader_the_same_way(monkeypatch: pytest.MonkeyPatch) -> None:
    """A lab's arm and its leader, both from its entry point: the leader's hand is the lab's,
    and its bus and URDF are its arm's."""
    arm = _lab_arm("lab_arm")
    hand = {"joint1": (0.2, 0.1)}
    _claims(monkeypatch, arm, leader_plugin("lab_arm", hand))
    leader = leader_of("lab_arm")
    assert leader is not None and leader.name == "lab_arm_leader" and leader.hand == hand
    assert leader.origin == "entry point lab_arm_leader" and leader.bus() == arm.bus()


def test_a_labs_plug_in_that_fails_to_load_stops_the_fallback(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A lab's arm that cannot be loaded may have been the default: servolab's own is not
    taken in its place (its motors are not the lab's), the problem is named."""
    from servolab.robots import registry

    monkeypatch.setattr(registry, "_entry_points", lambda: [
        ("lab_arm", "entry point lab_arm", ImportError("No module named 'lab_arm'"))])
    with pytest.raises(UsageError, match=r"servolab arm: robot 'lab_arm' could not be loaded "
                       r"\(.*No module named 'lab_arm'.*\) and may be the default; give "
                       r"--robot NAME"):
        default_robot("arm", {})


def test_a_leader_declared_by_an_alias_is_its_arms(monkeypatch: pytest.MonkeyPatch) -> None:
    from dataclasses import replace

    arm = replace(_lab_arm("lab_arm"), aliases=("lab_alias",))
    _claims(monkeypatch, arm, leader_plugin("lab_alias", {"joint1": (0.2, 0.1)},
                                            name="lab_arm_leader"))
    leader = leader_of("lab_arm")
    assert leader is not None and leader.name == "lab_arm_leader"


def test_emulated_teleop_moves_the_leader_about_the_arms_own_hand() -> None:
    """servolab teleop's scripted hand takes its homes and swings from the arm's leader
    plug-in, not from each joint's range."""
    from servolab.robots.teleop.run import Arm, _hand_homes

    assert _hand_homes(Arm.named(NAME)) == HAND
    assert _hand_homes(Arm.named(LEADER)) == HAND


def test_a_broken_robot_folder_does_not_hide_the_default(tmp_path: Path) -> None:
    """A robot folder cannot claim a command (no default_for), so its failure changes
    nothing: the default stays the arm's."""
    from servolab.robots.registry import PATH_VARIABLE

    broken = tmp_path / "robots" / "broken_arm"
    broken.mkdir(parents=True)
    (broken / "robot.yaml").write_text("summary: an arm whose URDF was never copied\n")
    environ = {PATH_VARIABLE: str(tmp_path / "robots")}
    assert "broken_arm" in discover(environ).problems
    assert default_robot("arm", environ) == NAME
