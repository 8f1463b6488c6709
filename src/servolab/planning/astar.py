"""A from-scratch A* on the 8-connected grid of :mod:`servolab.planning.grid` (pure Python).

The same graph and move costs as :class:`servolab.planning.dstar_lite.DStarLite` (a move costs
its step length times the mean of its two cells' costs; a diagonal may not cut the corner of an
occupied cell), searched forwards from ``start`` to ``goal`` with the octile distance as the
heuristic. Costs are ``>= 1`` (see :func:`~servolab.planning.grid.check_costs`), so the octile
distance is admissible and consistent: a cell popped from the queue is settled and is never
expanded again (a closed set, no re-opening).

It is written the way D* Lite is, so that the two can be compared fairly
(``benchmarks/planning.py``): a padded grid (a one-cell border of occupied cells, so neighbour
ids need no bounds checks), flat Python lists, a :mod:`heapq` binary heap with lazy deletion
(stale entries are skipped when popped), no recursion. Ties on ``f`` are broken towards the
larger ``g`` (deeper first), which expands fewer cells on open ground.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from servolab.planning.grid import SQRT2, IntArray, check_cell, check_costs

_INF = math.inf
_OCTILE = SQRT2 - 1.0


def astar(costs: npt.ArrayLike, start: Sequence[int] | npt.ArrayLike,
          goal: Sequence[int] | npt.ArrayLike) -> tuple[float, IntArray]:
    """The cheapest path from ``start`` to ``goal`` (``(row, col)`` cells) on ``costs``.

    Returns ``(cost, path)``: ``path`` an (N, 2) int array of ``(row, col)`` cells, start
    first and goal last. When no path exists (or the start or goal is occupied) the cost is
    ``inf`` and the path is empty, shape (0, 2). ValueError for a bad grid or a cell outside it.
    """
    grid = check_costs(costs)
    height, width = int(grid.shape[0]), int(grid.shape[1])
    sr, sc = check_cell("start", start, (height, width))
    gr, gc = check_cell("goal", goal, (height, width))
    w2 = width + 2
    padded = np.full((height + 2, w2), np.inf)
    padded[1:-1, 1:-1] = grid
    cost: list[float] = padded.ravel().tolist()
    s = (sr + 1) * w2 + sc + 1
    t = (gr + 1) * w2 + gc + 1
    empty = np.zeros((0, 2), dtype=np.int64)
    if cost[s] == _INF or cost[t] == _INF:
        return _INF, empty
    half = 0.5
    half_diag = SQRT2 / 2.0
    ortho = ((-w2, half), (w2, half), (-1, half), (1, half))
    diag = ((-w2 - 1, half_diag, -w2, -1), (-w2 + 1, half_diag, -w2, 1),
            (w2 - 1, half_diag, w2, -1), (w2 + 1, half_diag, w2, 1))
    n = len(cost)
    g: list[float] = [_INF] * n
    parent: list[int] = [-1] * n
    closed = bytearray(n)
    g[s] = 0.0
    trow, tcol = gr + 1, gc + 1

    def h(u: int) -> float:
        r, c = divmod(u, w2)
        dr = r - trow if r > trow else trow - r
        dc = c - tcol if c > tcol else tcol - c
        return dr + _OCTILE * dc if dr > dc else dc + _OCTILE * dr

    heap: list[tuple[float, float, int]] = [(h(s), 0.0, s)]
    pop = heapq.heappop
    push = heapq.heappush
    while heap:
        _f, neg_g, u = pop(heap)
        if closed[u]:
            continue  # a stale entry: u was settled through a cheaper one
        closed[u] = 1
        if u == t:
            break
        gu = -neg_g
        cu = cost[u]
        for off, hf in ortho:
            v = u + off
            cv = cost[v]
            if cv != _INF and not closed[v]:
                gv = gu + (cu + cv) * hf
                if gv < g[v]:
                    g[v] = gv
                    parent[v] = u
                    push(heap, (gv + h(v), -gv, v))
        for off, hf, oa, ob in diag:
            v = u + off
            cv = cost[v]
            if cv != _INF and not closed[v] and cost[u + oa] != _INF and cost[u + ob] != _INF:
                gv = gu + (cu + cv) * hf
                if gv < g[v]:
                    g[v] = gv
                    parent[v] = u
                    push(heap, (gv + h(v), -gv, v))
    if not closed[t]:
        return _INF, empty
    ids = [t]
    while ids[-1] != s:
        ids.append(parent[ids[-1]])
    array = np.array(ids[::-1], dtype=np.int64)
    return g[t], np.stack([array // w2 - 1, array % w2 - 1], axis=1)
