"""The figures in docs/ are made by code: the script that makes them must run, and the numbers
the docs quote from a run must be the ones the code gives.

``docs/plots.py`` writes the numbers to ``docs/img/figures.json``: for each, the doc, the text
the doc writes (the number as the doc rounds it, and the noise the doc states beside it:
how far other seeds move it) and the tolerance that noise is. The docs must hold each text,
and a new run (``--quick``: the 100 s treadmill run shortened to 10 s, compared with the 10 s
run's committed values; the navigation's corner run, a figure with no number, cut to its
first 10 s) must give each number again within its tolerance.
"""

from __future__ import annotations

import json
import math
import runpy
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.docblocks import prose

ROOT = Path(__file__).resolve().parent.parent
FIGURES = ROOT / "docs" / "img" / "figures.json"
IMAGES = ("rx28_joint_moves.png", "xm430_profiles.png", "bus_cycle_time.png",
          "floor_world.png", "gait_feet.png",
          "gait_joint_angles.png", "biped_walk.png", "mobile_eight.png", "mobile_slip.png",
          "mobile_fusion.png", "navigation_calibration.png", "navigation_plan.png",
          "navigation_plan_no_inflation.png", "navigation_loop.png", "navigation_corner.png",
          "treadmill_frame.png", "treadmill_overlay.png", "treadmill_run.png",
          "biped_physics_seed.png", "biped_fall_frame.png", "biped_zmp_plan.png",
          "biped_physics_zmp.png", "biped_zmp_frame.png", "arm_pick.png", "fleet_scale.png",
          "sim_speed.png")


def _figures(path: Path) -> dict[str, dict[str, Any]]:
    return dict(json.loads(path.read_text())["figures"])


#: the quick run of docs/plots.py takes about 85 s alone on the project's 2-core machine, more
#: beside the other worker's tests: the tests that share it have room for it in their setup
DOCS_RUN_TIMEOUT_S = 400


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """``python docs/plots.py DIR --quick``, once for the tests of this module."""
    out = tmp_path_factory.mktemp("img")
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(sys, "argv", ["plots.py", str(out), "--quick"])
        runpy.run_path(str(ROOT / "docs" / "plots.py"), run_name="__main__")
    yield out


@pytest.mark.slow
@pytest.mark.timeout(DOCS_RUN_TIMEOUT_S)
def test_docs_plots_script_makes_its_figures(quick_run: Path) -> None:
    for name in IMAGES:
        assert (quick_run / name).stat().st_size > 10_000
        assert (ROOT / "docs" / "img" / name).exists(), f"docs/img/{name} is not committed"


def test_docs_write_the_numbers_of_figures_json() -> None:
    """Every number of docs/img/figures.json is in its doc as the doc writes it, with the
    noise the doc states beside it (line breaks in the doc are spaces)."""
    figures = _figures(FIGURES)
    assert len(figures) >= 20
    missing = []
    for key, figure in figures.items():
        doc = ROOT / figure["doc"]
        text = " ".join(figure["text"].split())
        if text not in prose(doc):
            missing.append(f"{figure['doc']}: no {text!r} ({key} = {figure['value']}, from "
                           f"{figure['run']})")
    assert not missing, ("the docs do not write these numbers as docs/img/figures.json has "
                         "them (run python docs/plots.py and write the new ones):\n"
                         + "\n".join(missing))
    for doc in {figure["doc"] for figure in figures.values()}:
        assert doc.startswith("docs/") and doc != "docs/layout.md", doc


def _close(new: float, old: float, tolerance: float) -> bool:
    return abs(new - old) <= tolerance or math.isclose(new, old, rel_tol=1e-9, abs_tol=1e-9)


@pytest.mark.slow
@pytest.mark.timeout(DOCS_RUN_TIMEOUT_S)
def test_a_new_run_gives_the_docs_numbers_within_their_noise(quick_run: Path) -> None:
    """The numbers a --quick run makes again are the committed ones, within the noise each
    doc states: the code has not drifted from what the docs say it does."""
    committed, new = _figures(FIGURES), _figures(quick_run / "figures.json")
    assert set(new) == set(committed), "docs/plots.py's numbers are not figures.json's: run it"
    drifted = []
    for key, figure in committed.items():
        pairs = [("", new[key]["value"], figure["value"])]
        if "quick" in figure:
            pairs.append((" (10 s run)", new[key]["quick"]["value"], figure["quick"]["value"]))
        for what, got, want in pairs:
            if got is not None and not _close(got, want, figure["tolerance"]):
                drifted.append(f"{key}{what}: {got:g}, committed {want:g} ± "
                               f"{figure['tolerance']:g} ({figure['doc']})")
    assert not drifted, ("a new run moved these numbers by more than their docs' noise; "
                         "update the docs and figures.json (python docs/plots.py):\n"
                         + "\n".join(drifted))


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
