"""Continuous joints: start a trajectory from the turn of the joint nearest its first point.

Follows ``wraparound_joint`` (``src/trajectory.cpp``) and ``angles::shortest_angular_distance``
(ROS's ``angles`` package), which ros2_controllers applies to the state before a trajectory:
a continuous joint at 0 rad sent to 3π/2 rad turns -π/2 (to 2π - π/2), not +3π/2, so the
state before is moved by whole turns (0 becomes 2π) and the spline from it is short.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from .errors import TrajectoryValueError
from .spline import FloatArray

__all__ = ["normalize_angle", "shortest_angular_distance", "wraparound_joint"]

#: how close to a half turn a distance is treated as exactly a half turn
_HALF_TURN_EPS = 1e-9


def normalize_angle(angle: ArrayLike) -> FloatArray:
    """``angle`` in (-π, π], element-wise, as ``angles::normalize_angle`` computes it (C's
    ``fmod``, whose result has the dividend's sign)."""
    result = np.fmod(np.asarray(angle, dtype=np.float64) + math.pi, 2.0 * math.pi)
    return np.where(result <= 0.0, result + math.pi, result - math.pi)


def shortest_angular_distance(start: ArrayLike, end: ArrayLike) -> FloatArray:
    """The signed turn from ``start`` to ``end`` of at most half a turn, element-wise."""
    return normalize_angle(np.asarray(end, dtype=np.float64) - np.asarray(start, dtype=np.float64))


def wraparound_joint(current: ArrayLike, next_position: ArrayLike,
                     wraparound: Sequence[bool] | None) -> FloatArray:
    """``current`` with each continuous joint (``wraparound[i]`` true) moved to the turn that
    reaches ``next_position`` by the shortest way; other joints unchanged.

    ``wraparound`` None or empty means no joint is continuous (the C++'s default empty
    vector). At exactly half a turn the direction is the sign of ``next - current``.
    """
    cur = np.array(current, dtype=np.float64)
    nxt = np.asarray(next_position, dtype=np.float64)
    if not wraparound:
        return cur
    flags = np.asarray(wraparound, dtype=bool)
    if not (flags.shape == cur.shape == nxt.shape):
        raise TrajectoryValueError(
            f"wraparound flags {flags.shape}, current {cur.shape} and next {nxt.shape} "
            "positions must have one value a joint")
    dist = shortest_angular_distance(cur, nxt)
    half_turn = np.abs(np.abs(dist) - math.pi) < _HALF_TURN_EPS
    dist = np.where(half_turn, np.where(nxt > cur, np.abs(dist), -np.abs(dist)), dist)
    return np.where(flags, nxt - dist, cur)
