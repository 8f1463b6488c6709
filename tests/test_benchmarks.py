"""Smoke test of benchmarks/bus_cycle.py: its main runs end to end on a few cycles, prints the
three buses' lines and writes finite, positive figures. It checks that the benchmark works, not
how fast anything is."""

from __future__ import annotations

import importlib.util
import json
import math
import os
import re
import sys
from pathlib import Path
from types import ModuleType

import pytest

pytest.importorskip("dynamixel_sdk")

BENCHMARK = Path(__file__).resolve().parents[1] / "benchmarks" / "bus_cycle.py"
NUMBER = r"([-+]?\d+(?:\.\d+)?)"


def _load(path: Path = BENCHMARK, name: str = "bus_cycle") -> ModuleType:
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec and spec.loader
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while building
    try:
        spec.loader.exec_module(module)
    finally:
        sys.modules.pop(spec.name, None)
    return module


def _positive(value: float) -> bool:
    return isinstance(value, int | float) and math.isfinite(value) and value > 0


@pytest.mark.timeout(30)
def test_bus_cycle_quick_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bench = _load()
    out_json = tmp_path / "figures.json"
    assert bench.main(["--cycles", "3", "--rounds", "1", "--warmup", "1",
                       "--json", str(out_json)]) == 0
    out = capsys.readouterr().out

    # One ratio line per bus, each a finite positive number.
    ratios = re.findall(rf"^\(([abc])\) (.+): ratio ours/sdk = {NUMBER}$", out, re.MULTILINE)
    assert [key for key, _, _ in ratios] == ["a", "b", "c"], out
    assert "57142 bps" in ratios[0][1] and "RX-28" in ratios[0][1]
    assert "1000000 bps" in ratios[1][1] and "RX-28" in ratios[1][1]
    assert "XM430-W210" in ratios[2][1] and "protocol 2.0" in ratios[2][1]
    assert all(_positive(float(r)) for _, _, r in ratios)

    # Wire-time rows: two return delays per bus; emulated, analytic and SDK figures positive.
    wire = re.findall(rf"^\(([abc])\)\s+(\d+) \([\d.]+ ms\)\s+(\d+)/(\d+)\s+{NUMBER}\s+{NUMBER}"
                      rf"\s+{NUMBER}%\s+{NUMBER}\s+{NUMBER}$", out, re.MULTILINE)
    assert [(key, delay) for key, delay, *_ in wire] == [
        (k, d) for k in "abc" for d in ("250", "0")], out
    for _, _, _, _, emulated, analytic, _, sdk_ms, rate in wire:
        assert all(_positive(float(x)) for x in (emulated, analytic, sdk_ms, rate))

    # Host CPU rows: ours, ours SI and SDK per bus.
    cpu = re.findall(rf"^\(([abc])\)\s+{NUMBER}\s+{NUMBER}\s+{NUMBER}\s+{NUMBER}\s", out,
                     re.MULTILINE)
    assert [row[0] for row in cpu] == ["a", "b", "c"], out
    assert all(_positive(float(x)) for row in cpu for x in row[1:])

    figures = json.loads(out_json.read_text())
    assert sorted(figures["configs"]) == ["a", "b", "c"]
    for config in figures["configs"].values():
        assert len(config["wire"]) == 2
        for row in config["wire"]:
            for key in ("emulated_ms", "analytic_ms", "sdk_emulated_ms", "max_rate_hz"):
                assert _positive(row[key]), (key, row)
            assert abs(row["emulated_ms"] - row["analytic_ms"]) <= 0.03 * row["analytic_ms"]
        for side in ("ours", "ours_si", "sdk"):
            assert _positive(config["cpu"][side]["host_us"]), config["cpu"][side]
        assert _positive(config["cpu"]["ratio_ours_sdk"])


def test_bus_cycle_wire_figures_match_packet_sizes() -> None:
    """The analytic cross-check itself: 388 bytes for 20 RX-28 (68-byte SYNC_WRITE, 20 x 8-byte
    READ, 20 x 8-byte status), 133 bytes for 5 XM430 (39 + 19 out, 5 x 15 in)."""
    bench = _load()
    a, _, c = bench.CONFIGS
    fig = bench.analytic(a, 0)
    assert (fig["bytes_out"], fig["bytes_in"]) == (68 + 20 * 8, 20 * 8)
    assert fig["seconds"] == pytest.approx(388 * 10 / 57_142)
    fig = bench.analytic(c, 250)
    assert (fig["bytes_out"], fig["bytes_in"]) == (39 + 19, 5 * 15)
    assert fig["seconds"] == pytest.approx(133 * 10 / 1e6 + 5 * 0.5e-3)


MIDDLEWARE = BENCHMARK.with_name("middleware.py")


@pytest.mark.slow
@pytest.mark.timeout(120)
def test_middleware_quick_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """benchmarks/middleware.py --quick: eight setups (Twist and Image; servolab and bare
    Zenoh; one and two processes) each echo every ping and count every flood message, and the
    ratios servolab/zenoh come out finite. Its child processes are gone afterwards."""
    bench = _load(MIDDLEWARE, "middleware_bench")
    out_json = tmp_path / "figures.json"
    assert bench.main(["--quick", "--json", str(out_json)], progress=lambda s: None) == 0
    out = capsys.readouterr().out

    rows = re.findall(rf"^(Twist|Image)\s+(servolab|zenoh), (one process|two processes)\s+"
                      rf"(\d+)\s+{NUMBER}\s+{NUMBER}\s+{NUMBER}\s+{NUMBER}$", out, re.MULTILINE)
    assert [(m, e, p) for m, e, p, *_ in rows] == [
        (m, e, p) for m in ("Twist", "Image") for p in ("one process", "two processes")
        for e in ("servolab", "zenoh")], out
    sizes = {m: int(b) for m, _, _, b, *_ in rows}
    assert sizes == {"Twist": 52, "Image": 640 * 376 + 52}, sizes  # CDR of the two messages
    for *_, p50, p99, msg_s, _ in rows:
        assert all(_positive(float(x)) for x in (p50, p99, msg_s))
        assert float(p99) >= float(p50)

    ratios = re.findall(rf"^ratio (Twist|Image) (one process|two processes): latency p50 "
                        rf"x{NUMBER}, p99 x{NUMBER}, time per message x{NUMBER}$", out,
                        re.MULTILINE)
    assert len(ratios) == 4, out
    assert all(_positive(float(x)) for *_, a, b, c in ratios for x in (a, b, c))

    figures = json.loads(out_json.read_text())
    assert len(figures["rows"]) == 8 and len(figures["ratios"]) == 4
    assert not _children_running("--child"), "an echo process outlived the benchmark"


def _children_running(marker: str) -> list[int]:
    """PIDs of this process's children whose command line holds ``marker`` (Linux /proc)."""
    found = []
    for entry in Path("/proc").glob("[0-9]*"):
        try:
            ppid = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            cmdline = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode()
        except (OSError, IndexError, ValueError):
            continue
        if ppid == os.getpid() and marker in cmdline:
            found.append(int(entry.name))
    return found
