"""A hardware component as ros2_control drives it: ``hardware_interface::SystemInterface``.

A component is made from its ``<ros2_control>`` block (:class:`~..hardware_info.HardwareInfo`)
and goes through lifecycle_msgs' states: ``on_configure`` (open what it needs), ``on_activate``
(torque on, commands set to where the joints are, so nothing jumps), ``on_deactivate``.
Each update the controller manager calls :meth:`SystemInterface.read` (states from the
hardware into its state interfaces) and :meth:`SystemInterface.write` (its command
interfaces to the hardware). A read or write that fails returns False: ros2_control then
deactivates the component's controllers (``controller_manager.cpp``, "Deactivating following
hardware components as their read cycle resulted in an error") and the hardware keeps its
last command — the joints hold.

Components see their values through the shared tables of :mod:`.resources`; they never hold
controllers, and controllers never hold them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from ..hardware_info import ComponentInfo, HardwareInfo

#: ros2_control's standard interface names
#: (hardware_interface/types/hardware_interface_type_values.hpp)
POSITION, VELOCITY, ACCELERATION, EFFORT = "position", "velocity", "acceleration", "effort"


def initial_value(parameters: object, default: float = math.nan) -> float:
    """An interface's ``initial_value`` parameter (NaN when it has none, as ros2_control)."""
    text = getattr(parameters, "get", lambda _k: None)("initial_value")
    if text is None or text == "":
        return default
    try:
        return float(text)
    except ValueError:
        return default


class SystemInterface:
    """The base of a hardware component: exports the interfaces its block lists, and leaves
    reading and writing to the subclass."""

    def __init__(self, info: HardwareInfo) -> None:
        self.info = info
        self.name = info.name
        #: shared tables of values (set by the resource manager when the component loads)
        self.states: dict[str, float] = {}
        self.commands: dict[str, float] = {}
        #: the last error said, for list_hardware_components and the log
        self.error: str | None = None

    def components(self) -> Sequence[ComponentInfo]:
        return (*self.info.joints, *self.info.sensors, *self.info.gpios)

    def export_state_interfaces(self) -> list[tuple[str, float]]:
        """``(full name, initial value)`` of every state interface the block lists."""
        return [(f"{c.name}/{i.name}", initial_value(i.parameters))
                for c in self.components() for i in c.state_interfaces]

    def export_command_interfaces(self) -> list[tuple[str, float]]:
        return [(f"{c.name}/{i.name}", initial_value(i.parameters))
                for c in self.components() for i in c.command_interfaces]

    # -- lifecycle: each returns True on success ----------------------------------------

    def on_configure(self) -> bool:
        return True

    def on_activate(self) -> bool:
        return True

    def on_deactivate(self) -> bool:
        return True

    def on_shutdown(self) -> bool:
        return True

    def prepare_command_mode_switch(self, start: Sequence[str], stop: Sequence[str]) -> bool:
        """Whether the command interfaces ``start`` may be claimed once ``stop`` are
        released (e.g. a joint cannot take position and velocity at once)."""
        return True

    def perform_command_mode_switch(self, start: Sequence[str], stop: Sequence[str]) -> bool:
        """Change what the hardware obeys (a Dynamixel's operating mode)."""
        return True

    # -- the update loop ------------------------------------------------------------------

    def read(self, time: float, period: float) -> bool:
        raise NotImplementedError

    def write(self, time: float, period: float) -> bool:
        raise NotImplementedError
