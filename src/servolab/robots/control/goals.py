"""Ending an action goal the way a ros2_controllers controller ends it, for the controllers
that serve actions (:mod:`.joint_trajectory`, :mod:`.gripper_action`)."""

from __future__ import annotations

from ...rclpy.action import ServerGoalHandle
from ...rclpy.action.server import GoalEvent

#: how a goal ends, as the controllers say it
ENDINGS = ("succeed", "abort", "canceled")


def end_goal(handle: ServerGoalHandle, how: str) -> None:
    """End an active goal ``how`` (one of :data:`ENDINGS`). A goal the controller itself
    ends canceled (preempted by a newer goal, the controller deactivated) was never asked to
    cancel, and rcl_action's state machine cancels from CANCELING only: it goes through
    CANCELING first, as if asked."""
    if not handle.is_active:
        return
    if how == "canceled" and not handle.is_cancel_requested:
        handle._update_state(GoalEvent.CANCEL_GOAL)
    {"succeed": handle.succeed, "abort": handle.abort, "canceled": handle.canceled}[how]()
