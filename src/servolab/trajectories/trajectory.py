"""A joint trajectory sampled in time, as ros2_controllers' ``joint_trajectory_controller``
samples it (``Trajectory`` of ``src/trajectory.cpp`` and ``trajectory.hpp``, Jazzy).

Why a stateful class and not a function: ``Trajectory::sample`` has memory the controller
relies on. Its first call fixes the start of a trajectory stamped 0 ("start now"); it
remembers the segment it last found and searches on from there (samples are assumed to move
forward in time); and the state before the trajectory (where the robot was when the
trajectory arrived) is the start of the segment to the first point. This class keeps exactly
that memory, so a controller gets the same commands as from the C++.

What a sample gives, by when it falls (``SamplePhase``):

* before the time of the state before: nothing (``valid`` False), the C++'s ``false``;
* from there to the first point's time: the spline from the state before to the first point
  (method ``"splines"``) or the state before itself (``"none"``); segment indices (0, 0);
* from point i to point i+1: the spline between them, or point i+1 itself (``"none"``);
  indices (i, i+1);
* from the last point's time on: the last point, velocities and accelerations it does not
  give filled with zeros; indices (N-1, N), N standing for the C++'s ``end()``.

Differences from the C++ (all where the C++ needs things this package does not carry):
every point must have positions (the C++ can integrate them from velocities or
accelerations when ``allow_integration_in_goal_trajectories`` is set), a field is given for
all points or for none, efforts are not carried, and an empty trajectory is refused when it
is made (the C++ would crash on it in ``set_point_before_trajectory_msg``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum

import numpy as np
from numpy.typing import ArrayLike

from ._time import to_ns, to_s
from .errors import TrajectoryError, TrajectoryValueError
from .spline import FloatArray, PointState, interpolate_segment
from .wraparound import wraparound_joint

__all__ = ["InterpolationMethod", "SamplePhase", "Trajectory", "TrajectorySample"]


class InterpolationMethod(Enum):
    """The controller's ``interpolation_method`` parameter (``interpolation_methods.hpp``)."""

    SPLINES = "splines"
    NONE = "none"

    @classmethod
    def parse(cls, value: InterpolationMethod | str) -> InterpolationMethod:
        """``value`` as a method; refuses other names (the parameter's ``one_of`` does too)."""
        if isinstance(value, InterpolationMethod):
            return value
        try:
            return cls(value)
        except ValueError:
            raise TrajectoryValueError(
                f"interpolation method must be 'splines' or 'none', got {value!r}") from None


class SamplePhase(Enum):
    """Where a sample time falls relative to the trajectory."""

    #: before the time of the state before the trajectory: no sample (the C++ returns false)
    BEFORE_STATE_BEFORE = "before_state_before"
    #: between the state before and the first point
    BEFORE_FIRST_POINT = "before_first_point"
    #: between two points
    WITHIN = "within"
    #: at or after the last point: the last point is held
    AFTER_END = "after_end"


@dataclass(frozen=True)
class TrajectorySample:
    """One sample of a trajectory.

    ``state`` is None exactly when ``valid`` is False. ``start_index``/``end_index`` are the
    C++'s ``start_segment_itr``/``end_segment_itr`` as point indices, the number of points
    standing for ``end()``; None when ``valid`` is False (the C++ leaves them untouched).
    """

    valid: bool
    phase: SamplePhase
    state: PointState | None
    start_index: int | None
    end_index: int | None

    @property
    def after_end(self) -> bool:
        """True once the whole trajectory has played out (the last point is held)."""
        return self.phase is SamplePhase.AFTER_END


def _rows(values: ArrayLike | None, shape: tuple[int, int], what: str) -> FloatArray | None:
    """``values`` as an N×J float array, or None when not given."""
    if values is None:
        return None
    array = np.array(values, dtype=np.float64)
    if array.shape != shape:
        raise TrajectoryValueError(f"{what} must have shape {shape} (points × joints), got "
                                   f"{array.shape}")
    array.flags.writeable = False
    return array


class Trajectory:
    """Points to reach at times after a start, sampled as ``joint_trajectory_controller``
    samples them.

    ``time_from_start`` (N,) in seconds; ``positions`` (N×J); ``velocities`` and
    ``accelerations`` (N×J) or None when not given. ``start_time`` (s) is the trajectory's
    header stamp: 0 means "when first sampled". ``time_before``/``state_before`` are where the
    robot was when the trajectory arrived (``set_point_before_trajectory_msg``); they may be
    given here or later with :meth:`set_point_before_trajectory` (the controller sets them at
    its first update with the trajectory), and are needed only to sample before the first
    point. ``wraparound`` flags continuous joints (see :mod:`.wraparound`).
    """

    def __init__(self, time_from_start: ArrayLike, positions: ArrayLike,
                 velocities: ArrayLike | None = None, accelerations: ArrayLike | None = None,
                 *, start_time: float = 0.0, time_before: float | None = None,
                 state_before: PointState | None = None,
                 wraparound: Sequence[bool] | None = None) -> None:
        times = np.asarray(time_from_start, dtype=np.float64)
        if times.ndim != 1 or times.size == 0:
            raise TrajectoryValueError("time_from_start must be a non-empty 1-D array of "
                                       f"seconds, got shape {times.shape}")
        pos = np.asarray(positions, dtype=np.float64)
        if pos.ndim != 2 or pos.shape[0] != times.size or pos.shape[1] == 0:
            raise TrajectoryValueError(f"positions must have shape ({times.size}, joints), "
                                       f"got {pos.shape}")
        shape = (int(pos.shape[0]), int(pos.shape[1]))
        vel = _rows(velocities, shape, "velocities")
        acc = _rows(accelerations, shape, "accelerations")
        self._tfs_ns = [to_ns(t, "time_from_start") for t in times]
        self._points = tuple(
            PointState(pos[i], None if vel is None else vel[i], None if acc is None else acc[i])
            for i in range(shape[0]))
        self._start_ns = to_ns(start_time, "start_time")
        self._time_before_ns: int | None = None
        self._state_before: PointState | None = None
        self._sampled_already = False
        self._last_sample_idx = 0
        if (time_before is None) != (state_before is None):
            raise TrajectoryValueError("give both time_before and state_before, or neither")
        if time_before is not None and state_before is not None:
            self.set_point_before_trajectory(time_before, state_before, wraparound)

    # -- what the trajectory is -------------------------------------------------------------

    @property
    def points(self) -> tuple[PointState, ...]:
        """The waypoints, in order."""
        return self._points

    @property
    def time_from_start(self) -> FloatArray:
        """Each point's time after the start (s), as nanoseconds rounded it."""
        return np.array([to_s(t) for t in self._tfs_ns])

    @property
    def joint_count(self) -> int:
        """How many joints each point has values for."""
        return self._points[0].joint_count

    @property
    def start_time(self) -> float:
        """The start (s): the stamp given, or the first sample's time when the stamp was 0;
        0.0 while a "start now" trajectory has not been sampled (the C++'s
        ``time_from_start()``, which is the start time despite its name)."""
        return to_s(self._start_ns)

    @property
    def is_sampled_already(self) -> bool:
        """Whether :meth:`sample` has run: the controller sets the state before until then."""
        return self._sampled_already

    @property
    def last_sample_index(self) -> int:
        """The segment start the next monotonic :meth:`sample` searches from."""
        return self._last_sample_idx

    @property
    def state_before(self) -> PointState | None:
        """The state before the trajectory, as sampling uses it (zeros added, wrapped)."""
        return self._state_before

    def _anchored_start_ns(self) -> int:
        if self._start_ns == 0 and not self._sampled_already:
            raise TrajectoryError("a trajectory stamped 0 starts at its first sample: "
                                  "sample it before asking for its times")
        return self._start_ns

    def time_of_point(self, index: int) -> float:
        """When point ``index`` is to be reached (s): start + its time_from_start. The
        controller's goal-time check measures from the last point's time."""
        return to_s(self._anchored_start_ns() + self._tfs_ns[index])

    def end_time(self) -> float:
        """When the last point is to be reached (s)."""
        return self.time_of_point(len(self._points) - 1)

    def segment_at(self, sample_time: float) -> tuple[SamplePhase, int | None, int | None]:
        """Where ``sample_time`` falls: the phase and the segment's point indices as
        :meth:`sample` would give them, without sampling (nothing remembered, no search
        from the last sample: a plain lookup, also backwards in time)."""
        t = to_ns(sample_time, "sample_time")
        start = self._anchored_start_ns()
        if self._time_before_ns is not None and t < self._time_before_ns:
            return SamplePhase.BEFORE_STATE_BEFORE, None, None
        if t < start + self._tfs_ns[0]:
            return SamplePhase.BEFORE_FIRST_POINT, 0, 0
        last = len(self._points) - 1
        if t >= start + self._tfs_ns[last]:
            return SamplePhase.AFTER_END, last, last + 1
        for i in range(last):
            if start + self._tfs_ns[i] <= t < start + self._tfs_ns[i + 1]:
                return SamplePhase.WITHIN, i, i + 1
        # times that do not increase leave gaps no segment covers; the C++ then holds the end
        return SamplePhase.AFTER_END, last, last + 1

    # -- the state before -------------------------------------------------------------------

    def set_point_before_trajectory(self, time_before: float, state: PointState,
                                    wraparound: Sequence[bool] | None = None) -> None:
        """Where the robot was (``state``) at ``time_before`` (s), when the trajectory
        arrived: the start of the segment to the first point.

        As ``set_point_before_trajectory_msg`` does: a state without velocities
        (accelerations) gets zeros when the first point has them, so the first segment has
        the degree of the others; continuous joints are moved by whole turns towards the
        first point.
        """
        if state.joint_count != self.joint_count:
            raise TrajectoryValueError(f"the state before has {state.joint_count} joints, the "
                                       f"trajectory {self.joint_count}")
        first = self._points[0]
        velocities = state.velocities
        if velocities is None and first.velocities is not None:
            velocities = np.zeros(first.velocities.size)
        accelerations = state.accelerations
        if accelerations is None and first.accelerations is not None:
            accelerations = np.zeros(first.accelerations.size)
        positions = wraparound_joint(state.positions, first.positions, wraparound)
        self._time_before_ns = to_ns(time_before, "time_before")
        self._state_before = PointState(positions, velocities, accelerations)

    # -- sampling ---------------------------------------------------------------------------

    def sample(self, sample_time: float,
               method: InterpolationMethod | str = InterpolationMethod.SPLINES, *,
               search_monotonically_increasing: bool = True) -> TrajectorySample:
        """The state at ``sample_time`` (s), as ``Trajectory::sample`` gives it.

        The first call fixes a "start now" trajectory's start to ``sample_time``. With
        ``search_monotonically_increasing`` (the default, as in the C++) the segment found
        is remembered and the next call searches from it, so a later call with an earlier
        time past the first point finds no segment and gets the last point; the controller
        passes False for its look-ahead sample (the command for the next cycle). As in
        Jazzy, a sample after the end moves the remembered segment to the last point even
        with False (master fixed that): a look-ahead past the end makes the next normal
        sample, still inside the last segment, hold the last point one cycle early.
        """
        interpolation = InterpolationMethod.parse(method)
        t = to_ns(sample_time, "sample_time")
        if not self._sampled_already:
            if self._start_ns == 0:
                self._start_ns = t
            self._sampled_already = True

        if self._time_before_ns is not None and t < self._time_before_ns:
            return TrajectorySample(False, SamplePhase.BEFORE_STATE_BEFORE, None, None, None)

        first_ns = self._start_ns + self._tfs_ns[0]
        if t < first_ns:
            if self._state_before is None or self._time_before_ns is None:
                raise TrajectoryError("sampling before the first point needs the state before "
                                      "the trajectory: set_point_before_trajectory() first")
            if interpolation is InterpolationMethod.NONE:
                state = self._state_before
            else:
                state = interpolate_segment(self._state_before, self._points[0],
                                            to_s(t - self._time_before_ns),
                                            to_s(first_ns - self._time_before_ns))
            return TrajectorySample(True, SamplePhase.BEFORE_FIRST_POINT, state, 0, 0)

        last = len(self._points) - 1
        for i in range(self._last_sample_idx, last):
            t0 = self._start_ns + self._tfs_ns[i]
            t1 = self._start_ns + self._tfs_ns[i + 1]
            if t0 <= t < t1:
                if interpolation is InterpolationMethod.NONE:
                    state = self._points[i + 1]
                else:
                    state = interpolate_segment(self._points[i], self._points[i + 1],
                                                to_s(t - t0), to_s(t1 - t0))
                if search_monotonically_increasing:
                    self._last_sample_idx = i
                return TrajectorySample(True, SamplePhase.WITHIN, state, i, i + 1)

        self._last_sample_idx = last  # Jazzy: whatever search_monotonically_increasing says
        end = self._points[last]
        zeros = np.zeros(end.joint_count)
        held = PointState(end.positions,
                          zeros if end.velocities is None else end.velocities,
                          zeros if end.accelerations is None else end.accelerations)
        return TrajectorySample(True, SamplePhase.AFTER_END, held, last, last + 1)
