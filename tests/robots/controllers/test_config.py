"""The dynamixel_controllers configuration of seed 001: the shipped ``armstrong.yaml``, the
appendix as printed, and every malformed file refused with its line.

Facts from seed 001 (Armstrong): Listing 3.3 (controller_manager.launch: pan_tilt_port,
/dev/ttyUSB0, 57142 bps, IDs 1..65, update_rate 20), Table 2.2 (initial positions), Appendix A
(one JointPositionController per motor; m31..m51 all named pan_joint_33)."""

from __future__ import annotations

from pathlib import Path

import pytest

from servolab.robots.armstrong.hardware import CONFIG
from servolab.robots.controllers.config import ControllerConfigError, load

ROOT = Path(__file__).resolve().parents[3]
ARMSTRONG = CONFIG  # shipped with servolab.robots.armstrong
APPENDIX_A = ROOT / "tests" / "data" / "armstrong_appendix_a.yaml"

#: Table 2.2 of seed 001: motor ID -> initial position (raw)
TABLE_2_2 = {11: 512, 12: 444, 13: 512, 14: 512, 15: 512, 16: 338, 21: 512, 22: 512, 23: 408,
             24: 512, 25: 512, 26: 505, 31: 512, 32: 512, 33: 512, 41: 512, 42: 444, 43: 512,
             51: 512, 61: 512, 62: 512}


def test_armstrong_has_listing_3_3_and_table_2_2() -> None:
    config = load(ARMSTRONG)
    (port,) = config.manager.serial_ports
    assert (config.manager.namespace, port.name, port.port_name, port.baud_rate,
            port.min_motor_id, port.max_motor_id, port.update_rate) == (
        "dxl_manager", "pan_tilt_port", "/dev/ttyUSB0", 57142, 1, 65, 20.0)
    assert {c.motor.id: c.motor.init for c in config.controllers} == TABLE_2_2
    assert [c.name for c in config.controllers] == [f"controller_m{i}" for i in TABLE_2_2]
    assert all((c.motor.min, c.motor.max, c.joint_speed) == (0, 1023, 1.0)
               for c in config.controllers)
    assert not any(c.motor.flipped for c in config.controllers)


def test_appendix_a_as_printed_loads_with_a_warning_per_shared_joint_name() -> None:
    """In dynamixel_controllers a joint name only labels the state message; each controller
    drives its own motor ID, and seed 001 Figure 3.4 shows m31..m51 starting although the
    appendix names them all pan_joint_33. So the printed file loads, and says so once per
    controller that repeats a name."""
    config = load(APPENDIX_A)
    assert {c.motor.id: c.motor.init for c in config.controllers} == TABLE_2_2
    assert len(config.warnings) == 6  # m32, m33, m41, m42, m43, m51 repeat m31's name
    first = config.warnings[0]
    assert first.startswith(f"{APPENDIX_A}:")
    assert "'controller_m31'" in first and "'controller_m32'" in first
    assert "pan_joint_33" in first


def test_appendix_a_with_its_joint_names_fixed_loads_in_both_printed_layouts(
        tmp_path: Path) -> None:
    """The appendix nests joint_name/joint_speed/motor under 'controller :' for m11..m14 and
    joint_name/joint_speed only for the others: both read as dynamixel_controllers means."""
    text = APPENDIX_A.read_text()
    for motor in (31, 32, 33, 41, 42, 43, 51):
        head = f"controller_m{motor}:"
        start = text.index(head)
        text = (text[:start] + text[start:].replace("pan_joint_33", f"pan_joint_{motor}", 1))
    fixed = tmp_path / "appendix_a.yaml"
    fixed.write_text(text)
    config = load(fixed)
    assert {c.motor.id: c.motor.init for c in config.controllers} == TABLE_2_2
    assert config.controller("controller_m11").joint_name == "pan_joint_11"
    assert config.controller("controller_m16").motor.init == 338
    assert config.manager.serial_ports == ()  # a controllers-only file, as ROS users have


GOOD = """\
controller_m14:
  controller: {package: dynamixel_controllers, module: joint_position_controller,
               type: JointPositionController}
  joint_name: knee
  joint_speed: 1.0
  motor: {id: 14, init: 512, min: 0, max: 1023}
"""


@pytest.mark.parametrize(("old", "new", "line", "says"), [
    ("joint_speed: 1.0", "joint_sped: 1.0", 5, "did you mean 'joint_speed'"),
    ("joint_speed: 1.0", "joint_speed: -1.0", 5, "joint_speed must be > 0"),
    ("joint_speed: 1.0", "joint_speed: fast", 5, "must be a finite number"),
    ("init: 512", "init: 2000", 6, "init 2000 is outside min..max"),
    ("min: 0", "min: 1023", 6, "min and max are both 1023"),
    ("id: 14,", "id: 300,", 6, "motor id 300 is outside"),
    ("type: JointPositionController", "type: JointTorqueController", 2, "not supported"),
    ("  joint_name: knee\n", "", 2, "key 'joint_name' missing"),
    (", max: 1023", "", 6, "key 'max' missing"),
])
def test_malformed_controllers_are_refused_at_their_line(tmp_path: Path, old: str, new: str,
                                                         line: int, says: str) -> None:
    path = tmp_path / "robot.yaml"
    assert old in GOOD
    path.write_text(GOOD.replace(old, new))
    with pytest.raises(ControllerConfigError, match=says) as info:
        load(path)
    assert str(info.value).startswith(f"{path}:{line}:"), str(info.value)


def test_a_key_beside_and_under_controller_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "robot.yaml"
    path.write_text(GOOD.replace("type: JointPositionController}",
                                 "type: JointPositionController, joint_name: other}"))
    with pytest.raises(ControllerConfigError, match="joint_name is given twice"):
        load(path)


def test_two_controllers_of_one_motor_are_refused(tmp_path: Path) -> None:
    path = tmp_path / "robot.yaml"
    path.write_text(GOOD + GOOD.replace("controller_m14", "controller_x")
                    .replace("knee", "other"))
    with pytest.raises(ControllerConfigError, match=r"'controller_m14' .* 'controller_x' drive "
                                                    r"the same motor id 14"):
        load(path)


def test_min_above_max_flips_the_joint(tmp_path: Path) -> None:
    path = tmp_path / "robot.yaml"
    path.write_text(GOOD.replace("min: 0, max: 1023", "min: 1023, max: 0"))
    assert load(path).controller("controller_m14").motor.flipped


@pytest.mark.parametrize(("old", "new", "says"), [
    ("baud_rate: 57142.0", "baud_rate: 0", "baud_rate must be a positive whole number"),
    ("max_motor_id: 65", "max_motor_id: 0", "max_motor_id 0 is below min_motor_id 1"),
    ("update_rate: 20", "update_rate: 0", "update_rate must be > 0"),
    ("port_name: /dev/ttyUSB0", "port_nam: /dev/ttyUSB0", "did you mean 'port_name'"),
])
def test_malformed_manager_settings_are_refused(tmp_path: Path, old: str, new: str,
                                                says: str) -> None:
    manager = ("dynamixel_manager:\n  serial_ports:\n    pan_tilt_port:\n"
               "      port_name: /dev/ttyUSB0\n      baud_rate: 57142.0\n"
               "      min_motor_id: 1\n      max_motor_id: 65\n      update_rate: 20\n")
    path = tmp_path / "robot.yaml"
    path.write_text(manager.replace(old, new) + GOOD)
    with pytest.raises(ControllerConfigError, match=says):
        load(path)


def test_joint_speed_defaults_as_in_dynamixel_controllers_and_tuning_keys_load(
        tmp_path: Path) -> None:
    """dynamixel_controllers' JointController reads joint_speed (default 1.0 rad/s),
    joint_compliance_slope/_margin/_punch and joint_torque_limit (joint_controller.py)."""
    path = tmp_path / "robot.yaml"
    path.write_text(GOOD.replace("  joint_speed: 1.0\n", "  joint_compliance_slope: 64\n"
                                 "  joint_compliance_margin: 2\n  joint_compliance_punch: 40\n"
                                 "  joint_torque_limit: 0.5\n"))
    c = load(path).controller("controller_m14")
    assert (c.joint_speed, c.compliance_slope, c.compliance_margin, c.compliance_punch,
            c.torque_limit) == (1.0, 64, 2, 40, 0.5)


@pytest.mark.parametrize(("line", "says"), [
    ("  joint_torque_limit: 1.5\n", "joint_torque_limit must be within 0..1"),
    ("  joint_compliance_slope: 300\n", "joint_compliance_slope 300 is outside 0..254"),
])
def test_bad_tuning_is_refused(tmp_path: Path, line: str, says: str) -> None:
    path = tmp_path / "robot.yaml"
    path.write_text(GOOD + line)
    with pytest.raises(ControllerConfigError, match=says):
        load(path)


def test_a_position_beyond_the_rx28_is_refused_with_its_line(tmp_path: Path) -> None:
    """The RX-28 has positions 0..1023 (e-Manual): a max of 4095 would clamp nothing."""
    from servolab.robots.armstrong import hardware as armstrong

    path = tmp_path / "armstrong.yaml"
    path.write_text(ARMSTRONG.read_text().replace(
        "motor: {id: 14, init: 512, min: 0, max: 1023}",
        "motor: {id: 14, init: 512, min: 0, max: 4095}"))
    line = next(n for n, text in enumerate(path.read_text().splitlines(), 1)
                if "motor: {id: 14," in text)
    with pytest.raises(ControllerConfigError, match=r"motor max 4095 is outside the RX-28's"
                                                    r" positions 0\.\.1023") as info:
        armstrong.load_config(path)
    assert str(info.value).startswith(f"{path}:{line}:")
