"""The hardware components of a controller manager and their lifecycle states, as
ros2_control's ResourceManager keeps them (``resource_manager.cpp``, Jazzy).

A component's interfaces enter the shared tables (:class:`~.resources.Interfaces`) when it is
loaded; its state interfaces are available while it is configured (inactive or active), its
command interfaces only while it is active. A read or write that fails sends the component
back to ``unconfigured`` (ros2_control's ``on_error`` succeeding), which takes its interfaces
away: the controllers that used them are deactivated by the manager.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass

from .hardware import SystemInterface
from .resources import (
    ACTIVE,
    FINALIZED,
    INACTIVE,
    STATE_IDS,
    STATE_LABELS,
    UNCONFIGURED,
    Interfaces,
)


@dataclass
class Component:
    """One loaded component and its state."""

    system: SystemInterface
    state: int = UNCONFIGURED

    @property
    def name(self) -> str:
        return self.system.name

    @property
    def label(self) -> str:
        return STATE_LABELS[self.state]


class Components:
    """Every component, the interface tables they share, and the transitions between states."""

    def __init__(self) -> None:
        self.interfaces = Interfaces()
        self.by_name: dict[str, Component] = {}
        #: interface full name -> its component's name
        self.owner: dict[str, str] = {}

    def load(self, system: SystemInterface) -> Component:
        states = system.export_state_interfaces()
        commands = system.export_command_interfaces()
        self.interfaces.add(states, commands, system.name)
        system.states = self.interfaces.states
        system.commands = self.interfaces.commands
        for name, _ in (*states, *commands):
            self.owner[name] = system.name
        component = self.by_name[system.name] = Component(system)
        return component

    def __iter__(self) -> Iterator[Component]:
        return iter(self.by_name.values())

    def interfaces_of(self, component: str) -> tuple[list[str], list[str]]:
        """(state, command) interface names of one component, in its export order."""
        states = [n for n in self.interfaces.states if self.owner.get(n) == component]
        commands = [n for n in self.interfaces.commands if self.owner.get(n) == component]
        return states, commands

    def set_state(self, name: str, target: int) -> tuple[bool, str]:
        """Move component ``name`` to ``target`` through the states between (as
        ``set_component_state`` does): (ok, message)."""
        component = self.by_name[name]
        system = component.system
        def cleanup() -> bool:
            return True

        steps: dict[tuple[int, int], list[tuple[str, Callable[[], bool], int]]] = {
            (UNCONFIGURED, INACTIVE): [("configure", system.on_configure, INACTIVE)],
            (UNCONFIGURED, ACTIVE): [("configure", system.on_configure, INACTIVE),
                                     ("activate", system.on_activate, ACTIVE)],
            (INACTIVE, ACTIVE): [("activate", system.on_activate, ACTIVE)],
            (ACTIVE, INACTIVE): [("deactivate", system.on_deactivate, INACTIVE)],
            (ACTIVE, UNCONFIGURED): [("deactivate", system.on_deactivate, INACTIVE),
                                     ("cleanup", cleanup, UNCONFIGURED)],
            (INACTIVE, UNCONFIGURED): [("cleanup", cleanup, UNCONFIGURED)],
        }
        if target == component.state:
            return True, f"component '{name}' is already {component.label}"
        if target == FINALIZED:
            if component.state == ACTIVE:
                system.on_deactivate()
            system.on_shutdown()
            component.state = FINALIZED
            self._availability(component)
            return True, f"component '{name}' is finalized"
        path = steps.get((component.state, target))
        if path is None:
            return False, (f"component '{name}' cannot go from {component.label} to "
                           f"{STATE_LABELS.get(target, target)}")
        for what, step, state in path:
            if not step():
                self._availability(component)
                return False, (f"Failed to {what} hardware component '{name}'"
                               + (f": {system.error}" if system.error else ""))
            component.state = state
        self._availability(component)
        return True, f"component '{name}' is {component.label}"

    def failed(self, name: str) -> None:
        """A read or write failed: the component is unconfigured (ros2_control's on_error)."""
        component = self.by_name[name]
        component.state = UNCONFIGURED
        self._availability(component)

    def _availability(self, component: Component) -> None:
        states, commands = self.interfaces_of(component.name)
        table = self.interfaces
        if component.state in (INACTIVE, ACTIVE):
            table.available_states.update(states)
        else:
            table.available_states.difference_update(states)
        if component.state == ACTIVE:
            table.available_commands.update(commands)
        else:
            table.available_commands.difference_update(commands)


def state_id(text: str) -> int | None:
    """A lifecycle state by label (``active``) or id (``3``)."""
    text = text.strip().lower()
    if text.isdigit():
        number = int(text)
        return number if number in STATE_LABELS else None
    return STATE_IDS.get(text)
