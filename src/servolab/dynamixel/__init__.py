"""The Dynamixel layer: everything between a Python value in SI units and bytes on the bus.

- :mod:`.protocol1`, :mod:`.protocol2` — packets of both protocol versions, host and device side
- :mod:`.models`, :mod:`.units` — control tables as data; raw ticks <-> SI units
- :mod:`.wire` — byte time and baud-rate matching, the facts both ends of the wire share
- :mod:`.ports` — serial port, in-memory port, pseudo-terminal server, ports by URL
- :mod:`.bus` — the driver (:class:`Bus`)
- :mod:`.emulator`, :mod:`.virtual_motor`, :mod:`.plant` — emulated motors: the bus side,
  each servo's firmware (its :mod:`.control_table`, :mod:`.gains`, :mod:`.motor_alarms`) over
  a plant in SI units

Emulated motors live in a simulation (:mod:`servolab.sim`), which owns their time; open them
as a port like any other: ``Bus.open("emu://rx28:11-16", baudrate=57142)``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

#: Each public name and the module it lives in, imported on first use, so that the driver
#: (``from servolab.dynamixel.bus import Bus``) loads no emulator.
_EXPORTS: dict[str, str] = {
    **dict.fromkeys(("Bus", "BusStats", "PingResult"), "bus"),
    "MixedBus": "mixed_bus",
    **dict.fromkeys(("Emulator", "Faults", "VirtualMotor", "build_emulator"), "emulator"),
    **dict.fromkeys(("CommError", "ConfigError", "CorruptResponse", "DynamixelError",
                     "MotorError", "NoResponse", "PacketError", "PortError"), "errors"),
    **dict.fromkeys(("MODELS", "Model", "Register", "load_model", "model", "model_by_number",
                     "register_model"), "models"),
    "MotorSpec": "motorspec",
    **dict.fromkeys(("KinematicServo", "ServoCommand", "ServoPlant"), "plant"),
    **dict.fromkeys(("MemoryPort", "Port", "PtyServer", "SerialPort", "open_port"), "ports"),
}

__all__ = [
    "MODELS",
    "Bus",
    "BusStats",
    "CommError",
    "ConfigError",
    "CorruptResponse",
    "DynamixelError",
    "Emulator",
    "Faults",
    "KinematicServo",
    "MemoryPort",
    "MixedBus",
    "Model",
    "MotorError",
    "MotorSpec",
    "NoResponse",
    "PacketError",
    "PingResult",
    "Port",
    "PortError",
    "PtyServer",
    "Register",
    "SerialPort",
    "ServoCommand",
    "ServoPlant",
    "VirtualMotor",
    "build_emulator",
    "load_model",
    "model",
    "model_by_number",
    "open_port",
    "register_model",
]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

if TYPE_CHECKING:
    from .bus import Bus, BusStats, PingResult
    from .emulator import Emulator, Faults, VirtualMotor, build_emulator
    from .errors import (
        CommError,
        ConfigError,
        CorruptResponse,
        DynamixelError,
        MotorError,
        NoResponse,
        PacketError,
        PortError,
    )
    from .mixed_bus import MixedBus
    from .models import (
        MODELS,
        Model,
        Register,
        load_model,
        model,
        model_by_number,
        register_model,
    )
    from .motorspec import MotorSpec
    from .plant import KinematicServo, ServoCommand, ServoPlant
    from .ports import MemoryPort, Port, PtyServer, SerialPort, open_port
