"""Our from-scratch A* (planning/astar.py) against scipy's Dijkstra, an independent
implementation, on random grids: equal costs, a valid path whose own summed move costs
(grid.path_cost) equal the cost returned, and "no path" where Dijkstra finds none."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.sparse.csgraph import dijkstra  # type: ignore[import-untyped]

from servolab.planning.astar import astar
from servolab.planning.dstar_lite import DStarLite
from servolab.planning.grid import adjacency, path_cost


def _oracle(costs: np.ndarray, start: tuple[int, int], goal: tuple[int, int]) -> float:
    width = costs.shape[1]
    dist = dijkstra(adjacency(costs), indices=start[0] * width + start[1])
    return float(dist[goal[0] * width + goal[1]])


@pytest.mark.parametrize("seed", range(40))
def test_astar_cost_equals_dijkstra_on_random_grids(seed: int) -> None:
    rng = np.random.default_rng(seed)
    height, width = (int(x) for x in rng.integers(2, 30, 2))
    costs = 1.0 + rng.integers(0, 17, (height, width)) / 4.0
    if seed % 2:
        costs[:] = 1.0  # unit costs: the length in cells
    costs[rng.random((height, width)) < rng.uniform(0.0, 0.4)] = np.inf
    start = (int(rng.integers(height)), int(rng.integers(width)))
    goal = (int(rng.integers(height)), int(rng.integers(width)))
    costs[start] = costs[goal] = 1.0
    expected = _oracle(costs, start, goal)
    cost, path = astar(costs, start, goal)
    if math.isinf(expected):
        assert math.isinf(cost) and path.shape == (0, 2)
        return
    assert cost == pytest.approx(expected, rel=1e-12, abs=1e-12)
    assert tuple(path[0]) == start and tuple(path[-1]) == goal
    assert path_cost(costs, path) == pytest.approx(cost, rel=1e-12, abs=1e-12)
    # the same graph as D* Lite's
    assert DStarLite(costs, start, goal).cost() == pytest.approx(cost, rel=1e-9, abs=1e-12)


def test_astar_on_an_empty_grid_is_the_octile_distance() -> None:
    cost, path = astar(np.ones((10, 20)), (0, 0), (9, 19))
    assert cost == pytest.approx(9 * math.sqrt(2) + 10)
    assert len(path) == 20
    cost, path = astar(np.ones((3, 3)), (1, 1), (1, 1))
    assert cost == 0.0 and path.tolist() == [[1, 1]]


def test_astar_does_not_cut_corners_and_reports_no_path() -> None:
    costs = np.ones((2, 2))
    costs[0, 1] = np.inf
    cost, path = astar(costs, (0, 0), (1, 1))
    assert cost == pytest.approx(2.0) and path.tolist() == [[0, 0], [1, 0], [1, 1]]
    costs[1, 0] = np.inf  # the only way left is the forbidden corner cut
    cost, path = astar(costs, (0, 0), (1, 1))
    assert math.isinf(cost) and path.shape == (0, 2)
    with pytest.raises(ValueError, match="outside"):
        astar(costs, (0, 0), (2, 0))
    with pytest.raises(ValueError, match=">= 1"):
        astar(np.full((2, 2), 0.5), (0, 0), (1, 1))
