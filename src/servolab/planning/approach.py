"""Will the local planner arrive? A dry run of DWA's last metre on a map, before the robot moves.

dwa_local_planner scores a trajectory's obstacle cost (``occdist_scale`` x the highest costmap
cost along it) against its progress (``goal_distance_bias`` per cell nearer the goal). A goal
inside the inflated band of an obstacle is pulled at less strongly than the band pushes back:
with seed 000's D.3 (``occdist_scale`` 0.8, every forward trajectory at least ``min_trans_vel``
for ``sim_time`` + ``stop_time_buffer``), a goal 0.3 m from a wall is never approached closer
than about ``xy_goal_tolerance`` + 2 cm, and move_base gives it up as oscillating ten seconds
later. The cost at the goal alone does not tell (goals of cost 44 and of 81 both stall, one of
27 does not), so this module asks DWA itself.

:func:`dry_run` plays the controller on a fixed map and plan with ideal wheels: each cycle the
robot moves exactly along the chosen arc for one controller period, and its velocity is the
command. Everything else is the real thing: :func:`~servolab.planning.dwa.compute_velocity`
with the oscillation flags and the goal latch kept between cycles. It starts on the plan a
given pose (the robot's, before it drives) or a given distance before the goal, facing along
the plan, at rest, and stops at the first of:
the goal reached, no valid trajectory, or no progress (``stall_time`` without getting
``stall_distance`` closer). Real wheels lag their commands, so the dry run is a prediction,
not a proof; its use is to refuse, before driving, goals DWA cannot settle on.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .dwa import DwaConfig, DwaStatus, GoalLatch, OscillationFlags, compute_velocity, simulate
from .errors import PlanningValueError

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class DryRun:
    """How the dry run ended: ``status`` (``"reached"``, ``"stalled"``, ``"no valid
    trajectory"``, ``"timed out"``), the pose it ended at, the distance left to the goal (m),
    the costmap cost of the cell it ended on, and the simulated seconds it took."""

    status: str
    pose: tuple[float, float, float]
    distance: float
    cost: int
    seconds: float

    @property
    def reached(self) -> bool:
        return self.status == "reached"


def start_on_plan(plan: FloatArray, before: float) -> tuple[float, float, float]:
    """The plan's point ``before`` m (along the plan) short of its end, facing along the plan
    there; the plan's first point when it is shorter."""
    steps = np.hypot(*np.diff(plan, axis=0).T)
    left = np.concatenate((np.cumsum(steps[::-1])[::-1], [0.0]))  # length to the end
    k = int(np.argmax(left <= before)) if np.any(left <= before) else len(plan) - 1
    k = max(0, k - 1) if left[k] < before and k > 0 else k
    ahead = min(k + 3, len(plan) - 1)
    if ahead == k:
        yaw = 0.0 if k == 0 else math.atan2(*(plan[k] - plan[k - 1])[::-1])
    else:
        yaw = math.atan2(*(plan[ahead] - plan[k])[::-1])
    return float(plan[k, 0]), float(plan[k, 1]), yaw


def dry_run(costmap: npt.ArrayLike, plan: npt.ArrayLike, config: DwaConfig, *,
            resolution: float, origin: Sequence[float] = (0.0, 0.0),
            goal_yaw: float | None = None, start: Sequence[float] | None = None,
            before: float = 1.0, stall_time: float = 5.0, stall_distance: float = 0.02,
            max_time: float = 60.0,
            footprint: npt.ArrayLike | None = None) -> DryRun:
    """Play DWA (see the module docstring) from ``start`` ``(x, y, yaw)``, or from the plan's
    point ``before`` m short of its end, until it ends; ``footprint`` as DWA takes it."""
    path = np.asarray(plan, dtype=np.float64)
    if path.ndim != 2 or path.shape[1] != 2 or len(path) == 0:
        raise PlanningValueError(f"plan must be (M, 2) points, not shape {path.shape}")
    grid = np.asarray(costmap)
    for name, value in (("before", before), ("stall_time", stall_time),
                        ("stall_distance", stall_distance), ("max_time", max_time)):
        if not (math.isfinite(value) and value > 0):
            raise PlanningValueError(f"dry_run: {name} must be > 0, not {value!r}")
    x, y, yaw = start_on_plan(path, before) if start is None else (float(v) for v in start)
    goal = path[-1]
    v = omega = 0.0
    period = config.sim_period
    oscillation, latch = OscillationFlags(), GoalLatch()
    t, best, best_at = 0.0, math.inf, 0.0

    def ended(status: str) -> DryRun:
        col = math.floor((x - origin[0]) / resolution)
        row = math.floor((y - origin[1]) / resolution)
        inside = 0 <= row < grid.shape[0] and 0 <= col < grid.shape[1]
        return DryRun(status, (x, y, yaw), math.hypot(goal[0] - x, goal[1] - y),
                      int(grid[row, col]) if inside else -1, t)

    while t < max_time:
        result = compute_velocity((x, y, yaw), (v, omega), grid, path, config,
                                  resolution=resolution, origin=origin, goal_yaw=goal_yaw,
                                  oscillation=oscillation, latch=latch, footprint=footprint)
        if result.status is DwaStatus.GOAL_REACHED:
            return ended("reached")
        if result.status is DwaStatus.NO_VALID_TRAJECTORY:
            return ended("no valid trajectory")
        v, omega = result.v, result.omega
        moved = simulate((x, y, yaw), np.array([v]), np.array([omega]), period, 1)[0, -1]
        x, y, yaw = (float(c) for c in moved)
        t += period
        distance = math.hypot(goal[0] - x, goal[1] - y)
        if distance < best - stall_distance or result.status is DwaStatus.ROTATING:
            best, best_at = min(best, distance), t
        elif t - best_at >= stall_time:
            return ended("stalled")
    return ended("timed out")
