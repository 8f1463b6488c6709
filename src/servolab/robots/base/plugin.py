"""The shipped differential-drive bases as servolab robot plug-ins: seed 000's two-wheel and
four-motor robots and a TurtleBot3 Waffle, one :class:`~..plugin.RobotPlugin` per base file.
Nothing here imports the base until asked."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..plugin import BusSummary, RobotPlugin
from . import ON_STOP, SHIPPED

if TYPE_CHECKING:
    from ...middleware.view.layout import Layout


def base_bus(path: Path) -> BusSummary:
    """What the base of the file ``path`` is on its bus."""
    from .config import load

    base = load(path)
    return BusSummary.of(base.model.name, tuple(m.id for m in base.motors), base.protocol,
                         base.baudrate)


def open_base_file(path: Path, port: str | None) -> Any:
    """The base of the file ``path``: emulated on the simulated floor, or on ``port``."""
    from .config import load
    from .mobile_base import open_base

    return open_base(load(path), port)


def _layout() -> Layout:
    from .layout import LAYOUT

    return LAYOUT


def _base(name: str, summary: str, aliases: tuple[str, ...] = ()) -> RobotPlugin:
    def config() -> Path:
        from .config import shipped_base

        return shipped_base(name)

    return RobotPlugin(name, summary, bus=lambda: base_bus(config()),
                       open=lambda port: open_base_file(config(), port), on_stop=ON_STOP,
                       config=config, layout=_layout, aliases=aliases, commands=("drive",))


ROBOTS = tuple(_base(name, summary) for name, summary in SHIPPED.items())
