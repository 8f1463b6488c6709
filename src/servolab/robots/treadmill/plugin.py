"""The treadmill as a servolab robot plug-in: seed 002's ball on three omni-wheels; its
configuration is the thesis's rig (``treadmill.yaml``: ball, camera, tracker, controller).
Nothing here imports the robot until asked."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..plugin import BusSummary, RobotPlugin
from . import ON_STOP

if TYPE_CHECKING:
    from ...middleware.view.layout import Layout


def _bus() -> BusSummary:
    from .node import TREADMILL_BAUDRATE, TREADMILL_IDS, TREADMILL_MODEL

    return BusSummary.of(TREADMILL_MODEL, TREADMILL_IDS, 2, TREADMILL_BAUDRATE)


def _config() -> Path:
    from .config import SHIPPED_RIG

    return SHIPPED_RIG


def _open(port: str | None) -> Any:
    from .node import Treadmill

    return Treadmill.open(port)


def _layout() -> Layout:
    from .layout import LAYOUT

    return LAYOUT


ROBOTS = (RobotPlugin("treadmill", "seed 002's ball treadmill on three omni-wheels",
                      bus=_bus, open=_open, on_stop=ON_STOP, config=_config, layout=_layout,
                      aliases=("seed002",), commands=("flyball",)),)
