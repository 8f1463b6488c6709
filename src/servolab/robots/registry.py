"""The robots servolab ships, by name, as ``dm_control.suite.load`` finds its domains.

``load("armstrong")`` gives the robot on emulated motors; ``load("armstrong", port=DEV)`` the
same robot on real ones. Each entry says what the robot is on its bus (model, IDs, protocol,
baud rate) and which configuration file it starts from, so ``servolab robots`` can list them and
``servolab robots show NAME`` print that file for a user to copy and edit. A fifth robot is one
more :class:`RobotEntry` here and a subpackage beside the others.

The entries import nothing of their robot until loaded: ``servolab robots`` reads only the
configuration files.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import ServolabError
from .armstrong import ON_STOP as ARMSTRONG_ON_STOP
from .base import ON_STOP as BASE_ON_STOP
from .treadmill import ON_STOP as TREADMILL_ON_STOP


class UnknownRobotError(ServolabError, ValueError):
    """A robot name that is not in :data:`ROBOTS`."""


@dataclass(frozen=True)
class BusSummary:
    """What a robot is on its bus, for a listing."""

    model: str
    ids: tuple[int, ...]
    protocol: int
    baudrate: int

    def __str__(self) -> str:
        return (f"{len(self.ids)} x {self.model} (IDs {_ranges(self.ids)}), Protocol "
                f"{self.protocol:.1f}, {self.baudrate} bps")


@dataclass(frozen=True)
class RobotEntry:
    """One robot: its name, the seed it comes from, its default configuration file (None when
    its parameters are in code), how to describe its bus and how to open it."""

    name: str
    summary: str
    config: Callable[[], Path | None]
    bus: Callable[[], BusSummary]
    opener: Callable[[str | None], Any]
    stops_by: str

    def load(self, port: str | None = None) -> Any:
        return self.opener(port)


def _ranges(ids: tuple[int, ...]) -> str:
    """``11-16,21-26``: runs of consecutive IDs, as ``emu://`` URLs write them."""
    parts: list[str] = []
    start = previous = None
    for i in sorted(ids):
        if previous is not None and i == previous + 1:
            previous = i
            continue
        if start is not None:
            parts.append(f"{start}" if start == previous else f"{start}-{previous}")
        start = previous = i
    if start is not None:
        parts.append(f"{start}" if start == previous else f"{start}-{previous}")
    return ",".join(parts)


# -- Armstrong ---------------------------------------------------------------------------------

def _armstrong_config() -> Path:
    from .armstrong.hardware import CONFIG

    return CONFIG


def _armstrong_bus() -> BusSummary:
    from .armstrong import hardware

    config = hardware.load_config()
    port = config.manager.serial_ports[0]
    ids = tuple(c.motor.id for c in config.controllers if c.motor.id not in hardware.ABSENT)
    return BusSummary(hardware.MODEL, ids, 1, port.baud_rate)


def _armstrong(port: str | None) -> Any:
    from .armstrong.control_node import Armstrong

    return Armstrong(port=port)


# -- differential-drive bases ------------------------------------------------------------------

def _base_entry(name: str, summary: str) -> RobotEntry:
    def config() -> Path:
        from .base.config import shipped_base

        return shipped_base(name)

    def bus() -> BusSummary:
        from .base.config import load

        base = load(config())
        return BusSummary(base.model.name, tuple(m.id for m in base.motors), base.protocol,
                          base.baudrate)

    def opener(port: str | None) -> Any:
        from .base.config import load
        from .base.mobile_base import open_base

        return open_base(load(config()), port)

    return RobotEntry(name, summary, config, bus, opener, BASE_ON_STOP)


# -- the treadmill -----------------------------------------------------------------------------

def _treadmill_bus() -> BusSummary:
    from .treadmill.node import TREADMILL_BAUDRATE, TREADMILL_IDS, TREADMILL_MODEL

    return BusSummary(TREADMILL_MODEL, TREADMILL_IDS, 2, TREADMILL_BAUDRATE)


def _treadmill(port: str | None) -> Any:
    from .treadmill.node import Treadmill

    return Treadmill.open(port)


#: every robot servolab ships, by name
ROBOTS: dict[str, RobotEntry] = {e.name: e for e in (
    RobotEntry("armstrong", "seed 001's 21-servo biped (20 on its bus), dynamixel_motor "
               "controllers", _armstrong_config, _armstrong_bus, _armstrong,
               ARMSTRONG_ON_STOP),
    _base_entry("seed000", "seed 000's two-wheel robot, EX-106+ in wheel mode"),
    _base_entry("seed000_4motor", "seed 000 A.2's four-motor robot"),
    _base_entry("turtlebot3_waffle", "a TurtleBot3 Waffle (seed 002's robot), XM430 wheels"),
    RobotEntry("treadmill", "seed 002's ball treadmill on three omni-wheels",
               lambda: None, _treadmill_bus, _treadmill, TREADMILL_ON_STOP),
)}


def entry(name: str) -> RobotEntry:
    try:
        return ROBOTS[name]
    except KeyError:
        raise UnknownRobotError(f"no robot {name!r}; there are {', '.join(ROBOTS)}") from None


def load(name: str, port: str | None = None) -> Any:
    """The robot ``name`` on emulated motors, or on the serial port (or pyserial URL)
    ``port``: Armstrong's :class:`~.armstrong.control_node.Armstrong`, a base's
    :class:`~.base.mobile_base.MobileBase`, the treadmill's :class:`~.treadmill.node.Treadmill`.
    Each closes with ``close()`` (Armstrong also as a context manager)."""
    return entry(name).load(port)


def robot_models() -> dict[str, Callable[[], str]]:
    """The robot descriptions ``servolab robots show`` prints, by name: written from the
    robot's one model each time (:mod:`.armstrong.description`), not shipped as files."""
    from .armstrong.description import assumptions_table, model_file

    return {"armstrong.urdf": lambda: model_file("urdf"),
            "armstrong.mjcf": lambda: model_file("mjcf"),
            "armstrong.assumptions": assumptions_table}


def shipped_files() -> dict[str, Path]:
    """Every configuration file servolab ships, by the name ``servolab robots show`` takes:
    each robot's default file, and the navigation's parameter files and scene."""
    from ..sim.scene import DEFAULT_SCENE
    from .navigation.params import DEFAULT_COSTMAP, DEFAULT_DWA, DEFAULT_MOVE_BASE

    files = {name: path for name, e in ROBOTS.items() if (path := e.config()) is not None}
    files.update({"costmap_params": DEFAULT_COSTMAP, "dwa_params": DEFAULT_DWA,
                  "move_base_params": DEFAULT_MOVE_BASE, "nav_scene": DEFAULT_SCENE})
    return files
