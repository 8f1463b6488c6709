"""The OpenMANIPULATOR-X's Foxglove / Lichtblick layout (``servolab view --layout
open_manipulator_x``): the arm in 3D from its URDF and /tf, its joints' angles, the gripper's
opening and the load gravity puts on the shoulder and elbow.

``/joint_states`` lists the joints in the ``<ros2_control>`` block's order (joint1 to joint4,
then gripper_left_joint), as joint_state_broadcaster publishes them; effort is N m (servolab's
hardware gives an XM430's present current times its torque constant).
"""

from __future__ import annotations

from servolab.middleware.view.layout import Layout, Plot, ThreeD

from . import NAME

#: the arm's joints, in /joint_states' order
ARM = ("joint1", "joint2", "joint3", "joint4")


def layout() -> Layout:
    return Layout(NAME, f"{NAME}: the arm in 3D, its joints, its gripper and its gravity load", (
        ThreeD("robot", ("/tf", "/tf_static"), frame="world", urdf_topic="/robot_description"),
        Plot("joints", [f"/joint_states.position[{i}]" for i in range(len(ARM))],
             title=f"{', '.join(ARM)} (rad)"),
        Plot("gripper", [f"/joint_states.position[{len(ARM)}]"],
             title="gripper_left_joint (m, positive opens)"),
        Plot("load", ["/joint_states.effort[1]", "/joint_states.effort[2]"],
             title="joint2, joint3 effort (N m): what holds the arm up")))
