"""t_step and the playback rate: one is derived from the other (issue 27).

Seed 001 section 4.2.4.4: the control node plays one row per period of ``ros::Rate
loop_rate(4.5)``, "each movement ... is executed in 222ms. Therefore a sequence of 17
movements will be executed in 3.7s". A half cycle is four rows (Appendix D's four phases), so
the t_step the robot walked is 4 / 4.5 s = 888.9 ms; Table 5.1's 2000 ms is 2 rows a second.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from servolab.cli import main
from servolab.gait.errors import GaitValueError
from servolab.gait.walking import GaitParameters, generate_walk


def test_the_default_t_step_is_the_seeds_playback() -> None:
    params = GaitParameters()
    assert params == GaitParameters.at_rate(4.5)  # seed 001: ros::Rate loop_rate(4.5)
    assert params.play_rate == pytest.approx(4.5)
    walk = generate_walk(params)
    row = walk.time_ms[1] - walk.time_ms[0]
    assert row == pytest.approx(222.2, abs=0.05)  # "executed in 222ms"
    assert walk.motors.shape[0] / params.play_rate == pytest.approx(3.78, abs=0.005)
    assert walk.time_ms[4] == pytest.approx(params.t_step)  # a half cycle is four rows


@pytest.mark.parametrize("rate", [2.0, 4.5, 10.0])
def test_rate_and_t_step_give_each_other(rate: float) -> None:
    params = GaitParameters.at_rate(rate, l_step=30.0)
    assert params.t_step == pytest.approx(4000.0 / rate)
    assert params.play_rate == pytest.approx(rate)
    assert params.l_step == 30.0


@pytest.mark.parametrize("rate", [0.0, -1.0, math.inf, math.nan])
def test_a_rate_that_is_not_positive_is_refused(rate: float) -> None:
    with pytest.raises(GaitValueError, match="rate must be a positive number"):
        GaitParameters.at_rate(rate)
    with pytest.raises(GaitValueError, match="not both"):
        GaitParameters.at_rate(4.5, t_step=2000.0)


def _summary(out: Path) -> dict[str, object]:
    data = json.loads((out / "summary.json").read_text())
    assert isinstance(data, dict)
    return data


@pytest.mark.slow
def test_gait_generate_writes_the_rate_to_play_at(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["gait", "generate", "--out", str(tmp_path / "a")]) == 0
    summary = _summary(tmp_path / "a")
    assert summary["play_rate_hz"] == pytest.approx(4.5)
    assert summary["played_s"] == pytest.approx(17 / 4.5)
    assert summary["parameters"]["t_step"] == pytest.approx(4000 / 4.5)  # type: ignore[index]
    out = capsys.readouterr().out
    assert "play it at 4.5 rows a second (3.78 s a sequence): servolab walk --file " in out
    assert "--rate" not in out

    for argv in (["--t-step", "2000"], ["--rate", "2"]):
        folder = tmp_path / argv[0].strip("-")
        assert main(["gait", "generate", *argv, "--out", str(folder)]) == 0
        summary = _summary(folder)
        assert summary["parameters"]["t_step"] == pytest.approx(2000)  # type: ignore[index]
        assert summary["play_rate_hz"] == pytest.approx(2.0)
        assert summary["duration_ms"] == pytest.approx(16 * 500.0)
        assert f"--file {folder / 'gait.csv'} --rate 2\n" in capsys.readouterr().out


def test_gait_generate_refuses_t_step_and_rate_together(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        main(["gait", "generate", "--t-step", "2000", "--rate", "2", "--out", str(tmp_path)])
    assert stop.value.code == 2
    assert "error: argument --rate: not allowed with argument --t-step" in \
        capsys.readouterr().err
