"""The treadmill's Foxglove / Lichtblick layout (``servolab view --layout treadmill``)."""

from __future__ import annotations

from ...middleware.view.layout import Image, Layout, Plot
from .node import FICTRAC_TOPIC, OVERLAY_TOPIC

LAYOUT = Layout(
    "treadmill", "servolab flyball: the fly camera with Listing 1's overlay, the fly's pose and "
    "the ball's rotation", (
        Image("camera", OVERLAY_TOPIC),
        Plot("fly", ["/fly/pose.x", "/fly/pose.y", "/fly/pose.theta"], title="fly pose"),
        Plot("ball", [f"{FICTRAC_TOPIC}.data[0]", f"{FICTRAC_TOPIC}.data[1]",
                      f"{FICTRAC_TOPIC}.data[2]"], title="ball rotation")))
