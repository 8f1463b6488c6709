"""A run's frame timing from capture stamps and handling times (robots/treadmill/timing.py),
checked against counts made by hand for a schedule with known drops and delays."""

from __future__ import annotations

import math

import numpy as np
import pytest

from servolab.robots.treadmill.timing import frame_timing, sequence_of, sequences_of

RATE = 66.0
PERIOD = 1.0 / RATE


def test_a_camera_that_keeps_up() -> None:
    stamps = 5.0 + PERIOD * np.arange(100)
    t = frame_timing(stamps, stamps + 0.002, frame_rate=RATE, late_after=PERIOD)
    assert t["frames"] == t["camera_frames"] == 100
    assert t["dropped_frames"] == t["late_frames"] == 0
    assert t["achieved_fps"] == pytest.approx(RATE)
    assert t["interval_ms"]["p50"] == pytest.approx(1000 * PERIOD)
    assert t["latency_ms"]["max"] == pytest.approx(2.0)


def test_drops_and_late_frames_are_counted() -> None:
    """Frames 10, 11 and 40 never arrive (3 dropped); frames 20-24 are handled 30 ms after
    their capture (5 late, against one 15.2 ms period)."""
    taken = [k for k in range(60) if k not in (10, 11, 40)]
    stamps = np.array(taken) * PERIOD
    # a camera's jitter of a few ms does not change the count
    jitter = np.random.default_rng(0).uniform(-0.003, 0.003, len(taken))
    handled = stamps + 0.001 + np.where((np.array(taken) >= 20) & (np.array(taken) < 25),
                                        0.030, 0.0)
    t = frame_timing(stamps + jitter, handled + jitter, frame_rate=RATE, late_after=PERIOD)
    assert t["dropped_frames"] == 3 and t["camera_frames"] == 60 and t["frames"] == 57
    assert t["late_frames"] == 5
    assert t["interval_ms"]["max"] >= 1000 * (3 * PERIOD) - 6.0  # the gap of frames 10-11
    assert [sequence_of(s, stamps[0] + jitter[0], RATE) for s in stamps + jitter] == taken
    # against numpy's own percentile of the intervals, computed here
    assert t["interval_ms"]["p99"] == pytest.approx(
        np.percentile(np.diff(handled + jitter) * 1000, 99))


def test_a_frame_stamped_late_does_not_share_the_next_ones_number() -> None:
    """A camera (or a simulated one on a busy machine) that stamps frame 1 0.6 periods late
    and frame 2 on time: rounding alone numbers both 2. Numbers only go up, so frame 2 is 3:
    stamps cannot tell that lateness from a drop, but the counts stay whole (frames handled
    + dropped = the camera's frames)."""
    stamps = np.array([0.0, 1.6 * PERIOD, 2 * PERIOD, 3 * PERIOD])
    assert list(sequences_of(stamps, RATE)) == [0, 2, 3, 4]
    t = frame_timing(stamps, stamps, frame_rate=RATE, late_after=PERIOD)
    assert t["camera_frames"] == t["frames"] + t["dropped_frames"] == 5


def test_no_frames() -> None:
    t = frame_timing([], [], frame_rate=RATE, late_after=PERIOD)
    assert t["frames"] == 0 and math.isnan(t["achieved_fps"])


def test_mismatched_lists_are_refused() -> None:
    with pytest.raises(ValueError, match="one value per frame"):
        frame_timing([0.0, 1.0], [0.0], frame_rate=RATE, late_after=PERIOD)
