"""Dynamixel Protocol 1.0 (AX, RX, EX and MX servos in 1.0 firmware).

Packet: ``FF FF ID LENGTH CODE PARAM... CHECKSUM`` where LENGTH = number of parameters + 2 and
CHECKSUM = ~(ID + LENGTH + CODE + sum(PARAM)) & 0xFF. CODE is the instruction from the host, the
error byte from the device.
"""

from __future__ import annotations

from collections.abc import Sequence

from .errors import PacketError
from .packets import (
    BROADCAST_ID,
    Frame,
    FrameResult,
    Instruction,
    Protocol,
    Status,
    StreamParser,
)

HEADER = b"\xff\xff"

PING = 0x01
READ = 0x02
WRITE = 0x03
REG_WRITE = 0x04
ACTION = 0x05
RESET = 0x06
SYNC_WRITE = 0x83
BULK_READ = 0x92

INSTRUCTIONS = {
    "PING": PING, "READ": READ, "WRITE": WRITE, "REG_WRITE": REG_WRITE, "ACTION": ACTION,
    "RESET": RESET, "SYNC_WRITE": SYNC_WRITE, "BULK_READ": BULK_READ,
}

# Status error byte, bit by bit (e-Manual, Protocol 1.0, "Status Packet").
INPUT_VOLTAGE = 0x01
ANGLE_LIMIT = 0x02
OVERHEATING = 0x04
RANGE = 0x08
CHECKSUM = 0x10
OVERLOAD = 0x20
INSTRUCTION = 0x40

ERROR_BITS = {
    INPUT_VOLTAGE: "input voltage", ANGLE_LIMIT: "angle limit", OVERHEATING: "overheating",
    RANGE: "range", CHECKSUM: "checksum", OVERLOAD: "overload", INSTRUCTION: "instruction",
}
#: The bits that say the instruction was refused: undefined instruction or ACTION without
#: REG_WRITE, bad checksum, a value out of range, a Goal Position outside the angle limits
#: (e-Manual, Protocol 1.0, "Status Packet", Error; its bit 7 is always 0, so a status with
#: it set is taken as failed too). The others (overload, overheating, input voltage) describe
#: the motor's state: they are set in every status while the condition lasts, and the
#: instruction is carried out all the same (a READ returns its data).
INSTRUCTION_ERRORS = INSTRUCTION | CHECKSUM | RANGE | ANGLE_LIMIT | 0x80
HARDWARE_ERRORS = OVERLOAD | OVERHEATING | INPUT_VOLTAGE


def checksum(body: bytes | bytearray) -> int:
    """The 1.0 checksum of ID, LENGTH, CODE and parameters."""
    return ~sum(body) & 0xFF


def encode(motor_id: int, code: int, params: bytes = b"") -> bytes:
    if not 0 <= motor_id <= 0xFE:
        raise PacketError(f"protocol 1.0: ID {motor_id} is outside 0..254")
    if len(params) > 253:
        raise PacketError(f"protocol 1.0: {len(params)} parameters, at most 253 fit a packet")
    body = bytes((motor_id, len(params) + 2, code)) + bytes(params)
    return HEADER + body + bytes((checksum(body),))


class Parser(StreamParser):
    header = HEADER

    def _try_frame(self) -> FrameResult:
        buf = self._buffer
        if len(buf) < 4:
            return None
        motor_id, length = buf[2], buf[3]
        if motor_id == 0xFF or length < 2:
            return False
        size = length + 4
        if len(buf) < size:
            return None
        if checksum(buf[2:size - 1]) != buf[size - 1]:
            return self._reject(buf[2], size)
        return Frame(motor_id, buf[4], bytes(buf[5:size - 1])), size


class Protocol1(Protocol):
    version = 1
    max_id = 253
    instructions = INSTRUCTIONS
    field_size = 1
    error_bits = ERROR_BITS

    def encode_instruction(self, packet: Instruction) -> bytes:
        return encode(packet.id, packet.instruction, packet.params)

    def encode_status(self, packet: Status) -> bytes:
        return encode(packet.id, packet.error, packet.params)

    def parser(self, *, keep_rejected: bool = False) -> Parser:
        return Parser(keep_rejected=keep_rejected)

    def as_status(self, frame: Frame) -> Status:
        return Status(frame.id, frame.code, frame.params)

    def status_size(self, n_params: int) -> int:
        return 6 + n_params

    # -- status packets checked in place ----------------------------------------------------------
    error_at = 4
    params_at = 5

    def status_prefix(self, motor_id: int, n_params: int) -> bytes:
        return HEADER + bytes((motor_id, n_params + 2))

    def match_status_at(self, buf: bytes, start: int, size: int, prefix: bytes,
                        state: int) -> int:
        last = start + size - 1
        if buf.startswith(prefix, start) and ~sum(buf[start + 2:last]) & 0xFF == buf[last]:
            return buf[start + 4]
        return -1

    def failed(self, error: int) -> int:
        return error & INSTRUCTION_ERRORS

    def alert(self, error: int) -> int:
        return error & HARDWARE_ERRORS

    def implausible_error(self, error: int) -> str | None:
        # e-Manual, Protocol 1.0, "Status Packet", Error: bits 0-6 are named, bit 7 is 0.
        return "error bit 7, which Protocol 1.0 keeps at 0" if error & 0x80 else None

    # -- builders ------------------------------------------------------------------------------
    def reset(self, motor_id: int) -> Instruction:
        self.check_id(motor_id, broadcast=True)
        return Instruction(motor_id, RESET)

    def bulk_read(self, requests: Sequence[tuple[int, int, int]]) -> Instruction:
        params = bytearray((0x00,))
        for motor_id, address, length in requests:
            self.check_id(motor_id)
            self.check_address(address, length)
            params += bytes((length, motor_id, address))
        return Instruction(BROADCAST_ID, BULK_READ, bytes(params))


PROTOCOL1 = Protocol1()
