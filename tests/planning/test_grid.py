"""grid.padded_adjacency, the graph D* Lite's compiled first search runs on (issue 30), against
grid.adjacency, the oracle built the other way (coordinates -> COO -> CSR): the same moves with
the same float weights, entry for entry, on grids with obstacles and fractional costs.

Exact equality, not approximate, because D* Lite relies on it: after its compiled first search
``g == rhs`` must hold with ``==`` for every cell, and ``rhs`` is recomputed in Python with the
float operations ``(c_a + c_b) * (step / 2)`` that both builders use."""

from __future__ import annotations

import math

import numpy as np
import pytest

from servolab.planning.grid import adjacency, padded_adjacency


def pad(costs: np.ndarray) -> np.ndarray:
    padded = np.full((costs.shape[0] + 2, costs.shape[1] + 2), np.inf)
    padded[1:-1, 1:-1] = costs
    return padded


def interior_ids(height: int, width: int) -> np.ndarray:
    """Padded ids of the cells ``0 .. height * width - 1`` of the unpadded grid, in order."""
    rows, cols = np.divmod(np.arange(height * width), width)
    return (rows + 1) * (width + 2) + cols + 1


@pytest.mark.parametrize(("height", "width"), [(1, 1), (1, 7), (6, 1), (9, 13), (17, 11)])
@pytest.mark.parametrize("obstacles", [0.0, 0.3, 0.6])
def test_padded_adjacency_equals_adjacency(height: int, width: int, obstacles: float) -> None:
    rng = np.random.default_rng(height * 1000 + width + int(obstacles * 10))
    costs = 1.0 + rng.integers(0, 17, (height, width)) / 4.0 + rng.random((height, width))
    costs[rng.random((height, width)) < obstacles] = np.inf
    expected = adjacency(costs)
    graph = padded_adjacency(pad(costs))
    assert graph.shape == ((height + 2) * (width + 2),) * 2
    ids = interior_ids(height, width)
    inner = graph[ids][:, ids]
    assert inner.nnz == expected.nnz == graph.nnz  # and so no move touches the border
    assert (inner != expected).nnz == 0  # same pattern, bit-identical weights
    assert (graph != graph.T).nnz == 0  # symmetric: Dijkstra from the goal = distance to it


def test_no_corner_cutting_and_isolated_cells() -> None:
    costs = np.array([[1.0, np.inf, 2.0],
                      [1.0, 1.0, np.inf],
                      [np.inf, np.inf, 3.0]])
    graph = padded_adjacency(pad(costs)).toarray()
    ids = interior_ids(3, 3)
    dense = graph[np.ix_(ids, ids)]
    assert dense[0, 4] == 0.0  # (0,0)->(1,1): (0,1) is occupied, the corner is cut
    assert dense[0, 3] == 1.0 and dense[3, 4] == 1.0
    assert dense[4, 2] == 0.0 and dense[4, 8] == 0.0  # diagonals past occupied corners
    assert not dense[[2, 8]].any()  # (0,2) and (2,2): every neighbour or corner occupied
    assert dense[1].sum() == 0.0 and dense[:, 1].sum() == 0.0  # an occupied cell: no moves


@pytest.mark.parametrize(("padded", "message"), [
    (np.ones((3, 3)), "border of occupied"),
    (np.full((2, 5), np.inf), "at least 3 x 3"),
    (np.full((3, 3, 3), np.inf), "at least 3 x 3"),
])
def test_padded_adjacency_refuses_a_grid_without_its_border(padded: np.ndarray,
                                                            message: str) -> None:
    """A free border cell would make ``u + offset`` wrap round to the next row's far end."""
    with pytest.raises(ValueError, match=message):
        padded_adjacency(padded)


def test_weights_are_step_times_mean_cost() -> None:
    costs = np.array([[1.0, 3.0], [2.0, 5.0]])
    graph = padded_adjacency(pad(costs))
    ids = interior_ids(2, 2)
    assert graph[ids[0], ids[1]] == 2.0
    assert graph[ids[0], ids[3]] == pytest.approx(3.0 * math.sqrt(2.0))
    assert graph[ids[3], ids[0]] == graph[ids[0], ids[3]]
