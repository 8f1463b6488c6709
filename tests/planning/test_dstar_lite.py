"""D* Lite (seed 000, D.1) against scipy's Dijkstra, an independent implementation: the property
of issue 18 -- equal path costs after the first plan and after every step of randomised
sequences of robot moves and cell changes -- plus the path's own validity, checked here without
the planner's or grid.py's move costs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse.csgraph import dijkstra  # type: ignore[import-untyped]

from servolab.planning.dstar_lite import DStarLite
from servolab.planning.errors import NoPath, PlanningError
from servolab.planning.grid import adjacency, check_costs, move_cost, path_cost

SQRT2 = math.sqrt(2.0)


def random_grid(rng: np.random.Generator, height: int, width: int,
                obstacles: float = 0.2) -> np.ndarray:
    """Costs 1..5 in steps of 0.25 (exact in binary, and fractional), 20 % occupied."""
    costs = 1.0 + rng.integers(0, 17, (height, width)) / 4.0
    costs[rng.random((height, width)) < obstacles] = np.inf
    return costs


def oracle(costs: np.ndarray, start: tuple[int, int], goal: tuple[int, int]) -> float:
    width = costs.shape[1]
    dist = dijkstra(adjacency(costs), indices=start[0] * width + start[1])
    return float(dist[goal[0] * width + goal[1]])


def independent_cost(costs: np.ndarray, path: np.ndarray, start: tuple[int, int],
                     goal: tuple[int, int]) -> float:
    """Check the path's validity and sum its moves, without grid.py: ends, 8-neighbour steps,
    free cells, no corner cut; each move costs its length times the mean of its two cells."""
    assert path.ndim == 2 and path.shape[1] == 2
    assert tuple(path[0]) == start and tuple(path[-1]) == goal
    assert np.all(np.isfinite(costs[path[:, 0], path[:, 1]])), "path through an occupied cell"
    total = 0.0
    for (r0, c0), (r1, c1) in zip(path[:-1].tolist(), path[1:].tolist(), strict=True):
        dr, dc = r1 - r0, c1 - c0
        assert max(abs(dr), abs(dc)) == 1, f"{(r0, c0)} -> {(r1, c1)} is not a move"
        step = 1.0
        if dr and dc:
            assert np.isfinite(costs[r0 + dr, c0]) and np.isfinite(costs[r0, c0 + dc]), (
                f"{(r0, c0)} -> {(r1, c1)} cuts an occupied corner")
            step = SQRT2
        total += step * (costs[r0, c0] + costs[r1, c1]) / 2.0
    return total


def check_against_oracle(planner: DStarLite, costs: np.ndarray) -> float:
    start, goal = planner.start, planner.goal
    expected = oracle(costs, start, goal)
    if math.isinf(expected):
        with pytest.raises(NoPath):
            planner.plan()
        with pytest.raises(NoPath):
            planner.path()
        assert planner.cost() == math.inf
        return expected
    cost = planner.plan()
    assert cost == pytest.approx(expected, rel=1e-12, abs=1e-9)
    assert planner.cost() == cost
    path = planner.path()
    assert independent_cost(costs, path, start, goal) == pytest.approx(cost, rel=1e-12)
    return expected


def free_pair(rng: np.random.Generator, costs: np.ndarray
              ) -> tuple[tuple[int, int], tuple[int, int]] | None:
    free = np.argwhere(np.isfinite(costs))
    if len(free) < 2:
        return None
    a, b = free[rng.choice(len(free), 2, replace=False)]
    return (int(a[0]), int(a[1])), (int(b[0]), int(b[1]))


def run_sequence(seed: int, height: int, width: int, steps: int) -> None:
    """First plan, then ``steps`` rounds of: maybe move the robot along its path, then change
    a few cells -- some on the current path ahead of the robot, some anywhere -- to occupied,
    free or another cost; after each round D* Lite must agree with Dijkstra."""
    rng = np.random.default_rng(seed)
    costs = random_grid(rng, height, width)
    pair = free_pair(rng, costs)
    if pair is None:
        return
    start, goal = pair
    planner = DStarLite(costs, start, goal)
    check_against_oracle(planner, costs)
    for _ in range(steps):
        expected = oracle(costs, planner.start, goal)
        if math.isfinite(expected) and planner.start != goal and rng.random() < 0.7:
            path = planner.path()
            advance = int(rng.integers(1, min(3, len(path) - 1) + 1))
            planner.move_to(path[advance])
            path = path[advance:]
        else:
            path = np.array([planner.start])
        k = int(rng.integers(1, 5))
        cells = np.column_stack([rng.integers(0, height, k), rng.integers(0, width, k)])
        if len(path) > 2 and rng.random() < 0.6:  # hit the current path ahead of the robot
            cells[0] = path[rng.integers(1, len(path) - 1)]
        kind = rng.random(k)
        values = np.where(kind < 0.4, np.inf,
                          np.where(kind < 0.7, 1.0, 1.0 + rng.integers(0, 17, k) / 4.0))
        # The robot's and the goal's cells stay free (move_to would refuse an occupied start).
        keep = ~(np.all(cells == planner.start, axis=1) | np.all(cells == goal, axis=1))
        cells, values = cells[keep], values[keep]
        costs[cells[:, 0], cells[:, 1]] = values
        planner.update_cells(cells, values)
        check_against_oracle(planner, costs)


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), height=st.integers(8, 25), width=st.integers(8, 25))
def test_first_plan_equals_dijkstra(seed: int, height: int, width: int) -> None:
    rng = np.random.default_rng(seed)
    costs = random_grid(rng, height, width)
    pair = free_pair(rng, costs)
    if pair is not None:
        check_against_oracle(DStarLite(costs, *pair), costs)


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), height=st.integers(8, 25), width=st.integers(8, 25))
def test_repairs_equal_dijkstra_after_every_move_and_change(seed: int, height: int,
                                                            width: int) -> None:
    run_sequence(seed, height, width, steps=20)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(3))
def test_long_sequences_on_larger_grids(seed: int) -> None:
    run_sequence(1000 + seed, 120, 150, steps=100)


def test_uniform_grid_cost_is_length_in_cells() -> None:
    planner = DStarLite(np.ones((10, 10)), (0, 0), (9, 4))
    assert planner.plan() == pytest.approx(5.0 + 4.0 * SQRT2)
    assert len(planner.path()) == 10


def test_diagonal_does_not_cut_an_occupied_corner() -> None:
    costs = np.ones((2, 2))
    costs[0, 1] = np.inf
    planner = DStarLite(costs, (0, 0), (1, 1))
    assert planner.plan() == pytest.approx(2.0)  # around the corner, not sqrt(2)
    np.testing.assert_array_equal(planner.path(), [[0, 0], [1, 0], [1, 1]])
    assert move_cost(costs, (0, 0), (1, 1)) == math.inf
    costs[1, 0] = np.inf
    with pytest.raises(NoPath, match=r"no path from \(0, 0\) to \(1, 1\)"):
        DStarLite(costs, (0, 0), (1, 1)).plan()


def test_move_cost_is_step_times_mean_of_cells() -> None:
    costs = np.array([[1.0, 3.0], [2.0, 5.0]])
    assert move_cost(costs, (0, 0), (0, 1)) == 2.0
    assert move_cost(costs, (0, 0), (1, 1)) == pytest.approx(3.0 * SQRT2)
    assert path_cost(costs, [[0, 0], [1, 0], [1, 1]]) == 1.5 + 3.5
    with pytest.raises(ValueError, match="not 8-neighbours"):
        move_cost(costs, (0, 0), (0, 0))


def test_adjacency_matches_move_cost() -> None:
    rng = np.random.default_rng(7)
    costs = random_grid(rng, 9, 11, obstacles=0.3)
    graph = adjacency(costs).toarray()
    width = costs.shape[1]
    for r in range(9):
        for c in range(11):
            for dr in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    if (dr or dc) and 0 <= r + dr < 9 and 0 <= c + dc < 11:
                        expected = move_cost(costs, (r, c), (r + dr, c + dc))
                        got = graph[r * width + c, (r + dr) * width + c + dc]
                        assert got == (0.0 if math.isinf(expected) else expected)
    assert np.count_nonzero(graph) == np.count_nonzero(np.isfinite(graph) & (graph > 0))


def test_start_equals_goal_costs_nothing() -> None:
    planner = DStarLite(np.ones((3, 3)), (1, 1), (1, 1))
    assert planner.plan() == 0.0
    np.testing.assert_array_equal(planner.path(), [[1, 1]])


def test_no_path_then_freed() -> None:
    costs = np.ones((5, 5))
    costs[:, 2] = np.inf
    planner = DStarLite(costs, (0, 0), (4, 4))
    with pytest.raises(NoPath):
        planner.plan()
    # not bad input (nothing given was wrong, and cells may free): a failure, exit status 1
    assert isinstance(NoPath("x"), PlanningError) and not isinstance(NoPath("x"), ValueError)
    planner.update_cells([[2, 2]], [1.0])
    costs[2, 2] = 1.0
    assert planner.plan() == pytest.approx(oracle(costs, (0, 0), (4, 4)))
    planner.update_cells([[2, 2]], np.inf)
    with pytest.raises(NoPath):
        planner.path()


@pytest.mark.parametrize(("start", "goal", "message"), [
    ((0, 5), (1, 1), r"start \(0, 5\) is outside the 4 x 5 grid"),
    ((1, 1), (-1, 0), r"goal \(-1, 0\) is outside the 4 x 5 grid"),
    ((2, 2), (1, 1), r"start \(2, 2\) is an occupied cell"),
    ((1, 1), (2, 2), r"goal \(2, 2\) is an occupied cell"),
    ((1.5, 1), (1, 1), r"start must be a \(row, col\) pair of integers"),
])
def test_bad_start_or_goal_refused(start: tuple[float, int], goal: tuple[int, int],
                                   message: str) -> None:
    costs = np.ones((4, 5))
    costs[2, 2] = np.inf
    with pytest.raises(ValueError, match=message):
        DStarLite(costs, start, goal)


def test_bad_moves_and_updates_refused() -> None:
    costs = np.ones((4, 5))
    costs[2, 2] = np.inf
    planner = DStarLite(costs, (0, 0), (3, 4))
    with pytest.raises(ValueError, match=r"start \(2, 2\) is an occupied cell"):
        planner.move_to((2, 2))
    with pytest.raises(ValueError, match=r"cell \(4, 0\) is outside"):
        planner.update_cells([[4, 0]], 1.0)
    with pytest.raises(ValueError, match=r"got 0\.5 for cell \(1, 1\)"):
        planner.update_cells([[1, 1]], 0.5)
    with pytest.raises(ValueError, match="got nan"):
        planner.update_cells([[1, 1]], np.nan)


@pytest.mark.parametrize("bad", [0.5, np.nan, -np.inf, 0.0])
def test_bad_costs_refused(bad: float) -> None:
    costs = np.ones((3, 3))
    costs[1, 2] = bad
    with pytest.raises(ValueError, match=r"at cell \(1, 2\)"):
        check_costs(costs)
    with pytest.raises(ValueError, match="cell costs must be >= 1"):
        DStarLite(costs, (0, 0), (2, 2))
