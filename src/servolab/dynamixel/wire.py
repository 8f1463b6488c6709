"""The wire: what a byte costs on a Dynamixel bus and which UARTs understand each other.

Both ends of the bus need these facts — the driver to size its timeouts, the emulator to time
its answers and to stay deaf at a wrong baud rate — so they live here, where neither end owns
them.
"""

from __future__ import annotations

BITS_PER_BYTE = 10  # start + 8 data + stop, no parity (every Dynamixel UART)
#: How far apart two UART baud rates may be and still read each other's bytes.
BAUD_TOLERANCE = 0.03


def byte_time(baudrate: float) -> float:
    """Seconds one byte occupies the wire at ``baudrate``."""
    return BITS_PER_BYTE / baudrate


def wire_time(size: int, baudrate: float) -> float:
    """Seconds ``size`` bytes occupy the wire at ``baudrate`` (10 bits each)."""
    return size * BITS_PER_BYTE / baudrate


def baud_matches(a: float, b: float, tolerance: float = BAUD_TOLERANCE) -> bool:
    """Whether two UARTs at these rates understand each other (within ``tolerance``): an
    RX-28 at its factory 57142 bps answers a host at 57600 bps."""
    # (max(a, b) by a comparison: the builtin parses its keywords at every call, and the emulator
    # asks this of every motor that hears a packet)
    return abs(a - b) <= tolerance * (b if b > a else a)
