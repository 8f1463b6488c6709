"""benchmarks/fleet.py on a short run (--quick: 5 and 20 nodes, 1 000 messages): peer to peer
and through two routers chained, servolab and bare Zenoh, and 1 and 2 robots through one
router, each fleet fully discovered by the observer (the liveliness tokens rmw_zenoh's graph
reads), its memory per node and message rate positive, and the messages lost counted. It
checks that the benchmark works, not how fast anything is."""

from __future__ import annotations

import json
import math
import runpy
from pathlib import Path

import pytest

BENCHMARK = Path(__file__).resolve().parents[1] / "benchmarks" / "fleet.py"

#: no deadline of its own, but its floods fill both cores: never beside a test that has one
pytestmark = [pytest.mark.slow, pytest.mark.realtime]


@pytest.mark.timeout(400)   # 12 fleets of one or two processes, beside a busy worker
def test_fleet_quick_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bench = runpy.run_path(str(BENCHMARK), run_name="fleet_bench")
    out = tmp_path / "fleet.json"
    assert bench["main"](["--quick", "--json", str(out)]) == 0
    rows = json.loads(out.read_text())
    assert {(r["engine"], r["topology"], r["nodes"], r["robots"]) for r in rows} == {
        (e, t, n, 1) for e in ("servolab", "zenoh") for t in ("peer", "two routers")
        for n in (5, 20)} | {(e, "router", 5, robots) for e in ("servolab", "zenoh")
                             for robots in (1, 2)}
    for r in rows:
        assert math.isfinite(r["discovery_s"]) and r["discovery_s"] > 0, r
        assert r["rss_per_node_kib"] > 0 and r["messages_per_s"] > 0, r
        # KEEP_LAST publishers drop when congested (rmw_zenoh's choice), so a flood on a
        # busy machine loses some: counted, never more than was sent
        sent = r["nodes"] * r["robots"] * (1_000 // (r["nodes"] * r["robots"]))
        assert 0 <= r["messages_lost"] < sent, r
    printed = capsys.readouterr().out
    for topology in ("peer", "two routers"):
        assert f"ratio {topology}, 20 nodes: discovery x" in printed
        assert f"growth servolab, {topology}: discovery x" in printed
    assert "ratio 2 robots: discovery x" in printed
