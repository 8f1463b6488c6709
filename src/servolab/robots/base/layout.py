"""A differential-drive base's Foxglove / Lichtblick layout (``servolab view --layout base``)."""

from __future__ import annotations

from ...middleware.view.layout import Layout, Plot, ThreeD

LAYOUT = Layout(
    "base", "servolab drive: the base's odometry in 3D and its wheel commands", (
        ThreeD("odom", ("/odom", "/tf"), frame="odom", follow="base_footprint"),
        Plot("speed", ["/cmd_vel.linear.x", "/cmd_vel.angular.z", "/odom.twist.twist.linear.x"],
             title="commanded and measured speed")))
