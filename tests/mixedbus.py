"""An emulated bus that mixes Protocol 1.0 and 2.0 motors at both factory rates, on a
simulation's virtual clock (every byte 10 bits' time), and a URL scheme that opens it, so
that the ``servolab`` commands can be run on it in-process as on any port.

``mixed_bus()`` builds one; ``use_mixed_scheme(monkeypatch, bus)`` makes ``mixed://NAME`` open
ports to it (each opening a new port to the same motors, so a test can look at them after the
command has closed its port).
"""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from servolab.dynamixel import MemoryPort, model
from servolab.dynamixel import ports as dxl_ports
from servolab.dynamixel.emulator import Emulator, VirtualMotor
from servolab.sim import Simulation

#: (model, ID) of the mixed bus, each at its model's factory rate: X-series 2.0 at 57600,
#: XL-320 (2.0) at 1 Mbps, RX-28 (1.0) at 57142, AX-12A (1.0) at 1 Mbps.
MIXED = (("XM430-W210", 1), ("XM430-W210", 2), ("XL430-W250", 3), ("XL-320", 4),
         ("RX-28", 11), ("RX-28", 12), ("AX-12A", 21), ("MX-28", 30))


@dataclass
class EmulatedMixedBus:
    simulation: Simulation
    emulator: Emulator

    def port(self, baudrate: int | None = None) -> MemoryPort:
        return MemoryPort(self.emulator, baudrate or 57600, clock=self.simulation,
                          name="mixed://", lock=self.simulation.lock)

    def found(self) -> set[tuple[int, str, int, int]]:
        """(ID, model, protocol, baud rate as a host sets it) of every motor."""
        return {(m.id, m.model.name, m.model.protocol,
                 1_000_000 if m.baudrate == 1_000_000 else 57600)
                for m in self.emulator.motors}


def mixed_bus(motors: tuple[tuple[str, int], ...] = MIXED) -> EmulatedMixedBus:
    simulation = Simulation()
    emulator = simulation.add_emulator(Emulator(None))
    for name, motor_id in motors:
        emulator.add(VirtualMotor(model(name), motor_id))
    return EmulatedMixedBus(simulation, emulator)


_OPEN: dict[str, EmulatedMixedBus] = {}


def open_mixed(rest: str, baudrate: int | None, **options: object) -> MemoryPort:
    """The ``mixed://`` handler (see :data:`servolab.dynamixel.ports.URL_SCHEMES`)."""
    return _OPEN[rest].port(baudrate)


def use_mixed_scheme(monkeypatch: pytest.MonkeyPatch, bus: EmulatedMixedBus,
                     name: str = "bus") -> str:
    """Make ``mixed://NAME`` open ports to ``bus``; returns that URL."""
    monkeypatch.setitem(dxl_ports.URL_SCHEMES, "mixed", f"{__name__}:open_mixed")
    monkeypatch.setitem(_OPEN, name, bus)
    return f"mixed://{name}"
