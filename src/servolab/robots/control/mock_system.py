"""ros2_control's ``mock_components/GenericSystem``: hardware that is only its interfaces.

As ``hardware_interface/src/mock_components/generic_system.cpp`` (Jazzy) behaves:

- every state interface starts at its ``initial_value`` (NaN without one);
- ``read`` mirrors each finite command to the state interface of the same name; a NaN
  command (never written) changes nothing; an infinite one is an error;
- with the hardware parameter ``calculate_dynamics: true`` a joint commanded in velocity
  integrates its position (backward Euler), and one commanded in position derives its
  velocity and acceleration from the change;
- ``position_state_following_offset`` is added to every mirrored position;
- ``disable_commands: true`` mirrors nothing.

It is what a URDF asks for with ``<plugin>mock_components/GenericSystem</plugin>``, and what
servolab runs when a robot's controllers are to be tried with no motors at all.
"""

from __future__ import annotations

import math

from ..hardware_info import HardwareInfo
from .hardware import ACCELERATION, POSITION, VELOCITY, SystemInterface

PLUGIN = "mock_components/GenericSystem"


def _flag(info: HardwareInfo, name: str) -> bool:
    return info.hardware_parameters.get(name, "").strip().lower() == "true"


class GenericSystem(SystemInterface):
    """See the module docstring."""

    def __init__(self, info: HardwareInfo) -> None:
        super().__init__(info)
        self.calculate_dynamics = _flag(info, "calculate_dynamics")
        self.disable_commands = _flag(info, "disable_commands")
        try:
            self.offset = float(info.hardware_parameters.get(
                "position_state_following_offset", "0") or 0)
        except ValueError:
            self.offset = 0.0
        #: per joint: the command interface that moves it in calculate_dynamics
        self._modes = {j.name: next((i.name for i in j.command_interfaces
                                     if i.name in (POSITION, VELOCITY, ACCELERATION)), None)
                       for j in info.joints}

    def read(self, time: float, period: float) -> bool:
        if self.disable_commands:
            return True
        states, commands = self.states, self.commands
        dynamic = {f"{j}/{i}" for j, mode in self._modes.items() if self.calculate_dynamics
                   for i in (POSITION, VELOCITY, ACCELERATION)}
        for name, command in commands.items():
            if name in dynamic or name not in states:
                continue
            if math.isinf(command):
                self.error = f"{self.name}: command {name} is infinite"
                return False
            if math.isfinite(command):
                states[name] = command + (self.offset if name.endswith("/" + POSITION) else 0)
        if self.calculate_dynamics:
            for joint, mode in self._modes.items():
                self._integrate(joint, mode, period)
        return True

    def _integrate(self, joint: str, mode: str | None, period: float) -> None:
        states, commands = self.states, self.commands
        position, velocity = f"{joint}/{POSITION}", f"{joint}/{VELOCITY}"
        acceleration = f"{joint}/{ACCELERATION}"
        if position not in states or mode is None or period <= 0:
            return
        command = commands.get(f"{joint}/{mode}", math.nan)
        if mode == VELOCITY:
            if math.isfinite(command):
                old = states.get(velocity, 0.0)
                old = old if math.isfinite(old) else 0.0
                if velocity in states:
                    states[velocity] = command
                if acceleration in states:
                    states[acceleration] = (command - old) / period
            v = command if math.isfinite(command) else states.get(velocity, math.nan)
            if math.isfinite(v):
                base = states[position] if math.isfinite(states[position]) else 0.0
                states[position] = base + v * period + self.offset
        elif mode == POSITION and math.isfinite(command):
            old = states[position]
            states[position] = command + self.offset
            if velocity in states and math.isfinite(old):
                old_v = states[velocity] if math.isfinite(states[velocity]) else 0.0
                states[velocity] = (states[position] - old) / period
                if acceleration in states:
                    states[acceleration] = (states[velocity] - old_v) / period

    def write(self, time: float, period: float) -> bool:
        return True
