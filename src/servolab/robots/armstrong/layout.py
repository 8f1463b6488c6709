"""Armstrong's Foxglove / Lichtblick layout (``servolab view --layout armstrong``): the biped in
3D from its URDF and /tf, one leg's joint angles, the motors' diagnostics."""

from __future__ import annotations

from ...middleware.view.layout import Layout, Plot, Raw, ThreeD

#: the joints plotted for the biped: the first leg's six, in /joint_states' (the URDF's) order
_LEG_JOINTS = 6
#: the biped's URDF root link, which its /tf tree hangs from (nothing places it in a world)
ROOT_LINK = "pelvis"

LAYOUT = Layout(
    "armstrong", "servolab walk: the biped in 3D from its URDF and /tf, one leg's joint angles "
    "over time, the motors' diagnostics", (
        ThreeD("robot", ("/tf", "/tf_static"), frame=ROOT_LINK, urdf_topic="/robot_description"),
        Plot("leg", [f"/joint_states.position[{i}]" for i in range(_LEG_JOINTS)],
             title="left leg: hip yaw, roll, pitch, knee, ankle pitch, roll (rad)"),
        Raw("diagnostics", "/diagnostics")))
