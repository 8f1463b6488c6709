"""How far a joint may stray from the trajectory, as ``joint_trajectory_controller`` decides
it (``include/joint_trajectory_controller/tolerances.hpp``, Jazzy; defaults from
``src/joint_trajectory_controller_parameters.yaml``).

A tolerance of 0 is *not enforced*: any error passes. That is how the C++ stores "no
tolerance", so a goal's -1 ("erase the default", control_msgs/JointTolerance) also becomes
0 here, and ``goal_time`` 0 means "wait for the goal tolerances as long as it takes". The
defaults come from the controller's parameters:

====================================  =========  ============================================
parameter                             default    becomes
====================================  =========  ============================================
constraints.stopped_velocity_tolerance  0.01     every joint's goal velocity tolerance
constraints.goal_time                 0.0        goal_time_tolerance (must be >= 0)
constraints.<joint>.trajectory        0.0        the joint's path position tolerance
constraints.<joint>.goal              0.0        the joint's goal position tolerance
====================================  =========  ============================================

(path velocity/acceleration and goal acceleration tolerances have no parameter: 0.) A
FollowJointTrajectory goal overrides them per joint and field: a value > 0 replaces the
default, 0 keeps it, -1 (within float32's epsilon) erases it to 0, and any other negative
value makes the controller ignore *all* the goal's tolerances and keep the defaults.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike

from .errors import TrajectoryValueError

__all__ = ["Constraints", "GoalTolerances", "JointConstraints", "JointTolerance",
           "SegmentTolerances", "StateTolerance", "ToleranceCheck",
           "check_state_tolerance_per_joint", "check_state_tolerances",
           "default_segment_tolerances", "goal_time_exceeded", "resolve_tolerance_source",
           "segment_tolerances_from_goal", "state_tolerance_message"]

#: control_msgs/JointTolerance's "erase" value
ERASE_VALUE = -1.0
#: how near -1 a goal's value counts as -1: ``std::numeric_limits<float>::epsilon()``
_ERASE_EPS = float(np.finfo(np.float32).eps)


def _number(value: object, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise TrajectoryValueError(f"{what} must be a number, got {value!r}")
    number = float(value)
    if math.isnan(number):
        raise TrajectoryValueError(f"{what} must be a number, got NaN")
    return number


@dataclass(frozen=True)
class StateTolerance:
    """Largest allowed absolute error of one joint (``StateTolerances``); 0 = not enforced."""

    position: float = 0.0
    velocity: float = 0.0
    acceleration: float = 0.0


@dataclass(frozen=True)
class SegmentTolerances:
    """The tolerances of a trajectory: ``state_tolerance`` applies while moving (one a
    joint, controller order), ``goal_state_tolerance`` after the last point, and
    ``goal_time_tolerance`` (s) is how long after the last point's time the goal tolerances
    may still be unmet (0: no limit)."""

    state_tolerance: tuple[StateTolerance, ...]
    goal_state_tolerance: tuple[StateTolerance, ...]
    goal_time_tolerance: float = 0.0


@dataclass(frozen=True)
class JointConstraints:
    """``constraints.<joint>``: the path (``trajectory``) and ``goal`` position tolerances."""

    trajectory: float = 0.0
    goal: float = 0.0


@dataclass(frozen=True)
class Constraints:
    """The controller's ``constraints`` parameters; defaults as the parameter YAML gives."""

    stopped_velocity_tolerance: float = 0.01
    goal_time: float = 0.0
    joints: Mapping[str, JointConstraints] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.goal_time >= 0.0:  # also refuses NaN
            raise TrajectoryValueError(f"constraints.goal_time must be >= 0, got "
                                       f"{self.goal_time!r} (the parameter's validation)")

    @classmethod
    def from_parameters(cls, constraints: Mapping[str, object]) -> Constraints:
        """From the ``constraints`` mapping of a controller's parameters, as a YAML file
        gives it (``{"goal_time": 0.5, "joint1": {"trajectory": 0.05, "goal": 0.03}}``).

        Every key other than ``stopped_velocity_tolerance``, ``goal_time`` and
        ``decelerate_on_cancel`` is a joint; of a joint, ``trajectory`` and ``goal`` are
        read and ``max_deceleration_on_cancel`` is accepted (it concerns stopping, not
        tolerances). Any other key is refused, so a typo does not silently keep a default.
        """
        kwargs: dict[str, float] = {}
        joints: dict[str, JointConstraints] = {}
        for key, value in constraints.items():
            if key in ("stopped_velocity_tolerance", "goal_time"):
                kwargs[key] = _number(value, f"constraints.{key}")
            elif key == "decelerate_on_cancel":
                continue
            elif isinstance(value, Mapping):
                unknown = set(value) - {"trajectory", "goal", "max_deceleration_on_cancel"}
                if unknown:
                    raise TrajectoryValueError(
                        f"constraints.{key} has unknown keys {sorted(map(str, unknown))}")
                joints[str(key)] = JointConstraints(
                    _number(value.get("trajectory", 0.0), f"constraints.{key}.trajectory"),
                    _number(value.get("goal", 0.0), f"constraints.{key}.goal"))
            else:
                raise TrajectoryValueError(f"constraints.{key} must be a joint's mapping "
                                           f"(trajectory, goal), got {value!r}")
        return cls(joints=joints, **kwargs)


def default_segment_tolerances(joints: Sequence[str],
                               constraints: Constraints) -> SegmentTolerances:
    """The tolerances of a trajectory that names none: ``get_segment_tolerances(params)``.

    A joint without ``constraints.<joint>`` gets 0 (not enforced) for both; constraints of
    names not in ``joints`` are ignored, as the parameter library only declares
    ``constraints.<joint>`` for the controller's joints.
    """
    state, goal = [], []
    for joint in joints:
        limits = constraints.joints.get(joint, JointConstraints())
        state.append(StateTolerance(position=limits.trajectory))
        goal.append(StateTolerance(position=limits.goal,
                                   velocity=constraints.stopped_velocity_tolerance))
    return SegmentTolerances(tuple(state), tuple(goal), constraints.goal_time)


def resolve_tolerance_source(default_value: float, goal_value: float) -> float:
    """A goal's tolerance against the default: > 0 replaces it, -1 erases it (0, not
    enforced), 0 keeps the default; another negative value is refused."""
    if goal_value > 0.0:
        return float(goal_value)
    if abs(goal_value - ERASE_VALUE) < _ERASE_EPS:
        return 0.0
    if goal_value < 0.0:  # NaN is neither: it keeps the default, as in the C++
        raise TrajectoryValueError("Illegal tolerance value.")
    return float(default_value)


@dataclass(frozen=True)
class JointTolerance:
    """One entry of a goal's ``path_tolerance`` or ``goal_tolerance``
    (control_msgs/JointTolerance): 0 keeps the default, -1 erases it."""

    name: str
    position: float = 0.0
    velocity: float = 0.0
    acceleration: float = 0.0


@dataclass(frozen=True)
class GoalTolerances:
    """The tolerances a goal asked for, and, when the goal's were refused and the defaults
    kept, the line the controller logs as its error (None when accepted)."""

    tolerances: SegmentTolerances
    error: str | None = None


def _override(defaults: tuple[StateTolerance, ...], active: list[StateTolerance],
              entries: Sequence[JointTolerance], joints: Sequence[str], where: str) -> str | None:
    """Apply ``entries`` to ``active`` (in place); the error line if one is refused."""
    for entry in entries:
        if entry.name not in joints:
            return (f"joint '{entry.name}' specified in goal.{where} does not exist. "
                    "Using default tolerances.")
        i = list(joints).index(entry.name)
        values = {}
        for interface in ("position", "velocity", "acceleration"):
            try:
                values[interface] = resolve_tolerance_source(getattr(defaults[i], interface),
                                                             getattr(entry, interface))
            except TrajectoryValueError:
                return (f"joint '{entry.name}' specified in goal.{where} has a invalid "
                        f"{interface} tolerance. Using default tolerances.")
        active[i] = replace(active[i], **values)
    return None


def segment_tolerances_from_goal(defaults: SegmentTolerances, joints: Sequence[str],
                                 path_tolerance: Sequence[JointTolerance] = (),
                                 goal_tolerance: Sequence[JointTolerance] = (),
                                 goal_time_tolerance: float = 0.0) -> GoalTolerances:
    """A FollowJointTrajectory goal's tolerances over ``defaults``, as
    ``get_segment_tolerances(logger, default_tolerances, goal, joints)`` makes them.

    ``joints`` are the controller's, in its order. Each field resolves against the
    *default* (not against an earlier entry for the same joint). If the goal time, any
    joint name or any value is refused, the whole goal's tolerances are dropped and
    ``defaults`` returned with the error line, as the C++ does; the goal itself is still
    executed.
    """
    if len(defaults.state_tolerance) != len(joints) or \
            len(defaults.goal_state_tolerance) != len(joints):
        raise TrajectoryValueError(f"defaults have tolerances for "
                                   f"{len(defaults.state_tolerance)} joints, not {len(joints)}")
    try:
        goal_time = resolve_tolerance_source(defaults.goal_time_tolerance, goal_time_tolerance)
    except TrajectoryValueError:
        return GoalTolerances(defaults, f"Specified illegal goal_time_tolerance: "
                                        f"{goal_time_tolerance:f}. Using default tolerances")
    state = list(defaults.state_tolerance)
    error = _override(defaults.state_tolerance, state, path_tolerance, joints, "path_tolerance")
    if error is not None:
        return GoalTolerances(defaults, error)
    goal = list(defaults.goal_state_tolerance)
    error = _override(defaults.goal_state_tolerance, goal, goal_tolerance, joints,
                      "goal_tolerance")
    if error is not None:
        return GoalTolerances(defaults, error)
    return GoalTolerances(SegmentTolerances(tuple(state), tuple(goal), goal_time))


def _violations(error_position: float, error_velocity: float, error_acceleration: float,
                tolerance: StateTolerance) -> list[str]:
    out = []
    for name, error, limit in (("Position", error_position, tolerance.position),
                               ("Velocity", error_velocity, tolerance.velocity),
                               ("Acceleration", error_acceleration, tolerance.acceleration)):
        if limit > 0.0 and abs(error) > limit:
            out.append(f"{name} Error: {error:f}, {name} Tolerance: {limit:f}")
    return out


def _errors_of(errors: ArrayLike | None, joint_index: int) -> float:
    """One joint's error; a field not given counts as 0, as in the C++."""
    if errors is None:
        return 0.0
    array = np.asarray(errors, dtype=np.float64)
    return 0.0 if array.size == 0 else float(array[joint_index])


def check_state_tolerance_per_joint(error_positions: ArrayLike, joint_index: int,
                                    tolerance: StateTolerance,
                                    error_velocities: ArrayLike | None = None,
                                    error_accelerations: ArrayLike | None = None) -> bool:
    """Whether joint ``joint_index``'s errors (desired - actual, arrays of all joints) are
    within ``tolerance``; a tolerance of 0 passes every error, missing errors count as 0."""
    return not _violations(_errors_of(error_positions, joint_index),
                           _errors_of(error_velocities, joint_index),
                           _errors_of(error_accelerations, joint_index), tolerance)


def state_tolerance_message(error_positions: ArrayLike, joint_index: int,
                            tolerance: StateTolerance,
                            error_velocities: ArrayLike | None = None,
                            error_accelerations: ArrayLike | None = None) -> str | None:
    """The C++'s error log for a joint outside ``tolerance`` on one line (its lines joined
    with "; "), or None when the joint is within it."""
    lines = _violations(_errors_of(error_positions, joint_index),
                        _errors_of(error_velocities, joint_index),
                        _errors_of(error_accelerations, joint_index), tolerance)
    if not lines:
        return None
    return f"State tolerances failed for joint {joint_index}: " + "; ".join(lines)


@dataclass(frozen=True)
class ToleranceCheck:
    """The joints (indices) outside their tolerances, and the message of each."""

    violating: tuple[int, ...]
    messages: tuple[str, ...]

    @property
    def ok(self) -> bool:
        """True when every joint is within its tolerance."""
        return not self.violating


def check_state_tolerances(error_positions: ArrayLike, tolerances: Sequence[StateTolerance],
                           error_velocities: ArrayLike | None = None,
                           error_accelerations: ArrayLike | None = None) -> ToleranceCheck:
    """:func:`check_state_tolerance_per_joint` for every joint, as the controller's update
    loops over them: which violate, with the messages it would log."""
    positions = np.asarray(error_positions, dtype=np.float64)
    if positions.ndim != 1 or positions.size != len(tolerances):
        raise TrajectoryValueError(f"{positions.size} position errors for "
                                   f"{len(tolerances)} joints' tolerances")
    violating, messages = [], []
    for i, tolerance in enumerate(tolerances):
        message = state_tolerance_message(positions, i, tolerance, error_velocities,
                                          error_accelerations)
        if message is not None:
            violating.append(i)
            messages.append(message)
    return ToleranceCheck(tuple(violating), tuple(messages))


def goal_time_exceeded(time_since_last_point: float, goal_time_tolerance: float) -> bool:
    """Whether a goal still outside its goal tolerances has run out of time: more than
    ``goal_time_tolerance`` seconds after the last point's time, and the tolerance is not 0
    (0: the controller waits as long as it takes)."""
    return goal_time_tolerance != 0.0 and time_since_last_point > goal_time_tolerance
