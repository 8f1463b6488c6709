"""The 8-connected grid graph that D* Lite plans on, shared by the planner, its oracle and tests.

A grid is a 2-D float array of *cell costs*, indexed ``costs[row, col]``:

* ``np.inf`` marks an occupied (lethal) cell: no move enters or leaves it;
* any finite value must be ``>= 1``: the price of crossing that cell, per cell length. The
  caller decides how a costmap maps onto it (e.g. ``1 + k * cost / 252`` for ROS's 0..252
  non-lethal costs); a free grid is all ones.

Why ``>= 1``: the planner's heuristic is the octile distance (the length of the shortest
8-connected path on an empty grid). It is admissible and consistent only if no move is cheaper
than its length, i.e. if no cell costs less than 1. A lower bound of 1 rather than "> 0" keeps the
heuristic useful without rescaling it each time a cell changes.

Move cost (the convention of this package)::

    c(a, b) = step(a, b) * (costs[a] + costs[b]) / 2,   step = 1 or sqrt(2)

the mean of the two cells' costs times the step's length: half of the move lies in each cell.
The mean rather than the max because it is the line integral of a piecewise-constant cost along
the step, it is symmetric (so the graph is undirected and D* Lite's Pred = Succ), and on a
uniform grid of ones a path's cost is its length in cells, as ``servolab plan --no-inflation``
promises. A diagonal move may not cut the corner of an occupied cell: both orthogonal cells it
passes between must be free, otherwise a point robot would graze the obstacle's corner.

A cell's cost change therefore alters only moves inside the 3 x 3 block around it (its own moves,
and the diagonals that pass its corner), which is what keeps D* Lite's repair local.

The graph is built as a scipy.sparse CSR matrix twice over, on purpose: :func:`adjacency`
(cell ids of the grid itself, assembled from coordinates) is the tests' and the benchmark's
independent oracle; :func:`padded_adjacency` (ids of the grid bordered with occupied cells,
written straight into CSR form, about 3x faster) is what D* Lite initialises its distances
from (issue 30). A test checks that the two agree entry for entry.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
from scipy import sparse  # type: ignore[import-untyped]

from servolab.planning.errors import PlanningValueError

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

SQRT2 = math.sqrt(2.0)

#: The 8 neighbour offsets (d_row, d_col): the 4 orthogonal ones first, then the diagonals.
OFFSETS: IntArray = np.array(
    [(-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (-1, 1), (1, -1), (1, 1)], dtype=np.int64
)
#: Length of each step in :data:`OFFSETS`, in cells.
STEPS: FloatArray = np.array([1.0] * 4 + [SQRT2] * 4)


def check_costs(costs: npt.ArrayLike) -> FloatArray:
    """``costs`` as a fresh 2-D float64 array; ValueError naming the first bad value.

    NaN, ``-inf`` and finite costs below 1 are refused: a NaN would make every comparison in
    the planner false (silently wrong paths), and a cost below 1 would break the heuristic.
    """
    array = np.array(costs, dtype=np.float64)  # a copy: the planner owns its grid
    if array.ndim != 2 or array.shape[0] < 1 or array.shape[1] < 1:
        raise PlanningValueError(f"costs must be a non-empty 2-D array, got shape {array.shape}")
    bad = ~((array >= 1.0) & (np.isfinite(array) | (array == np.inf)))
    if np.any(bad):
        r, c = np.argwhere(bad)[0]
        raise PlanningValueError(
            f"cell costs must be >= 1 or +inf (occupied), got {float(array[r, c])!r} at cell "
            f"({r}, {c})"
        )
    return array


def check_cell(name: str, cell: Sequence[int] | npt.ArrayLike, shape: tuple[int, int]
               ) -> tuple[int, int]:
    """``cell`` as a ``(row, col)`` pair of ints inside a grid of ``shape``; ValueError else."""
    array = np.asarray(cell)
    if array.shape != (2,) or not np.issubdtype(array.dtype, np.integer):
        raise PlanningValueError(f"{name} must be a (row, col) pair of integers, got {cell!r}")
    r, c = int(array[0]), int(array[1])
    if not (0 <= r < shape[0] and 0 <= c < shape[1]):
        raise PlanningValueError(
            f"{name} {(r, c)} is outside the {shape[0]} x {shape[1]} grid"
        )
    return r, c


def move_cost(costs: FloatArray, a: Sequence[int], b: Sequence[int]) -> float:
    """Cost of the single move from cell ``a`` to neighbouring cell ``b``; ``inf`` if it is
    forbidden (an occupied end, or a diagonal cutting an occupied corner).

    ValueError if ``a`` and ``b`` are not 8-neighbours: that is a broken path, not a blocked one.
    """
    ra, ca = int(a[0]), int(a[1])
    rb, cb = int(b[0]), int(b[1])
    dr, dc = rb - ra, cb - ca
    if max(abs(dr), abs(dc)) != 1:
        raise PlanningValueError(f"cells {(ra, ca)} and {(rb, cb)} are not 8-neighbours")
    cost_a, cost_b = float(costs[ra, ca]), float(costs[rb, cb])
    if dr != 0 and dc != 0:
        if costs[ra + dr, ca] == np.inf or costs[ra, ca + dc] == np.inf:
            return math.inf
        return (cost_a + cost_b) * (SQRT2 / 2.0)
    return (cost_a + cost_b) * 0.5


def path_cost(costs: FloatArray, path: npt.ArrayLike) -> float:
    """Summed move costs along ``path`` (an (N, 2) array of cells); ``inf`` if any move is
    forbidden, ValueError if two consecutive cells are not neighbours. Independent of the
    planner, so that tests can check the planner's own cost against it."""
    cells = np.asarray(path, dtype=np.int64)
    if cells.ndim != 2 or cells.shape[1] != 2 or len(cells) == 0:
        raise PlanningValueError("path must be a non-empty (N, 2) array of cells, got "
                                 f"{cells.shape}")
    total = 0.0
    for a, b in itertools.pairwise(cells):
        total += move_cost(costs, a, b)
    return total


def adjacency(costs: FloatArray) -> sparse.csr_matrix:
    """The grid graph as a scipy.sparse CSR matrix over cell ids ``row * width + col``.

    Built with one vectorised mask per neighbour offset (no per-cell Python loop), for use as an
    independent oracle with :func:`scipy.sparse.csgraph.dijkstra`. Forbidden moves are absent,
    not stored as ``inf`` entries (csgraph would treat an explicit ``inf`` as an edge).
    """
    costs = np.asarray(costs, dtype=np.float64)
    height, width = costs.shape
    free = np.isfinite(costs)
    ids = np.arange(height * width, dtype=np.int64).reshape(height, width)
    sources: list[IntArray] = []
    targets: list[IntArray] = []
    weights: list[FloatArray] = []
    for (dr, dc), step in zip(OFFSETS, STEPS, strict=True):
        # Slices selecting the sources (rs, cs) whose neighbour (rs + dr, cs + dc) exists.
        rs = slice(max(0, -dr), height - max(0, dr))
        cs = slice(max(0, -dc), width - max(0, dc))
        rt = slice(max(0, dr), height + min(0, dr))
        ct = slice(max(0, dc), width + min(0, dc))
        ok = free[rs, cs] & free[rt, ct]
        if dr != 0 and dc != 0:
            ok &= free[rt, cs] & free[rs, ct]  # the two cells the diagonal passes between
        sources.append(ids[rs, cs][ok])
        targets.append(ids[rt, ct][ok])
        weights.append((costs[rs, cs][ok] + costs[rt, ct][ok]) * (step / 2.0))
    n = height * width
    return sparse.csr_matrix(
        (np.concatenate(weights), (np.concatenate(sources), np.concatenate(targets))),
        shape=(n, n),
    )


def padded_adjacency(padded: npt.ArrayLike) -> sparse.csr_matrix:
    """The grid graph of ``padded``, a grid whose one-cell border is occupied, as a CSR matrix
    over its flat ids ``row * width + col`` (padded coordinates, the ids D* Lite uses).

    Why it exists beside :func:`adjacency`: D* Lite's first plan is one compiled Dijkstra over
    this graph (issue 30), and with :func:`adjacency` building it would take longer than the
    search itself (``benchmarks/planning.py``). :func:`adjacency` goes
    through scipy's COO -> CSR conversion, which sorts each row and sums duplicates; here each
    cell has 8 slots in :data:`OFFSETS` order, so one boolean mask of the allowed moves gives
    the CSR arrays directly (rows in id order, each row's targets in offset order -- unsorted,
    which csgraph accepts). The occupied border is what makes ``u + offset`` a valid neighbour
    id for every interior ``u``, with no bounds test and no wrap-around between rows; border
    cells have no moves. ValueError if the border is not all ``inf``.

    The matrix is symmetric (the move cost is), so a Dijkstra from the goal along its rows is
    the distance *to* the goal, which is what D* Lite's ``g`` means.
    """
    grid = np.asarray(padded, dtype=np.float64)
    if grid.ndim != 2 or grid.shape[0] < 3 or grid.shape[1] < 3:
        raise PlanningValueError(f"padded must be a 2-D array of at least 3 x 3 cells, got "
                                 f"shape {grid.shape}")
    if not (np.all(grid[[0, -1], :] == np.inf) and np.all(grid[:, [0, -1]] == np.inf)):
        raise PlanningValueError("padded must have a border of occupied (inf) cells")
    width = grid.shape[1]
    n = grid.size
    flat = grid.ravel()
    free = np.isfinite(flat)
    offsets = OFFSETS[:, 0] * width + OFFSETS[:, 1]
    allowed = np.zeros((n, 8), dtype=bool)  # allowed[u, k]: the move u -> u + offsets[k]
    lo, hi = width + 1, n - width - 1  # every cell but the first and last rows' (all border)
    here = free[lo:hi]
    for k, (dr, dc) in enumerate(OFFSETS.tolist()):
        column = allowed[lo:hi, k]
        off = dr * width + dc
        np.logical_and(here, free[lo + off:hi + off], out=column)
        if dr != 0 and dc != 0:  # the two cells the diagonal passes between
            column &= free[lo + dr * width:hi + dr * width]
            column &= free[lo + dc:hi + dc]
    slots = np.flatnonzero(allowed)  # row-major: grouped by source, as CSR wants
    # slot = 8 * source + k, split with a shift and a mask (cheaper than // and %).
    sources = slots >> 3
    kinds = slots & 7
    targets = sources + offsets[kinds]
    # The same float operations as adjacency and D* Lite's loops: (c_a + c_b) * (step / 2).
    weights = (flat[sources] + flat[targets]) * (STEPS / 2.0)[kinds]
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(sources, minlength=n), out=indptr[1:])
    return sparse.csr_matrix((weights, targets, indptr), shape=(n, n))
