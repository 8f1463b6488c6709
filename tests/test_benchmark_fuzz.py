"""Smoke test of benchmarks/fuzz.py: the long run of the fuzzers, at scale 2 and on one
file's fuzzers, finds them, counts their inputs from hypothesis's statistics and reports none
failing. It checks that the benchmark works, not how fast anything is."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.test_benchmarks import _load

BENCHMARK = Path(__file__).resolve().parents[1] / "benchmarks" / "fuzz.py"


@pytest.mark.slow
def test_fuzz_quick_run(tmp_path: Path) -> None:
    bench = _load(BENCHMARK, "fuzz_bench")
    out = tmp_path / "figures.json"
    assert bench.main(["--quick", "--only", "test_malformed", "--json", str(out)]) == 0
    figures = json.loads(out.read_text())
    assert figures["scale"] == 2 and figures["failing"] == 0
    assert len(figures["fuzzers"]) == 3  # test_malformed.py's

    for name, counts in figures["fuzzers"].items():
        assert counts["tried"] > 0, name  # every fuzzer ran and was counted
    assert figures["inputs"] > figures["suite_inputs"] > 0
