"""The walking-pattern generator: seed 001's Appendix D (feet), Appendix E (motor angles),
Table 5.1 (parameters) and Table 4.3 (a printed excerpt of the generated file)."""

from __future__ import annotations

import dataclasses
import importlib.util
import math
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest

from servolab.gait.plots import plot_foot_positions, plot_joint_angles
from servolab.gait.walking import (
    MOTOR_COLUMNS,
    GaitParameters,
    foot_positions,
    generate_walk,
)
from servolab.kinematics.leg import ARMSTRONG_LEG

# Table 4.3 of seed 001, the printed cells of its three rows (columns m11..m16, m21, m22,
# and m62 after the "..."). MATLAB's csvwrite prints 5 significant digits.
TABLE_4_3_COLUMNS = ("m11", "m12", "m13", "m14", "m15", "m16", "m21", "m22", "m62")
TABLE_4_3 = (
    ("0", "-27.666", "0.61939", "-42.992", "15.326", "-0.61939", "0", "-14.746", "0"),
    ("0", "-26.595", "6.7817", "-40.935", "14.34", "-6.7817", "0", "-12.398", "0"),
    ("0", "-27.476", "-2.9396", "-42.628", "15.152", "2.9396", "0", "-15.152", "0"),
)
# seeds/README.md: the printed file runs from the last sample back to the first, so the
# printed rows are samples 16, 15 and (the last printed row) 0 of the sequence.
TABLE_4_3_SAMPLES = (16, 15, 0)


def test_table_4_3_printed_rows() -> None:
    walk = generate_walk()
    assert walk.motors.shape == (17, 21)
    columns = [MOTOR_COLUMNS.index(name) for name in TABLE_4_3_COLUMNS]
    for sample, row in zip(TABLE_4_3_SAMPLES, TABLE_4_3, strict=True):
        shown = tuple(f"{walk.motors[sample, c] + 0.0:.5g}" for c in columns)
        assert shown == row, sample


def test_row_order_is_time_order_and_walks_forwards() -> None:
    """Sample 0 is t = 0 (Appendix D's time vector, t_step / 4 apart: one row period of the
    robot's 4.5 Hz loop); while a foot is lifted (z = -275) it moves forwards (x grows) and
    the other foot backwards under the hip."""
    walk = generate_walk()
    assert walk.time_ms == pytest.approx(np.arange(17) * 1000.0 / 4.5)
    for lifted, stance in ((walk.feet.right, walk.feet.left), (walk.feet.left, walk.feet.right)):
        up = np.flatnonzero(lifted[:, 2] == -275.0)
        assert len(up) == 2
        assert np.all(lifted[up + 1, 0] > lifted[up - 1, 0])
        assert np.all(stance[up + 1, 0] < stance[up - 1, 0])


def test_readme_foot_samples() -> None:
    """seeds/README.md: 17 samples; sample 0, 15 and 16 of a literal port of Appendix D."""
    feet = foot_positions()
    assert feet.left.shape == feet.right.shape == (17, 3)
    for sample, left, right in ((0, (20, -9.5), (-20, 9.5)), (15, (20, 22), (-20, 37)),
                                (16, (20, 2), (-20, 17))):
        assert feet.left[sample] == pytest.approx([*left, -295.0])
        assert feet.right[sample] == pytest.approx([*right, -295.0])
    assert set(np.concatenate([feet.left[:, 2], feet.right[:, 2]])) == {-295.0, -275.0}


def _benchmark() -> ModuleType:
    """benchmarks/gait.py, whose per-sample loop port of Appendix D (``loop_feet``) is the
    reference here too: statement by statement as the appendix writes it."""
    path = Path(__file__).resolve().parents[2] / "benchmarks" / "gait.py"
    spec = importlib.util.spec_from_file_location("gait_benchmark", path)
    assert spec and spec.loader
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    try:
        spec.loader.exec_module(module)
    finally:
        sys.modules.pop(spec.name, None)
    return module


@pytest.mark.parametrize("params", [
    GaitParameters(),
    GaitParameters(c_step=1),
    GaitParameters(c_step=7, l_step=30, s_step=10, h_step=15, d_step=25, y_start=3),
    GaitParameters(c_step=2, l_step=0, s_step=0, h_step=0, d_step=0),
])
def test_vectorised_port_equals_the_literal_loop(params: GaitParameters) -> None:
    left, right = _benchmark().loop_feet(params, ARMSTRONG_LEG)
    feet = foot_positions(params)
    np.testing.assert_allclose(feet.left, left, atol=1e-12)
    np.testing.assert_allclose(feet.right, right, atol=1e-12)
    assert feet.time_ms[-1] == params.c_step * params.t_step


def test_appendix_e_upper_body() -> None:
    """Appendix E: MATLAB row l odd (our sample 0, 2, ...) takes P_odd (m31 = m41 = 30),
    even l takes P_par (-30); the other seven upper-body motors stay 0; m11 = m21 = 0."""
    motors = generate_walk().motors
    m31, m41 = MOTOR_COLUMNS.index("m31"), MOTOR_COLUMNS.index("m41")
    expected = np.where(np.arange(17) % 2 == 0, 30.0, -30.0)
    assert motors[:, m31] == pytest.approx(expected)
    assert motors[:, m41] == pytest.approx(expected)
    rest = [i for i in range(12, 21) if i not in (m31, m41)] + [0, 6]
    assert not motors[:, rest].any()


def test_table_5_1_defaults() -> None:
    """Table 5.1's values, except t_step: derived from the robot's 4.5 rows a second
    (tests/gait/test_timing.py), Table 5.1's 2000 ms being that of 2 rows a second."""
    p = GaitParameters()
    assert (p.d_step, p.l_step, p.c_step, p.h_step, p.s_step) == (15.0, 40.0, 4, 20.0, 20.0)
    assert p.t_step == pytest.approx(4 * 1000 / 4.5)
    assert GaitParameters.at_rate(2.0).t_step == 2000.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.l_step = 10.0  # type: ignore[misc]
    with pytest.raises(TypeError):
        GaitParameters(2000.0)  # type: ignore[call-arg]


@pytest.mark.parametrize(("changes", "message"), [
    ({"t_step": 0.0}, "t_step"), ({"t_step": math.nan}, "t_step"),
    ({"c_step": 0}, "c_step"), ({"c_step": 2.5}, "c_step"), ({"c_step": True}, "c_step"),
    ({"d_step": -1.0}, "d_step"), ({"l_step": -40.0}, "l_step"),
    ({"h_step": math.inf}, "h_step"), ({"s_step": -20.0}, "s_step"),
    ({"y_start": math.nan}, "y_start"), ({"arm_swing": math.inf}, "arm_swing"),
])
def test_nonsensical_parameters_are_refused(changes: dict[str, Any], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        GaitParameters(**changes)


@pytest.mark.parametrize(("changes", "message"), [
    ({"d_step": 310.0}, "d_step"),
    ({"s_step": 100.0, "t_step": 2000.0},
     r"gait sample 1 \(t = 500 ms\): the left foot at \(20, -117, -295\)"),
    ({"h_step": 200.0, "t_step": 2000.0},
     r"gait sample 2 \(t = 1000 ms\): the right foot .* above"),
])
def test_unreachable_gait_names_the_first_sample(changes: dict[str, Any], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        generate_walk(GaitParameters(**changes))


def test_plots_are_written(tmp_path: Path) -> None:
    walk = generate_walk()
    for plot, name in ((plot_foot_positions, "feet.png"), (plot_joint_angles, "angles.png")):
        path = plot(walk, tmp_path / name)
        assert path.stat().st_size > 1000
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
