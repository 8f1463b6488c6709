"""Joint trajectories as ros2_controllers' ``joint_trajectory_controller`` (ROS 2 Jazzy
branch) handles them, so a controller written in Python commands what the ROS one would.
Pure: numpy arrays and seconds in, arrays out; no I/O, no threads, no clock, no messages.

Each module follows one part of ``ros-controls/ros2_controllers``,
``joint_trajectory_controller/`` (read for its behaviour; the code here is our own):

==================  ==========================================================================
module              follows
==================  ==========================================================================
``spline``          ``src/trajectory.cpp``: ``Trajectory::interpolate_between_points``
                    (linear / cubic / quintic by the fields both ends give)
``trajectory``      ``src/trajectory.cpp``, ``include/.../trajectory.hpp``: ``Trajectory``,
                    ``sample``, ``set_point_before_trajectory_msg``;
                    ``include/.../interpolation_methods.hpp``
``wraparound``      ``src/trajectory.cpp``: ``wraparound_joint`` (and ROS ``angles``)
``tolerances``      ``include/.../tolerances.hpp``: ``get_segment_tolerances`` (both),
                    ``check_state_tolerance_per_joint``; defaults from
                    ``src/joint_trajectory_controller_parameters.yaml``; the goal-time check
                    of ``JointTrajectoryController::update``
``validation``      ``src/joint_trajectory_controller.cpp``: ``validate_trajectory_msg``
``joint_order``     ``src/joint_trajectory_controller.cpp``: ``fill_partial_goal``,
                    ``sort_to_local_joint_order``
==================  ==========================================================================

Documentation: ``doc/userdoc.rst``, ``doc/trajectory.rst``, ``doc/parameters.rst``; cases
from ``test/test_trajectory.cpp``, ``test/test_tolerances.cpp`` and
``test/test_trajectory_controller.cpp`` are tests/test_trajectories.py's.
"""

from .errors import TrajectoryError, TrajectoryValueError
from .joint_order import JointArrays, fill_partial_goal, sort_to_local_joint_order
from .spline import (
    PointState,
    SplineKind,
    interpolate_between_points,
    interpolate_segment,
    spline_kind,
)
from .tolerances import (
    Constraints,
    GoalTolerances,
    JointConstraints,
    JointTolerance,
    SegmentTolerances,
    StateTolerance,
    ToleranceCheck,
    check_state_tolerance_per_joint,
    check_state_tolerances,
    default_segment_tolerances,
    goal_time_exceeded,
    resolve_tolerance_source,
    segment_tolerances_from_goal,
    state_tolerance_message,
)
from .trajectory import InterpolationMethod, SamplePhase, Trajectory, TrajectorySample
from .validation import ValidationConfig, validate_trajectory
from .wraparound import normalize_angle, shortest_angular_distance, wraparound_joint

__all__ = [
    "Constraints",
    "GoalTolerances",
    "InterpolationMethod",
    "JointArrays",
    "JointConstraints",
    "JointTolerance",
    "PointState",
    "SamplePhase",
    "SegmentTolerances",
    "SplineKind",
    "StateTolerance",
    "ToleranceCheck",
    "Trajectory",
    "TrajectoryError",
    "TrajectorySample",
    "TrajectoryValueError",
    "ValidationConfig",
    "check_state_tolerance_per_joint",
    "check_state_tolerances",
    "default_segment_tolerances",
    "fill_partial_goal",
    "goal_time_exceeded",
    "interpolate_between_points",
    "interpolate_segment",
    "normalize_angle",
    "resolve_tolerance_source",
    "segment_tolerances_from_goal",
    "shortest_angular_distance",
    "sort_to_local_joint_order",
    "spline_kind",
    "state_tolerance_message",
    "validate_trajectory",
    "wraparound_joint",
]
