"""A real motor answers an instruction that arrived whole but with a bad checksum (1.0) or CRC
(2.0) with that error; the emulator must too, or a driver's handling of it goes untested."""

from __future__ import annotations

import pytest

from servolab.dynamixel import Bus
from servolab.dynamixel.protocol1 import PROTOCOL1
from servolab.dynamixel.protocol2 import PROTOCOL2


@pytest.mark.parametrize(("spec", "proto", "address", "expected"), [
    ("rx28:3", PROTOCOL1, 36, ("checksum",)),
    ("xm430-w210:3", PROTOCOL2, 132, ("crc",)),
])
def test_bad_checksum_gets_checksum_error(spec: str, proto, address: int,
                                          expected: tuple[str, ...]) -> None:
    bus = Bus.open(f"emu://{spec}", baudrate=1_000_000)
    packet = bytearray(proto.encode_instruction(proto.read(3, address, 2)))
    packet[-1] ^= 0x5A
    bus.port.write(bytes(packet))
    reply = bus.port.read(64, 0.01)
    status = proto.decode_status(reply)
    assert status.id == 3
    assert proto.error_names(status.error) == expected
    assert status.params == b""   # nothing was read


def test_bad_checksum_to_absent_id_or_broadcast_is_silent() -> None:
    bus = Bus.open("emu://rx28:3", baudrate=1_000_000)
    for target in (4, 254):
        packet = bytearray(PROTOCOL1.encode_instruction(PROTOCOL1.write(target, 30, b"\x00\x02")))
        packet[-1] ^= 0x01
        bus.port.write(bytes(packet))
        assert bus.port.read(64, 0.01) == b""
    # ... and the corrupt WRITE changed nothing.
    assert bus.read(3, "goal_position", raw=True) == 512
