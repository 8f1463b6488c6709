"""D* Lite's first plan against a compiled search (issue 30), and what its incremental repair
buys over planning from scratch (issue 18).

On square grids of 200², 500² and 1000² cells with 20 % of the cells occupied at random
(seeded; every other cell costs 1; the start ``MARGIN`` cells in from the top-left corner and
the goal as far in from the bottom-right one, a grid re-drawn until a path joins them), for
:class:`servolab.planning.dstar_lite.DStarLite`:

- **first plan**: the planner built and its first search (``DStarLite(...)`` + ``plan()``),
  which since issue 30 is one compiled backward Dijkstra from the goal labelling every cell
  (``first_search="compiled"``, the default), against the anchor measured in the same run:
  scipy's Dijkstra (``scipy.sparse.csgraph.dijkstra`` from the start over
  :func:`servolab.planning.grid.adjacency`, one source, no early exit: scipy has none for a
  single target), its search alone and with ``adjacency`` building its CSR graph. Printed as
  ratios D* Lite / Dijkstra, both; the goal is D* Lite / (Dijkstra with its graph built)
  ``<= FIRST_GOAL`` (1.5) on 1000². Beside them, for scale: D* Lite's own incremental first
  search (``first_search="incremental"``, the first plan before issue 30), our from-scratch
  A* (:func:`servolab.planning.astar.astar`, pure Python, octile heuristic), and Dijkstra
  over the planner's faster graph builder (:func:`servolab.planning.grid.padded_adjacency`),
  the strictest anchor. Each is the best of ``FIRST_REPEATS`` (the first calls on 1000² run
  cold), the timings of one repeat interleaved so that a load on the machine weighs on all
  alike. The anchor searches from the start, D* Lite from the goal; scipy's Dijkstra is
  slower from a source in the grid's right-hand columns than its left-hand ones (the same
  graph, the same cells reached), so the goal at the bottom right costs D* Lite's search
  more than the start at the top left costs the anchor's;
- **repair after k changes near the robot** (k = 1, 10, 50): the robot first moves
  ``MOVED`` cells along its path (``move_to`` + ``plan`` each); then k free cells within
  ``RADIUS`` cells (Chebyshev) of its position become occupied, of which some lie on its
  current path ahead (1 of 1, 3 of 10, 5 of 50: the changes must matter); the repair is
  ``update_cells`` + ``plan`` (both timed), against A* and Dijkstra from the robot's cell on
  the same changed grid. Dijkstra is given twice: the search alone (the graph already built,
  the most favourable to scipy) and including ``adjacency`` (building the CSR graph of the
  changed grid, which a from-scratch planner has to do when cells change). The changes are
  then undone (an untimed repair) before the next k, so every k starts from the same plan; a
  draw of cells that cuts every path is drawn again. The same moves and changes are repaired
  by a planner whose first search was the incremental one, timed alike: the repair before
  issue 30. Its best of ``REPEATS`` is the same work as the compiled planner's; its *first*
  application is printed too, because there it is not: a detour leads the incremental
  planner into cells its first search left unexpanded, which the compiled one has labelled.

All costs are checked equal (the run fails otherwise). Each repair time is the best of
``REPEATS`` (apply, time, undo). Repair ratios are the from-scratch time over the repair's;
their goal, a repair at least 10x faster than *any* from-scratch search, is judged against the
fastest of them (usually Dijkstra's search alone) and printed per grid and k.

Run: ``.venv/bin/python benchmarks/planning.py [--quick] [--json PATH]``. ``--quick`` runs
60² and 120² grids only (seconds); the full run takes well under two minutes.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
from scipy.sparse.csgraph import dijkstra  # type: ignore[import-untyped]

from servolab.planning.astar import astar
from servolab.planning.dstar_lite import DStarLite, FirstSearch
from servolab.planning.grid import adjacency, padded_adjacency

FULL_SIZES = (200, 500, 1000)
QUICK_SIZES = (60, 120)
OBSTACLES = 0.2
SEED = 18
KS = (1, 10, 50)
ON_PATH = {1: 1, 10: 3, 50: 5}
MOVED = 5       # cells the robot moves along its path before the changes
RADIUS = 6      # changes within this many cells (Chebyshev) of the robot
REPEATS = 3
FIRST_REPEATS = 5  # the first plan's: its first calls on 1000² run cold (up to 2x slower)
MARGIN = 15     # start and goal this many cells in from opposite corners
GOAL_RATIO = 10.0
FIRST_GOAL = 1.5  # D* Lite's first plan / (scipy's Dijkstra + building its graph), at most
FIRST_GOAL_SIZE = 1000  # ... on this grid (issue 30)

T = TypeVar("T")
Cell = tuple[int, int]


def timed(work: Callable[[], T]) -> tuple[float, T]:
    t0 = time.perf_counter()
    result = work()
    return time.perf_counter() - t0, result


def make_grid(size: int, seed: int) -> tuple[np.ndarray, Cell, Cell]:
    """A size² grid, 20 % occupied, with a path from near one corner to the opposite one."""
    rng = np.random.default_rng(seed)
    start, goal = (MARGIN, MARGIN), (size - 1 - MARGIN, size - 1 - MARGIN)
    for _ in range(100):
        costs = np.ones((size, size))
        costs[rng.random((size, size)) < OBSTACLES] = np.inf
        costs[start] = costs[goal] = 1.0
        if math.isfinite(astar(costs, start, goal)[0]):
            return costs, start, goal
    raise RuntimeError(f"no {size}² grid with a path in 100 draws")  # pragma: no cover


def scratch(costs: np.ndarray, start: Cell, goal: Cell) -> dict[str, float]:
    """A* and Dijkstra from scratch on ``costs``: best times of REPEATS, and the costs."""
    width = costs.shape[1]
    astar_s, dijkstra_s, build_s = math.inf, math.inf, math.inf
    astar_cost = dijkstra_cost = math.inf
    for _ in range(REPEATS):
        t, (astar_cost, _path) = timed(lambda: astar(costs, start, goal))
        astar_s = min(astar_s, t)
        t_build, graph = timed(lambda: adjacency(costs))
        t, dist = timed(lambda g=graph: dijkstra(g, indices=start[0] * width + start[1]))
        dijkstra_s, build_s = min(dijkstra_s, t), min(build_s, t_build)
        dijkstra_cost = float(dist[goal[0] * width + goal[1]])
    return {"astar_s": astar_s, "dijkstra_s": dijkstra_s, "dijkstra_build_s": build_s,
            "dijkstra_with_build_s": dijkstra_s + build_s, "astar_cost": astar_cost,
            "dijkstra_cost": dijkstra_cost}


def _same(name: str, *costs: float) -> None:
    if not all(math.isclose(c, costs[0], rel_tol=1e-9) for c in costs):
        raise RuntimeError(f"{name}: the planners disagree on the cost: {costs}")


def pick_changes(rng: np.random.Generator, costs: np.ndarray, robot: Cell, goal: Cell,
                 path: np.ndarray, k: int) -> np.ndarray:
    """k free cells within RADIUS of the robot, ON_PATH[k] of them on its path ahead."""
    r0, c0 = robot
    near = [(int(r), int(c)) for r, c in path[1:].tolist()
            if max(abs(r - r0), abs(c - c0)) <= RADIUS and (r, c) != goal][1:]
    on_path = near[:ON_PATH[k]]  # the path's cells ahead, skipping the very next one
    rows, cols = np.mgrid[max(0, r0 - RADIUS):r0 + RADIUS + 1,
                          max(0, c0 - RADIUS):c0 + RADIUS + 1]
    rows, cols = rows.ravel(), cols.ravel()
    keep = (rows < costs.shape[0]) & (cols < costs.shape[1])
    rows, cols = rows[keep], cols[keep]
    free = np.isfinite(costs[rows, cols])
    taken = set(on_path) | {robot, goal}
    others = [(int(r), int(c)) for r, c in zip(rows[free], cols[free], strict=True)
              if (int(r), int(c)) not in taken]
    chosen = [others[i] for i in rng.permutation(len(others))[:k - len(on_path)]]
    return np.array(on_path + chosen, dtype=np.int64).reshape(-1, 2)


def first_plan(costs: np.ndarray, start: Cell, goal: Cell
               ) -> tuple[dict[str, float], dict[FirstSearch, DStarLite]]:
    """The first plan's figures (best of FIRST_REPEATS, interleaved) and the two planners
    built."""
    width = costs.shape[1]
    source = start[0] * width + start[1]
    best = dict.fromkeys(("dstar_s", "dstar_incremental_s", "astar_s", "dijkstra_s",
                          "dijkstra_build_s", "fast_build_s"), math.inf)
    planners: dict[FirstSearch, DStarLite] = {}
    found: dict[str, float] = {}

    def plan(kind: FirstSearch) -> tuple[DStarLite, float]:
        p = DStarLite(costs, start, goal, first_search=kind)
        return p, p.plan()

    def padded_build() -> object:
        padded = np.full((costs.shape[0] + 2, width + 2), np.inf)
        padded[1:-1, 1:-1] = costs
        return padded_adjacency(padded)

    for _ in range(FIRST_REPEATS):
        for key, kind in (("dstar_s", "compiled"), ("dstar_incremental_s", "incremental")):
            t, (planners[kind], found[key]) = timed(lambda k=kind: plan(k))
            best[key] = min(best[key], t)
        t, (found["astar_s"], _path) = timed(lambda: astar(costs, start, goal))
        best["astar_s"] = min(best["astar_s"], t)
        t, graph = timed(lambda: adjacency(costs))
        best["dijkstra_build_s"] = min(best["dijkstra_build_s"], t)
        t, dist = timed(lambda g=graph: dijkstra(g, indices=source))
        best["dijkstra_s"] = min(best["dijkstra_s"], t)
        found["dijkstra_s"] = float(dist[goal[0] * width + goal[1]])
        t, _graph = timed(padded_build)
        best["fast_build_s"] = min(best["fast_build_s"], t)
    _same("first plan", *found.values())
    dstar = best["dstar_s"]
    with_build = best["dijkstra_s"] + best["dijkstra_build_s"]
    with_fast_build = best["dijkstra_s"] + best["fast_build_s"]
    return {**best, "dijkstra_with_build_s": with_build,
            "dijkstra_with_fast_build_s": with_fast_build,
            "ratio_dstar_astar": dstar / best["astar_s"],
            "ratio_dstar_dijkstra": dstar / best["dijkstra_s"],
            "ratio_dstar_dijkstra_with_build": dstar / with_build,
            "ratio_dstar_dijkstra_with_fast_build": dstar / with_fast_build,
            "ratio_incremental_dijkstra_with_build": best["dstar_incremental_s"] / with_build,
            "speedup_over_incremental": best["dstar_incremental_s"] / dstar,
            "goal_met": dstar / with_build <= FIRST_GOAL,
            "cost": found["dstar_s"]}, planners


def bench_grid(size: int, seed: int) -> dict[str, Any]:
    costs, start, goal = make_grid(size, seed)
    first, planners = first_plan(costs, start, goal)
    planner, before = planners["compiled"], planners["incremental"]
    # the robot moves along its path
    path = planner.path()
    for cell in path[1:MOVED + 1]:
        for p in (planner, before):
            p.move_to(cell)
            p.plan()
    robot = planner.start
    path = planner.path()
    rng = np.random.default_rng(seed + 1)
    repairs = []
    for k in KS:
        for _ in range(50):
            cells = pick_changes(rng, costs, robot, goal, path, k)
            changed = costs.copy()
            changed[cells[:, 0], cells[:, 1]] = np.inf
            if math.isfinite(astar(changed, robot, goal)[0]):
                break
        else:  # pragma: no cover
            raise RuntimeError(f"{size}²: every draw of {k} changes cuts the robot off")
        repair_s = {"compiled": math.inf, "incremental": math.inf}
        first_s: dict[str, float] = {}
        repair_cost = {"compiled": math.inf, "incremental": math.inf}
        for _ in range(REPEATS):
            for kind, p in (("compiled", planner), ("incremental", before)):
                def repair(p: DStarLite = p, changes: np.ndarray = cells) -> float:
                    p.update_cells(changes, np.inf)
                    return p.plan()
                t, repair_cost[kind] = timed(repair)
                repair_s[kind] = min(repair_s[kind], t)
                first_s.setdefault(kind, t)
                p.update_cells(cells, 1.0)  # undo, untimed
                p.plan()
        fresh = scratch(changed, robot, goal)
        _same(f"{size}² k={k}", *repair_cost.values(), fresh["astar_cost"],
              fresh["dijkstra_cost"])
        fastest = min(fresh["astar_s"], fresh["dijkstra_s"])
        repairs.append({
            "k": k, "on_path": ON_PATH[k], "cost": repair_cost["compiled"],
            "repair_s": repair_s["compiled"],
            "repair_incremental_init_s": repair_s["incremental"],
            "repair_first_s": first_s["compiled"],
            "repair_incremental_init_first_s": first_s["incremental"],
            "astar_s": fresh["astar_s"], "dijkstra_s": fresh["dijkstra_s"],
            "dijkstra_with_build_s": fresh["dijkstra_with_build_s"],
            "ratio_astar_repair": fresh["astar_s"] / repair_s["compiled"],
            "ratio_dijkstra_repair": fresh["dijkstra_s"] / repair_s["compiled"],
            "ratio_dijkstra_with_build_repair": (fresh["dijkstra_with_build_s"]
                                                 / repair_s["compiled"]),
            "ratio_fastest_repair": fastest / repair_s["compiled"],
            "ratio_incremental_init_repair": repair_s["incremental"] / repair_s["compiled"],
            "goal_met": fastest / repair_s["compiled"] >= GOAL_RATIO,
        })
    return {"size": size, "start": list(start), "goal": list(goal), "robot": list(robot),
            "occupied_share": float(np.mean(np.isinf(costs))), "first": first,
            "repairs": repairs}


def _ms(seconds: float) -> str:
    return f"{seconds * 1e3:9.2f} ms"


def report(grids: Sequence[dict[str, Any]]) -> tuple[list[str], list[str]]:
    lines = [f"D* Lite vs from-scratch A* (ours) and scipy Dijkstra; 20 % obstacles, best of "
             f"{FIRST_REPEATS} (first plan) or {REPEATS} (repairs)",
             "first plan: ratio = D* Lite's time / the anchor's, the anchor scipy's Dijkstra "
             "timed in this run (its search alone, and '+build' with adjacency building its "
             "CSR graph)",
             "repair: ratio = from-scratch time / D* Lite's time"]
    goals = []
    for g in grids:
        n, f = g["size"], g["first"]
        lines.append(f"\n{n}² grid, start {tuple(g['start'])} goal {tuple(g['goal'])}, "
                     f"path cost {f['cost']:.1f}")
        lines.append(
            f"  first plan: D* Lite {_ms(f['dstar_s'])} | Dijkstra {_ms(f['dijkstra_s'])} "
            f"(+build {_ms(f['dijkstra_with_build_s'])}) | D* Lite / Dijkstra = "
            f"{f['ratio_dstar_dijkstra']:.2f}, D* Lite / (Dijkstra+build) = "
            f"{f['ratio_dstar_dijkstra_with_build']:.2f}")
        lines.append(
            f"    for scale: incremental first search (before issue 30) "
            f"{_ms(f['dstar_incremental_s'])}, / (Dijkstra+build) = "
            f"{f['ratio_incremental_dijkstra_with_build']:.2f} (the compiled one "
            f"{f['speedup_over_incremental']:.1f}x faster) | A* {_ms(f['astar_s'])}, D* Lite "
            f"/ A* = {f['ratio_dstar_astar']:.2f} | Dijkstra + padded_adjacency "
            f"{_ms(f['dijkstra_with_fast_build_s'])}, D* Lite / that = "
            f"{f['ratio_dstar_dijkstra_with_fast_build']:.2f}")
        if n == FIRST_GOAL_SIZE:
            verdict = "met" if f["goal_met"] else "NOT met"
            goals.append(f"{verdict}: {n}² first plan: D* Lite "
                         f"{f['ratio_dstar_dijkstra_with_build']:.2f}x scipy's Dijkstra with "
                         f"its graph built (goal <= {FIRST_GOAL}x)")
        for r in g["repairs"]:
            lines.append(
                f"  repair k={r['k']:<2} (robot at {tuple(g['robot'])}, {r['on_path']} on the "
                f"path): {_ms(r['repair_s'])} | A* {_ms(r['astar_s'])} "
                f"x{r['ratio_astar_repair']:.1f} | Dijkstra {_ms(r['dijkstra_s'])} "
                f"x{r['ratio_dijkstra_repair']:.1f} "
                f"(+build x{r['ratio_dijkstra_with_build_repair']:.1f})")
            lines.append(
                f"    after the incremental first search (before issue 30): "
                f"{_ms(r['repair_incremental_init_s'])}; the first of the {REPEATS} "
                f"applications {_ms(r['repair_first_s'])} here, "
                f"{_ms(r['repair_incremental_init_first_s'])} there")
            verdict = "met" if r["goal_met"] else "NOT met"
            goals.append(f"{verdict}: {n}² k={r['k']}: repair {r['ratio_fastest_repair']:.1f}x "
                         f"faster than the fastest from-scratch search (goal 10x)")
    lines.append("\nGoals:")
    lines.extend(f"  {line}" for line in goals)
    return lines, goals


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0] if __doc__ else "")
    parser.add_argument("--quick", action="store_true", help="small grids only (seconds)")
    parser.add_argument("--json", metavar="PATH", help="write the figures as JSON")
    args = parser.parse_args(argv)
    sizes = QUICK_SIZES if args.quick else FULL_SIZES
    t0 = time.perf_counter()
    grids = [bench_grid(n, SEED + n) for n in sizes]
    lines, goals = report(grids)
    print("\n".join(lines))
    elapsed = time.perf_counter() - t0
    print(f"\n(total {elapsed:.1f} s)")
    if args.json:
        figures = {"quick": args.quick, "seed": SEED, "obstacles": OBSTACLES, "ks": list(KS),
                   "first_goal": FIRST_GOAL, "first_goal_size": FIRST_GOAL_SIZE,
                   "moved": MOVED, "radius": RADIUS, "repeats": REPEATS,
                   "first_repeats": FIRST_REPEATS, "grids": grids,
                   "goals": goals, "elapsed_s": elapsed}
        Path(args.json).write_text(json.dumps(figures, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
