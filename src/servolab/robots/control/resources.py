"""The interfaces of a robot's hardware and who holds them: ros2_control's ResourceManager.

Every hardware component exports *state interfaces* (``joint1/position``: what it reads) and
*command interfaces* (``joint1/position``: what it is told). ros2_control's rules, kept here:

- a component is ``unconfigured``, ``inactive`` or ``active`` (lifecycle_msgs' states); its
  state interfaces are available once it is configured (inactive or active), its command
  interfaces only while it is active (``resource_manager.cpp``: ``make_*_available``);
- a command interface is claimed by one controller at a time; a state interface by any
  number (``command_interface_is_claimed``);
- a value nobody has written is NaN (``hardware_interface::Handle``'s default).

Values live in one flat dict per kind, keyed by the interface's full name, which the hardware
and the controllers share through :class:`Handle` objects: no copies in the update loop.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass

from ..errors import RobotValueError

#: lifecycle_msgs/msg/State ids and labels a hardware component or controller takes
UNKNOWN, UNCONFIGURED, INACTIVE, ACTIVE, FINALIZED = 0, 1, 2, 3, 4
STATE_LABELS = {UNKNOWN: "unknown", UNCONFIGURED: "unconfigured", INACTIVE: "inactive",
                ACTIVE: "active", FINALIZED: "finalized"}
STATE_IDS = {label: number for number, label in STATE_LABELS.items()}


class InterfaceError(RobotValueError):
    """An interface asked for that no component exports, or one claimed twice."""


class Handle:
    """One interface's value: ``get_value`` / ``set_value`` as ros2_control's loaned
    interfaces give them, on the shared table of values."""

    __slots__ = ("_values", "interface", "name", "prefix")

    def __init__(self, name: str, values: dict[str, float]) -> None:
        self.name = name
        self.prefix, _, self.interface = name.rpartition("/")
        self._values = values

    def get_value(self) -> float:
        return self._values[self.name]

    def set_value(self, value: float) -> None:
        self._values[self.name] = float(value)

    def get_name(self) -> str:
        return self.name

    def get_prefix_name(self) -> str:
        return self.prefix

    def get_interface_name(self) -> str:
        return self.interface

    def __repr__(self) -> str:
        return f"Handle({self.name}={self._values.get(self.name, math.nan)!r})"


@dataclass
class ComponentStatus:
    """A hardware component as ``list_hardware_components`` tells of it."""

    name: str
    type: str
    plugin: str
    state: int
    state_interfaces: tuple[str, ...]
    command_interfaces: tuple[str, ...]

    @property
    def label(self) -> str:
        return STATE_LABELS[self.state]


class Interfaces:
    """The tables of values and the claims on them. The hardware components register their
    interfaces at load; :mod:`.manager` claims and releases them for its controllers."""

    def __init__(self) -> None:
        self.states: dict[str, float] = {}
        self.commands: dict[str, float] = {}
        #: command interface -> the controller that holds it
        self.claimed: dict[str, str] = {}
        #: interfaces whose component is in a state that offers them
        self.available_states: set[str] = set()
        self.available_commands: set[str] = set()

    def add(self, states: Iterable[tuple[str, float]], commands: Iterable[tuple[str, float]],
            owner: str) -> None:
        for name, initial in states:
            if name in self.states:
                raise InterfaceError(f"{owner}: state interface {name} is exported twice")
            self.states[name] = initial
        for name, initial in commands:
            if name in self.commands:
                raise InterfaceError(f"{owner}: command interface {name} is exported twice")
            self.commands[name] = initial

    def state(self, name: str) -> Handle:
        if name not in self.states:
            raise InterfaceError(f"no state interface {name!r}")
        return Handle(name, self.states)

    def command(self, name: str) -> Handle:
        if name not in self.commands:
            raise InterfaceError(f"no command interface {name!r}")
        return Handle(name, self.commands)

    def claim(self, names: Iterable[str], controller: str) -> list[Handle]:
        """The command interfaces ``names``, claimed by ``controller`` (all or none)."""
        names = list(names)
        for name in names:
            holder = self.claimed.get(name)
            if holder is not None and holder != controller:
                raise InterfaceError(f"command interface {name} is claimed by {holder}")
            if name not in self.commands:
                raise InterfaceError(f"no command interface {name!r}")
        for name in names:
            self.claimed[name] = controller
        return [Handle(n, self.commands) for n in names]

    def release(self, controller: str) -> None:
        for name in [n for n, holder in self.claimed.items() if holder == controller]:
            del self.claimed[name]

    def claimed_by(self, controller: str) -> list[str]:
        return [n for n, holder in self.claimed.items() if holder == controller]

    def __iter__(self) -> Iterator[str]:
        return iter(self.states)
