"""servolab.trajectories against ros2_controllers' joint_trajectory_controller (Jazzy).

Every test names the file of ``ros-controls/ros2_controllers`` (``joint_trajectory_controller/``,
branch ``jazzy``) that states the behaviour it checks, and the gtest case where one exists.
The splines are checked against independent implementations: scipy's CubicHermiteSpline for
the cubic, a 6×6 boundary-condition solve for the quintic, hand arithmetic for the line.
"""

from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import CubicHermiteSpline

from servolab.trajectories import (
    Constraints,
    InterpolationMethod,
    JointArrays,
    JointTolerance,
    PointState,
    SamplePhase,
    SegmentTolerances,
    SplineKind,
    StateTolerance,
    Trajectory,
    TrajectoryError,
    TrajectoryValueError,
    ValidationConfig,
    check_state_tolerance_per_joint,
    check_state_tolerances,
    default_segment_tolerances,
    fill_partial_goal,
    goal_time_exceeded,
    interpolate_between_points,
    interpolate_segment,
    resolve_tolerance_source,
    segment_tolerances_from_goal,
    sort_to_local_joint_order,
    spline_kind,
    validate_trajectory,
    wraparound_joint,
)

EPS = 1e-8  # test_trajectory.cpp's EPS
PACKAGE = Path(__file__).resolve().parents[1] / "src" / "servolab" / "trajectories"


# -- spline.py: Trajectory::interpolate_between_points (src/trajectory.cpp) --------------------


def test_linear_when_only_positions_by_hand() -> None:
    """trajectory.cpp, interpolate_between_points, "do linear interpolation"; doc/trajectory.rst
    ("Linear: used if only position is specified, returns position and velocity")."""
    a, b = PointState([0.0, 1.0, -2.0]), PointState([1.0, 3.0, 2.0])
    out = interpolate_segment(a, b, elapsed=0.5, duration=2.0)
    np.testing.assert_allclose(out.positions, [0.25, 1.5, -1.0])
    np.testing.assert_allclose(out.velocities, [0.5, 1.0, 2.0])
    np.testing.assert_allclose(out.accelerations, [0.0, 0.0, 0.0])


def test_cubic_matches_scipy_hermite() -> None:
    """trajectory.cpp, "do cubic interpolation" (positions and velocities on both ends)."""
    rng = np.random.default_rng(7)
    p0, p1, v0, v1 = (rng.uniform(-2, 2, 5) for _ in range(4))
    duration = 1.7
    reference = CubicHermiteSpline([0.0, duration], np.vstack([p0, p1]), np.vstack([v0, v1]),
                                   axis=0)
    a, b = PointState(p0, v0), PointState(p1, v1)
    assert spline_kind(a, b) is SplineKind.CUBIC
    for elapsed in np.linspace(0.0, duration, 7):
        out = interpolate_segment(a, b, elapsed, duration)
        np.testing.assert_allclose(out.positions, reference(elapsed), atol=1e-12)
        np.testing.assert_allclose(out.velocities, reference(elapsed, 1), atol=1e-12)
        np.testing.assert_allclose(out.accelerations, reference(elapsed, 2), atol=1e-11)


def test_quintic_matches_boundary_solve() -> None:
    """trajectory.cpp, "do quintic interpolation": the quintic meeting position, velocity and
    acceleration at both ends, here solved as a 6×6 linear system for all joints at once."""
    rng = np.random.default_rng(11)
    p0, p1, v0, v1, a0, a1 = (rng.uniform(-3, 3, 4) for _ in range(6))
    duration = 0.8
    powers = duration ** np.arange(6)
    system = np.array([
        [1, 0, 0, 0, 0, 0],
        [0, 1, 0, 0, 0, 0],
        [0, 0, 2, 0, 0, 0],
        powers,
        [0, *(np.arange(1, 6) * powers[:5])],
        [0, 0, *(np.arange(2, 6) * np.arange(1, 5) * powers[:4])],
    ], dtype=float)
    coefficients = np.linalg.solve(system, np.vstack([p0, v0, a0, p1, v1, a1]))  # 6 × joints
    a, b = PointState(p0, v0, a0), PointState(p1, v1, a1)
    assert spline_kind(a, b) is SplineKind.QUINTIC
    for elapsed in np.linspace(0.0, duration, 6):
        t = elapsed ** np.arange(6)
        dt = np.array([0, 1, 2 * t[1], 3 * t[2], 4 * t[3], 5 * t[4]])
        ddt = np.array([0, 0, 2, 6 * t[1], 12 * t[2], 20 * t[3]])
        out = interpolate_segment(a, b, elapsed, duration)
        np.testing.assert_allclose(out.positions, t @ coefficients, atol=1e-10)
        np.testing.assert_allclose(out.velocities, dt @ coefficients, atol=1e-9)
        np.testing.assert_allclose(out.accelerations, ddt @ coefficients, atol=1e-8)


def test_interpolation_pos_vel_case() -> None:
    """test_trajectory.cpp, TestTrajectory.interpolation_pos_vel: x^3 - 2x; the end's
    acceleration is ignored because the start gives none (trajectory.hpp: lowest common
    specification)."""
    start = PointState([0.0], [-2.0])
    end = PointState([4.0], [10.0], [0.0])
    at_start = interpolate_between_points(1.0, start, 3.0, end, 1.0)
    assert at_start.positions[0] == pytest.approx(0.0, abs=EPS)
    assert at_start.velocities[0] == pytest.approx(-2.0, abs=EPS)
    assert at_start.accelerations[0] == pytest.approx(0.0, abs=EPS)
    middle = interpolate_between_points(1.0, start, 3.0, end, 1.0 + math.sqrt(2.0))
    assert middle.positions[0] == pytest.approx(0.0, abs=EPS)
    assert middle.velocities[0] == pytest.approx(4.0, abs=EPS)
    assert middle.accelerations[0] == pytest.approx(6.0 * math.sqrt(2.0), abs=EPS)
    at_end = interpolate_between_points(1.0, start, 3.0, end, 3.0)
    assert at_end.positions[0] == pytest.approx(4.0, abs=EPS)
    assert at_end.velocities[0] == pytest.approx(10.0, abs=EPS)
    assert at_end.accelerations[0] == pytest.approx(12.0, abs=EPS)


def test_interpolation_pos_vel_accel_case() -> None:
    """test_trajectory.cpp, TestTrajectory.interpolation_pos_vel_accel:
    x(x-1)(x-2)(x-3)(x-4) from 1 s to 3 s."""
    start = PointState([0.0], [24.0], [-100.0])
    end = PointState([0.0], [4.0], [0.0])
    for sample, expected in ((1.0, (0.0, 24.0, -100.0)), (2.0, (0.0, -6.0, 10.0)),
                             (3.0, (0.0, 4.0, 0.0))):
        out = interpolate_between_points(1.0, start, 3.0, end, sample)
        assert (out.positions[0], out.velocities[0], out.accelerations[0]) == \
            pytest.approx(expected, abs=EPS)


def test_degree_is_the_lowest_common_and_one_gap_gives_zeros() -> None:
    """trajectory.hpp (interpolate_between_points' comment: lowest common specification) and
    trajectory.cpp's three branches: accelerations on both ends without velocities on both
    match none of them, and the freshly zeroed output is returned."""
    pos = PointState([1.0, 2.0])
    pos_vel = PointState([1.0, 2.0], [0.1, 0.2])
    pos_vel_acc = PointState([1.0, 2.0], [0.1, 0.2], [0.0, 0.0])
    pos_acc = PointState([1.0, 2.0], None, [0.5, 0.5])
    assert spline_kind(pos, pos_vel_acc) is SplineKind.LINEAR
    assert spline_kind(pos_vel, pos_vel_acc) is SplineKind.CUBIC
    assert spline_kind(pos_vel_acc, pos_vel_acc) is SplineKind.QUINTIC
    assert spline_kind(pos_acc, pos_vel_acc) is SplineKind.UNCOVERED
    out = interpolate_segment(pos_acc, PointState([3.0, 4.0], [0.0, 0.0], [0.0, 0.0]), 0.5, 1.0)
    for field in (out.positions, out.velocities, out.accelerations):
        np.testing.assert_array_equal(field, [0.0, 0.0])


def test_outside_the_segment_is_clamped_and_linear() -> None:
    """trajectory.cpp: duration_so_far < 0 or > the segment's duration is clamped and
    has_velocity = has_accel = false (linear, velocity = the chord's slope)."""
    a, b = PointState([0.0], [5.0], [1.0]), PointState([2.0], [-5.0], [1.0])
    after = interpolate_segment(a, b, elapsed=3.0, duration=1.0)
    assert (after.positions[0], after.velocities[0], after.accelerations[0]) == (2.0, 2.0, 0.0)
    before = interpolate_segment(a, b, elapsed=-1.0, duration=1.0)
    assert (before.positions[0], before.velocities[0], before.accelerations[0]) == \
        (0.0, 2.0, 0.0)


def test_zero_duration_keeps_the_start_terms() -> None:
    """trajectory.cpp: the higher coefficients stay 0 when duration_btwn_points is 0."""
    out = interpolate_segment(PointState([1.0], [2.0], [3.0]), PointState([9.0], [0.0], [0.0]),
                              0.0, 0.0)
    assert (out.positions[0], out.velocities[0], out.accelerations[0]) == (1.0, 2.0, 3.0)


# -- trajectory.py: Trajectory::sample (src/trajectory.cpp, trajectory.hpp) --------------------

NOW = 100.0  # the time the trajectory arrives (any time; the C++ tests use the clock)


def _positions_trajectory() -> Trajectory:
    """test_trajectory.cpp's p1..p3: positions 1, 2, 3 at 1, 2, 3 s; the state before 0."""
    return Trajectory([1.0, 2.0, 3.0], [[1.0], [2.0], [3.0]], start_time=0.0,
                      time_before=NOW, state_before=PointState([0.0]))


def test_sample_trajectory_positions_case() -> None:
    """test_trajectory.cpp, TestTrajectory.sample_trajectory_positions: from the state before
    to p1 linearly, between points, and the last point held, with the segment indices and
    last_sample_index the C++ checks."""
    traj = _positions_trajectory()
    first = traj.sample(NOW)
    assert traj.is_sampled_already and traj.start_time == NOW  # stamp 0: start now
    assert first.phase is SamplePhase.BEFORE_FIRST_POINT
    assert (first.start_index, first.end_index, traj.last_sample_index) == (0, 0, 0)
    assert first.state is not None
    assert (first.state.positions[0], first.state.velocities[0],
            first.state.accelerations[0]) == pytest.approx((0.0, 1.0, 0.0), abs=EPS)

    earlier = traj.sample(NOW - 0.5)  # before the state before: false
    assert not earlier.valid and earlier.state is None
    assert earlier.phase is SamplePhase.BEFORE_STATE_BEFORE and traj.last_sample_index == 0

    expected = [  # (after NOW, position, start index, end index, last_sample_index)
        (0.5, 0.5, 0, 0, 0), (1.0, 1.0, 0, 1, 0), (1.5, 1.5, 0, 1, 0), (2.5, 2.5, 1, 2, 1),
        (3.0, 3.0, 2, 3, 2), (3.125, 3.0, 2, 3, 2), (30.0, 3.0, 2, 3, 2)]
    for after, position, start, end, last in expected:
        sample = traj.sample(NOW + after)
        assert sample.valid and sample.state is not None
        assert sample.state.positions[0] == pytest.approx(position, abs=EPS), after
        assert (sample.start_index, sample.end_index, traj.last_sample_index) == \
            (start, end, last), after
    assert sample.after_end and sample.phase is SamplePhase.AFTER_END


def test_state_before_gets_the_first_points_degree() -> None:
    """test_trajectory.cpp, TestTrajectory.fill_point_before_with_same_degree_as_traj:
    trajectory.cpp's set_point_before_trajectory_msg gives the state before zero velocities
    and accelerations when the first point has them, so the first segment is quintic."""
    traj = Trajectory([1.0, 2.0], [[1.0], [2.0]], [[0.0], [0.0]], [[0.0], [0.0]],
                      time_before=NOW, state_before=PointState([0.0]))
    assert traj.state_before is not None
    np.testing.assert_array_equal(traj.state_before.velocities, [0.0])
    np.testing.assert_array_equal(traj.state_before.accelerations, [0.0])
    sample = traj.sample(NOW)
    assert sample.state is not None
    assert (sample.state.positions[0], sample.state.velocities[0],
            sample.state.accelerations[0]) == pytest.approx((0.0, 0.0, 0.0), abs=EPS)
    middle = traj.sample(NOW + 0.5)  # the quintic rest-to-rest from 0 to 1 is at 1/2
    assert middle.state is not None and middle.state.positions[0] == pytest.approx(0.5)
    assert middle.state.accelerations[0] == pytest.approx(0.0, abs=1e-12)


def test_state_before_without_velocity_starts_at_rest() -> None:
    """test_trajectory.cpp, TestTrajectory.sample_trajectory_velocity_with_interpolation_
    strange_without_vel (with positions given here): the state before without velocities
    gets 0, so the first segment is cubic from rest (acceleration 2·c2 = 6·1/1 - 2·1)."""
    traj = Trajectory([1.0], [[1.0]], [[1.0]], time_before=NOW, state_before=PointState([0.0]))
    sample = traj.sample(NOW)
    assert sample.state is not None
    assert (sample.state.positions[0], sample.state.velocities[0],
            sample.state.accelerations[0]) == pytest.approx((0.0, 0.0, 4.0), abs=EPS)


def test_after_the_end_holds_the_last_point_as_given() -> None:
    """trajectory.cpp, sample, "whole animation has played out": the last point itself,
    velocities/accelerations it lacks resized with zeros (test_trajectory.cpp,
    sample_trajectory_velocity_with_interpolation: "sample past given points" keeps p3's
    velocity)."""
    traj = Trajectory([1.0, 2.0], [[0.0, 0.0], [1.0, 2.0]], [[0.0, 0.0], [0.5, -0.5]],
                      start_time=10.0, time_before=9.0, state_before=PointState([0.0, 0.0]))
    sample = traj.sample(12.5)
    assert sample.after_end and sample.state is not None
    np.testing.assert_array_equal(sample.state.positions, [1.0, 2.0])
    np.testing.assert_array_equal(sample.state.velocities, [0.5, -0.5])
    np.testing.assert_array_equal(sample.state.accelerations, [0.0, 0.0])


def test_skip_interpolation_case() -> None:
    """test_trajectory.cpp, TestTrajectory.skip_interpolation; doc/trajectory.rst ("none"
    returns the initial point until the first point's time, then the next point)."""
    traj = _positions_trajectory()
    expected = [(0.0, 0.0, 0, 0), (0.5, 0.0, 0, 0), (1.0, 2.0, 0, 1), (1.5, 2.0, 0, 1),
                (2.5, 3.0, 1, 2), (3.0, 3.0, 2, 3), (3.125, 3.0, 2, 3)]
    for after, position, start, end in expected:
        sample = traj.sample(NOW + after, "none")
        assert sample.state is not None
        assert sample.state.positions[0] == pytest.approx(position, abs=EPS)
        assert (sample.start_index, sample.end_index) == (start, end)
        if after < 3.0:  # no velocities were given, and none are made up
            assert sample.state.velocities is None and sample.state.accelerations is None
            assert sample.state.as_arrays()[1].tolist() == [0.0]  # zeros for a command
    assert not traj.sample(NOW - 0.5, InterpolationMethod.NONE).valid
    with pytest.raises(TrajectoryValueError):
        traj.sample(NOW, "cubic")


def test_future_stamp_interpolates_from_the_state_before_over_the_wait() -> None:
    """trajectory.cpp, sample: before start + the first point's time_from_start the segment
    runs from the state before (at its own time) to the first point."""
    traj = Trajectory([1.0], [[4.0]], start_time=NOW + 1.0, time_before=NOW,
                      state_before=PointState([0.0]))
    sample = traj.sample(NOW + 1.0)  # halfway through the 2 s from the state before
    assert sample.phase is SamplePhase.BEFORE_FIRST_POINT and sample.state is not None
    assert (sample.state.positions[0], sample.state.velocities[0]) == pytest.approx((2.0, 2.0))
    assert traj.end_time() == pytest.approx(NOW + 2.0)
    assert traj.time_of_point(0) == pytest.approx(NOW + 2.0)


def test_first_point_at_zero_is_not_interpolated_from_the_state_before() -> None:
    """doc/trajectory.rst: "If the first point is starting at t=0, there is no interpolation
    from the initial point to the trajectory"."""
    traj = Trajectory([0.0, 1.0], [[5.0], [6.0]], time_before=NOW,
                      state_before=PointState([0.0]))
    sample = traj.sample(NOW)
    assert sample.phase is SamplePhase.WITHIN and sample.state is not None
    assert sample.state.positions[0] == pytest.approx(5.0)


def test_sampling_before_the_first_point_needs_the_state_before() -> None:
    """trajectory.hpp: the controller calls set_point_before_trajectory_msg before the first
    sample; the C++ would interpolate from an empty point, this refuses."""
    traj = Trajectory([1.0], [[1.0]])
    with pytest.raises(TrajectoryError):
        traj.sample(NOW)
    with pytest.raises(TrajectoryError):  # a "start now" trajectory has no times yet
        Trajectory([1.0], [[1.0]]).end_time()
    traj.set_point_before_trajectory(NOW, PointState([0.0]))
    sample = traj.sample(NOW + 0.25)
    assert sample.state is not None and sample.state.positions[0] == pytest.approx(0.25)


def test_monotonic_search_and_the_jazzy_look_ahead_past_the_end() -> None:
    """trajectory.cpp (jazzy), sample: the search starts at last_sample_idx_, and the "played
    out" branch sets it to the last point even with search_monotonically_increasing false
    (master sets it only when true). JointTrajectoryController::update samples the next
    cycle's command with false."""
    traj = _positions_trajectory()
    traj.sample(NOW)  # the first sample fixes a "start now" trajectory's start
    traj.sample(NOW + 2.5)
    assert traj.last_sample_index == 1
    look_ahead = traj.sample(NOW + 2.9, search_monotonically_increasing=False)
    assert look_ahead.phase is SamplePhase.WITHIN and traj.last_sample_index == 1
    traj.sample(NOW + 3.1, search_monotonically_increasing=False)
    assert traj.last_sample_index == 2  # Jazzy
    held = traj.sample(NOW + 2.95)  # inside the last segment, but the search starts at 2
    assert held.after_end and held.state is not None and held.state.positions[0] == 3.0
    assert traj.segment_at(NOW + 2.95) == (SamplePhase.WITHIN, 1, 2)  # a plain lookup


def test_wraparound_cases() -> None:
    """test_trajectory.cpp, TestWrapAroundJoint.no_wraparound, wraparound_single_joint,
    wraparound_all_joints, wraparound_all_joints_no_offset (trajectory.cpp, wraparound_joint)."""
    start, target = np.zeros(3), np.full(3, 1.5 * math.pi)
    np.testing.assert_array_equal(wraparound_joint(start, target, [False] * 3), start)
    np.testing.assert_array_equal(wraparound_joint(start, target, [True, False, False]),
                                  [2 * math.pi, 0.0, 0.0])
    np.testing.assert_array_equal(wraparound_joint(start, target, [True] * 3),
                                  np.full(3, 2 * math.pi))
    np.testing.assert_array_equal(wraparound_joint(target, target, [True] * 3), target)
    # exactly half a turn: the direction of next - current (trajectory.cpp's singularity rule)
    assert wraparound_joint([0.0], [math.pi], [True])[0] == pytest.approx(0.0)
    assert wraparound_joint([math.pi], [0.0], [True])[0] == pytest.approx(math.pi)


def test_state_before_is_wrapped_towards_the_first_point() -> None:
    """trajectory.cpp, set_point_before_trajectory_msg: wraparound_joint on the state before."""
    traj = Trajectory([1.0], [[1.5 * math.pi, 1.5 * math.pi]], time_before=NOW,
                      state_before=PointState([0.0, 0.0]), wraparound=[True, False])
    assert traj.state_before is not None
    np.testing.assert_allclose(traj.state_before.positions, [2 * math.pi, 0.0])


def test_trajectory_refuses_wrong_shapes() -> None:
    """trajectory.hpp's Trajectory holds a message; here arrays, so their shapes are checked."""
    with pytest.raises(TrajectoryValueError):
        Trajectory([], np.zeros((0, 2)))
    with pytest.raises(TrajectoryValueError):
        Trajectory([1.0, 2.0], [[1.0], [2.0]], velocities=[[0.0]])
    with pytest.raises(TrajectoryValueError):
        Trajectory([1.0], [[1.0]], time_before=NOW)


# -- tolerances.py: include/joint_trajectory_controller/tolerances.hpp -------------------------

JOINTS = ("joint1", "joint2", "joint3")


def _fixture_defaults() -> SegmentTolerances:
    """test_tolerances.cpp, TestTolerancesFixture::SetUp: 0.1 path and goal position, the
    stopped velocity tolerance as goal velocity (the fixture's default_goal_time 0.1 and
    stopped_velocity_tolerance 0.1)."""
    return SegmentTolerances(tuple(StateTolerance(position=0.1) for _ in JOINTS),
                             tuple(StateTolerance(position=0.1, velocity=0.1) for _ in JOINTS),
                             0.1)


def test_parameter_defaults() -> None:
    """src/joint_trajectory_controller_parameters.yaml: stopped_velocity_tolerance 0.01,
    goal_time 0.0, constraints.<joint>.trajectory and .goal 0.0 (tolerances.hpp,
    get_segment_tolerances(params) puts them in place)."""
    tolerances = default_segment_tolerances(JOINTS, Constraints())
    assert tolerances.goal_time_tolerance == 0.0
    assert tolerances.state_tolerance == (StateTolerance(),) * 3
    assert tolerances.goal_state_tolerance == (StateTolerance(velocity=0.01),) * 3


def test_tolerances_from_the_documented_example() -> None:
    """tolerances.hpp, get_segment_tolerances' comment (goal_time 1.0, stopped 0.02,
    foo_joint trajectory 0.05 goal 0.03, bar_joint goal 0.01)."""
    constraints = Constraints.from_parameters({
        "goal_time": 1.0, "stopped_velocity_tolerance": 0.02, "decelerate_on_cancel": False,
        "foo_joint": {"trajectory": 0.05, "goal": 0.03}, "bar_joint": {"goal": 0.01}})
    tolerances = default_segment_tolerances(["foo_joint", "bar_joint", "baz"], constraints)
    assert tolerances.goal_time_tolerance == 1.0
    assert tolerances.state_tolerance == (StateTolerance(position=0.05), StateTolerance(),
                                          StateTolerance())
    assert tolerances.goal_state_tolerance == (
        StateTolerance(position=0.03, velocity=0.02),
        StateTolerance(position=0.01, velocity=0.02), StateTolerance(velocity=0.02))
    with pytest.raises(TrajectoryValueError):  # goal_time's validation: gt_eq 0.0
        Constraints(goal_time=-1.0)
    with pytest.raises(TrajectoryValueError):
        Constraints.from_parameters({"foo_joint": {"goal_tolerance": 0.1}})


def test_get_segment_tolerances_case() -> None:
    """test_tolerances.cpp, TestTolerancesFixture.test_get_segment_tolerances: a goal's path
    and goal tolerances, the latter in jumbled order, replace the defaults."""
    path = [JointTolerance(j, 0.2, 0.3, 0.4) for j in JOINTS]
    goal = [JointTolerance("joint2", 1.2, 2.2, 3.2), JointTolerance("joint3", 1.3, 2.3, 3.3),
            JointTolerance("joint1", 1.1, 2.1, 3.1)]
    result = segment_tolerances_from_goal(_fixture_defaults(), JOINTS, path, goal, 2.0)
    assert result.error is None
    assert result.tolerances.goal_time_tolerance == 2.0
    assert result.tolerances.state_tolerance == (StateTolerance(0.2, 0.3, 0.4),) * 3
    assert result.tolerances.goal_state_tolerance == (
        StateTolerance(1.1, 2.1, 3.1), StateTolerance(1.2, 2.2, 3.2),
        StateTolerance(1.3, 2.3, 3.3))


def test_minus_one_erases_and_zero_keeps() -> None:
    """test_tolerances.cpp, TestTolerancesFixture.test_deactivate_tolerances (-1 gives 0, which
    check_state_tolerance_per_joint does not enforce); tolerances.hpp,
    resolve_tolerance_source: 0 keeps the default (doc/userdoc.rst quotes JointTolerance.msg)."""
    erase = [JointTolerance(j, -1.0, -1.0, -1.0) for j in JOINTS]
    erased = segment_tolerances_from_goal(_fixture_defaults(), JOINTS, erase, erase, -1.0)
    assert erased.error is None
    assert erased.tolerances == SegmentTolerances((StateTolerance(),) * 3,
                                                  (StateTolerance(),) * 3, 0.0)
    kept = segment_tolerances_from_goal(_fixture_defaults(), JOINTS,
                                        [JointTolerance("joint1")], [JointTolerance("joint2")])
    assert kept.tolerances == _fixture_defaults()
    assert resolve_tolerance_source(0.5, -1.0 + 1e-8) == 0.0  # within float32's epsilon
    with pytest.raises(TrajectoryValueError):
        resolve_tolerance_source(0.5, -1.001)


@pytest.mark.parametrize(("where", "field"), [(w, f) for w in ("path", "goal")
                                              for f in ("position", "velocity", "acceleration")])
def test_invalid_tolerances_case(where: str, field: str) -> None:
    """test_tolerances.cpp, TestTolerancesFixture.test_invalid_tolerances: a negative value
    other than -1 drops all of the goal's tolerances (the defaults are used), logging which."""
    bad = [JointTolerance("joint1", **{field: -123.0})]
    other = [JointTolerance("joint2", 0.5, 0.5, 0.5)]
    path, goal = (bad, other) if where == "path" else (other, bad)
    result = segment_tolerances_from_goal(_fixture_defaults(), JOINTS, path, goal, 3.0)
    assert result.tolerances == _fixture_defaults()
    assert result.error == (f"joint 'joint1' specified in goal.{where}_tolerance has a invalid "
                            f"{field} tolerance. Using default tolerances.")


def test_invalid_goal_time_and_joint_case() -> None:
    """test_tolerances.cpp, test_invalid_tolerances ("negative goal_time_tolerance") and
    test_invalid_joints_path_tolerance / test_invalid_joints_goal_tolerance."""
    result = segment_tolerances_from_goal(_fixture_defaults(), JOINTS, goal_time_tolerance=-123.0)
    assert result.tolerances == _fixture_defaults()
    assert result.error == ("Specified illegal goal_time_tolerance: -123.000000. "
                            "Using default tolerances")
    result = segment_tolerances_from_goal(_fixture_defaults(), JOINTS,
                                          goal_tolerance=[JointTolerance("joint4", 0.5)])
    assert result.tolerances == _fixture_defaults()
    assert result.error == ("joint 'joint4' specified in goal.goal_tolerance does not exist. "
                            "Using default tolerances.")


def test_check_state_tolerance_per_joint() -> None:
    """tolerances.hpp, check_state_tolerance_per_joint: |error| > tolerance fails only where
    the tolerance is > 0; missing velocity/acceleration errors count as 0; the messages are
    its log lines."""
    tolerances = [StateTolerance(position=0.1), StateTolerance(),
                  StateTolerance(position=0.1, velocity=0.2)]
    errors = np.array([-0.15, 50.0, 0.05])
    velocity_errors = np.array([0.0, 50.0, 0.3])
    assert not check_state_tolerance_per_joint(errors, 0, tolerances[0])
    assert check_state_tolerance_per_joint(errors, 1, tolerances[1], velocity_errors)
    assert check_state_tolerance_per_joint(errors, 2, tolerances[2])  # no velocity errors
    check = check_state_tolerances(errors, tolerances, velocity_errors)
    assert not check.ok and check.violating == (0, 2)
    assert check.messages == (
        "State tolerances failed for joint 0: Position Error: -0.150000, "
        "Position Tolerance: 0.100000",
        "State tolerances failed for joint 2: Velocity Error: 0.300000, "
        "Velocity Tolerance: 0.200000")
    assert check_state_tolerances([0.0, 0.0, 0.0], tolerances).ok


def test_goal_time_exceeded() -> None:
    """src/joint_trajectory_controller.cpp, update: outside the goal tolerances, the goal is
    aborted once time_difference > goal_time_tolerance, never when it is 0
    (parameters.yaml: "If set to zero, the controller will wait a potentially infinite
    amount of time")."""
    assert goal_time_exceeded(0.6, 0.5)
    assert not goal_time_exceeded(0.5, 0.5)
    assert not goal_time_exceeded(1e6, 0.0)


# -- validation.py: validate_trajectory_msg (src/joint_trajectory_controller.cpp) -------------

CONFIG = ValidationConfig(JOINTS, allow_nonzero_velocity_at_trajectory_end=True)


def _validate(**changes: object) -> str | None:
    """test_trajectory_controller.cpp, invalid_message's good_traj_msg, with ``changes``."""
    message: dict[str, object] = {
        "joint_names": list(JOINTS), "time_from_start": [0.25], "positions": [[1.0, 2.0, 3.0]],
        "velocities": [[-1.0, -2.0, -3.0]], "config": CONFIG, "now": 1000.0}
    message.update(changes)
    return validate_trajectory(**message)  # type: ignore[arg-type]


def test_invalid_message_case() -> None:
    """test_trajectory_controller.cpp, TrajectoryControllerTestParameterized.invalid_message,
    with validate_trajectory_msg's log lines."""
    assert _validate() is None
    assert _validate(joint_names=["bad_name"]) == \
        "Joints on incoming trajectory don't match the controller joints."
    assert _validate(joint_names=["joint1", "joint2", "bad_name"]) == \
        "Incoming joint bad_name doesn't match the controller's joints."
    assert _validate(time_from_start=[], positions=[], velocities=[]) == \
        "Empty trajectory received."
    assert _validate(positions=[[]]) == \
        "Mismatch between joint_names size (3) and positions (0) at point #0."
    assert _validate(positions=[[1.0, 2.0]]) == \
        "Mismatch between joint_names size (3) and positions (2) at point #0."
    assert _validate(positions=[[1.0, 2.0, 3.0, 4.0]]) is not None
    assert _validate(velocities=[[1.0, 2.0]]) == \
        "Mismatch between joint_names size (3) and velocities (2) at point #0."
    assert _validate(accelerations=[[1.0, 2.0]]) == \
        "Mismatch between joint_names size (3) and accelerations (2) at point #0."
    assert _validate(efforts=[[1.0, 2.0, 3.0]]) == (
        "Trajectories with effort fields are only supported for controllers using the "
        "'effort' command interface.")
    assert _validate(time_from_start=[0.25, 0.25], positions=[[1.0, 2.0, 3.0]] * 2,
                     velocities=[[-1.0, -2.0, -3.0]] * 2) == (
        "Time between points 0 and 1 is not strictly increasing, it is 0.250000 and "
        "0.250000 respectively")
    assert _validate(start_time=1e-9) == ("Received trajectory with non-zero start time "
                                          "(0.000000) that ends in the past (0.250000)")
    assert _validate(start_time=1000.0, time_from_start=[10.0]) is None  # ends in the future
    assert _validate(start_time=990.0, time_from_start=[10.0]) is None  # ends just now


def test_nonzero_end_velocity_case() -> None:
    """test_trajectory_controller.cpp, expect_invalid_when_message_with_nonzero_end_velocity_
    and_when_param_false; an empty message is refused without raising."""
    config = ValidationConfig(JOINTS)
    assert _validate(config=config, time_from_start=[], positions=[], velocities=[]) == \
        "Empty trajectory received."
    assert _validate(config=config) == ("Velocity of last trajectory point of joint joint1 is "
                                        "not zero: -1.000000000000000")
    assert _validate(config=config, velocities=[[0.0, 1e-9, 0.0]]) is None  # float eps
    assert _validate(config=config, velocities=None) is None  # no velocities: nothing to check


def test_partial_joints_and_ragged_points() -> None:
    """joint_trajectory_controller.cpp, validate_trajectory_msg: allow_partial_joints_goal
    (test_trajectory_controller.cpp, test_partial_joint_list_not_allowed), names given, no
    duplicate (servolab's addition), per-point fields optional, the first time unchecked."""
    assert _validate(joint_names=["joint2", "joint1"], positions=[[2.0, 1.0]],
                     velocities=[[2.0, 1.0]]) == \
        "Joints on incoming trajectory don't match the controller joints."
    partial = ValidationConfig(JOINTS, allow_partial_joints_goal=True)
    assert _validate(config=partial, joint_names=["joint2", "joint1"], positions=[[2.0, 1.0]],
                     velocities=[[0.0, 0.0]]) is None
    assert _validate(config=partial, joint_names=[], positions=[[]], velocities=None) == \
        "Empty joint names on incoming trajectory."
    assert _validate(joint_names=["joint1", "joint1", "joint3"]) == \
        "Incoming joint joint1 is named more than once."
    assert _validate(time_from_start=[0.0, 1.0], positions=[[0.0] * 3, [1.0] * 3],
                     velocities=[[], [0.0] * 3]) is None
    assert _validate(time_from_start=[math.nan]) == "time_from_start of point #0 is not finite: nan"


# -- joint_order.py: fill_partial_goal, sort_to_local_joint_order -----------------------------


def test_partial_joint_list_case() -> None:
    """test_trajectory_controller.cpp, test_partial_joint_list: joints {joint2, joint1} of
    three; joint3 holds its commanded position with zero velocity and acceleration
    (joint_trajectory_controller.cpp, fill_partial_goal then sort_to_local_joint_order)."""
    arrays = JointArrays(["joint2", "joint1"], [[2.0, 1.0]], [[8.0, 4.0]], [[1.0, 1.0]])
    filled = fill_partial_goal(arrays, JOINTS, hold_positions=[0.1, 0.2, 0.3])
    assert filled.joint_names == ("joint2", "joint1", "joint3")
    ordered = sort_to_local_joint_order(filled, JOINTS)
    assert ordered.joint_names == JOINTS
    np.testing.assert_array_equal(ordered.positions, [[1.0, 2.0, 0.3]])
    np.testing.assert_array_equal(ordered.velocities, [[4.0, 8.0, 0.0]])
    np.testing.assert_array_equal(ordered.accelerations, [[1.0, 1.0, 0.0]])
    full = JointArrays(JOINTS[::-1], [[3.0, 2.0, 1.0]])
    assert fill_partial_goal(full, JOINTS, [0.0, 0.0, 0.0]) is full  # dof names: unchanged
    np.testing.assert_array_equal(sort_to_local_joint_order(full, JOINTS).positions,
                                  [[1.0, 2.0, 3.0]])
    with pytest.raises(TrajectoryValueError):
        fill_partial_goal(arrays, JOINTS, hold_positions=[0.1, 0.2, math.nan])
    with pytest.raises(TrajectoryValueError):
        sort_to_local_joint_order(arrays, JOINTS)


def test_a_goal_end_to_end() -> None:
    """The controller's path for a goal (joint_trajectory_controller.cpp: validate, then in
    update fill_partial_goal, sort_to_local_joint_order, set_point_before_trajectory_msg,
    sample), cubic because the points give velocities."""
    config = ValidationConfig(JOINTS, allow_partial_joints_goal=True)
    names, times, positions, velocities = ["joint3"], [1.0, 2.0], [[1.0], [2.0]], [[1.0], [0.0]]
    assert validate_trajectory(names, times, positions, velocities, config=config,
                               now=NOW) is None
    arrays = sort_to_local_joint_order(
        fill_partial_goal(JointArrays(names, positions, velocities), JOINTS, [0.0, 0.5, 0.0]),
        JOINTS)
    traj = Trajectory(times, arrays.positions, arrays.velocities, time_before=NOW,
                      state_before=PointState([0.0, 0.5, 0.0]))
    traj.sample(NOW)  # the controller's first update: the start is now
    sample = traj.sample(NOW + 1.5)
    reference = CubicHermiteSpline([1.0, 2.0], [1.0, 2.0], [1.0, 0.0])
    assert sample.state is not None
    positions_now, velocities_now, _ = sample.state.as_arrays()
    np.testing.assert_allclose(positions_now, [0.0, 0.5, reference(1.5)])
    np.testing.assert_allclose(velocities_now, [0.0, 0.0, reference(1.5, 1)])


def test_the_package_is_pure() -> None:
    """The brief of servolab.trajectories (no I/O, no threads, no middleware): it imports
    only numpy, ruckig (an algorithm library: numbers in, numbers out; timing.py), a few
    standard modules and servolab's core errors."""
    allowed = {"__future__", "math", "dataclasses", "enum", "collections.abc", "numpy",
               "numpy.typing", "ruckig"}
    for path in sorted(PACKAGE.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                assert {a.name for a in node.names} <= allowed, path.name
            elif isinstance(node, ast.ImportFrom) and node.level == 0:
                assert node.module in allowed, f"{path.name} imports {node.module}"
            elif isinstance(node, ast.ImportFrom) and node.level == 2:
                assert node.module == "errors", f"{path.name} imports ..{node.module}"
