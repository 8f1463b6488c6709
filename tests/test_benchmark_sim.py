"""Smoke test of benchmarks/sim.py: its main runs end to end on a short run and writes, in its
JSON, every scenario with finite figures that add up. It checks that the benchmark works, not
how fast anything is (speed is the benchmark's to print)."""

from __future__ import annotations

import importlib.util
import json
import math
import sys
from pathlib import Path
from types import ModuleType

import pytest

BENCHMARK = Path(__file__).resolve().parents[1] / "benchmarks" / "sim.py"


def _load() -> ModuleType:
    spec = importlib.util.spec_from_file_location("sim_benchmark", BENCHMARK)
    assert spec and spec.loader
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while building
    try:
        spec.loader.exec_module(module)
    finally:
        sys.modules.pop(spec.name, None)
    return module


@pytest.mark.timeout(60)
def test_sim_benchmark_quick_run(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                 monkeypatch: pytest.MonkeyPatch) -> None:
    bench = _load()
    monkeypatch.setattr(bench, "pin_to_one_core", lambda: "not pinned (test)")
    out_json = tmp_path / "sim.json"
    assert bench.main(["--seconds", "0.5", "--json", str(out_json)]) == 0
    printed = capsys.readouterr().out
    assert "real-time factor" in printed and "50x goal" in printed

    figures = json.loads(out_json.read_text())
    scenarios = figures["scenarios"]
    assert sorted(scenarios) == ["a", "b", "c", "d"]
    assert "57142 bps" in scenarios["a"]["title"] and "1000000 bps" in scenarios["b"]["title"]
    for key, s in scenarios.items():
        assert s["simulated_s"] == pytest.approx(0.5, abs=0.06), key
        assert math.isfinite(s["real_time_factor"]) and s["real_time_factor"] > 0, key
        # 1 ms physics steps: as many steps as simulated milliseconds
        assert s["physics_steps"] == pytest.approx(s["simulated_s"] * 1000, abs=1), key
        shares = s["shares"]
        assert set(shares) >= {"physics", "driver_and_port"}, key
        assert all(0.0 <= v <= 1.0 for v in shares.values()), (key, shares)
        assert sum(shares.values()) == pytest.approx(1.0, abs=1e-6), (key, shares)
    assert scenarios["d"]["transactions"] == 0          # the world alone: nobody on the bus
    for key in "abc":
        assert scenarios[key]["transactions"] > 0 and scenarios[key]["state_rate_hz"] > 0
    # 20 Hz asked for; at 57142 bps the twenty READs do not fit in 50 ms, at 1 Mbps they do
    assert scenarios["a"]["state_rate_hz"] < 20.0
    assert scenarios["b"]["state_rate_hz"] == pytest.approx(20.0, abs=2.1)
