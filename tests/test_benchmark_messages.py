"""Smoke test of benchmarks/messages.py: it runs end to end on a short run and writes its
figures with ``--json`` (every case present, finite and positive). It checks that the
benchmark works, not how fast anything is."""

from __future__ import annotations

import json
import math
from pathlib import Path

from tests.test_benchmarks import _load

BENCHMARK = Path(__file__).resolve().parents[1] / "benchmarks" / "messages.py"


def test_messages_quick_run(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    bench = _load(BENCHMARK, "messages_bench")
    out = tmp_path / "figures.json"
    assert bench.main(["--quick", "--json", str(out)]) == 0
    rows = json.loads(out.read_text())
    assert [row["message"] for row in rows] == [label for label, _, _ in bench.CASES]
    for row in rows:
        for key in ("fast_us", "walk_us", "walk_over_fast"):
            assert math.isfinite(row[key]) and row[key] > 0, row
    assert "walk/fast" in capsys.readouterr().out
