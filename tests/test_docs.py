"""The figures in docs/ are made by code: the script that makes them must run."""

from __future__ import annotations

import runpy
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.slow
def test_docs_plots_script_makes_its_figures(tmp_path: Path, monkeypatch: pytest.MonkeyPatch
                                             ) -> None:
    monkeypatch.setattr(sys, "argv", ["plots.py", str(tmp_path), "--quick"])
    runpy.run_path(str(ROOT / "docs" / "plots.py"), run_name="__main__")
    for name in ("rx28_joint_moves.png", "bus_cycle_time.png", "floor_world.png",
                 "gait_feet.png", "gait_joint_angles.png", "biped_walk.png",
                 "mobile_eight.png", "mobile_slip.png", "mobile_fusion.png",
                 "navigation_calibration.png", "navigation_plan.png",
                 "navigation_plan_no_inflation.png", "navigation_loop.png",
                 "navigation_corner.png", "treadmill_frame.png", "treadmill_run.png"):
        assert (tmp_path / name).stat().st_size > 10_000
        assert (ROOT / "docs" / "img" / name).exists(), f"docs/img/{name} is not committed"


def test_docs_name_only_registers_that_exist() -> None:
    """Every register name written in backticks in docs/dynamixel.md exists in some model."""
    import re

    from servolab.dynamixel.models import MODELS

    known = {r.name for m in MODELS.values() for r in m.registers}
    text = (ROOT / "docs" / "dynamixel.md").read_text()
    candidates = set(re.findall(r"`([a-z]+(?:_[a-z]+)+)`", text))
    registers = {c for c in candidates if c.startswith(("goal_", "present_", "moving_",
                                                         "operating_", "torque_", "status_"))}
    assert registers, "the doc should name registers"
    assert registers <= known, registers - known
