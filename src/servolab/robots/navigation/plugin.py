"""Seed 000's navigation as a servolab robot plug-in: the two-wheel robot of the scene under its
overhead camera, planning with D* Lite and DWA. Its files are the scene and the planners'
parameter files (D.2, D.3, move_base's). Nothing here imports the robot until asked."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from ..base import ON_STOP
from ..plugin import BusSummary, RobotPlugin, ShownFile

if TYPE_CHECKING:
    from ...middleware.view.layout import Layout


def _bus() -> BusSummary:
    from ..base.plugin import base_bus
    from .params import load_nav_scene

    return base_bus(load_nav_scene().base)


def _open(port: str | None) -> Any:
    """The scene's base (the robot that navigates), emulated on the floor or on ``port``."""
    from ..base.plugin import open_base_file
    from .params import load_nav_scene

    return open_base_file(load_nav_scene().base, port)


def _files() -> Mapping[str, ShownFile]:
    from ...sim.scene import DEFAULT_SCENE
    from .params import DEFAULT_COSTMAP, DEFAULT_DWA, DEFAULT_MOVE_BASE

    return {"costmap_params": DEFAULT_COSTMAP, "dwa_params": DEFAULT_DWA,
            "move_base_params": DEFAULT_MOVE_BASE, "nav_scene": DEFAULT_SCENE}


def _layout() -> Layout:
    from .layout import LAYOUT

    return LAYOUT


ROBOTS = (RobotPlugin("navigation", "seed 000's robot navigating under its overhead camera "
                      "(D* Lite, DWA), on the scene's base", bus=_bus, open=_open,
                      on_stop=ON_STOP, files=_files, layout=_layout,
                      commands=("navigate", "plan")),)
