"""Each robot's Foxglove / Lichtblick layout (``servolab view --layout NAME`` writes it): the
panels its user looks at, on the topics its run publishes and records.

Topic names come from the robots' own modules, so a renamed topic renames the panel's too;
``tests/robots/test_view_layouts.py`` checks that every topic a layout shows is one the
robot's recorded run holds.
"""

from __future__ import annotations

from servolab.errors import UsageError
from servolab.middleware.view.layout import Image, Layout, Plot, Raw, ThreeD

from .navigation.display import COSTMAP_TOPIC, DRIVEN_PATH_TOPIC, GOAL_TOPIC, LOCAL_PLAN_TOPIC
from .treadmill.node import FICTRAC_TOPIC, OVERLAY_TOPIC

#: the joints plotted for the biped: the first leg's six, in /joint_states' (the URDF's) order
_LEG_JOINTS = 6
#: the biped's URDF root link, which its /tf tree hangs from (nothing places it in a world)
ARMSTRONG_ROOT = "pelvis"

LAYOUTS: dict[str, Layout] = {layout.name: layout for layout in (
    Layout("armstrong", "servolab walk: the biped in 3D from its URDF and /tf, one leg's joint "
           "angles over time, the motors' diagnostics", (
               ThreeD("robot", ("/tf", "/tf_static"), frame=ARMSTRONG_ROOT,
                      urdf_topic="/robot_description"),
               Plot("leg", [f"/joint_states.position[{i}]" for i in range(_LEG_JOINTS)],
                    title="left leg: hip yaw, roll, pitch, knee, ankle pitch, roll (rad)"),
               Raw("diagnostics", "/diagnostics"))),
    Layout("navigation", "servolab navigate: the map, the costmap, the global plan, the path "
           "driven, DWA's chosen trajectory and the goal, around the robot", (
               ThreeD("map", ("/map", COSTMAP_TOPIC, "/plan", DRIVEN_PATH_TOPIC,
                              LOCAL_PLAN_TOPIC, GOAL_TOPIC, "/tf"),
                      frame="map", follow="base_footprint"),
               Plot("speed", ["/cmd_vel.linear.x", "/cmd_vel.angular.z"],
                    title="cmd_vel (m/s, rad/s)"),
               Raw("status", "/navigate_to_pose/_action/status"))),
    Layout("base", "servolab drive: the base's odometry in 3D and its wheel commands", (
        ThreeD("odom", ("/odom", "/tf"), frame="odom", follow="base_footprint"),
        Plot("speed", ["/cmd_vel.linear.x", "/cmd_vel.angular.z", "/odom.twist.twist.linear.x"],
             title="commanded and measured speed"))),
    Layout("treadmill", "servolab flyball: the fly camera with Listing 1's overlay, the fly's "
           "pose and the ball's rotation", (
               Image("camera", OVERLAY_TOPIC),
               Plot("fly", ["/fly/pose.x", "/fly/pose.y", "/fly/pose.theta"],
                    title="fly pose"),
               Plot("ball", [f"{FICTRAC_TOPIC}.data[0]", f"{FICTRAC_TOPIC}.data[1]",
                             f"{FICTRAC_TOPIC}.data[2]"], title="ball rotation"))),
)}


def layout_named(name: str) -> Layout:
    """The layout called ``name``, or a one-line error listing the names there are."""
    try:
        return LAYOUTS[name]
    except KeyError:
        raise UsageError(f"no layout {name!r}; there are: {', '.join(sorted(LAYOUTS))}") \
            from None
