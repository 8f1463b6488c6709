"""A virtual run watched in the view keeps to the wall clock, and runs free again after."""

from __future__ import annotations

import time

import pytest

from servolab.clock import VirtualClock, WallClock
from servolab.errors import ServolabValueError
from servolab.middleware.view.pacing import MAX_LAG, PaceConfig, Pacer


class FakeWall:
    """A wall clock the test moves; sleeping moves it."""

    def __init__(self) -> None:
        self.t = 100.0
        self.slept: list[float] = []

    def __call__(self) -> float:
        return self.t

    def sleep(self, seconds: float) -> None:
        self.slept.append(seconds)
        self.t += seconds


def test_a_held_pacer_makes_virtual_time_wait_for_the_wall_clock() -> None:
    clock, wall = VirtualClock(), FakeWall()
    pacer = Pacer(clock, wall=wall, sleep=wall.sleep)
    pacer.hold()
    for _ in range(100):
        clock.advance(0.01)  # one second of a run that costs nothing to compute
    assert wall.t - 100.0 == pytest.approx(1.0, abs=0.011)
    assert pacer.waited == pytest.approx(1.0, abs=0.011)


def test_speed_two_takes_half_the_wall_time() -> None:
    clock, wall = VirtualClock(), FakeWall()
    pacer = Pacer(clock, PaceConfig(speed=2.0), wall=wall, sleep=wall.sleep)
    pacer.hold()
    clock.advance(0.5)
    for _ in range(100):
        clock.advance(0.01)
    assert wall.t - 100.0 == pytest.approx(0.75, abs=0.011)


def test_holds_nest_and_the_last_release_lets_the_run_go() -> None:
    clock, wall = VirtualClock(), FakeWall()
    pacer = Pacer(clock, wall=wall, sleep=wall.sleep)
    pacer.hold()
    pacer.hold()
    pacer.release()
    assert pacer.pacing  # one viewer is still there
    pacer.release()
    assert not pacer.pacing
    clock.advance(10.0)
    assert wall.slept == []
    pacer.release()  # more releases than holds: nothing to do


def test_a_run_slower_than_real_time_is_not_made_to_burst() -> None:
    clock, wall = VirtualClock(), FakeWall()
    pacer = Pacer(clock, wall=wall, sleep=wall.sleep)
    pacer.hold()
    wall.t += 5.0  # the computer took 5 s for the next step
    clock.advance(0.01)
    assert wall.slept == []
    clock.advance(0.01)  # from here it is paced again, not 5 s ahead of itself
    clock.advance(0.01)
    assert sum(wall.slept) <= 0.02 + MAX_LAG


def test_a_wall_clock_is_not_paced() -> None:
    pacer = Pacer(WallClock())
    pacer.hold()
    assert not pacer.pacing
    pacer.release()


def test_the_real_wall_clock_is_kept() -> None:
    """With time.monotonic: 0.3 s of virtual time takes at least 0.3 s (a lower bound, which
    a slow machine only makes longer)."""
    clock = VirtualClock()
    pacer = Pacer(clock)
    start = time.monotonic()
    pacer.hold()
    while clock.now() < 0.3:
        clock.advance(0.01)
    assert time.monotonic() - start >= 0.3 - 0.011


@pytest.mark.parametrize("bad", [0, -1.0, float("nan"), float("inf"), "1"])
def test_a_bad_speed_is_refused(bad: object) -> None:
    with pytest.raises(ServolabValueError, match="speed"):
        PaceConfig(speed=bad)  # type: ignore[arg-type]
