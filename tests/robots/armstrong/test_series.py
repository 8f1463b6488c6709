"""What a walk keeps in memory is bounded, however long it runs (robots/armstrong/series.py):
the commands sent and the states heard (the tracking plot), the supervisor's readings (the
alarm plot). Lengths are checked, not memory or time: benchmarks/soak.py measures the
resident set's slope of a real ``servolab walk``."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from servolab.gait.motionfile import MotionFile
from servolab.middleware.context import Context
from servolab.robots.armstrong.control_node import BipedNode
from servolab.robots.armstrong.poses import MOTORS
from servolab.robots.armstrong.series import CAPACITY, Series
from servolab.robots.armstrong.supervisor import SafetySupervisor


def test_a_short_series_keeps_every_sample() -> None:
    series = Series(2, capacity=8)
    for k in range(8):
        series.append(k * 0.1, k, None if k == 3 else -k)
    assert len(series) == 8 and series.stride == 1
    assert series.t == pytest.approx([k * 0.1 for k in range(8)])
    assert list(series.values(0)) == list(range(8))
    assert np.isnan(series.values(1)[3]) and series.values(1)[4] == -4


@pytest.mark.parametrize("count", [9, 100, 1000, 12_345])
def test_a_long_series_keeps_at_most_its_capacity_evenly_spread(count: int) -> None:
    series = Series(1, capacity=8)
    for k in range(count):
        series.append(float(k), float(k))
    assert 4 <= len(series) <= 8 and series.seen == count
    kept = series.t
    assert kept[0] == 0.0  # the start is always kept
    assert np.all(np.diff(kept) == series.stride)  # evenly spread: every stride-th sample
    assert kept[-1] >= count - series.stride  # and up to the end
    assert list(series.values()) == list(kept)


def test_the_capacity_must_be_even() -> None:
    with pytest.raises(ValueError, match="even"):
        Series(capacity=7)


def state(degrees: float) -> Any:
    return SimpleNamespace(current_pos=np.radians(degrees))


def test_the_biped_nodes_history_is_bounded_and_its_tracking_error_exact() -> None:
    """A day's walk in states: every series at most CAPACITY samples; the largest tracking
    error is measured as the states come, from the first row played on (not from the kept
    samples, which a long walk decimates)."""
    with Context.open() as context:
        node = BipedNode(context, history=True)
        assert set(node.sent) == set(node.heard) == set(MOTORS)
        node.send({"m11": 5.0})  # before the gait (the stand): not counted
        node._on_state("m11", state(-40.0))
        motion = MotionFile(("m11",), np.array([[10.0]]))
        node.create_rate = lambda hz: SimpleNamespace(sleep=lambda: None)  # type: ignore[method-assign]
        assert node.play(motion, steps=3, rate=1000.0) == 3
        for k in range(3 * CAPACITY):
            node._on_state("m11", state(10.0 + (7.5 if k == 4321 else 0.1 * (k % 3))))
        assert node.tracking == {"m11": pytest.approx(7.5)}
        for series in (*node.sent.values(), *node.heard.values()):
            assert len(series) <= CAPACITY
        assert node.heard["m11"].seen == 3 * CAPACITY + 1
        assert len(node.heard["m11"]) <= CAPACITY
        assert node.sent["m11"].seen == 4  # the stand's pose and the three rows


def test_the_supervisors_history_is_bounded() -> None:
    health = SimpleNamespace(silent_for=lambda now, since: 0.01, hardware=(), temperature=40.0)
    clock = SimpleNamespace(now=lambda: 0.0)
    manager = SimpleNamespace(
        controllers={"controller_m11": SimpleNamespace(motor_id=11)}, port=SimpleNamespace(
            silent_timeout=0.5, error_level_temp=75.0, warn_level_temp=70.0),
        context=SimpleNamespace(clock=clock), get_logger=lambda: None, sweep_listeners=[],
        health={11: health}, latest={11: SimpleNamespace(load=0.2)}, started=0.0)
    supervisor = SafetySupervisor(manager)  # type: ignore[arg-type]
    for sweep in range(3 * CAPACITY):
        assert supervisor.check(sweep * 0.05) == []
    (series,) = supervisor.history.values()
    assert len(series) <= CAPACITY and series.seen == 3 * CAPACITY
    assert set(series.values(0)) == {40.0} and set(series.values(1)) == {0.2}
