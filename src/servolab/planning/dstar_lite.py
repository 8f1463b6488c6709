"""D* Lite (Koenig & Likhachev 2002, the optimised version of seed 000's Appendix D.1) on the
8-connected grid of :mod:`servolab.planning.grid`.

D* Lite searches *backwards*, from the goal towards the robot, so that when the robot moves the
distances already computed (``g``, distance to the goal) stay valid, and when cells change only
the vertices whose distances the change affects are re-expanded. ``k_m`` accumulates the
heuristic distance the robot has travelled so that keys already in the queue stay lower bounds
without re-keying the queue.

The first plan (issue 30) is by default not D* Lite's own first search but one compiled
backward Dijkstra from the goal (:func:`scipy.sparse.csgraph.dijkstra` over
:func:`~servolab.planning.grid.padded_adjacency`), which sets ``g = rhs`` = the distance to the
goal for every cell (``inf`` for the occupied ones and those the goal cannot reach) and leaves
the queue empty. That is a valid D* Lite state: every vertex is locally consistent, which makes
every ``g`` the goal distance (Koenig & Likhachev 2002, the definitions of Lifelong Planning
A* that D* Lite builds on), and ``U`` must hold exactly the inconsistent vertices: none. So
:meth:`DStarLite.plan` returns at once, and the repairs (``update_cells``, ``move_to`` with
``k_m``) run unchanged: the vertices they make inconsistent are queued with the ``k_m`` and
start of that moment, as always.

It labels every reachable cell instead of stopping once the start is settled. Pure Python
could not afford that, but compiled code can: it is about as fast as scipy's Dijkstra with its
graph built, several times faster than D* Lite's own first search on large grids (the figures:
``benchmarks/planning.py``, quoted in docs/navigation.md). It also spares the first repair
that needs a detour the cells the focused search had left unexpanded. ``first_search="incremental"``
keeps D* Lite's own first search, the faster one when start and goal are close on a large grid,
because it expands only the cells around their path (on that grid 35 ms for a goal 20 cells
away, where the compiled search takes 0.3 s whatever the distance).

Implementation choices, all for speed on 1000 x 1000 grids in pure Python:

* the grid is padded with a one-cell border of occupied cells, so that neighbour ids are
  ``u + offset`` with no bounds checks;
* ``g``, ``rhs`` and the costs are flat Python lists indexed by padded cell id (reading a
  numpy array element by element from a Python loop is several times slower than a list);
  :attr:`DStarLite.g` and :attr:`DStarLite.rhs` give them back as 2-D numpy arrays;
* the priority queue is a :mod:`heapq` binary heap with lazy deletion: ``U.Update`` and
  ``U.Remove`` only record the vertex's current entry (``_entry[u]``, the tuple itself), and
  entries popped that are not the current one are stale and skipped. The heap is compacted
  when stale entries outnumber live ones;
* no recursion, no per-cell objects besides the heap's live entries.

Line numbers ``{nn}`` in comments refer to the pseudo code of D.1.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Sequence
from typing import Literal

import numpy as np
import numpy.typing as npt
from scipy.sparse.csgraph import dijkstra  # type: ignore[import-untyped]

from servolab.planning.errors import NoPath, PlanningValueError
from servolab.planning.grid import (
    SQRT2,
    FloatArray,
    IntArray,
    check_cell,
    check_costs,
    padded_adjacency,
)

_INF = math.inf
_OCTILE = SQRT2 - 1.0
_HALF = 0.5
_HALF_DIAG = SQRT2 / 2.0
#: Decimals a key's first part is rounded to. Two keys equal in exact arithmetic (a vertex the
#: start's value rests on, reached at exactly the heuristic's cost) can differ by a rounding
#: error; the lexicographic order must then fall to the second part, as the algorithm's proof
#: assumes, or the search stops one vertex early with the start's value wrong.
_KEY_DECIMALS = 9

Key = tuple[float, float, int]
FirstSearch = Literal["compiled", "incremental"]


class DStarLite:
    """Incremental shortest paths from a moving ``start`` to a fixed ``goal`` on a cost grid.

    ``costs``: 2-D cell costs (``inf`` occupied, else ``>= 1``; see :mod:`.grid`), copied.
    ``start``, ``goal``: ``(row, col)`` cells, inside the grid and free, else ValueError.
    ``first_search``: ``"compiled"`` (default) labels every cell with its distance to the goal
    at construction, by one compiled Dijkstra; ``"incremental"`` leaves the first search to
    :meth:`plan`, D* Lite's own, which stops once the start is settled (see the module's
    docstring for when each is faster). Both give the same costs, paths of the same cost, and
    the same repairs.

    Typical use::

        planner = DStarLite(costs, start, goal)
        planner.plan()                       # first search; NoPath if none
        while not at goal:
            cells = planner.path()           # (N, 2) cells, start first
            planner.move_to(cells[1])        # the robot advanced one cell (or more)
            planner.update_cells(seen, new)  # the sensors changed some cells
            planner.plan()                   # incremental repair
    """

    def __init__(self, costs: npt.ArrayLike, start: Sequence[int] | npt.ArrayLike,
                 goal: Sequence[int] | npt.ArrayLike, *,
                 first_search: FirstSearch = "compiled") -> None:
        if first_search not in ("compiled", "incremental"):
            raise PlanningValueError("first_search must be 'compiled' or 'incremental', got "
                                     f"{first_search!r}")
        grid = check_costs(costs)
        self._shape: tuple[int, int] = (int(grid.shape[0]), int(grid.shape[1]))
        height, width = self._shape
        self._width2 = w2 = width + 2
        padded = np.full((height + 2, w2), np.inf)
        padded[1:-1, 1:-1] = grid
        self._cost: list[float] = padded.ravel().tolist()
        n = padded.size
        self._entry: list[Key | None] = [None] * n
        self._heap: list[Key] = []
        self._live = 0  # number of vertices in U (live heap entries)
        # (offset, half step, corner offset a, corner offset b); corners 0 for orthogonal moves.
        self._ortho: list[tuple[int, float]] = [(-w2, _HALF), (w2, _HALF), (-1, _HALF),
                                                (1, _HALF)]
        self._diag: list[tuple[int, float, int, int]] = [
            (-w2 - 1, _HALF_DIAG, -w2, -1), (-w2 + 1, _HALF_DIAG, -w2, 1),
            (w2 - 1, _HALF_DIAG, w2, -1), (w2 + 1, _HALF_DIAG, w2, 1),
        ]
        self._goal = self._free_id("goal", goal)
        self._start = self._free_id("start", start)
        self._last = self._start
        self._km = 0.0
        self._g: list[float]
        self._rhs: list[float]
        if first_search == "compiled":
            # {02}-{06} and the first {10}-{28} at once: g = rhs = distance to the goal, U empty.
            # Exact, not approximate: Dijkstra's distance of a cell is its best neighbour's
            # distance plus that move, the very floats _best_rhs computes, so g == rhs holds
            # with ==, as the queue's bookkeeping needs.
            self._g = dijkstra(padded_adjacency(padded), indices=self._goal).tolist()
            self._rhs = self._g.copy()
        else:
            # {02}-{06}
            self._g = [_INF] * n
            self._rhs = [_INF] * n
            self._rhs[self._goal] = 0.0
            self._push(self._goal, round(self._h(self._start, self._goal), _KEY_DECIMALS), 0.0)

    # -- cells and ids -------------------------------------------------------------------------

    def _id(self, name: str, cell: Sequence[int] | npt.ArrayLike) -> int:
        r, c = check_cell(name, cell, self._shape)
        return (r + 1) * self._width2 + (c + 1)

    def _free_id(self, name: str, cell: Sequence[int] | npt.ArrayLike) -> int:
        u = self._id(name, cell)
        if self._cost[u] == _INF:
            raise PlanningValueError(f"{name} {self._cell(u)} is an occupied cell")
        return u

    def _cell(self, u: int) -> tuple[int, int]:
        r, c = divmod(u, self._width2)
        return r - 1, c - 1

    def _h(self, a: int, b: int) -> float:
        """Octile distance: the cost of the cheapest conceivable path (all cells cost 1)."""
        ra, ca = divmod(a, self._width2)
        rb, cb = divmod(b, self._width2)
        dr = abs(ra - rb)
        dc = abs(ca - cb)
        return dr + _OCTILE * dc if dr > dc else dc + _OCTILE * dr

    def _push(self, u: int, k1: float, k2: float) -> None:
        entry = (k1, k2, u)
        if self._entry[u] is None:
            self._live += 1
        self._entry[u] = entry
        heapq.heappush(self._heap, entry)

    def _unpad(self, values: list[float]) -> FloatArray:
        height = self._shape[0]
        return np.array(values).reshape(height + 2, self._width2)[1:-1, 1:-1].copy()

    # -- public state --------------------------------------------------------------------------

    @property
    def shape(self) -> tuple[int, int]:
        return self._shape

    @property
    def start(self) -> tuple[int, int]:
        return self._cell(self._start)

    @property
    def goal(self) -> tuple[int, int]:
        return self._cell(self._goal)

    @property
    def costs(self) -> FloatArray:
        """The planner's current cell costs (a copy)."""
        return self._unpad(self._cost)

    @property
    def g(self) -> FloatArray:
        """Current ``g`` (distance-to-goal estimates), 2-D; ``inf`` where the goal is out of
        reach (or, with ``first_search="incremental"``, where no search has reached yet)."""
        return self._unpad(self._g)

    @property
    def rhs(self) -> FloatArray:
        """Current one-step look-ahead values ``rhs``, 2-D."""
        return self._unpad(self._rhs)

    # -- the algorithm -------------------------------------------------------------------------

    def _best_rhs(self, s: int) -> float:
        """``min over s' in Succ(s) of c(s, s') + g(s')`` ({21}, {28}, {39})."""
        cost = self._cost
        g = self._g
        cs = cost[s]
        if cs == _INF:
            return _INF
        best = _INF
        for off, half in self._ortho:
            v = s + off
            cv = cost[v]
            if cv != _INF:
                val = (cs + cv) * half + g[v]
                if val < best:
                    best = val
        for off, half, oa, ob in self._diag:
            v = s + off
            cv = cost[v]
            if cv != _INF and cost[s + oa] != _INF and cost[s + ob] != _INF:
                val = (cs + cv) * half + g[v]
                if val < best:
                    best = val
        return best

    def compute_shortest_path(self) -> None:
        """{10}-{28}: expand vertices until the start is consistent and no queued key is lower
        than the start's. Cheap when nothing changed (one key comparison)."""
        heap = self._heap
        entry = self._entry
        g = self._g
        rhs = self._rhs
        cost = self._cost
        w2 = self._width2
        goal = self._goal
        start = self._start
        sr, sc = divmod(start, w2)
        km = self._km
        ortho = self._ortho
        diag = self._diag
        heappop = heapq.heappop
        heappush = heapq.heappush
        inf = _INF
        octile = _OCTILE

        def top() -> Key | None:
            while heap:
                e = heap[0]
                if entry[e[2]] is e:
                    return e
                heappop(heap)
            return None

        while True:
            e = top()
            # {10}: U.TopKey() < CalculateKey(s_start) OR rhs(s_start) > g(s_start)
            gs = g[start]
            rs = rhs[start]
            m = rs if rs < gs else gs
            # An empty U ends the search too: an inconsistent start would be queued.
            if e is None or not ((e[0], e[1]) < (round(m + km, _KEY_DECIMALS), m) or rs > gs):
                break
            u = e[2]
            k_old1, k_old2 = e[0], e[1]
            gu = g[u]
            ru = rhs[u]
            m = ru if ru < gu else gu
            ur, uc = divmod(u, w2)
            dr = ur - sr if ur > sr else sr - ur
            dc = uc - sc if uc > sc else sc - uc
            k_new1 = round(m + (dr + octile * dc if dr > dc else dc + octile * dr) + km,
                           _KEY_DECIMALS)
            if (k_old1, k_old2) < (k_new1, m):
                # {14}-{15} U.Update(u, k_new)
                ne = (k_new1, m, u)
                entry[u] = ne
                heappush(heap, ne)
                continue
            # U.Remove(u)
            heappop(heap)
            entry[u] = None
            self._live -= 1
            cu = cost[u]
            if gu > ru:
                # {16}-{20}: overconsistent, settle g(u) and relax its predecessors.
                g[u] = ru
                if cu == inf:
                    continue
                for off, half in ortho:
                    s = u + off
                    cv = cost[s]
                    if cv == inf or s == goal:
                        continue
                    val = (cu + cv) * half + ru
                    if val < rhs[s]:
                        rhs[s] = val
                        self._update_vertex(s)
                for off, half, oa, ob in diag:
                    s = u + off
                    cv = cost[s]
                    if cv == inf or s == goal or cost[u + oa] == inf or cost[u + ob] == inf:
                        continue
                    val = (cu + cv) * half + ru
                    if val < rhs[s]:
                        rhs[s] = val
                        self._update_vertex(s)
            else:
                # {21}-{28}: underconsistent, raise g(u) to inf and repair those that used it.
                g_old = gu
                g[u] = inf
                if cu != inf:
                    for off, half in ortho:
                        s = u + off
                        cv = cost[s]
                        if cv == inf or s == goal:
                            continue
                        if rhs[s] == (cu + cv) * half + g_old:
                            rhs[s] = self._best_rhs(s)
                            self._update_vertex(s)
                    for off, half, oa, ob in diag:
                        s = u + off
                        cv = cost[s]
                        if (cv == inf or s == goal or cost[u + oa] == inf
                                or cost[u + ob] == inf):
                            continue
                        if rhs[s] == (cu + cv) * half + g_old:
                            rhs[s] = self._best_rhs(s)
                            self._update_vertex(s)
                self._update_vertex(u)  # u in Pred(u) U {u}: its rhs is unchanged, g is not
        # Lazy deletion leaves stale entries behind: compact when they dominate the heap.
        if len(heap) > 4 * self._live + 1024:
            self._heap = [x for x in heap if entry[x[2]] is x]
            heapq.heapify(self._heap)

    def _update_vertex(self, u: int) -> None:
        """{07}-{09}: (re)queue ``u`` with its current key if inconsistent, else dequeue it."""
        gu = self._g[u]
        ru = self._rhs[u]
        if gu != ru:
            m = ru if ru < gu else gu
            self._push(u, round(m + self._h(self._start, u) + self._km, _KEY_DECIMALS), m)
        elif self._entry[u] is not None:
            self._entry[u] = None
            self._live -= 1

    def plan(self) -> float:
        """Run :meth:`compute_shortest_path` and return the start's cost to the goal.

        NoPath if the goal cannot be reached; the planner stays usable (cells may free later).
        """
        self.compute_shortest_path()
        cost = self._rhs[self._start]
        if cost == _INF:
            raise NoPath(f"no path from {self.start} to {self.goal}")
        return cost

    def cost(self) -> float:
        """The start's cost to the goal after planning; ``inf`` if no path (this one does not
        raise, so that a caller can test for it).

        It is ``rhs(s_start)``, not ``g(s_start)``: the optimised loop {10} stops as soon as the
        start is not underconsistent, so after an incremental search ``g(s_start)`` may still be
        ``inf`` while ``rhs(s_start)``, one step of look-ahead over settled successors, is
        exact."""
        self.compute_shortest_path()
        return self._rhs[self._start]

    def path(self) -> IntArray:
        """The cells from start to goal, an (N, 2) int array of ``(row, col)``; NoPath if none.

        Follows ``argmin c(s, s') + g(s')`` from the start, which after
        :meth:`compute_shortest_path` is a shortest path (every step strictly lowers ``g``
        since moves cost at least 1, so the walk cannot loop).
        """
        total = self.plan()
        cost = self._cost
        g = self._g
        s = self._start
        goal = self._goal
        cells = [s]
        limit = len(cost)
        while s != goal:
            cs = cost[s]
            best = _INF
            nxt = -1
            for off, half in self._ortho:
                v = s + off
                cv = cost[v]
                if cv != _INF:
                    val = (cs + cv) * half + g[v]
                    if val < best:
                        best, nxt = val, v
            for off, half, oa, ob in self._diag:
                v = s + off
                cv = cost[v]
                if cv != _INF and cost[s + oa] != _INF and cost[s + ob] != _INF:
                    val = (cs + cv) * half + g[v]
                    if val < best:
                        best, nxt = val, v
            if nxt < 0 or len(cells) > limit:  # pragma: no cover - would be a planner bug
                raise RuntimeError(f"path extraction failed at {self._cell(s)} (cost {total})")
            s = nxt
            cells.append(s)
        ids = np.array(cells, dtype=np.int64)
        return np.stack([ids // self._width2 - 1, ids % self._width2 - 1], axis=1)

    def move_to(self, cell: Sequence[int] | npt.ArrayLike) -> None:
        """The robot is now at ``cell`` (any free cell, usually the next one of :meth:`path`).

        {32}-{34}: ``k_m += h(s_last, s_start)`` so that queued keys remain lower bounds;
        nothing is searched until the next :meth:`plan`.
        """
        u = self._free_id("start", cell)
        self._km += self._h(self._last, u)
        self._start = self._last = u

    def update_cells(self, cells: npt.ArrayLike, new_costs: npt.ArrayLike) -> None:
        """Change the cost of ``cells`` ((N, 2) ``(row, col)``) to ``new_costs`` (scalar or (N,);
        ``inf`` = occupied, else ``>= 1``); the next :meth:`plan` repairs the path.

        Any cell may change, including the robot's or the goal's (the plan then has no path
        until it is freed). With the mean-cost convention a cell's change alters only moves
        within its 3 x 3 block, so {35}-{40} reduces to recomputing ``rhs`` of those vertices
        from their successors and requeuing them: the same result as the optimised
        comparison with ``c_old``, and no more than 9 vertices x 8 moves per changed cell.
        """
        array = np.asarray(cells)
        if array.ndim == 1 and array.shape == (2,):
            array = array[None, :]
        if array.ndim != 2 or array.shape[1] != 2 or not (
                np.issubdtype(array.dtype, np.integer) or array.size == 0):
            raise PlanningValueError(f"cells must be an (N, 2) integer array, got {cells!r}")
        idx = array.astype(np.int64)
        values = np.broadcast_to(np.asarray(new_costs, dtype=np.float64), (len(idx),))
        height, width = self._shape
        outside = ~((idx[:, 0] >= 0) & (idx[:, 0] < height) & (idx[:, 1] >= 0)
                    & (idx[:, 1] < width))
        if np.any(outside):
            r, c = idx[outside][0]
            raise PlanningValueError(f"cell {(int(r), int(c))} is outside the {height} x {width} "
                                     "grid")
        bad = ~((values >= 1.0) & (np.isfinite(values) | (values == np.inf)))
        if np.any(bad):
            raise PlanningValueError("cell costs must be >= 1 or +inf (occupied), got "
                                     f"{float(values[bad][0])!r} for cell "
                                     f"{tuple(idx[bad][0].tolist())}")
        ids = (idx[:, 0] + 1) * self._width2 + (idx[:, 1] + 1)
        cost = self._cost
        changed = [int(u) for u, v in zip(ids.tolist(), values.tolist(), strict=True)
                   if cost[u] != v]
        for u, v in zip(ids.tolist(), values.tolist(), strict=True):
            cost[u] = v  # the last value wins for a cell listed twice
        if not changed:
            return
        w2 = self._width2
        block = np.array([dr * w2 + dc for dr in (-1, 0, 1) for dc in (-1, 0, 1)])
        affected = np.unique((np.array(changed)[:, None] + block[None, :]).ravel())
        rows = affected // w2
        cols = affected % w2
        affected = affected[(rows >= 1) & (rows <= height) & (cols >= 1) & (cols <= width)]
        goal = self._goal
        for u in affected.tolist():
            if u != goal:
                self._rhs[u] = self._best_rhs(u)
            self._update_vertex(u)
