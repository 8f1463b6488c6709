"""DWA local planner (servolab.planning.dwa) on small synthetic costmaps."""

from __future__ import annotations

import math

import numpy as np
import pytest

from servolab.planning.costmap import (
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    inflate,
    inscribed_radius,
)
from servolab.planning.dwa import (
    DwaConfig,
    DwaStatus,
    GoalLatch,
    compute_velocity,
    distance_map,
    dynamic_window,
    find_best_trajectory,
    footprint_cost,
    goal_command,
    sample_window,
    score_samples,
    simulate,
    velocity_iterator,
)
from tests.planning.test_costmap import cv2_cells, has_tie, line_iterator

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


def test_a_latched_final_turn_is_not_braked_when_it_turns_faster_than_rot_stopped_vel() -> None:
    """ros-planning/navigation base_local_planner latched_stop_rotate_controller.cpp
    (computeVelocityCommandsStopRotate): once ``rotating_to_goal_`` is set the robot is not
    braked again; D.3's ``rot_stopped_vel`` equals ``min_rot_vel`` (0.4), so an odometry
    reading a hair above 0.4 rad/s would otherwise be braked every other cycle (issue 30)."""
    goal = (1.0, 1.5, math.pi)
    pose = (0.95, 1.52, 0.0)
    latch = GoalLatch()
    first = goal_command(pose, (0.0, 0.0), goal, D3, latch)
    assert first is not None and first.status is DwaStatus.ROTATING and latch.rotating_to_goal
    turning = goal_command(pose, (0.0, 0.4004), goal, D3, latch)
    assert turning is not None and turning.status is DwaStatus.ROTATING
    assert turning.omega >= 0.4004  # kept turning (up to the acceleration limit), not braked
    # without the latch the same reading is braked: the oscillation the issue found
    unlatched = goal_command(pose, (0.0, 0.4004), goal, D3)
    assert unlatched is not None and unlatched.status is DwaStatus.STOPPING
    assert abs(unlatched.omega) < 0.4004 - D3.acc_lim_theta * D3.sim_period + 1e-9
    # within yaw_goal_tolerance: zero command, reached once stopped (isGoalReached)
    aligned = (0.95, 1.52, math.pi - 0.1)
    slowing = goal_command(aligned, (0.0, 0.9), goal, D3, latch)
    assert slowing is not None and slowing.status is DwaStatus.STOPPING
    assert (slowing.v, slowing.omega) == (0.0, 0.0) and not latch.rotating_to_goal
    done = goal_command(aligned, (0.0, 0.3), goal, D3, latch)
    assert done is not None and done.status is DwaStatus.GOAL_REACHED


def test_latch_xy_goal_tolerance_keeps_turning_after_drifting_out() -> None:
    """DWAPlanner.cfg's latch_xy_goal_tolerance (default false): with it, a robot that has once
    been within xy_goal_tolerance finishes its turn there even if it drifts out."""
    goal = (1.0, 1.5, math.pi / 2)
    latched = DwaConfig(**{**D3.__dict__, "latch_xy_goal_tolerance": True})
    latch = GoalLatch()
    assert goal_command((0.95, 1.5, 0.0), (0.0, 0.0), goal, latched, latch) is not None
    drifted = (0.8, 1.5, 0.2)  # 0.2 m out, beyond the 0.15 m tolerance
    assert goal_command(drifted, (0.0, 0.5), goal, latched, latch) is not None
    assert goal_command(drifted, (0.0, 0.5), goal, D3, GoalLatch()) is None
    latch.reset()
    assert goal_command(drifted, (0.0, 0.5), goal, latched, latch) is None


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
    from servolab.robots.navigation.params import DEFAULT_DWA, load_dwa

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


# -- the footprint (issue 30) ------------------------------------------------------------------

#: a rectangular robot 0.5 m long and 0.3 m wide, centred on its wheel axis
RECTANGLE = np.array([[-0.25, -0.15], [0.25, -0.15], [0.25, 0.15], [-0.25, 0.15]])


def costmap_model_footprint_cost(costmap: np.ndarray, pose: tuple[float, float, float],
                                 footprint: np.ndarray, resolution: float,
                                 origin: tuple[float, float]) -> float:
    """base_local_planner's CostmapModel::footprintCost for a polygon (costmap_model.cpp), one
    pose at a time, as a loop: the footprint turned and moved as WorldModel::footprintCost
    does, worldToMap on each vertex (off the map: -1, here inf), lineCost over every edge and
    the last back to the first; the largest cell cost (pointCost's -1 for 254 and 255 kept as
    the cost itself, so that the caller sees which)."""
    rows, cols = costmap.shape
    c, s = math.cos(pose[2]), math.sin(pose[2])
    cells = []
    for px, py in footprint:
        wx, wy = pose[0] + (px * c - py * s), pose[1] + (px * s + py * c)
        if wx < origin[0] or wy < origin[1]:
            return math.inf
        mx, my = int((wx - origin[0]) / resolution), int((wy - origin[1]) / resolution)
        if mx >= cols or my >= rows:
            return math.inf
        cells.append((mx, my))
    worst = 0
    for (x0, y0), (x1, y1) in zip(cells, cells[1:] + cells[:1], strict=True):
        for x, y in line_iterator(x0, y0, x1, y1):
            worst = max(worst, int(costmap[y, x]))
    return float(worst)


@pytest.mark.parametrize("full_table", [True, False])
def test_footprint_cost_is_costmap_models_outline_maximum(full_table: bool,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    """Against the loop above, poses partly off the map included; ``full_table=False`` takes
    the path for footprints whose edges are too long for a table of every offset."""
    if not full_table:
        monkeypatch.setattr("servolab.planning.dwa._FULL_TABLE_ENTRIES", 0)
    rng = np.random.default_rng(3)
    costmap = rng.integers(0, 256, (37, 53)).astype(np.uint8)
    origin = (-0.3, 0.2)
    triangle = np.array([[0.4, 0.0], [-0.1, 0.23], [-0.13, -0.31]])
    for footprint in (RECTANGLE, triangle):
        poses = np.column_stack((rng.uniform(-0.6, 2.6, 600), rng.uniform(0.0, 2.2, 600),
                                 rng.uniform(-7.0, 7.0, 600)))
        got = footprint_cost(costmap, poses.reshape(20, 30, 3), footprint, resolution=RES,
                             origin=origin)
        assert got.shape == (20, 30)
        expected = [costmap_model_footprint_cost(costmap, tuple(p), footprint, RES, origin)
                    for p in poses]
        np.testing.assert_array_equal(got.ravel(), expected)
        assert 0.2 < np.mean(np.isinf(expected)) < 0.9   # some poses have a vertex off the map


def test_footprint_cost_against_opencvs_polygon_outline() -> None:
    """The cost is the maximum over the cells cv2.polylines draws for the vertices' cells (an
    independent Bresenham; compared where no edge has a tie)."""
    rng = np.random.default_rng(5)
    costmap = rng.integers(0, 253, (60, 60)).astype(np.uint8)
    compared = 0
    for x, y, theta in zip(rng.uniform(0.5, 2.5, 100), rng.uniform(0.5, 2.5, 100),
                           rng.uniform(-math.pi, math.pi, 100), strict=True):
        c, s = math.cos(theta), math.sin(theta)
        world = np.column_stack((x + (RECTANGLE[:, 0] * c - RECTANGLE[:, 1] * s),
                                 y + (RECTANGLE[:, 0] * s + RECTANGLE[:, 1] * c)))
        vertices = [(int(a), int(b)) for a, b in np.floor(world / RES)]
        edges = zip(vertices, vertices[1:] + vertices[:1], strict=True)
        if any(has_tie(*a, *b) for a, b in edges):
            continue
        cells = cv2_cells(vertices, closed=True, shape=costmap.shape)
        expected = max(int(costmap[r, q]) for q, r in cells)
        assert footprint_cost(costmap, (x, y, theta), RECTANGLE, resolution=RES) == expected
        compared += 1
    assert compared >= 20


def test_only_lethal_and_unknown_outline_cells_count_and_only_the_outline_is_seen() -> None:
    pose = (1.525, 1.525, 0.0)   # the rectangle covers cols 25..35, rows 27..33
    costmap = free_map()
    costmap[33, 28] = INSCRIBED_INFLATED_OBSTACLE
    assert footprint_cost(costmap, pose, RECTANGLE, resolution=RES) == 253
    costmap[27, 31] = NO_INFORMATION
    assert footprint_cost(costmap, pose, RECTANGLE, resolution=RES) == 255
    costmap[27, 31] = 0
    costmap[30, 27] = LETHAL_OBSTACLE        # strictly inside: costmap_model.cpp does not look
    assert footprint_cost(costmap, pose, RECTANGLE, resolution=RES) == 253
    assert footprint_cost(costmap, (0.1, 1.5, 0.0), RECTANGLE, resolution=RES) == math.inf
    with pytest.raises(ValueError, match="three"):
        footprint_cost(costmap, pose, RECTANGLE[:2], resolution=RES)


def post_costmap() -> np.ndarray:
    """A post 0.15 m x 0.1 m whose nearest cells are 0.2 m to the left of a robot at
    (1.525, 1.525): further than the rectangle's inscribed radius (0.15 m), so the inflation
    leaves the centre's cell at 152, but nearer than its corners (0.29 m)."""
    occupied = np.zeros((60, 60), dtype=bool)
    occupied[34:36, 29:32] = True                            # x 1.45..1.60, y 1.70..1.80
    return inflate(occupied, RES, 0.4, 10.0, inscribed_radius(RECTANGLE))


def test_a_rectangles_corner_sweeps_a_post_that_its_centre_stays_clear_of() -> None:
    """Turning on the spot, the rectangle's front or back corner sweeps through the post; the
    centre's cell (the circular check) is never inflated to 253."""
    costmap = post_costmap()
    pose = (1.525, 1.525, 0.0)
    assert costmap[30, 30] == 152                            # the centre's cell, 4 cells away
    # standing still the post is outside; turned by 0.4 rad either way an edge is on it
    for yaw, hit in ((0.0, False), (0.2, False), (-0.2, False), (0.4, True), (-0.4, True),
                     (1.0, True)):
        cost = footprint_cost(costmap, (*pose[:2], yaw), RECTANGLE, resolution=RES)
        assert bool(cost == LETHAL_OBSTACLE) == hit, yaw
    plan = straight_plan(y=1.525, x0=1.525, x1=2.8)
    circle = score_samples(pose, (0.0, 0.0), costmap, plan, SLOW, resolution=RES)
    polygon = score_samples(pose, (0.0, 0.0), costmap, plan, SLOW, resolution=RES,
                            footprint=RECTANGLE)
    spin = (circle.v == 0.0) & circle.feasible               # turning at 0.47 rad/s or more
    assert spin.sum() >= 10
    assert np.all(circle.valid[spin]) and np.all(circle.occ_cost[spin] == 152)
    assert not np.any(polygon.valid[spin])
    assert np.all(np.isinf(polygon.cost[spin])) and np.all(polygon.occ_cost[spin] == 254)
    # a polygon only ever takes trajectories away from the circle's
    assert np.all(polygon.valid <= circle.valid) and polygon.valid.any()
    np.testing.assert_array_equal(polygon.trajectories, circle.trajectories)


def test_the_footprints_outline_cost_enters_occ_cost() -> None:
    """ObstacleCostFunction::footprintCost: a pose costs max(outline, centre cell)."""
    costmap = free_map()
    costmap[:, 37] = 120                  # x 1.85..1.90: under the front edge, not the centre
    pose = (1.61, 1.5, 0.0)
    plan = straight_plan(y=1.5, x0=1.61, x1=1.9)
    circle = score_samples(pose, (0.1, 0.0), costmap, plan, D3, resolution=RES)
    polygon = score_samples(pose, (0.1, 0.0), costmap, plan, D3, resolution=RES,
                            footprint=RECTANGLE)
    assert np.all(circle.occ_cost == 0)
    np.testing.assert_array_equal(polygon.valid, circle.valid)
    assert polygon.valid.sum() >= 60 and not polygon.valid.all()
    assert np.all(polygon.occ_cost[polygon.valid] == 120)
    # samples invalid anyway are spared the footprint: their occ_cost is their centre's
    assert np.all(polygon.occ_cost[~polygon.valid] == 0)
    np.testing.assert_allclose(polygon.cost[polygon.valid] - circle.cost[circle.valid],
                               D3.occdist_scale * 120)


#: Recorded from score_samples as it was before issue 30 (centre cells only), for the scene of
#: test_a_circular_robot_scores_exactly_as_before: which samples were valid, how many had each
#: occ_cost (and which one 253), the best sample and its cost, the sum of the valid costs.
BEFORE_VALID = [*range(0, 6), *range(15, 27), *range(36, 48), *range(57, 69), *range(78, 107),
                124, 125]
BEFORE_OCC = {92: 42, 152: 42, 251: 41, 253: 1}
BEFORE_BEST, BEFORE_BEST_COST, BEFORE_COST_SUM = 62, 266.0, 981616.0000000001


def test_a_circular_robot_scores_exactly_as_before() -> None:
    occupied = np.zeros((60, 60), dtype=bool)
    occupied[26:34, 15:19] = True
    costmap = inflate(occupied, RES, 0.4, 10.0, 0.15)
    args = ((0.5, 1.5, 0.0), (0.1, 0.0), costmap, straight_plan(), SLOW)
    today = score_samples(*args, resolution=RES)
    none = score_samples(*args, resolution=RES, footprint=None)
    for field in ("v", "omega", "feasible", "trajectories", "valid", "path_cost", "goal_cost",
                  "alignment_cost", "goal_front_cost", "occ_cost", "cost"):
        np.testing.assert_array_equal(getattr(none, field), getattr(today, field), field)
    assert today.v.size == 126
    assert np.flatnonzero(today.valid).tolist() == BEFORE_VALID
    values, counts = np.unique(today.occ_cost, return_counts=True)
    assert dict(zip(values.astype(int).tolist(), counts.tolist(), strict=True)) == BEFORE_OCC
    assert np.flatnonzero(today.occ_cost == 253).tolist() == [115]
    assert int(np.argmin(today.cost)) == BEFORE_BEST
    assert float(today.cost[BEFORE_BEST]) == pytest.approx(BEFORE_BEST_COST, rel=1e-12)
    assert float(np.sum(today.cost[today.valid])) == pytest.approx(BEFORE_COST_SUM, rel=1e-12)


def test_compute_velocity_passes_the_footprint_to_the_scoring() -> None:
    costmap = post_costmap()
    pose, plan = (1.525, 1.525, 0.0), straight_plan(y=1.525, x0=1.525, x1=2.8)
    result = compute_velocity(pose, (0.0, 0.0), costmap, plan, SLOW, resolution=RES,
                              footprint=RECTANGLE)
    assert result.samples is not None
    scored = score_samples(pose, (0.0, 0.0), costmap, plan, SLOW, resolution=RES,
                           footprint=RECTANGLE)
    np.testing.assert_array_equal(result.samples.valid, scored.valid)
    np.testing.assert_array_equal(result.samples.cost, scored.cost)
    best = find_best_trajectory(pose, (0.0, 0.0), costmap, plan, SLOW, resolution=RES,
                                footprint=RECTANGLE)
    assert (best.v, best.omega) == (result.v, result.omega)
    assert np.all(footprint_cost(costmap, result.trajectory, RECTANGLE, resolution=RES)
                  < LETHAL_OBSTACLE)
    with pytest.raises(ValueError, match="finite"):
        score_samples(pose, (0.0, 0.0), costmap, plan, SLOW, resolution=RES,
                      footprint=[[0.1, 0.0], [0.0, math.nan], [-0.1, 0.0]])
