"""The controller types a controller manager can load, by the plugin names a controllers
file gives (``type: joint_trajectory_controller/JointTrajectoryController``).

The standard ones are ros2_controllers'; a lab adds its own by passing a mapping of its
types to :class:`~.manager.ControllerManager` (no shared registry is edited).
"""

from __future__ import annotations

from collections.abc import Mapping

from .controller import ControllerInterface


def standard_types() -> Mapping[str, type[ControllerInterface]]:
    """ros2_controllers' controllers that servolab ships, by type name."""
    from . import diff_drive, forward_command, joint_state_broadcaster, joint_trajectory
    from .gripper_action import CONTROLLERS as GRIPPER_ACTION

    classes: list[type[ControllerInterface]] = [
        joint_state_broadcaster.JointStateBroadcaster,
        joint_trajectory.JointTrajectoryController,
        forward_command.ForwardCommandController,
        forward_command.MultiInterfaceForwardCommandController,
        forward_command.JointGroupPositionController,
        forward_command.JointGroupVelocityController,
        forward_command.JointGroupEffortController,
        diff_drive.DiffDriveController,
        *GRIPPER_ACTION,
    ]
    return {c.TYPE: c for c in classes}
