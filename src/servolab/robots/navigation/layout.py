"""The navigation's Foxglove / Lichtblick layout (``servolab view --layout navigation``)."""

from __future__ import annotations

from ...middleware.view.layout import Layout, Plot, Raw, ThreeD
from .display import COSTMAP_TOPIC, DRIVEN_PATH_TOPIC, GOAL_TOPIC, LOCAL_PLAN_TOPIC

LAYOUT = Layout(
    "navigation", "servolab navigate: the map, the costmap, the global plan, the path driven, "
    "DWA's chosen trajectory and the goal, around the robot", (
        ThreeD("map", ("/map", f"/{COSTMAP_TOPIC}", "/plan", f"/{DRIVEN_PATH_TOPIC}",
                       f"/{LOCAL_PLAN_TOPIC}", f"/{GOAL_TOPIC}", "/tf"), frame="map",
               follow="base_footprint"),
        Plot("speed", ["/cmd_vel.linear.x", "/cmd_vel.angular.z"], title="cmd_vel (m/s, rad/s)"),
        Raw("status", "/navigate_to_pose/_action/status")))
