"""D* Lite (seed 000, D.1) against scipy's Dijkstra, an independent implementation: the property
of issue 18 -- equal path costs after the first plan and after every step of randomised
sequences of robot moves and cell changes -- plus the path's own validity, checked here without
the planner's or grid.py's move costs.

Issue 30 made the first search a compiled backward Dijkstra (``first_search="compiled"``, the
default, so the tests above run it). The tests at the end check what it must leave behind --
every cell's ``g`` its distance to the goal, ``g == rhs`` everywhere, nothing left to expand --
and that repairs from that state agree, step for step, with a planner whose first search was
D* Lite's own (``first_search="incremental"``)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse.csgraph import dijkstra  # type: ignore[import-untyped]

from servolab.planning.dstar_lite import DStarLite, FirstSearch
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
@pytest.mark.slow
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


# -- issue 30: the compiled first search -------------------------------------------------------


def goal_distances(costs: np.ndarray, goal: tuple[int, int]) -> np.ndarray:
    """Every cell's distance *to* ``goal``: scipy's Dijkstra from the goal over the reversed
    edges (the transpose of adjacency, the COO-built oracle, not the planner's graph)."""
    height, width = costs.shape
    dist = dijkstra(adjacency(costs).T.tocsr(), indices=goal[0] * width + goal[1])
    return np.asarray(dist).reshape(height, width)


def one_step_lookahead(costs: np.ndarray, g: np.ndarray) -> np.ndarray:
    """``min over moves s -> s' of c(s, s') + g(s')`` for every cell, written from the move
    cost's definition (grid.py's docstring), without grid.py: D* Lite's ``rhs``."""
    height, width = costs.shape
    pc = np.full((height + 2, width + 2), np.inf)
    pc[1:-1, 1:-1] = costs
    pg = np.full((height + 2, width + 2), np.inf)
    pg[1:-1, 1:-1] = g
    best = np.full((height, width), np.inf)
    here = pc[1:-1, 1:-1]
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            if not (dr or dc):
                continue
            there = pc[1 + dr:1 + dr + height, 1 + dc:1 + dc + width]
            step = SQRT2 if dr and dc else 1.0
            value = step * (here + there) / 2.0 + pg[1 + dr:1 + dr + height, 1 + dc:1 + dc + width]
            if dr and dc:  # no corner cutting
                corners = (np.isinf(pc[1 + dr:1 + dr + height, 1:-1])
                           | np.isinf(pc[1:-1, 1 + dc:1 + dc + width]))
                value[corners] = np.inf
            value[np.isinf(here) | np.isinf(there)] = np.inf
            best = np.minimum(best, value)
    return best


def next_to(a: tuple[int, int], b: tuple[int, int]) -> bool:
    """``a`` is ``b`` or one of its 8 neighbours (it would lie in ``b``'s enclosing ring)."""
    return max(abs(a[0] - b[0]), abs(a[1] - b[1])) <= 1


def enclose(costs: np.ndarray, cell: tuple[int, int]) -> None:
    """Occupy the ring of 8 cells around ``cell`` (those inside the grid)."""
    r, c = cell
    ring = costs[max(0, r - 1):r + 2, max(0, c - 1):c + 2]
    keep = costs[r, c]
    ring[...] = np.inf
    costs[r, c] = keep


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), height=st.integers(3, 20), width=st.integers(3, 20),
       obstacles=st.sampled_from([0.0, 0.2, 0.45]), walled=st.booleans(),
       goal_enclosed=st.booleans())
def test_compiled_first_search_leaves_every_cell_at_its_goal_distance(
        seed: int, height: int, width: int, obstacles: float, walled: bool,
        goal_enclosed: bool) -> None:
    """After construction every vertex is locally consistent, ``g == rhs``, and ``g`` is the
    goal distance -- which local consistency everywhere implies (Koenig & Likhachev 2002,
    D* Lite, the definitions it takes from Lifelong Planning A*) -- ``inf`` where the goal is
    out of reach: behind a full wall, or everywhere when the goal is enclosed. The queue is
    then empty, so plan() expands nothing: ``g`` is the same before and after it."""
    rng = np.random.default_rng(seed)
    costs = random_grid(rng, height, width, obstacles)
    if walled:  # a full wall: the cells beyond it cannot reach the goal
        costs[:, int(rng.integers(0, width))] = np.inf
    pair = free_pair(rng, costs)
    if pair is None:
        return
    start, goal = pair
    goal_enclosed = goal_enclosed and not next_to(start, goal)
    if goal_enclosed:
        enclose(costs, goal)
    planner = DStarLite(costs, start, goal)
    expected = goal_distances(costs, goal)
    g, rhs = planner.g, planner.rhs
    np.testing.assert_array_equal(np.isinf(g), np.isinf(expected))
    np.testing.assert_allclose(g[np.isfinite(g)], expected[np.isfinite(expected)],
                               rtol=1e-12, atol=1e-9)
    np.testing.assert_array_equal(g, rhs)  # exactly: the queue's bookkeeping compares with ==
    # ... and so must the rhs a repair would recompute (the planner's own {21}-{28} floats) and
    # the one Dijkstra left, or the first update_cells would queue needless 1-ulp repairs.
    ids = [(r + 1) * (width + 2) + c + 1 for r in range(height) for c in range(width)
           if (r, c) != goal]
    assert [planner._best_rhs(u) for u in ids] == [planner._rhs[u] for u in ids]
    lookahead = one_step_lookahead(costs, g)
    lookahead[goal] = 0.0  # rhs(goal) = 0 by definition
    np.testing.assert_allclose(rhs, lookahead, rtol=1e-12, atol=1e-9)
    if goal_enclosed:
        assert np.isinf(g).sum() == g.size - 1  # only the goal itself reaches the goal
    check_against_oracle(planner, costs)
    np.testing.assert_array_equal(planner.g, g)  # plan() had nothing left to expand


def run_lockstep(seed: int, height: int, width: int, steps: int,
                 goal_enclosed: bool) -> None:
    """The same sequence of moves and cell changes on a planner initialised by the compiled
    search and one by D* Lite's own; after every step both agree with each other and with
    Dijkstra (costs, NoPath alike), and both paths are valid and of that cost."""
    rng = np.random.default_rng(seed)
    costs = random_grid(rng, height, width)
    pair = free_pair(rng, costs)
    if pair is None:
        return
    start, goal = pair
    if goal_enclosed and not next_to(start, goal):  # no path at first: repairs must open it
        enclose(costs, goal)
    kinds: tuple[FirstSearch, ...] = ("compiled", "incremental")
    planners = [DStarLite(costs, start, goal, first_search=kind) for kind in kinds]
    for step in range(steps + 1):
        results = [check_against_oracle(p, costs) for p in planners]
        assert results[0] == results[1] or math.isclose(*results, rel_tol=1e-12)
        if step == steps:
            break
        robot = planners[0].start
        if math.isfinite(results[0]) and robot != goal and rng.random() < 0.6:
            path = planners[0].path()
            cell = path[int(rng.integers(1, min(3, len(path) - 1) + 1))]
            for p in planners:
                p.move_to(cell)
            robot = planners[0].start
        k = int(rng.integers(1, 6))
        cells = np.column_stack([rng.integers(0, height, k), rng.integers(0, width, k)])
        if goal_enclosed and rng.random() < 0.5:  # reopen (or re-close) the goal's ring
            r, c = goal
            cells[0] = (min(max(r + int(rng.integers(-1, 2)), 0), height - 1),
                        min(max(c + int(rng.integers(-1, 2)), 0), width - 1))
        draw = rng.random(k)
        values = np.where(draw < 0.35, np.inf, 1.0 + rng.integers(0, 17, k) / 4.0)
        keep = ~(np.all(cells == robot, axis=1) | np.all(cells == goal, axis=1))
        cells, values = cells[keep], values[keep]
        costs[cells[:, 0], cells[:, 1]] = values
        for p in planners:
            p.update_cells(cells, values)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), height=st.integers(4, 16), width=st.integers(4, 16),
       goal_enclosed=st.booleans())
def test_repairs_after_compiled_init_equal_those_after_incremental_init(
        seed: int, height: int, width: int, goal_enclosed: bool) -> None:
    run_lockstep(seed, height, width, steps=12, goal_enclosed=goal_enclosed)


def test_compiled_and_incremental_first_search_agree_on_a_maze_with_unreachable_rooms() -> None:
    """A deterministic case: a walled-off room the goal cannot reach, the start inside it (no
    path), then a door opened: the repair reaches into cells the compiled search left at
    ``inf``."""
    costs = np.ones((12, 14))
    costs[:, 6] = np.inf  # the wall
    costs[2:10, 9] = 2.5  # a costlier band on the goal's side
    planners = [DStarLite(costs, (5, 2), (6, 12), first_search=kind)
                for kind in ("compiled", "incremental")]
    assert np.isinf(planners[0].g[:, :7]).all() and np.isfinite(planners[0].g[:, 7:]).all()
    for p in planners:
        with pytest.raises(NoPath):
            p.plan()
        p.update_cells([[11, 6]], 1.0)  # a door at the bottom of the wall
    costs[11, 6] = 1.0
    expected = oracle(costs, (5, 2), (6, 12))
    assert math.isfinite(expected)
    for p in planners:
        assert check_against_oracle(p, costs) == expected
        p.move_to((6, 3))
    assert planners[0].plan() == pytest.approx(planners[1].plan(), rel=1e-12)
    assert planners[0].plan() == pytest.approx(oracle(costs, (6, 3), (6, 12)), rel=1e-12)


def test_first_search_must_be_named() -> None:
    with pytest.raises(ValueError, match="first_search must be 'compiled' or 'incremental'"):
        DStarLite(np.ones((3, 3)), (0, 0), (2, 2), first_search="dijkstra")  # type: ignore[arg-type]
