"""The shipped differential-drive bases as servolab robot plug-ins: seed 000's two-wheel and
four-motor robots and a TurtleBot3 Waffle, one :class:`~..plugin.RobotPlugin` per base file.
Each is served on the simulated floor (``servolab sim --robot NAME``); a base whose
controllers file is shipped beside its base file (``<name>_controllers.yaml``) also has a URDF
with its ``<ros2_control>`` block (:mod:`.ros2_control`), so ``servolab control run NAME`` brings
it up. Nothing here imports the base until asked."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..plugin import BusSummary, RobotPlugin, ServedRobot, ShownFile
from . import ON_STOP, SHIPPED

if TYPE_CHECKING:
    from collections.abc import Callable, Mapping

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


def served_base(path: Path, baudrate: int | None) -> ServedRobot:
    """The base of the file ``path``'s motors, rolling its wheels on the simulated floor."""
    from .config import load
    from .ros2_control import floor_figures, on_floor

    base = load(path)
    spec = base_bus(path).motor_spec()
    return ServedRobot(spec if baudrate is None else spec.at_baudrate(baudrate),
                       place=on_floor(base), report=floor_figures,
                       what=f"rolling the {base.name} base on the floor")


def base_urdf(path: Path) -> str:
    """The URDF, with its ``<ros2_control>`` block, of the base of the file ``path``."""
    from .config import load
    from .ros2_control import control_urdf

    return control_urdf(load(path))


def _base(name: str, summary: str, aliases: tuple[str, ...] = ()) -> RobotPlugin:
    def config() -> Path:
        from .config import shipped_base

        return shipped_base(name)

    # a controllers file beside the base file: the base runs under ros2_control too
    controllers = Path(__file__).with_name(f"{name}_controllers.yaml")
    description: Callable[[], str] | None = None

    def files() -> Mapping[str, ShownFile]:
        return {}

    if controllers.is_file():
        def description() -> str:
            return base_urdf(config())

        def files() -> Mapping[str, ShownFile]:
            return {f"{name}.controllers": controllers}

    return RobotPlugin(name, summary, bus=lambda: base_bus(config()),
                       open=lambda port: open_base_file(config(), port), on_stop=ON_STOP,
                       config=config, files=files, description=description,
                       served=lambda baudrate: served_base(config(), baudrate),
                       layout=_layout, aliases=aliases, commands=("drive",))


ROBOTS = tuple(_base(name, summary) for name, summary in SHIPPED.items())
