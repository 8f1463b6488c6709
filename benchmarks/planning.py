"""What D* Lite's incremental repair buys over planning from scratch (issue 18).

On square grids of 200², 500² and 1000² cells with 20 % of the cells occupied at random
(seeded; every other cell costs 1; the start ``MARGIN`` cells in from the top-left corner and
the goal as far in from the bottom-right one, a grid re-drawn until a path joins them), for
:class:`servolab.planning.dstar_lite.DStarLite`:

- **first plan**: the planner built and its first search (``DStarLite(...)`` + ``plan()``),
  against a from-scratch A* of our own (:func:`servolab.planning.astar.astar`, pure Python
  like D* Lite, octile heuristic) and scipy's Dijkstra (``scipy.sparse.csgraph.dijkstra`` from
  the start over :func:`servolab.planning.grid.adjacency`, one source, no early exit: scipy
  has none for a single target);
- **repair after k changes near the robot** (k = 1, 10, 50): the robot first moves
  ``MOVED`` cells along its path (``move_to`` + ``plan`` each); then k free cells within
  ``RADIUS`` cells (Chebyshev) of its position become occupied, of which some lie on its
  current path ahead (1 of 1, 3 of 10, 5 of 50: the changes must matter); the repair is
  ``update_cells`` + ``plan`` (both timed), against A* and Dijkstra from the robot's cell on
  the same changed grid. Dijkstra is given twice: the search alone (the graph already built,
  the most favourable to scipy) and including ``adjacency`` (building the CSR graph of the
  changed grid, which a from-scratch planner has to do when cells change). The changes are
  then undone (an untimed repair) before the next k, so every k starts from the same plan; a
  draw of cells that cuts every path is drawn again.

All three costs are checked equal (the run fails otherwise). Each time is the best of
``REPEATS`` (apply, time, undo for the repair). Ratios are the from-scratch time over the
repair's; the goal, a repair at least 10x faster than *any* from-scratch search, is judged
against the fastest of the three (usually Dijkstra's search alone) and printed per grid and k.

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
from servolab.planning.dstar_lite import DStarLite
from servolab.planning.grid import adjacency

FULL_SIZES = (200, 500, 1000)
QUICK_SIZES = (60, 120)
OBSTACLES = 0.2
SEED = 18
KS = (1, 10, 50)
ON_PATH = {1: 1, 10: 3, 50: 5}
MOVED = 5       # cells the robot moves along its path before the changes
RADIUS = 6      # changes within this many cells (Chebyshev) of the robot
REPEATS = 3
MARGIN = 15     # start and goal this many cells in from opposite corners
GOAL_RATIO = 10.0

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


def bench_grid(size: int, seed: int) -> dict[str, Any]:
    costs, start, goal = make_grid(size, seed)
    # first plan
    first_s = math.inf
    planner: DStarLite | None = None
    first_cost = math.inf
    for _ in range(REPEATS):
        def build() -> tuple[DStarLite, float]:
            p = DStarLite(costs, start, goal)
            return p, p.plan()
        t, (planner, first_cost) = timed(build)
        first_s = min(first_s, t)
    assert planner is not None
    base = scratch(costs, start, goal)
    _same(f"{size}² first plan", first_cost, base["astar_cost"], base["dijkstra_cost"])
    first = {"dstar_s": first_s, "astar_s": base["astar_s"], "dijkstra_s": base["dijkstra_s"],
             "dijkstra_with_build_s": base["dijkstra_with_build_s"],
             "ratio_dstar_astar": first_s / base["astar_s"],
             "ratio_dstar_dijkstra": first_s / base["dijkstra_s"],
             "ratio_dstar_dijkstra_with_build": first_s / base["dijkstra_with_build_s"],
             "cost": first_cost}
    # the robot moves along its path
    path = planner.path()
    for cell in path[1:MOVED + 1]:
        planner.move_to(cell)
        planner.plan()
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
        repair_s = math.inf
        repair_cost = math.inf
        for _ in range(REPEATS):
            def repair(p: DStarLite = planner, changes: np.ndarray = cells) -> float:
                p.update_cells(changes, np.inf)
                return p.plan()
            t, repair_cost = timed(repair)
            repair_s = min(repair_s, t)
            planner.update_cells(cells, 1.0)  # undo, untimed
            planner.plan()
        fresh = scratch(changed, robot, goal)
        _same(f"{size}² k={k}", repair_cost, fresh["astar_cost"], fresh["dijkstra_cost"])
        fastest = min(fresh["astar_s"], fresh["dijkstra_s"])
        repairs.append({
            "k": k, "on_path": ON_PATH[k], "cost": repair_cost, "repair_s": repair_s,
            "astar_s": fresh["astar_s"], "dijkstra_s": fresh["dijkstra_s"],
            "dijkstra_with_build_s": fresh["dijkstra_with_build_s"],
            "ratio_astar_repair": fresh["astar_s"] / repair_s,
            "ratio_dijkstra_repair": fresh["dijkstra_s"] / repair_s,
            "ratio_dijkstra_with_build_repair": fresh["dijkstra_with_build_s"] / repair_s,
            "ratio_fastest_repair": fastest / repair_s,
            "goal_met": fastest / repair_s >= GOAL_RATIO,
        })
    return {"size": size, "start": list(start), "goal": list(goal), "robot": list(robot),
            "occupied_share": float(np.mean(np.isinf(costs))), "first": first,
            "repairs": repairs}


def _ms(seconds: float) -> str:
    return f"{seconds * 1e3:9.2f} ms"


def report(grids: Sequence[dict[str, Any]]) -> tuple[list[str], list[str]]:
    lines = [f"D* Lite vs from-scratch A* (ours) and scipy Dijkstra; 20 % obstacles, best "
             f"of {REPEATS}; ratio = from-scratch time / D* Lite's time",
             "(Dijkstra: search alone; '+build' includes building the CSR graph)"]
    goals = []
    for g in grids:
        n, f = g["size"], g["first"]
        lines.append(f"\n{n}² grid, start {tuple(g['start'])} goal {tuple(g['goal'])}, "
                     f"path cost {f['cost']:.1f}")
        lines.append(f"  first plan: D* Lite {_ms(f['dstar_s'])} | A* {_ms(f['astar_s'])} | "
                     f"Dijkstra {_ms(f['dijkstra_s'])} (+build "
                     f"{_ms(f['dijkstra_with_build_s'])}) | D* Lite / A* = "
                     f"{f['ratio_dstar_astar']:.2f}, D* Lite / Dijkstra = "
                     f"{f['ratio_dstar_dijkstra']:.2f}")
        for r in g["repairs"]:
            lines.append(
                f"  repair k={r['k']:<2} (robot at {tuple(g['robot'])}, {r['on_path']} on the "
                f"path): {_ms(r['repair_s'])} | A* {_ms(r['astar_s'])} "
                f"x{r['ratio_astar_repair']:.1f} | Dijkstra {_ms(r['dijkstra_s'])} "
                f"x{r['ratio_dijkstra_repair']:.1f} "
                f"(+build x{r['ratio_dijkstra_with_build_repair']:.1f})")
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
                   "moved": MOVED, "radius": RADIUS, "repeats": REPEATS, "grids": grids,
                   "goals": goals, "elapsed_s": elapsed}
        Path(args.json).write_text(json.dumps(figures, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
