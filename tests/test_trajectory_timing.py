"""servolab.trajectories.timing: ruckig's time-optimal, jerk-limited moves, and the points a
FollowJointTrajectory goal is made of.

Facts from outside this code: a jerk-limited rest-to-rest move of one joint over a distance
d long enough to reach full speed v with acceleration a and jerk j takes
d / v + v / a + a / j (the acceleration ramps each take a / j; the velocity then cruises); a
cubic Hermite spline through samples of a smooth curve with exact derivatives errs by at
most h^4 max|x''''| / 384 on a step h (de Boor, A Practical Guide to Splines, the Hermite
interpolation error)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from servolab.trajectories import PointState, interpolate_between_points
from servolab.trajectories.errors import TrajectoryValueError
from servolab.trajectories.timing import MoveLimits, time_optimal

LIMITS = MoveLimits((2.0, 2.0, 1.0), (5.0, 4.0, 5.0), (50.0, 40.0, 50.0))


def test_a_long_move_takes_the_textbook_time_of_its_slowest_joint() -> None:
    # joint 0 alone: 3 rad at v 2, a 5, j 50 -> 3 / 2 + 2 / 5 + 5 / 50
    one = MoveLimits((2.0,), (5.0,), (50.0,))
    move = time_optimal([0.0], [3.0], one)
    assert move.duration == pytest.approx(3 / 2 + 2 / 5 + 5 / 50, rel=1e-9)
    # three joints: each one's own time, all of them arriving at the slowest one's
    alone = [time_optimal([0.0], [d], MoveLimits((v,), (a,), (j,))).duration
             for d, v, a, j in zip((3.0, -1.0, 0.5), LIMITS.velocity, LIMITS.acceleration,
                                   LIMITS.jerk, strict=True)]
    together = time_optimal([0.0, 0.0, 0.0], [3.0, -1.0, 0.5], LIMITS)
    assert together.duration == pytest.approx(max(alone), rel=1e-9)


def test_every_sample_keeps_the_limits_and_the_move_ends_at_rest() -> None:
    move = time_optimal([0.1, 0.2, -0.3], [1.5, -0.8, 0.4], LIMITS)
    t = np.linspace(0.0, move.duration, 2001)
    rows = [move.at(float(s)) for s in t]
    velocity = np.array([r[1] for r in rows])
    acceleration = np.array([r[2] for r in rows])
    assert np.all(np.abs(velocity) <= np.array(LIMITS.velocity) + 1e-9)
    assert np.all(np.abs(acceleration) <= np.array(LIMITS.acceleration) + 1e-9)
    jerk = np.diff(acceleration, axis=0) / np.diff(t)[:, None]
    assert np.all(np.abs(jerk) <= np.array(LIMITS.jerk) * 1.001)
    assert rows[0][0] == pytest.approx([0.1, 0.2, -0.3])
    assert rows[-1][0] == pytest.approx([1.5, -0.8, 0.4])
    assert np.abs(rows[-1][1]).max() == pytest.approx(0.0, abs=1e-9)


def test_the_goal_points_the_controller_splines_follow_the_profile() -> None:
    """Positions and velocities every 50 ms: joint_trajectory_controller's cubic splines
    between them (servolab.trajectories' copy of its interpolation) stay within 0.1 mrad
    of ruckig's profile; the first point is one period in, the last the target at rest at
    exactly the duration."""
    move = time_optimal([0.0, 0.0, 0.0], [1.0, 0.5, -0.6], LIMITS)
    times, positions, velocities, accelerations = move.sample(0.05)
    assert times[0] == pytest.approx(0.05) and times[-1] == move.duration
    assert np.all(np.diff(times) > 0)
    assert positions[-1] == pytest.approx([1.0, 0.5, -0.6])
    assert np.all(velocities[-1] == 0.0) and np.all(accelerations[-1] == 0.0)
    worst = 0.0
    knots = [(0.0, PointState([0.0, 0.0, 0.0], [0.0, 0.0, 0.0]))] + [
        (float(t), PointState(p, v)) for t, p, v in zip(times, positions, velocities,
                                                        strict=True)]
    for (ta, a), (tb, b) in itertools.pairwise(knots):
        for s in np.linspace(ta, tb, 7):
            splined = interpolate_between_points(ta, a, tb, b, float(s)).positions
            worst = max(worst, float(np.abs(splined - move.at(float(s))[0]).max()))
    assert worst < 1e-4


def test_a_move_to_where_it_is_takes_no_time_and_a_start_velocity_is_kept() -> None:
    assert time_optimal([0.3, 0.3, 0.3], [0.3, 0.3, 0.3], LIMITS).duration == 0.0
    moving = time_optimal([0.0, 0.0, 0.0], [0.5, 0.0, 0.0], LIMITS,
                          start_velocity=[1.0, 0.0, 0.0])
    assert moving.at(0.0)[1] == pytest.approx([1.0, 0.0, 0.0])
    assert time_optimal([0.0, 0.0, 0.0], [0.1, 0.0, 0.0], LIMITS,
                        minimum_duration=2.0).duration == pytest.approx(2.0)


def test_scaling_slows_the_speeds_and_accelerations() -> None:
    slow = LIMITS.scaled(0.5, 0.5)
    assert slow.velocity == (1.0, 1.0, 0.5) and slow.acceleration == (2.5, 2.0, 2.5)
    assert slow.jerk == LIMITS.jerk
    assert time_optimal([0.0] * 3, [3.0, 0.0, 0.0], slow).duration > \
        time_optimal([0.0] * 3, [3.0, 0.0, 0.0], LIMITS).duration


@pytest.mark.parametrize(("call", "message"), [
    (lambda: MoveLimits((1.0,), (1.0, 2.0), (1.0,)), "one number a joint"),
    (lambda: MoveLimits((1.0,), (0.0,), (1.0,)), "acceleration limits must be > 0"),
    (lambda: LIMITS.scaled(1.5), r"velocity scaling must be in \(0, 1\]"),
    (lambda: time_optimal([0.0, 0.0], [1.0, 1.0, 1.0], LIMITS), "the start must be 3 numbers"),
    (lambda: time_optimal([0.0] * 3, [float("nan")] * 3, LIMITS), "the target must be finite"),
    (lambda: time_optimal([0.0] * 3, [1.0] * 3, LIMITS).sample(0.0), "sampling period"),
])
def test_bad_input_is_refused_naming_it(call: object, message: str) -> None:
    with pytest.raises(TrajectoryValueError, match=message):
        call()  # type: ignore[operator]
