"""The sequence played in a loop (seed 001 section 4.2.4.4: the control node plays the file
N times in a row, so its last row is followed by its first): an odd c_step is refused, and
no generated sequence turns a joint more at the wrap than between two rows inside it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from servolab.cli import main
from servolab.gait.errors import GaitValueError
from servolab.gait.walking import (
    MOTOR_COLUMNS,
    GaitParameters,
    check_loop,
    foot_positions,
    generate_walk,
    loop_jumps,
)
from tests.gait.test_walking import _benchmark

M12 = MOTOR_COLUMNS.index("m12")


def _wrap_within(motors: np.ndarray) -> None:
    """The issue's measure: per joint column, |last row - first row| is no larger than the
    largest change between two consecutive rows inside the sequence."""
    wrap = np.abs(motors[-1] - motors[0])
    inner = np.abs(np.diff(motors, axis=0)).max(axis=0)
    assert np.all(wrap <= inner + 1e-9), [
        (MOTOR_COLUMNS[k], round(float(wrap[k]), 3), round(float(inner[k]), 3))
        for k in np.flatnonzero(wrap > inner + 1e-9)]


@pytest.mark.parametrize("params", [
    GaitParameters(),
    GaitParameters(c_step=2),
    GaitParameters(c_step=8, l_step=30, h_step=15),
    GaitParameters(c_step=6, l_step=60, s_step=30, h_step=30, d_step=20),
    GaitParameters(c_step=2, l_step=0, s_step=0, h_step=0),
])
def test_the_wrap_turns_no_joint_more_than_a_row_inside(params: GaitParameters) -> None:
    motors = generate_walk(params).motors
    _wrap_within(motors)
    wrap, inner = loop_jumps(motors)
    assert wrap == pytest.approx(np.abs(motors[-1] - motors[0]))
    assert inner == pytest.approx(np.abs(np.diff(motors, axis=0)).max(axis=0))


def test_the_seeds_wrap_is_its_stand_pose_back_to_appendix_d_start() -> None:
    """With the seed's c_step 4 the last row is Table 4.2's stand pose (left foot (20, 2),
    right (-20, 17), seeds/README.md) and the wrap goes back to Appendix D's start: at most
    3.6 degrees (the hip and ankle roll), where a row inside changes up to 26.6 (the knee)."""
    walk = generate_walk()
    assert walk.feet.left[-1] == pytest.approx([20, 2, -295])
    assert walk.feet.right[-1] == pytest.approx([-20, 17, -295])
    wrap, inner = loop_jumps(walk.motors)
    assert float(wrap.max()) == pytest.approx(3.56, abs=0.01)
    assert float(inner[:12].max()) == pytest.approx(26.57, abs=0.01)


@pytest.mark.parametrize("c_step", [1, 3, 5, 7])
def test_an_odd_c_step_is_refused_naming_it(c_step: int) -> None:
    """What the seed's generator writes for an odd c_step ends with the left foot behind
    (x = -20) where the first row has it forward (x = +20), both feet planted: looped, m12
    jumps 12.7 degrees between two rows and the planted feet are dragged 40 mm."""
    params = GaitParameters(c_step=c_step)
    feet = foot_positions(params)  # Appendix D as written: no refusal there
    assert feet.left[0, 0] == 20 and feet.left[-1, 0] == -20
    assert feet.left[-1, 2] == feet.right[-1, 2] == feet.left[0, 2]  # both planted
    seed_motors = np.asarray(_benchmark().loop_walk(params))
    assert abs(seed_motors[-1, M12] - seed_motors[0, M12]) == pytest.approx(12.73, abs=0.01)
    even = " or ".join(str(n) for n in (c_step - 1, c_step + 1) if n > 0)
    with pytest.raises(GaitValueError) as caught:
        generate_walk(params)
    message = str(caught.value)
    assert message.startswith(f"c_step {c_step}: odd, so the sequence ends with the right "
                              "foot forward")
    assert "drag both planted feet 40 mm and turn m12 (left hip pitch) 12.73 degrees" in message
    assert message.endswith(f"use an even c_step ({even})")
    assert "\n" not in message


def test_a_wrap_that_drags_a_planted_foot_is_refused_naming_the_parameter() -> None:
    """With an even c_step the first row (Appendix D's start, feet 2 * y_start = 19 mm apart)
    and the others (d_step apart) differ by |d_step - 2 y_start|: 4 mm with the seed's
    values, a wrap within the rows' changes; 41 mm with d_step 60 and a small sway is not."""
    with pytest.raises(GaitValueError) as caught:
        generate_walk(GaitParameters(d_step=60, s_step=5))
    message = str(caught.value)
    assert message.startswith("d_step 60 mm: played in a loop, the wrap from the last row "
                              "back to the first turns m23 (right hip roll) ")
    assert "the first row has the feet 19 mm apart sideways (2 y_start), the others 60 mm " \
        "(d_step), so the wrap drags a planted foot 41 mm; with Table 5.1's d_step 15 mm it " \
        "stays within" in message
    assert "\n" not in message
    # y_start = d_step / 2 closes it: no slide at the wrap
    _wrap_within(generate_walk(GaitParameters(d_step=60, s_step=5, y_start=30)).motors)


def test_check_loop_on_any_sequence() -> None:
    ok = np.array([[0.0, 0.0], [10.0, 1.0], [5.0, 2.0], [1.0, 1.0]])
    check_loop(ok, ("a", "b"))
    jump = np.array([[0.0, 0.0], [1.0, 10.0], [2.0, 20.0], [3.0, 30.0]])
    with pytest.raises(GaitValueError, match=r"^walk\.csv: played in a loop, the wrap from the "
                       r"last row back to the first turns m24 \(right knee\) 30\.00 degrees, "
                       r"more than any two rows inside it do \(10\.00\)$"):
        check_loop(jump, ("m14", "m24"), what="walk.csv")
    check_loop(np.zeros((1, 2)), ("a", "b"))  # one row: no wrap


def test_gait_generate_refuses_an_odd_c_step_before_writing(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "g"
    assert main(["gait", "generate", "--c-step", "3", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.startswith("servolab gait generate: error: c_step 3: odd")
    assert not out.exists()
