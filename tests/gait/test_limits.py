"""A gait beyond the joints' limits is refused at generation (issue 27), not only when the
robot is about to play it. The limits are the robot's: ``robots.armstrong.hardware
.joint_limits`` of its configuration, the same fact ``servolab walk`` checks files against;
the gait layer takes them as an argument (tests/test_layers.py: it imports no robot)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

import numpy as np
import pytest

from servolab.cli import main
from servolab.gait.errors import GaitValueError
from servolab.gait.walking import (
    LEG_MOTOR_JOINTS,
    MOTOR_COLUMNS,
    GaitParameters,
    generate_walk,
    motor_joint,
)
from servolab.kinematics.leg import JOINT_NAMES, leg_motor_angles
from servolab.robots.armstrong.hardware import CONFIG, joint_limits, load_config


@pytest.fixture(scope="module")
def limits() -> dict[str, tuple[float, float]]:
    return joint_limits(load_config())


def test_h_step_150_is_refused_naming_parameter_joint_angle_and_limit(
        limits: dict[str, tuple[float, float]]) -> None:
    """h_step 150 lifts the right foot so high at row 2 that its knee (m24) passes the RX-28's
    end, 150 degrees from the centre (1023 positions over 300 degrees, init 512)."""
    unchecked = generate_walk(GaitParameters(h_step=150))  # the leg reaches: only limits stop it
    m24 = MOTOR_COLUMNS.index("m24")
    low, high = limits["m24"]
    assert unchecked.motors[2, m24] > high
    assert not np.any(unchecked.motors[:2] > np.array([limits[c][1] for c in MOTOR_COLUMNS]))
    with pytest.raises(GaitValueError) as caught:
        generate_walk(GaitParameters(h_step=150), limits=limits)
    assert str(caught.value) == (
        f"h_step 150 mm: row 2 (t = {2 * 1000 / 4.5:g} ms) turns m24 (right knee) to "
        f"{unchecked.motors[2, m24]:.2f} degrees, beyond its limit {high:.2f} (range "
        f"[{low:.2f}, {high:.2f}]); with Table 5.1's h_step 20 mm it stays within")


def test_the_seeds_gait_keeps_the_limits(limits: dict[str, tuple[float, float]]) -> None:
    assert generate_walk(limits=limits).motors.shape == (17, 21)


@pytest.mark.parametrize(("changes", "start", "end"), [
    ({"arm_swing": 200.0}, "arm_swing 200 degrees: row 0 (t = 0 ms) turns m31 (left shoulder) "
     "to 200.00 degrees", "; with Table 5.1's arm_swing 30 degrees it stays within"),
    ({"h_step": 130.0, "d_step": 40.0}, "d_step 40 mm and h_step 130 mm: row 2 ",
     "; with Table 5.1's d_step 15 mm or h_step 20 mm it stays within"),
    ({"h_step": 150.0, "l_step": 30.0}, "h_step 150 mm: row 2 ",
     "; with Table 5.1's h_step 20 mm it stays within"),
])
def test_the_parameter_that_takes_a_joint_beyond_is_named(
        limits: dict[str, tuple[float, float]], changes: dict[str, Any], start: str,
        end: str) -> None:
    with pytest.raises(GaitValueError) as caught:
        generate_walk(GaitParameters(**changes), limits=limits)
    message = str(caught.value)
    assert message.startswith(start) and message.endswith(end), message
    assert "\n" not in message


def test_when_no_one_parameter_is_to_blame_all_changed_ones_are_named() -> None:
    """Narrow limits that the seed's gait breaks too: no single Table 5.1 value fixes it."""
    narrow = {"m14": (-40.0, 0.0)}
    with pytest.raises(GaitValueError, match=r"^l_step 30 mm: row \d+ .* turns m14 \(left knee\) "
                       r"to -\d+\.\d\d degrees, beyond its limit -40\.00 \(range \[-40\.00, "
                       r"0\.00\]\)$"):
        generate_walk(GaitParameters(l_step=30), limits=narrow)
    with pytest.raises(GaitValueError, match=r"^Table 5\.1's parameters: row 0 "):
        generate_walk(limits=narrow)


def test_motor_joint_names_follow_the_legs_motor_columns() -> None:
    """LEG_MOTOR_JOINTS is the order leg_motor_angles puts the joints in: one joint turned,
    one column moves."""
    for j, name in enumerate(JOINT_NAMES):
        q = np.zeros((1, 6))
        q[0, j] = 0.5
        sides: tuple[tuple[Literal["left", "right"], int], ...] = (("left", 11), ("right", 21))
        for side, first in sides:
            column = int(np.flatnonzero(leg_motor_angles(q, side)[0])[0])
            assert LEG_MOTOR_JOINTS[column] == name.replace("_", " ")
            assert motor_joint(f"m{first + column}") == f"{side} {name.replace('_', ' ')}"
    assert motor_joint("m51") == "m51"


def test_gait_generate_refuses_h_step_150_before_writing(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "g"
    assert main(["gait", "generate", "--h-step", "150", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert err.startswith("servolab gait generate: error: h_step 150 mm: row 2 ")
    assert "m24 (right knee) to 158.71 degrees, beyond its limit" in err
    assert not out.exists()


def test_gait_generate_takes_the_limits_of_the_given_configuration(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """--config: a knee allowed only ~18 degrees down refuses even the seed's gait."""
    path = tmp_path / "narrow.yaml"
    path.write_text(CONFIG.read_text().replace(
        "motor: {id: 14, init: 512, min: 0, max: 1023}",
        "motor: {id: 14, init: 512, min: 450, max: 1023}"))
    low = joint_limits(load_config(path))["m14"][0]
    out = tmp_path / "g"
    assert main(["gait", "generate", "--config", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"turns m14 (left knee) to -42.63 degrees, beyond its limit {low:.2f}" in err
    assert not out.exists()
