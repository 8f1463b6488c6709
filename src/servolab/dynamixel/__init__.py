"""The Dynamixel layer: everything between a Python value in SI units and bytes on the bus.

- :mod:`.protocol1`, :mod:`.protocol2` — packets of both protocol versions, host and device side
- :mod:`.models`, :mod:`.units` — control tables as data; raw ticks <-> SI units
- :mod:`.ports` — serial port, in-memory port, pseudo-terminal server
- :mod:`.bus` — the driver (:class:`Bus`)
- :mod:`.emulator` — virtual motors that answer and move
"""

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
)
from .models import MODELS, Model, Register, model, model_by_number
from .motorspec import MotorSpec
from .ports import MemoryPort, Port, PtyServer, SerialPort

__all__ = [
    "MODELS", "Bus", "BusStats", "CommError", "ConfigError", "CorruptResponse",
    "DynamixelError", "Emulator", "Faults", "MemoryPort", "Model", "MotorError", "MotorSpec",
    "NoResponse", "PacketError", "PingResult", "Port", "PtyServer", "Register", "SerialPort",
    "VirtualMotor", "build_emulator", "model", "model_by_number",
]
