"""The dynamic window approach (DWA) for a differential drive, scored as ROS's
dwa_local_planner scores it, with every velocity sample simulated and scored at once in numpy.

What is reproduced, and from where (ros-planning/navigation, Noetic):

* **The window** (base_local_planner ``SimpleTrajectoryGenerator::initialise`` with
  ``use_dwa``): the velocities reachable within one controller period
  ``sim_period = 1 / controller_frequency`` from the current ``(v, omega)``, clipped to
  ``[min_vel_x, max_vel_x]`` and ``[-max_rot_vel, max_rot_vel]``; each axis sampled as
  ``VelocityIterator`` does (``n`` evenly spaced values from low to high, plus 0 where the range
  crosses it), linear outer and angular inner, so ``argmin`` ties resolve as ROS's strict ``<``.
* **Feasibility** (``generateTrajectory``): a sample slower than ``min_trans_vel`` *and* turning
  slower than ``min_rot_vel`` is dropped (D.3's warning about ``min_trans_vel: 0``), as is one
  faster than ``max_trans_vel``. Dropped samples stay in the arrays, marked infeasible, so that
  every array has one row per sample.
* **The arc** is held at the sample's velocity for ``sim_time`` (``continued_acceleration`` is
  off in DWA). ROS integrates it with Euler steps of ``sim_granularity`` metres /
  ``angular_sim_granularity`` radians, a step count per sample; here one step count serves all
  samples (the finest any sample needs, so no sample is checked more coarsely than in ROS) and
  the poses are the exact arc (closed form, ``sinc``), which Euler steps only approximate.
* **Scoring** (``DWAPlanner::reconfigure`` / ``updatePlanAndLocalCosts``, critics in
  ``map_grid_cost_function.cpp`` and ``obstacle_cost_function.cpp``)::

      cost = resolution * path_distance_bias * (path_dist(end) + path_dist(fwd))
           + resolution * goal_distance_bias * (goal_dist(end) + goal_front_dist(fwd))
           + occdist_scale * max(costmap cost over the trajectory's cells)

  ``path_dist`` / ``goal_dist`` are ``MapGrid`` distances in cells: a 4-connected wavefront,
  one per cell, through cells that are not lethal, inscribed or unknown, from the plan's cells
  (path) or the plan's last cell on the map (the local goal). ``fwd`` is the forward point,
  ``forward_point_distance`` ahead of the end pose (``setXShift``); ``goal_front_dist`` is the
  distance to the goal moved ``forward_point_distance`` further along the robot-to-goal line
  (the "nose" target). The alignment term ``path_dist(fwd)`` is dropped once the robot is within
  ``forward_point_distance`` of the goal, as ROS does (keeping the nose on the path there
  destabilises). The resolution factor is ROS's: it makes the biases weights per metre.
* **Invalid** (a negative critic score in ROS, here cost ``inf``): any trajectory point off the
  map, on a lethal (254), inscribed (253) or unknown (255) cell, or on a cell the path or goal
  wavefront does not reach; with a polygon ``footprint``, also any pose whose footprint has a
  vertex off the map or a lethal or unknown cell on its outline (below). The forward point is
  scored with ``stop_on_failure`` off, as ROS's alignment and goal-front critics are: an
  unreachable forward point costs the grid's cell count (``MapGrid::unreachableCellCosts``), it
  does not invalidate the trajectory; off the map it costs the same (ROS would reject it, but
  ROS's local map rolls with the robot and ours is the whole floor, whose edge the nose may
  overhang near a wall).
* **stop_time_buffer**: dwa_planner.cpp stores it but no critic of Noetic's DWA reads it.
  servolab applies what the parameter says: the arc is continued ``stop_time_buffer`` seconds
  past ``sim_time`` at the same velocity, and those extra points must be free too (they are
  collision-checked, not scored), so a chosen trajectory leaves the robot that long to stop.
* **Footprint** (``ObstacleCostFunction::footprintCost``, base_local_planner/src/
  obstacle_cost_function.cpp, through ``WorldModel::footprintCost(x, y, theta, footprint)`` to
  ``CostmapModel::footprintCost``, costmap_model.cpp). ``footprint=None`` is a circular robot:
  each pose's centre cell is checked, lethal, inscribed and unknown invalid (costmap_model.cpp's
  branch for a footprint of fewer than three points), which is enough because the inflation
  marks every cell within the inscribed radius of an obstacle 253. A polygon ``footprint`` (K,
  2), in metres in the robot's frame, is laid down at every pose (the scored ones and the
  stop_time_buffer ones) as costmap_model.cpp does it: turned and moved to the pose, each vertex
  taken to its cell (a vertex off the map: invalid, ``worldToMap`` failing), each edge, and the
  one from the last vertex back to the first, rasterised from cell to cell with Bresenham's
  algorithm (``lineCost`` over ``LineIterator``, the cells costmap_2d's ``raytraceLine`` visits;
  :func:`servolab.planning.costmap.line_cells`). A lethal (254) or unknown (255) cell on the
  outline invalidates the trajectory (``pointCost``'s -1); an inscribed (253) one does not,
  since the inscribed radius says where the robot's inscribed circle may not go, not its edges.
  The footprint's cost is the largest cost on its outline (:func:`footprint_cost`), and the
  pose's is the larger of that and its centre cell's (``occ_cost = max(footprint_cost, centre
  cost)``); ``occ_cost`` is the largest over the scored poses. Only the outline is rasterised,
  as in ROS: an obstacle wholly inside the polygon is not seen at that pose. A moving robot
  usually meets an obstacle with an edge first, but the outline is drawn between its vertices'
  cells, so it moves in jumps of whole cells and can pass over an obstacle one cell across
  between two poses (ROS's can too; the centre test below still holds). The centre cell:
  ``CostmapModel``'s polygon branch does not test it and the obstacle critic only takes its cost
  into the maximum, but the path and goal critics (``MapGrid`` with ``stop_on_failure``) mark
  lethal, inscribed and unknown cells as obstacles and reject a trajectory with a point on one
  (-3), whatever the footprint. So here the centre test is the same for both (the
  stop_time_buffer poses included), and a polygon only adds invalid trajectories to a circle's.
  ROS's DWA is handed ``Costmap2DROS::getRobotFootprint()``, which for a ``robot_radius`` is the
  16-gon of ``makeFootprintFromRadius``, so ROS lays down even a round robot's outline;
  servolab's ``None`` leaves that out: the 16-gon's outline runs between its inscribed radius
  (0.98 of the radius), within which the centre test already finds every obstacle, and the
  radius, so the two differ only in that rim and the cells' rounding.
* **Goal** (``LatchedStopRotateController``): within ``xy_goal_tolerance`` the robot first stops
  (decelerating within the acceleration limits while moving faster than ``trans_stopped_vel`` /
  ``rot_stopped_vel``), then turns in place to the goal yaw (``rotateToGoal``: at least
  ``min_rot_vel``, at most ``max_rot_vel``, within ``acc_lim_theta`` of the current rate and no
  faster than ``sqrt(2 acc_lim_theta |error|)`` so it can stop there), and is done within
  ``yaw_goal_tolerance`` and stopped (``isGoalReached``). The controller's latches are
  :class:`GoalLatch`, kept by the caller between cycles as the oscillation flags are: once the
  robot has stopped and started turning (``rotating_to_goal_``) it is not braked again however
  fast it turns, and with ``latch_xy_goal_tolerance`` it stays "at the goal" once it has been
  within ``xy_goal_tolerance``. ``DWAPlannerROS::setPlan`` clears both (``resetLatching``)
  whenever move_base hands over a new plan. Without the rotation latch, a turn at
  ``min_rot_vel`` with ``rot_stopped_vel == min_rot_vel`` (D.3) reads as "not stopped" on the
  next cycle and is braked, every other cycle.
* **Oscillation** (``OscillationCostFunction``, base_local_planner/src/
  oscillation_cost_function.cpp): :class:`OscillationFlags`, the critic's state, which the
  caller keeps between cycles and passes in. After each chosen trajectory the flags note its
  direction; once the robot has reversed (forward after backward, or, while slower than
  ``min_trans_vel``, turning one way after the other) it may only keep the new direction until
  it has moved ``oscillation_reset_dist`` from where that happened. Noetic's reset nests its
  angle test inside the distance test, so only the distance counts; so here.
  ``DWAPlanner::setPlan`` clears the flags whenever move_base hands over a plan.
* **Not implemented**: footprint scaling with speed (``scaling_speed``, ``max_scaling_factor``).
  ``ObstacleCostFunction::footprintCost`` multiplies the footprint's points by
  ``getScalingFactor``'s ``1 + max_scaling_factor * (v - scaling_speed) / (max_trans_vel -
  scaling_speed)`` for a trajectory faster than ``scaling_speed`` (lost in 2014 and restored by
  ros-planning/navigation PR #886, so Noetic has it), the 16-gon of a ``robot_radius`` included.
  servolab lays the footprint down as it is given (padded by the caller, as Costmap2DROS pads
  it) at every speed, and ``None`` has nothing to scale. D.3 writes ``scaling_speed: 0.10`` and
  ``max_scaling_factor: 0.2``, so at its 0.15 m/s ROS's footprint would be 20 % larger.
  ``twirling_scale`` is 0 in D.3.

Coordinates: world metres, ``costmap[row, col] = [y, x]``, cell ``(floor((x - ox) / res),
floor((y - oy) / res))`` as ``Costmap2D::worldToMap``. Pure numpy/scipy; nothing of servolab's
robots layer is imported: :meth:`DwaConfig.from_params` copies the fields of any object that has
them (``servolab.robots.navigation.params.DwaParams``).
"""

from __future__ import annotations

import enum
import functools
import math
import threading
from collections.abc import Sequence
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.sparse import coo_matrix  # type: ignore[import-untyped]
from scipy.sparse.csgraph import dijkstra  # type: ignore[import-untyped]

from servolab.planning.costmap import (
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    check_footprint,
    line_cells,
)
from servolab.planning.errors import PlanningValueError

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

#: generateTrajectory's tolerance on the velocity limits
_EPS = 1e-4


@dataclass(frozen=True)
class DwaConfig:
    """The dwa_local_planner parameters the planner uses, named as D.3 writes them, with
    DWAPlanner.cfg's defaults (``servolab.robots.navigation.params.DwaParams`` takes its
    defaults for these from here)."""

    max_vel_x: float = 0.55
    min_vel_x: float = 0.0
    max_trans_vel: float = 0.55
    min_trans_vel: float = 0.1
    trans_stopped_vel: float = 0.1
    max_rot_vel: float = 1.0
    min_rot_vel: float = 0.4
    rot_stopped_vel: float = 0.1
    acc_lim_x: float = 2.5
    acc_lim_theta: float = 3.2
    yaw_goal_tolerance: float = 0.05
    xy_goal_tolerance: float = 0.10
    sim_time: float = 1.7
    sim_granularity: float = 0.025
    angular_sim_granularity: float = 0.1
    vx_samples: int = 3
    vtheta_samples: int = 20
    path_distance_bias: float = 32.0
    goal_distance_bias: float = 24.0
    occdist_scale: float = 0.01
    forward_point_distance: float = 0.325
    stop_time_buffer: float = 0.2
    oscillation_reset_dist: float = 0.05
    controller_frequency: float = 20.0
    latch_xy_goal_tolerance: bool = False

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "latch_xy_goal_tolerance":
                if not isinstance(value, bool | np.bool_):
                    raise PlanningValueError(f"DwaConfig: {f.name} must be true or false, not "
                                             f"{value!r}")
                continue
            if f.name in ("vx_samples", "vtheta_samples"):
                if isinstance(value, bool) or not isinstance(value, (int, np.integer)) \
                        or value < 1:
                    raise PlanningValueError(f"DwaConfig: {f.name} must be an integer >= 1, "
                                             f"not {value!r}")
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float, np.integer,
                                                                 np.floating)) \
                    or not math.isfinite(value):
                raise PlanningValueError(f"DwaConfig: {f.name} must be a finite number, not "
                                         f"{value!r}")
            if f.name not in ("min_vel_x", "max_vel_x", "forward_point_distance") and value < 0:
                raise PlanningValueError(f"DwaConfig: {f.name} must be >= 0, not {value!r}")
        for name in ("sim_time", "sim_granularity", "angular_sim_granularity",
                     "controller_frequency"):
            if getattr(self, name) <= 0:
                raise PlanningValueError(f"DwaConfig: {name} must be > 0, not "
                                         f"{getattr(self, name)!r}")
        if self.min_vel_x > self.max_vel_x:
            raise PlanningValueError(f"DwaConfig: min_vel_x {self.min_vel_x} is above max_vel_x "
                                     f"{self.max_vel_x}")

    @classmethod
    def from_params(cls, params: object) -> DwaConfig:
        """The fields of ``params`` (e.g. a ``DwaParams``) that this planner uses; a field the
        object lacks keeps its default."""
        values = {f.name: getattr(params, f.name) for f in fields(cls) if hasattr(params, f.name)}
        return cls(**values)

    @property
    def sim_period(self) -> float:
        """One controller period, the time the window's accelerations act over (DWAPlannerROS
        sets ``sim_period`` from ``controller_frequency``)."""
        return 1.0 / self.controller_frequency


class DwaStatus(enum.Enum):
    """What :func:`compute_velocity` decided."""

    MOVING = "moving"              #: the best trajectory of the window
    NO_VALID_TRAJECTORY = "no_valid_trajectory"  #: every sample invalid: stop (v = omega = 0)
    STOPPING = "stopping"          #: within xy tolerance, braking before the final turn
    ROTATING = "rotating"          #: within xy tolerance, turning in place to the goal yaw
    GOAL_REACHED = "goal_reached"  #: within both tolerances: v = omega = 0


@dataclass(frozen=True)
class DwaSamples:
    """Every sample of one window, row ``i`` of each array for sample ``i``."""

    v: FloatArray             #: (N,) linear velocities, m/s
    omega: FloatArray         #: (N,) angular velocities, rad/s
    feasible: BoolArray       #: (N,) passes the min/max translational-rotational checks
    trajectories: FloatArray  #: (N, T + 1, 3) poses (x, y, theta) at t = k sim_time / T
    valid: BoolArray          #: (N,) feasible, on the map, no point on an impassable cell
    path_cost: FloatArray     #: (N,) path distance of the end, cells
    goal_cost: FloatArray     #: (N,) goal distance of the end, cells
    alignment_cost: FloatArray   #: (N,) path distance of the forward point, cells
    goal_front_cost: FloatArray  #: (N,) distance of the forward point to the goal's nose
    #: (N,) largest costmap cost along the trajectory: its centre cells, and with a polygon
    #: footprint also its outline's cells, laid down only for samples that every other test
    #: leaves valid (the footprint cannot make an invalid sample valid, so the others are
    #: spared the work, and their occ_cost is their centre cells')
    occ_cost: FloatArray
    cost: FloatArray          #: (N,) total cost, inf where invalid


@dataclass
class OscillationFlags:
    """The oscillation critic's state (see the module docstring), one per robot; strafing is
    left out (a differential drive has no ``vy``)."""

    forward_pos: bool = False
    forward_neg: bool = False
    rotating_pos: bool = False
    rotating_neg: bool = False
    forward_pos_only: bool = False
    forward_neg_only: bool = False
    rot_pos_only: bool = False
    rot_neg_only: bool = False
    #: where the last restriction was set (x, y)
    stationary: tuple[float, float] = (0.0, 0.0)

    def reset(self) -> None:
        """``resetOscillationFlags``: every flag cleared (a new plan, or moved far enough)."""
        for name in ("forward_pos", "forward_neg", "rotating_pos", "rotating_neg",
                     "forward_pos_only", "forward_neg_only", "rot_pos_only", "rot_neg_only"):
            setattr(self, name, False)

    @property
    def restricted(self) -> bool:
        return (self.forward_pos_only or self.forward_neg_only or self.rot_pos_only
                or self.rot_neg_only)

    def forbidden(self, v: FloatArray, omega: FloatArray) -> BoolArray:
        """``scoreTrajectory``'s -5: the samples that would reverse a restricted direction."""
        return np.asarray((self.forward_pos_only & (v < 0)) | (self.forward_neg_only & (v > 0))
                          | (self.rot_pos_only & (omega < 0))
                          | (self.rot_neg_only & (omega > 0)), dtype=bool)

    def update(self, pose: Sequence[float], v: float, omega: float, min_trans_vel: float,
               reset_dist: float) -> None:
        """``updateOscillationFlags`` after a valid trajectory ``(v, omega)`` was chosen at
        ``pose`` ``(x, y, ...)``."""
        flag_set = False
        if v < 0.0:
            if self.forward_pos:
                self.forward_neg_only = flag_set = True
            self.forward_pos, self.forward_neg = False, True
        if v > 0.0:
            if self.forward_neg:
                self.forward_pos_only = flag_set = True
            self.forward_neg, self.forward_pos = False, True
        if abs(v) <= min_trans_vel:  # turning counts only when not driving on
            if omega < 0:
                if self.rotating_pos:
                    self.rot_neg_only = flag_set = True
                self.rotating_pos, self.rotating_neg = False, True
            if omega > 0:
                if self.rotating_neg:
                    self.rot_pos_only = flag_set = True
                self.rotating_neg, self.rotating_pos = False, True
        if flag_set:
            self.stationary = (float(pose[0]), float(pose[1]))
        if self.restricted and math.hypot(pose[0] - self.stationary[0],
                                          pose[1] - self.stationary[1]) > reset_dist:
            self.reset()


@dataclass
class GoalLatch:
    """``LatchedStopRotateController``'s state, one per goal: ``rotating_to_goal`` once the
    robot stopped within ``xy_goal_tolerance`` and began its final turn, ``xy_tolerance`` once
    it has been within ``xy_goal_tolerance`` (kept only with ``latch_xy_goal_tolerance``)."""

    rotating_to_goal: bool = False
    xy_tolerance: bool = False

    def reset(self) -> None:
        """``resetLatching``: a new plan (``DWAPlannerROS::setPlan``) or a new goal."""
        self.rotating_to_goal = self.xy_tolerance = False


@dataclass(frozen=True)
class DwaResult:
    """The command to send and why: ``trajectory`` is the chosen sample's (T + 1, 3) poses, or
    an empty (0, 3) array when no trajectory was chosen (goal handling, nothing valid)."""

    v: float
    omega: float
    status: DwaStatus
    trajectory: FloatArray
    cost: float = math.inf
    samples: DwaSamples | None = None


# -- input checks ------------------------------------------------------------------------------


def _finite(name: str, values: npt.ArrayLike, shape: tuple[int, ...] | None = None) -> FloatArray:
    """``values`` as floats; ValueError if not finite or not of ``shape`` (a NaN pose would
    otherwise fall into every comparison as False and pick an arbitrary sample)."""
    array = np.asarray(values, dtype=np.float64)
    if shape is not None and array.shape != shape:
        raise PlanningValueError(f"{name} must have shape {shape}, not {array.shape}")
    if not np.all(np.isfinite(array)):
        raise PlanningValueError(f"{name} must be finite, got {array.tolist()!r}")
    return array


def _check_costmap(costmap: npt.ArrayLike) -> npt.NDArray[np.int64]:
    grid = np.asarray(costmap)
    if grid.ndim != 2 or grid.size == 0:
        raise PlanningValueError(f"costmap must be a non-empty 2-D array, not shape {grid.shape}")
    if not np.issubdtype(grid.dtype, np.integer) or grid.min() < 0 or grid.max() > 255:
        raise PlanningValueError("costmap must hold integer costs 0..255 (costmap_2d's)")
    return grid.astype(np.int64)


def _check_frame(resolution: float, origin: Sequence[float]) -> tuple[float, float, float]:
    if not (math.isfinite(resolution) and resolution > 0):
        raise PlanningValueError(f"resolution must be > 0 m, not {resolution!r}")
    ox, oy = (float(c) for c in _finite("origin", origin, (2,)))
    return float(resolution), ox, oy


# -- window and samples ------------------------------------------------------------------------


def dynamic_window(v: float, omega: float,
                   config: DwaConfig) -> tuple[tuple[float, float], tuple[float, float]]:
    """``((v_low, v_high), (omega_low, omega_high))`` reachable within one ``sim_period`` from
    ``(v, omega)`` under ``acc_lim_x``/``acc_lim_theta``, clipped to the velocity limits.

    When the current speed already lies outside a limit (a slower limit was just loaded) the
    window collapses onto the nearest reachable limit rather than going empty."""
    v, omega = (float(c) for c in _finite("velocity", (v, omega), (2,)))
    dt = config.sim_period
    v_lo = max(config.min_vel_x, v - config.acc_lim_x * dt)
    v_hi = min(config.max_vel_x, v + config.acc_lim_x * dt)
    w_lo = max(-config.max_rot_vel, omega - config.acc_lim_theta * dt)
    w_hi = min(config.max_rot_vel, omega + config.acc_lim_theta * dt)
    if v_lo > v_hi:
        v_lo = v_hi = v_hi if v > config.max_vel_x else v_lo
    if w_lo > w_hi:
        w_lo = w_hi = w_hi if omega > config.max_rot_vel else w_lo
    return (v_lo, v_hi), (w_lo, w_hi)


def velocity_iterator(low: float, high: float, samples: int) -> FloatArray:
    """base_local_planner's ``VelocityIterator``: ``samples`` evenly spaced values from ``low``
    to ``high`` (at least 2 unless ``low == high``), with 0 inserted where the range crosses it
    so that stopping or driving straight is always a candidate."""
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 1:
        raise PlanningValueError(f"samples must be an integer >= 1, not {samples!r}")
    if not (math.isfinite(low) and math.isfinite(high)) or low > high:
        raise PlanningValueError(f"bad velocity range [{low}, {high}]")
    if low == high:
        return np.array([low])
    values = np.linspace(low, high, max(2, int(samples)))
    if low < 0 < high and not np.any(values == 0.0):
        values = np.sort(np.append(values, 0.0))
    return values


def sample_window(v: float, omega: float,
                  config: DwaConfig) -> tuple[FloatArray, FloatArray, BoolArray]:
    """All (v, omega) samples of the window, linear outer and angular inner as ROS loops, and
    which of them pass generateTrajectory's minimum/maximum speed checks."""
    (v_lo, v_hi), (w_lo, w_hi) = dynamic_window(v, omega, config)
    vs = velocity_iterator(v_lo, v_hi, config.vx_samples)
    ws = velocity_iterator(w_lo, w_hi, config.vtheta_samples)
    v_grid, w_grid = (a.ravel() for a in np.meshgrid(vs, ws, indexing="ij"))
    speed = np.abs(v_grid)
    too_slow = (speed + _EPS < config.min_trans_vel) & (np.abs(w_grid) + _EPS
                                                       < config.min_rot_vel)
    too_fast = speed - _EPS > config.max_trans_vel
    return v_grid, w_grid, ~(too_slow | too_fast)


def simulate(pose: npt.ArrayLike, v: npt.ArrayLike, omega: npt.ArrayLike, duration: float,
             steps: int) -> FloatArray:
    """Poses (N, steps + 1, 3) of every sample held at ``(v[i], omega[i])`` for ``duration``
    seconds from ``pose``, at ``t = k duration / steps`` (k = 0 .. steps), all at once.

    The unicycle's arc in closed form: ``x(t) = x0 + v t cos(th0 + w t / 2) sinc(w t / 2)``
    (and ``sin`` for y), exact for a constant twist and without a special case for w = 0."""
    p = _finite("pose", pose, (3,))
    vs = _finite("v", v).reshape(-1)
    ws = _finite("omega", omega).reshape(-1)
    if vs.shape != ws.shape:
        raise PlanningValueError(f"v and omega differ in length: {vs.size} and {ws.size}")
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1:
        raise PlanningValueError(f"steps must be an integer >= 1, not {steps!r}")
    if not (math.isfinite(duration) and duration > 0):
        raise PlanningValueError(f"duration must be > 0 s, not {duration!r}")
    t = np.linspace(0.0, duration, int(steps) + 1)[None, :]          # (1, T + 1)
    half = ws[:, None] * t / 2.0                                      # (N, T + 1)
    dist = vs[:, None] * t * np.sinc(half / np.pi)                    # chord length
    heading = p[2] + half
    out = np.empty((vs.size, t.shape[1], 3))
    out[..., 0] = p[0] + dist * np.cos(heading)
    out[..., 1] = p[1] + dist * np.sin(heading)
    out[..., 2] = p[2] + 2.0 * half
    return out


def step_count(v: FloatArray, omega: FloatArray, duration: float, config: DwaConfig) -> int:
    """generateTrajectory's step count, the largest any sample needs, so that no sample moves
    more than ``sim_granularity`` m or turns more than ``angular_sim_granularity`` rad a step."""
    if v.size == 0:
        return 1
    need = max(float(np.max(np.abs(v))) * duration / config.sim_granularity,
               float(np.max(np.abs(omega))) * duration / config.angular_sim_granularity)
    return max(1, math.ceil(need - 1e-9))


# -- distance maps (MapGrid) -------------------------------------------------------------------


def passable(costmap: npt.ArrayLike) -> BoolArray:
    """Cells a trajectory may cross: below INSCRIBED (253); lethal, inscribed and unknown (255)
    are not (CostmapModel::footprintCost for a circular robot, MapGrid's obstacle cells)."""
    return np.asarray(_check_costmap(costmap) < INSCRIBED_INFLATED_OBSTACLE, dtype=bool)


def distance_map(costmap: npt.ArrayLike, targets: npt.ArrayLike) -> FloatArray:
    """MapGrid's ``target_dist``: cells (4-connected steps, each 1) from the nearest target cell
    ``(col, row)`` through passable cells; ``inf`` on impassable or unreached cells. Targets on
    impassable cells or off the grid are skipped; none left gives all ``inf``."""
    ok = passable(costmap)
    rows, cols = ok.shape
    cells = np.asarray(targets, dtype=np.int64).reshape(-1, 2)
    inside = (cells[:, 0] >= 0) & (cells[:, 0] < cols) & (cells[:, 1] >= 0) & (cells[:, 1] < rows)
    cells = cells[inside]
    cells = cells[ok[cells[:, 1], cells[:, 0]]]
    result = np.full(ok.shape, np.inf)
    if cells.size == 0:
        return result
    ids = np.arange(ok.size).reshape(ok.shape)
    right = ok[:, :-1] & ok[:, 1:]
    down = ok[:-1, :] & ok[1:, :]
    src = np.concatenate((ids[:, :-1][right], ids[:-1, :][down]))
    dst = np.concatenate((ids[:, 1:][right], ids[1:, :][down]))
    graph = coo_matrix((np.ones(src.size), (src, dst)), shape=(ok.size, ok.size)).tocsr()
    sources = np.unique(cells[:, 1] * cols + cells[:, 0])
    dist = dijkstra(graph, directed=False, indices=sources, unweighted=True, min_only=True)
    result = np.asarray(dist, dtype=np.float64).reshape(ok.shape)
    result[~ok] = np.inf
    return result


def world_to_cells(xy: FloatArray, resolution: float,
                   origin: Sequence[float] = (0.0, 0.0)) -> npt.NDArray[np.int64]:
    """``Costmap2D::worldToMap`` without the bounds check: ``(col, row)`` of each point
    ``(..., 2)``."""
    res, ox, oy = _check_frame(resolution, origin)
    cells = np.floor((np.asarray(xy, dtype=np.float64) - np.array([ox, oy])) / res)
    return np.asarray(cells, dtype=np.int64)


def footprint_cost(costmap: npt.ArrayLike, poses: npt.ArrayLike, footprint: npt.ArrayLike, *,
                   resolution: float, origin: Sequence[float] = (0.0, 0.0)) -> FloatArray:
    """``CostmapModel::footprintCost`` of the polygon ``footprint`` (K, 2) at each pose
    ``(..., 3)``: the largest cost of the cells on its outline (see the module docstring), an
    array of the poses' leading shape; ``inf`` where a vertex falls off the map (ROS's -1).
    254 (lethal) or 255 (unknown) means invalid, as ``pointCost``'s -1; 253 does not. The
    centre cell is not looked at (the caller adds it, as ``ObstacleCostFunction`` does)."""
    grid = _check_costmap(costmap)
    res, ox, oy = _check_frame(resolution, origin)
    p = _finite("poses", poses)
    if p.ndim < 1 or p.shape[-1] != 3:
        raise PlanningValueError(f"poses must be (..., 3) = (x, y, theta), not shape {p.shape}")
    return _footprint_cost(grid, p, check_footprint(footprint), res, (ox, oy))


#: The most entries (cells along an edge x edge offsets) of a table of every edge offset that
#: :func:`_footprint_cost` keeps (2 MB; an edge of up to 38 cells). Longer edges get a table of
#: the offsets that occur in the cycle instead.
_FULL_TABLE_ENTRIES = 1 << 18


def _offset_table(dx: npt.NDArray[np.intp], dy: npt.NDArray[np.intp],
                  cols: int) -> npt.NDArray[np.intp]:
    """The cells of the lines from (0, 0) to each ``(dx[i], dy[i])`` as flat offsets
    ``y * cols + x`` in a grid ``cols`` wide, one row per cell along the lines: (L, len(dx))."""
    xs, ys = line_cells(0, 0, dx, dy)
    return np.ascontiguousarray((ys * cols + xs).T, dtype=np.intp)


@functools.lru_cache(maxsize=4)
def _full_offset_table(reach: int, cols: int) -> npt.NDArray[np.intp]:
    """:func:`_offset_table` of every ``(dx, dy)`` with ``|dx|, |dy| <= reach``, column
    ``(dx + reach) * (2 reach + 1) + dy + reach`` (read-only, kept between cycles)."""
    span = np.arange(-reach, reach + 1)
    ends_x, ends_y = np.meshgrid(span, span, indexing="ij")
    table = _offset_table(ends_x.ravel(), ends_y.ravel(), cols)
    table.flags.writeable = False
    return table


class _Scratch(threading.local):
    """Arrays :func:`_footprint_cost` keeps between cycles, one set a thread. Its intermediate
    arrays are hundreds of kilobytes each (vertices x ~5000 poses); allocated anew each cycle,
    glibc maps them fresh from the system and every page faults on first touch, which took
    longer than the arithmetic (measured: 1.4 ms instead of 0.75 for a rectangle, 4 ms
    instead of 1.2 for a 16-gon). Reused, they cost nothing after the first cycle."""

    def __init__(self) -> None:
        self.buffers: dict[str, npt.NDArray[np.generic]] = {}

    def array(self, name: str, shape: tuple[int, int], dtype: type[np.generic]
              ) -> npt.NDArray[Any]:
        """A buffer of ``shape`` (contents undefined), grown when a cycle needs more."""
        size = shape[0] * shape[1]
        buffer = self.buffers.get(name)
        if buffer is None or buffer.dtype != dtype or buffer.size < size:
            buffer = self.buffers[name] = np.empty(size, dtype=dtype)
        return buffer[:size].reshape(shape)


_SCRATCH = _Scratch()


def _footprint_cost(grid: npt.NDArray[np.int64], poses: FloatArray, polygon: FloatArray,
                    resolution: float, origin: tuple[float, float]) -> FloatArray:
    """:func:`footprint_cost` on checked inputs, every pose and edge at once.

    An edge's cells depend only on its start cell and its offset ``(dx, dy)`` to its end cell,
    so :func:`servolab.planning.costmap.line_cells` rasterises every offset up to the longest
    edge once (cached; for very long edges only the offsets that occur), into a table of
    flat-index offsets ``dy * cols + dx``, one row for each cell along an edge. For each row,
    every edge takes its entry, adds its start cell's flat index and gathers the costs from a
    uint8 copy of the grid, and the largest is kept. The arrays are (vertex, pose), the poses
    flattened and last so that numpy's loops run along them (a DWA cycle has ~120 samples x
    ~40 poses), in buffers kept between cycles (:class:`_Scratch`). A polygon with a vertex off
    the map costs ``inf``; its start cells are clipped and the grid padded by the longest edge
    so that its lookups stay in bounds."""
    rows, cols = grid.shape
    # the longest edge in cells, from the polygon: |floor(a) - floor(b)| <= floor(|a - b|) + 1
    edges = np.roll(polygon, -1, axis=0) - polygon
    reach = int(np.max(np.hypot(edges[:, 0], edges[:, 1])) / resolution + 1e-6) + 1
    width = 2 * reach + 1

    flat_poses = poses.reshape(-1, 3)
    shape = (len(polygon), len(flat_poses))                    # (K, M)
    scratch = _SCRATCH
    wx, wy, tmp = (scratch.array(name, shape, np.float64) for name in ("wx", "wy", "tmp"))
    cx, cy, code, offset_column, index = (scratch.array(name, shape, np.intp)
                                          for name in ("cx", "cy", "code", "column", "index"))
    costs, worst = (scratch.array(name, shape, np.uint8) for name in ("costs", "worst"))
    # the vertices, as orient_footprint places them (x + (px cos - py sin), the same sums)
    cos, sin = np.cos(flat_poses[:, 2]), np.sin(flat_poses[:, 2])
    px, py = polygon[:, 0:1], polygon[:, 1:2]
    np.multiply(px, cos, out=wx)
    wx -= np.multiply(py, sin, out=tmp)
    wx += flat_poses[:, 0]
    np.multiply(px, sin, out=wy)
    wy += np.multiply(py, cos, out=tmp)
    wy += flat_poses[:, 1]
    for w, o, c in ((wx, origin[0], cx), (wy, origin[1], cy)):  # worldToMap, as world_to_cells
        w -= o
        w /= resolution
        np.floor(w, out=w)
        c[...] = w
    inside = np.all((cx.view(np.uintp) < cols) & (cy.view(np.uintp) < rows), axis=0)
    np.multiply(cx, width, out=code)
    code += cy
    offset_column[:-1] = code[1:]                              # edge i: vertex i -> i + 1
    offset_column[-1] = code[0]
    offset_column -= code
    offset_column += reach * width + reach
    if (reach + 1) * width * width <= _FULL_TABLE_ENTRIES:
        table = _full_offset_table(reach, cols)                # (L, width * width)
    else:                                                      # long edges: what occurs
        present, inverse = np.unique(offset_column, return_inverse=True)
        table = _offset_table(present // width - reach, present % width - reach, cols)
        offset_column[...] = inverse.reshape(shape)
    pad = reach * (cols + 1)
    start = cy                                                 # cy is done with: reuse it
    start *= cols
    start += cx
    np.clip(start, 0, grid.size - 1, out=start)
    start += pad
    flat = np.zeros(grid.size + 2 * pad, dtype=np.uint8)
    flat[pad:pad + grid.size] = grid.ravel()
    worst[...] = 0
    for offsets in table:                                      # one cell along every edge
        np.take(offsets, offset_column, out=index)
        index += start
        np.take(flat, index, out=costs)
        np.maximum(worst, costs, out=worst)
    return np.where(inside, worst.max(axis=0).astype(np.float64), math.inf).reshape(
        poses.shape[:-1])


# -- scoring -----------------------------------------------------------------------------------


def score_samples(pose: npt.ArrayLike, velocity: npt.ArrayLike, costmap: npt.ArrayLike,
                  plan: npt.ArrayLike, config: DwaConfig, *, resolution: float,
                  origin: Sequence[float] = (0.0, 0.0),
                  oscillation: OscillationFlags | None = None,
                  footprint: npt.ArrayLike | None = None) -> DwaSamples:
    """Simulate and score every sample of the window (see the module docstring for the cost).

    ``pose`` is (x, y, theta), ``velocity`` (v, omega), ``plan`` the global path as world
    points (M, 2), its last point on the map being the local goal. ``footprint`` is the robot's
    polygon (K, 2), metres in its own frame (x forward), laid down along every trajectory, or
    None for a circular robot, whose centre cells alone are checked (module docstring,
    "Footprint")."""
    p = _finite("pose", pose, (3,))
    vel = _finite("velocity", velocity, (2,))
    grid = _check_costmap(costmap)
    res, ox, oy = _check_frame(resolution, origin)
    polygon = None if footprint is None else check_footprint(footprint)
    path = _finite("plan", plan)
    if path.ndim != 2 or path.shape[1] != 2 or path.shape[0] == 0:
        raise PlanningValueError("plan must be (M, 2) world points, M >= 1, not shape "
                                 f"{path.shape}")
    rows, cols = grid.shape

    vs, ws, feasible = sample_window(float(vel[0]), float(vel[1]), config)
    # scored part (sim_time) plus the stop_time_buffer part, simulated together
    steps = step_count(vs, ws, config.sim_time, config)
    dt = config.sim_time / steps
    extra = math.ceil(config.stop_time_buffer / dt - 1e-9)
    poses = simulate(p, vs, ws, dt * (steps + extra), steps + extra) if extra else \
        simulate(p, vs, ws, config.sim_time, steps)
    trajectories = poses[:, :steps + 1]

    path_cells = world_to_cells(path, res, (ox, oy))
    on_map = ((path_cells[:, 0] >= 0) & (path_cells[:, 0] < cols)
              & (path_cells[:, 1] >= 0) & (path_cells[:, 1] < rows))
    path_dist = distance_map(grid, path_cells)
    goal_xy = path[on_map][-1] if on_map.any() else path[-1]
    goal_dist = distance_map(grid, world_to_cells(goal_xy, res, (ox, oy)))
    # the nose target: the goal pushed forward_point_distance along robot -> goal
    heading = math.atan2(goal_xy[1] - p[1], goal_xy[0] - p[0])
    nose = goal_xy + config.forward_point_distance * np.array([math.cos(heading),
                                                               math.sin(heading)])
    front_dist = distance_map(grid, world_to_cells(nose, res, (ox, oy)))

    def lookup(table: FloatArray | npt.NDArray[np.int64], xy: FloatArray,
               outside: float) -> FloatArray:
        c = world_to_cells(xy, res, (ox, oy))
        inside = (c[..., 0] >= 0) & (c[..., 0] < cols) & (c[..., 1] >= 0) & (c[..., 1] < rows)
        cc = np.where(inside[..., None], c, 0)
        return np.where(inside, table[cc[..., 1], cc[..., 0]].astype(np.float64), outside)

    cell_cost = lookup(grid, poses[..., :2], math.inf)               # (N, T + extra + 1)
    occ = np.max(cell_cost[:, :steps + 1], axis=1)
    collision_free = np.all(cell_cost < INSCRIBED_INFLATED_OBSTACLE, axis=1)
    path_along = lookup(path_dist, trajectories[..., :2], math.inf)
    goal_along = lookup(goal_dist, trajectories[..., :2], math.inf)
    reachable = np.all(np.isfinite(path_along), axis=1) & np.all(np.isfinite(goal_along), axis=1)
    valid = feasible & collision_free & reachable
    if oscillation is not None:
        valid &= ~oscillation.forbidden(vs, ws)
    if polygon is not None:
        # the footprint can only take a sample away: lay it down on the ones still valid
        rows_left = np.flatnonzero(valid)
        outline = _footprint_cost(grid, poses if rows_left.size == valid.size
                                  else poses[rows_left], polygon, res, (ox, oy))
        valid[rows_left] = np.all(outline < LETHAL_OBSTACLE, axis=1)
        occ[rows_left] = np.maximum(occ[rows_left], np.max(outline[:, :steps + 1], axis=1,
                                                           initial=0.0))

    end = trajectories[:, -1]
    fwd = end[:, :2] + config.forward_point_distance * np.column_stack((np.cos(end[:, 2]),
                                                                       np.sin(end[:, 2])))
    unreachable = float(grid.size)  # MapGrid::unreachableCellCosts, stop_on_failure off
    align = lookup(path_dist, fwd, unreachable)
    align = np.where(np.isfinite(align), align, unreachable)
    front = lookup(front_dist, fwd, unreachable)
    front = np.where(np.isfinite(front), front, unreachable)
    near_goal = math.hypot(p[0] - goal_xy[0], p[1] - goal_xy[1]) \
        <= config.forward_point_distance
    align_scale = 0.0 if near_goal else res * config.path_distance_bias

    path_cost = path_along[:, -1]
    goal_cost = goal_along[:, -1]
    with np.errstate(invalid="ignore"):
        cost = (res * config.path_distance_bias * path_cost + align_scale * align
                + res * config.goal_distance_bias * (goal_cost + front)
                + config.occdist_scale * occ)
    cost = np.where(valid, cost, math.inf)
    return DwaSamples(v=vs, omega=ws, feasible=feasible, trajectories=trajectories, valid=valid,
                      path_cost=path_cost, goal_cost=goal_cost, alignment_cost=align,
                      goal_front_cost=front, occ_cost=occ, cost=cost)


def find_best_trajectory(pose: npt.ArrayLike, velocity: npt.ArrayLike, costmap: npt.ArrayLike,
                         plan: npt.ArrayLike, config: DwaConfig, *, resolution: float,
                         origin: Sequence[float] = (0.0, 0.0),
                         oscillation: OscillationFlags | None = None,
                         footprint: npt.ArrayLike | None = None) -> DwaResult:
    """The lowest-cost sample of the window (the first of equals, as ROS's strict ``<``), or
    zero velocity and :attr:`DwaStatus.NO_VALID_TRAJECTORY` when every sample is invalid.
    ``oscillation``, if given, is consulted and then updated with the choice; ``footprint`` as
    :func:`score_samples`."""
    samples = score_samples(pose, velocity, costmap, plan, config, resolution=resolution,
                            origin=origin, oscillation=oscillation, footprint=footprint)
    if not np.any(samples.valid):
        return DwaResult(0.0, 0.0, DwaStatus.NO_VALID_TRAJECTORY, np.empty((0, 3)),
                         math.inf, samples)
    best = int(np.argmin(samples.cost))
    v, omega = float(samples.v[best]), float(samples.omega[best])
    if oscillation is not None:
        x, y = (float(c) for c in np.asarray(pose, dtype=np.float64)[:2])
        oscillation.update((x, y), v, omega, config.min_trans_vel,
                           config.oscillation_reset_dist)
    return DwaResult(v, omega, DwaStatus.MOVING, samples.trajectories[best].copy(),
                     float(samples.cost[best]), samples)


# -- goal handling (LatchedStopRotateController) -----------------------------------------------


def angle_diff(target: float, current: float) -> float:
    """``angles::shortest_angular_distance(current, target)``, in (-pi, pi]."""
    d = math.remainder(target - current, 2.0 * math.pi)
    return math.pi if d == -math.pi else d


def goal_command(pose: npt.ArrayLike, velocity: npt.ArrayLike, goal: npt.ArrayLike,
                 config: DwaConfig, latch: GoalLatch | None = None) -> DwaResult | None:
    """What to do near the goal ``(x, y)`` or ``(x, y, yaw)``; None while the robot is farther
    than ``xy_goal_tolerance`` (then DWA drives). Without a goal yaw, reaching the position
    and stopping is the goal. ``latch`` (kept by the caller between cycles) is consulted and
    updated as ``computeVelocityCommandsStopRotate`` does; without one nothing is latched."""
    p = _finite("pose", pose, (3,))
    vel = _finite("velocity", velocity, (2,))
    g = _finite("goal", goal)
    if g.shape not in ((2,), (3,)):
        raise PlanningValueError(f"goal must be (x, y) or (x, y, yaw), not shape {g.shape}")
    latch = latch if latch is not None else GoalLatch()
    within = math.hypot(p[0] - g[0], p[1] - g[1]) <= config.xy_goal_tolerance
    if not within and not (config.latch_xy_goal_tolerance and latch.xy_tolerance):
        return None
    if config.latch_xy_goal_tolerance:
        latch.xy_tolerance = True
    empty = np.empty((0, 3))
    v, w = float(vel[0]), float(vel[1])
    dt = config.sim_period
    stopped = abs(v) <= config.trans_stopped_vel and abs(w) <= config.rot_stopped_vel
    error = 0.0 if g.shape == (2,) else angle_diff(float(g[2]), float(p[2]))
    if abs(error) <= config.yaw_goal_tolerance:
        latch.rotating_to_goal = False
        # the command is zero; isGoalReached also wants the robot stopped
        return DwaResult(0.0, 0.0, DwaStatus.GOAL_REACHED if stopped else DwaStatus.STOPPING,
                         empty, 0.0)
    if not latch.rotating_to_goal and not stopped:
        # stopWithAccLimits: brake as hard as the limits allow
        v_new = math.copysign(max(0.0, abs(v) - config.acc_lim_x * dt), v)
        w_new = math.copysign(max(0.0, abs(w) - config.acc_lim_theta * dt), w)
        return DwaResult(v_new, w_new, DwaStatus.STOPPING, empty)
    latch.rotating_to_goal = True
    # rotateToGoal
    rate = min(config.max_rot_vel, max(config.min_rot_vel, abs(error)))
    rate = min(max(rate, abs(w) - config.acc_lim_theta * dt), abs(w) + config.acc_lim_theta * dt)
    rate = min(rate, math.sqrt(2.0 * config.acc_lim_theta * abs(error)))
    rate = min(config.max_rot_vel, max(config.min_rot_vel, rate))
    return DwaResult(0.0, math.copysign(rate, error), DwaStatus.ROTATING, empty)


def compute_velocity(pose: npt.ArrayLike, velocity: npt.ArrayLike, costmap: npt.ArrayLike,
                     plan: npt.ArrayLike, config: DwaConfig, *, resolution: float,
                     origin: Sequence[float] = (0.0, 0.0),
                     goal_yaw: float | None = None,
                     oscillation: OscillationFlags | None = None,
                     latch: GoalLatch | None = None,
                     footprint: npt.ArrayLike | None = None) -> DwaResult:
    """One controller cycle, as DWAPlannerROS::computeVelocityCommands: goal handling within
    ``xy_goal_tolerance`` of the plan's last point (``latch`` kept by the caller, see
    :class:`GoalLatch`), else the best DWA trajectory (``footprint`` as :func:`score_samples`:
    the padded polygon, or None for a circular robot)."""
    path = _finite("plan", plan)
    if path.ndim != 2 or path.shape[1] != 2 or path.shape[0] == 0:
        raise PlanningValueError("plan must be (M, 2) world points, M >= 1, not shape "
                                 f"{path.shape}")
    goal = path[-1] if goal_yaw is None else np.append(path[-1], goal_yaw)
    near = goal_command(pose, velocity, goal, config, latch)
    if near is not None:
        return near
    return find_best_trajectory(pose, velocity, costmap, path, config, resolution=resolution,
                                origin=origin, oscillation=oscillation, footprint=footprint)
