"""DWA local planner (servolab.planning.dwa) on small synthetic costmaps."""

from __future__ import annotations

import math

import numpy as np
import pytest

from servolab.planning.costmap import INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE
from servolab.planning.dwa import (
    DwaConfig,
    DwaStatus,
    compute_velocity,
    distance_map,
    dynamic_window,
    find_best_trajectory,
    goal_command,
    sample_window,
    score_samples,
    simulate,
    velocity_iterator,
)

RES = 0.05
#: seed 000's D.3 values (the shipped dwa_params.yaml)
D3 = DwaConfig(max_vel_x=0.15, min_vel_x=0.0, max_trans_vel=0.15, min_trans_vel=0.1,
               trans_stopped_vel=0.1, max_rot_vel=1.5, min_rot_vel=0.4, rot_stopped_vel=0.4,
               acc_lim_x=1.0, acc_lim_theta=2.0, yaw_goal_tolerance=0.3, xy_goal_tolerance=0.15,
               sim_time=1.0, vx_samples=6, vtheta_samples=20, path_distance_bias=64.0,
               goal_distance_bias=24.0, occdist_scale=0.8, forward_point_distance=0.325,
               stop_time_buffer=0.2)
#: D.3 with a slow controller (2 Hz), so that one period's window holds sharp turns
SLOW = DwaConfig(**{**D3.__dict__, "controller_frequency": 2.0})


def free_map(size: int = 60) -> np.ndarray:
    return np.zeros((size, size), dtype=np.uint8)


def straight_plan(y: float = 1.5, x0: float = 0.5, x1: float = 2.5) -> np.ndarray:
    xs = np.arange(x0, x1 + 1e-9, RES / 2)
    return np.column_stack((xs, np.full_like(xs, y)))


def cells_of(traj: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    c = np.floor(traj[..., :2] / RES).astype(int)
    return c[..., 1], c[..., 0]


def test_drives_straight_at_a_goal_ahead() -> None:
    result = compute_velocity((0.5, 1.5, 0.0), (0.1, 0.0), free_map(), straight_plan(), D3,
                              resolution=RES)
    assert result.status is DwaStatus.MOVING
    assert result.v > 0.1
    assert abs(result.omega) < 0.15
    assert result.trajectory[-1, 0] > 0.6


def test_turns_away_from_an_obstacle_ahead_and_never_through_it() -> None:
    costmap = free_map()
    costmap[26:34, 12:17] = LETHAL_OBSTACLE                         # x 0.60..0.85, y 1.30..1.70
    costmap[25:35, 11:18][costmap[25:35, 11:18] == 0] = INSCRIBED_INFLATED_OBSTACLE
    result = find_best_trajectory((0.5, 1.5, 0.0), (0.1, 0.0), costmap, straight_plan(), SLOW,
                                  resolution=RES)
    assert result.status is DwaStatus.MOVING
    assert abs(result.omega) >= 0.3
    rows, cols = cells_of(result.trajectory)
    assert np.all(costmap[rows, cols] < INSCRIBED_INFLATED_OBSTACLE)
    samples = result.samples
    assert samples is not None
    rows, cols = cells_of(samples.trajectories)
    hits = np.any(costmap[rows, cols] >= INSCRIBED_INFLATED_OBSTACLE, axis=1)
    assert hits.any()                       # going straight would hit it...
    assert not np.any(samples.valid & hits)  # ...and no valid sample does
    assert np.all(np.isinf(samples.cost[hits]))


def test_stop_time_buffer_rejects_a_trajectory_that_ends_just_short_of_a_wall() -> None:
    costmap = free_map()
    costmap[10:50, 15] = LETHAL_OBSTACLE    # a wall at x = 0.75..0.80, the goal behind it
    cfg = DwaConfig(**{**D3.__dict__, "vtheta_samples": 1, "max_rot_vel": 0.0,
                       "min_rot_vel": 0.0, "min_trans_vel": 0.0, "stop_time_buffer": 0.0})
    pose, vel = (0.5, 1.5, 0.0), (0.15, 0.0)
    # 0.15 m/s for 1 s ends at x = 0.65: free without a buffer...
    free = score_samples(pose, vel, costmap, straight_plan(), cfg, resolution=RES)
    assert free.valid[np.argmax(free.v)]
    # ...but with 1 s of buffer the robot would reach 0.80 before stopping
    buffered = score_samples(pose, vel, costmap, straight_plan(),
                             DwaConfig(**{**cfg.__dict__, "stop_time_buffer": 1.0}),
                             resolution=RES)
    assert not buffered.valid[np.argmax(buffered.v)]
    assert buffered.trajectories.shape == free.trajectories.shape  # the buffer is not scored


def test_window_respects_acceleration_limits() -> None:
    v0, w0 = 0.1, 0.2
    (v_lo, v_hi), (w_lo, w_hi) = dynamic_window(v0, w0, D3)
    dt = 1.0 / D3.controller_frequency
    assert v_lo == pytest.approx(v0 - D3.acc_lim_x * dt)
    assert v_hi == pytest.approx(min(D3.max_vel_x, v0 + D3.acc_lim_x * dt))
    assert (w_lo, w_hi) == pytest.approx((w0 - D3.acc_lim_theta * dt, w0 + D3.acc_lim_theta * dt))
    vs, ws, _ = sample_window(v0, w0, D3)
    assert np.all(np.abs(vs - v0) <= D3.acc_lim_x * dt + 1e-12)
    assert np.all(np.abs(ws - w0) <= D3.acc_lim_theta * dt + 1e-12)
    assert np.all((vs >= D3.min_vel_x) & (vs <= D3.max_vel_x))
    # at rest the window cannot reverse (min_vel_x 0) and includes stopping
    (v_lo, v_hi), (w_lo, w_hi) = dynamic_window(0.0, 0.0, D3)
    assert v_lo == 0.0 and v_hi == pytest.approx(0.05)
    assert 0.0 in velocity_iterator(w_lo, w_hi, 6)   # zero inserted, as VelocityIterator does


def test_min_speeds_drop_samples_as_generate_trajectory_does() -> None:
    vs, ws, feasible = sample_window(0.0, 0.0, D3)
    slow = (np.abs(vs) + 1e-4 < D3.min_trans_vel) & (np.abs(ws) + 1e-4 < D3.min_rot_vel)
    np.testing.assert_array_equal(feasible, ~slow)


def test_all_samples_are_simulated_at_once() -> None:
    pose = (0.5, 1.5, 0.3)
    samples = score_samples(pose, (0.1, 0.0), free_map(), straight_plan(), D3, resolution=RES)
    n = samples.v.size
    assert n == len(np.unique(samples.v)) * len(np.unique(samples.omega))
    assert n >= D3.vx_samples * D3.vtheta_samples
    t = samples.trajectories
    assert t.ndim == 3 and t.shape[0] == n and t.shape[2] == 3
    for arr in (samples.omega, samples.valid, samples.cost, samples.path_cost,
                samples.goal_cost, samples.occ_cost):
        assert arr.shape == (n,)
    np.testing.assert_allclose(t[:, 0], np.tile(pose, (n, 1)))
    # the step never exceeds the granularities, and the arc ends at sim_time
    step = np.hypot(*np.diff(t[..., :2], axis=1).transpose(2, 0, 1))
    assert step.max() <= D3.sim_granularity + 1e-12
    np.testing.assert_allclose(t[:, -1, 2], pose[2] + samples.omega * D3.sim_time)


def test_closed_form_arc_matches_fine_euler_integration() -> None:
    v, w, T = np.array([0.2, 0.1, 0.0]), np.array([1.0, -0.5, 0.7]), 2.0
    exact = simulate((1.0, 2.0, 0.5), v, w, T, 4)[:, -1]
    n = 200_000
    dt = T / n
    x, y, th = np.full(3, 1.0), np.full(3, 2.0), np.full(3, 0.5)
    for _ in range(0, n, 1000):  # Euler in vectorised chunks of 1000 steps
        k = np.arange(1000)[:, None]
        ths = th + w * dt * k
        x = x + np.sum(v * np.cos(ths), axis=0) * dt
        y = y + np.sum(v * np.sin(ths), axis=0) * dt
        th = th + w * dt * 1000
    np.testing.assert_allclose(exact[:, 0], x, atol=1e-5)
    np.testing.assert_allclose(exact[:, 1], y, atol=1e-5)


def test_distance_map_is_a_four_connected_wavefront_around_obstacles() -> None:
    costmap = np.zeros((5, 5), dtype=np.uint8)
    costmap[1:4, 2] = LETHAL_OBSTACLE
    d = distance_map(costmap, [(0, 2)])
    assert d[2, 0] == 0 and d[2, 1] == 1
    assert d[2, 3] == 7            # around the wall: 4-connected, no diagonals
    assert np.isinf(d[2, 2])


def test_at_the_goal_it_stops_then_rotates_to_the_goal_yaw() -> None:
    plan = straight_plan(x1=1.0)
    pose = (0.95, 1.52, 0.0)
    turning = compute_velocity(pose, (0.0, 0.0), free_map(), plan, D3, resolution=RES,
                               goal_yaw=math.pi / 2)
    assert turning.status is DwaStatus.ROTATING
    assert turning.v == 0.0
    assert D3.min_rot_vel <= turning.omega <= D3.max_rot_vel
    right = goal_command(pose, (0.0, 0.0), (1.0, 1.5, -math.pi / 2), D3)
    assert right is not None and right.v == 0.0 and right.omega < 0
    done = compute_velocity((0.95, 1.52, 1.4), (0.0, 0.0), free_map(), plan, D3,
                            resolution=RES, goal_yaw=math.pi / 2)
    assert done.status is DwaStatus.GOAL_REACHED and (done.v, done.omega) == (0.0, 0.0)
    braking = goal_command(pose, (0.15, 0.0), (1.0, 1.5, 1.0), D3)
    assert braking is not None and braking.status is DwaStatus.STOPPING
    assert 0.0 <= braking.v < 0.15
    assert goal_command((0.5, 1.5, 0.0), (0.0, 0.0), (1.0, 1.5, 0.0), D3) is None


def test_boxed_in_robot_gets_no_valid_trajectory_and_stops() -> None:
    costmap = free_map()
    costmap[25:36, 5:16] = LETHAL_OBSTACLE
    costmap[29:32, 9:12] = 0     # a 3 x 3 pocket around the robot
    result = compute_velocity((0.525, 1.525, 0.0), (0.1, 0.0), costmap, straight_plan(), D3,
                              resolution=RES)
    assert result.status is DwaStatus.NO_VALID_TRAJECTORY
    assert (result.v, result.omega) == (0.0, 0.0)
    assert result.trajectory.shape == (0, 3)


@pytest.mark.parametrize("change", [{"vx_samples": -1}, {"vtheta_samples": 0},
                                    {"sim_time": 0.0}, {"acc_lim_x": math.nan},
                                    {"vx_samples": 2.5}])
def test_bad_config_is_refused(change: dict[str, object]) -> None:
    with pytest.raises(ValueError):
        DwaConfig(**{**D3.__dict__, **change})


def test_bad_inputs_are_refused() -> None:
    with pytest.raises(ValueError, match="pose"):
        compute_velocity((math.nan, 1.5, 0.0), (0.0, 0.0), free_map(), straight_plan(), D3,
                         resolution=RES)
    with pytest.raises(ValueError, match="velocity"):
        score_samples((0.5, 1.5, 0.0), (0.0, math.inf), free_map(), straight_plan(), D3,
                      resolution=RES)
    with pytest.raises(ValueError, match="plan"):
        compute_velocity((0.5, 1.5, 0.0), (0.0, 0.0), free_map(), np.empty((0, 2)), D3,
                         resolution=RES)
    with pytest.raises(ValueError, match="costmap"):
        score_samples((0.5, 1.5, 0.0), (0.0, 0.0), np.full((4, 4), 0.5), straight_plan(), D3,
                      resolution=RES)
    with pytest.raises(ValueError, match="samples"):
        velocity_iterator(0.0, 1.0, -3)
    with pytest.raises(ValueError, match="resolution"):
        score_samples((0.5, 1.5, 0.0), (0.0, 0.0), free_map(), straight_plan(), D3,
                      resolution=0.0)


def test_config_from_the_seed_parameter_file() -> None:
    from servolab.robots.navigation.params import load_dwa
    from servolab.robots.navigation.run import DEFAULT_DWA

    path = DEFAULT_DWA  # seed 000 D.3, shipped with servolab.robots.navigation
    cfg = DwaConfig.from_params(load_dwa(path))
    assert cfg == D3


def test_oscillation_flags_forbid_turning_back_until_the_robot_has_moved() -> None:
    """base_local_planner's OscillationCostFunction (oscillation_cost_function.cpp): turning
    on the spot one way after the other sets rot_*_only; a sample turning back is invalid
    until the robot has moved more than oscillation_reset_dist (D.3: 0.05 m)."""
    from servolab.planning.dwa import OscillationFlags

    flags = OscillationFlags()
    flags.update((1.0, 1.0), 0.0, 0.5, D3.min_trans_vel, D3.oscillation_reset_dist)
    assert not flags.restricted  # one direction so far: nothing to forbid
    flags.update((1.0, 1.0), 0.0, -0.5, D3.min_trans_vel, D3.oscillation_reset_dist)
    assert flags.rot_neg_only and not flags.rot_pos_only
    v = np.array([0.0, 0.0, 0.12, 0.12])
    omega = np.array([0.5, -0.5, 0.3, 0.0])
    assert flags.forbidden(v, omega).tolist() == [True, False, True, False]
    # driving forward faster than min_trans_vel does not count as turning; 4 cm is not enough
    flags.update((1.04, 1.0), 0.12, 0.3, D3.min_trans_vel, D3.oscillation_reset_dist)
    assert flags.rot_neg_only
    flags.update((1.06, 1.0), 0.12, 0.0, D3.min_trans_vel, D3.oscillation_reset_dist)
    assert not flags.restricted  # 6 cm from where the flag was set: cleared


def test_a_forbidden_turn_is_not_chosen() -> None:
    """With rot_neg_only set, the planner's pick never turns positive, where without flags it
    would: a goal up and to the left, the robot at rest facing +x."""
    from servolab.planning.dwa import OscillationFlags

    plan = np.array([[0.5 + 0.025 * k, 1.5 + 0.025 * k] for k in range(40)])
    free = compute_velocity((0.5, 1.5, -0.6), (0.0, 0.0), free_map(), plan, SLOW,
                            resolution=RES)
    assert free.omega > 0
    flags = OscillationFlags(rotating_neg=True, rot_neg_only=True, stationary=(0.5, 1.5))
    held = compute_velocity((0.5, 1.5, -0.6), (0.0, 0.0), free_map(), plan, SLOW,
                            resolution=RES, oscillation=flags)
    assert held.status is DwaStatus.MOVING and held.omega <= 0
