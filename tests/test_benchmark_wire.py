"""The benchmarks' wire figures, which are arithmetic and virtual time, checked against the
packet sizes of the protocol documents: apart from tests/test_benchmarks.py, whose quick runs
hold the wall clock (``realtime``), so these never wait for it."""

from __future__ import annotations

import pytest

from tests.test_benchmarks import CONTROL, _load


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


def test_control_wire_figure_is_the_packet_sizes() -> None:
    """One update of 5 XM430 at 1 Mbps, return delay 0: SYNC_READ 10 + 4 + 5 = 19 bytes out,
    5 statuses of 10 + 1 + 10 = 21 bytes in, SYNC_WRITE 10 + 4 + 5 x 5 = 39 bytes out
    (e-Manual, Protocol 2.0: Sync Read / Sync Write), 163 bytes = 1.63 ms; the virtual wire
    the emulated motors run on takes the same."""
    bench = _load(CONTROL, "control_bench")
    assert bench.analytic_wire(5, 0.0) == pytest.approx(163 * 10 / 1e6)
    assert bench.analytic_wire(5, 0.5e-3) == pytest.approx(163 * 10 / 1e6 + 5 * 0.5e-3)
    assert bench.virtual_wire(2, 0, updates=5) == pytest.approx(bench.analytic_wire(2, 0.0))
