"""Dynamixel Protocol 2.0 (X-series, MX and PRO servos in 2.0 firmware).

Packet: ``FF FF FD 00 ID LEN_L LEN_H INST PARAM... CRC_L CRC_H``. LEN counts the instruction,
the (stuffed) parameters and the CRC. The CRC is CRC-16/BUYPASS (polynomial 0x8005, initial 0,
no reflection) over everything before it. Byte stuffing: wherever ``FF FF FD`` occurs in the
instruction and parameters, an extra ``FD`` follows it, so a header never appears in a body.
Status packets carry instruction 0x55 and then the error byte.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from struct import unpack_from as _unpack_from
from typing import ClassVar

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

HEADER = b"\xff\xff\xfd\x00"
MAX_LENGTH = 1024  # as the ROBOTIS SDK bounds RX/TX packets; longer is taken as corruption

PING = 0x01
READ = 0x02
WRITE = 0x03
REG_WRITE = 0x04
ACTION = 0x05
FACTORY_RESET = 0x06
REBOOT = 0x08
CLEAR = 0x10
STATUS = 0x55
SYNC_READ = 0x82
SYNC_WRITE = 0x83
FAST_SYNC_READ = 0x8A
BULK_READ = 0x92
BULK_WRITE = 0x93
FAST_BULK_READ = 0x9A

INSTRUCTIONS = {
    "PING": PING, "READ": READ, "WRITE": WRITE, "REG_WRITE": REG_WRITE, "ACTION": ACTION,
    "FACTORY_RESET": FACTORY_RESET, "REBOOT": REBOOT, "CLEAR": CLEAR,
    "SYNC_READ": SYNC_READ, "SYNC_WRITE": SYNC_WRITE, "BULK_READ": BULK_READ,
    "BULK_WRITE": BULK_WRITE, "FAST_SYNC_READ": FAST_SYNC_READ,
    "FAST_BULK_READ": FAST_BULK_READ,
}

# The error byte: the low 7 bits are a number, bit 7 is the hardware-error alert.
RESULT_FAIL = 0x01
INSTRUCTION_ERROR = 0x02
CRC_ERROR = 0x03
DATA_RANGE = 0x04
DATA_LENGTH = 0x05
DATA_LIMIT = 0x06
ACCESS = 0x07
ALERT = 0x80

ERROR_NUMBERS = {
    RESULT_FAIL: "result fail", INSTRUCTION_ERROR: "instruction", CRC_ERROR: "crc",
    DATA_RANGE: "data range", DATA_LENGTH: "data length", DATA_LIMIT: "data limit",
    ACCESS: "access",
}

# Bits of the hardware_error_status register (address 70 on the X-series).
HARDWARE_ERRORS = {
    0x01: "input voltage", 0x04: "overheating", 0x08: "motor encoder",
    0x10: "electrical shock", 0x20: "overload",
}

FACTORY_RESET_ALL = 0xFF
FACTORY_RESET_EXCEPT_ID = 0x01
FACTORY_RESET_EXCEPT_ID_BAUD = 0x02


def _crc_table() -> list[int]:
    table = []
    for i in range(256):
        crc = i << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) if crc & 0x8000 else crc << 1
        table.append(crc & 0xFFFF)
    return table


_CRC_TABLE = _crc_table()
@functools.cache
def _word_table() -> list[int]:
    """The CRC after two more bytes, indexed by the CRC so far XOR those bytes (big-endian):
    the register is 16 bits wide, so two bytes shift all of it out and the result depends on
    that XOR alone. Half as many steps as the byte table; built on first use (65 536 entries,
    a few ms) and kept."""
    t = _CRC_TABLE
    return [((t[hi] & 0xFF) << 8) ^ t[lo ^ (t[hi] >> 8)]
            for hi in range(256) for lo in range(256)]


def crc16(data: bytes | bytearray, crc: int = 0) -> int:
    """CRC-16 of Protocol 2.0 over ``data``."""
    return crc16_at(data, 0, len(data), crc)


def crc16_at(data: bytes | bytearray, start: int, stop: int, crc: int = 0) -> int:
    """CRC-16 of ``data[start:stop]``, continuing from ``crc``, without copying the slice."""
    n = stop - start
    if n >= 2:
        words = _word_table()
        for word in _unpack_from(f">{n >> 1}H", data, start):
            crc = words[crc ^ word]
    if n & 1:
        crc = ((crc << 8) ^ _CRC_TABLE[((crc >> 8) ^ data[stop - 1]) & 0xFF]) & 0xFFFF
    return crc


def stuff(body: bytes) -> bytes:
    """Insert ``FD`` after every ``FF FF FD`` in ``body`` (instruction + parameters)."""
    if b"\xff\xff\xfd" not in body:
        return body
    return body.replace(b"\xff\xff\xfd", b"\xff\xff\xfd\xfd")


def unstuff(body: bytes) -> bytes:
    """Undo :func:`stuff`."""
    if b"\xff\xff\xfd\xfd" not in body:
        return body
    return body.replace(b"\xff\xff\xfd\xfd", b"\xff\xff\xfd")


def encode(motor_id: int, code: int, params: bytes = b"") -> bytes:
    if not 0 <= motor_id <= 0xFE or motor_id == 0xFD:
        raise PacketError(f"protocol 2.0: ID {motor_id} is not 0..252 or 254 (broadcast)")
    body = stuff(bytes((code,)) + bytes(params))
    length = len(body) + 2
    if length > MAX_LENGTH:
        raise PacketError(f"protocol 2.0: packet length {length} exceeds {MAX_LENGTH}")
    packet = HEADER + bytes((motor_id, length & 0xFF, length >> 8)) + body
    crc = crc16(packet)
    return packet + bytes((crc & 0xFF, crc >> 8))


# -- Fast Sync Read / Fast Bulk Read status ----------------------------------------------------
# The instruction packets are SYNC_READ's and BULK_READ's with the instruction 0x8A / 0x9A
# (dynamixel_sdk 4.1.0, protocol2_packet_handler.syncReadTx / bulkReadTx with fast_option).
# The answer is ONE status packet from the broadcast ID for all the motors read:
#
#     FF FF FD 00  FE  LEN_L LEN_H  55  | ERR ID DATA... CRC_L CRC_H | ERR ID DATA... CRC | ...
#
# one block per motor, in the order of the request. LEN = 1 + sum(4 + L_k), the instruction
# and the blocks (3 motors x 4 bytes: 25, the e-Manual's example). Each block ends with the
# CRC-16 of every byte of the packet from the header up to that CRC, the CRCs of the blocks
# before it included (a running CRC: the last one is the packet's CRC, the one the SDK checks
# in rxPacket). The bytes are not stuffed: the SDK's rxPacket(port, fast_option=True)
# does not unstuff them, and its fastSyncReadRx / fastBulkReadRx find each block by counting
# 4 + L_k bytes. The first motor of the request sends the 8 bytes of head and its block.
#: bytes before the first block: header, reserved, ID 0xFE, LEN (2), instruction 0x55
FAST_HEAD = 8


def fast_status_length(lengths: Sequence[int]) -> int:
    """LEN of the fast status packet whose blocks carry ``lengths`` data bytes each."""
    return 1 + sum(4 + n for n in lengths)


def fast_status_head(length: int) -> bytes:
    """The 8 bytes the first motor sends before its block, for a packet of LEN ``length``."""
    return HEADER + bytes((BROADCAST_ID, length & 0xFF, length >> 8, STATUS))


def fast_block(head: bytes, crc: int, error: int, motor_id: int, data: bytes) -> bytes:
    """What one motor puts on the wire: ``head`` (:func:`fast_status_head` for the first
    motor, else nothing), its error byte, ID and data, and the running CRC, which goes on
    from ``crc``: the CRC of every byte of the packet before these."""
    piece = head + bytes((error, motor_id)) + data
    crc = crc16(piece, crc)
    return piece + bytes((crc & 0xFF, crc >> 8))


def encode_fast_status(blocks: Sequence[tuple[int, int, bytes]]) -> bytes:
    """The whole fast status packet of ``blocks``, (id, error, data) each, in request order."""
    if not blocks:
        raise PacketError("protocol 2.0: a fast status packet has at least one block")
    head = fast_status_head(fast_status_length([len(data) for _, _, data in blocks]))
    crc = 0
    out = bytearray()
    for motor_id, error, data in blocks:
        piece = fast_block(head, crc, error, motor_id, data)
        crc = crc16(piece, crc)
        out += piece
        head = b""
    return bytes(out)


def match_fast_status(buf: bytes, prefix: bytes, state: int, ids: Sequence[int],
                      ends: Sequence[int]) -> list[int] | tuple[()] | None:
    """Check in place a fast status packet that is the whole of ``buf``: it starts with
    ``prefix`` (its :func:`fast_status_head`; ``state`` the CRC of it), block k comes from
    ``ids[k]`` and its CRC sits at ``buf[ends[k]]``. Returns the blocks' error bytes (``()``
    when all are 0), or None when anything is not exactly as expected."""
    if not buf.startswith(prefix) or len(buf) != ends[-1] + 2:
        return None
    crc, at = state, len(prefix)
    errors: list[int] | None = None
    for k, (motor_id, end) in enumerate(zip(ids, ends, strict=True)):
        if buf[at + 1] != motor_id:
            return None
        crc = crc16_at(buf, at, end, crc)
        if crc != buf[end] | buf[end + 1] << 8:
            return None
        crc = crc16_at(buf, end, end + 2, crc)
        if buf[at]:
            if errors is None:
                errors = [0] * len(ids)
            errors[k] = buf[at]
        at = end + 2
    return () if errors is None else errors


def read_fast_status(buf: bytes, at: int, ids: Sequence[int], lengths: Sequence[int]
                     ) -> tuple[list[Status], bool]:
    """The blocks of the fast status packet whose head starts at ``buf[at]``, as far as they
    came whole and valid (the right ID at its place, its running CRC right), as statuses; and
    whether it stopped at a block that came corrupt or only in part (False: it stopped where
    the bytes ended, between two blocks)."""
    crc = crc16_at(buf, at, at + FAST_HEAD)
    pos = at + FAST_HEAD
    found: list[Status] = []
    for motor_id, n in zip(ids, lengths, strict=True):
        end = pos + 2 + n
        if end + 2 > len(buf):
            return found, pos < len(buf)
        crc = crc16_at(buf, pos, end, crc)
        if buf[pos + 1] != motor_id or crc != buf[end] | buf[end + 1] << 8:
            return found, True
        crc = crc16_at(buf, end, end + 2, crc)
        found.append(Status(motor_id, buf[pos], bytes(buf[pos + 2:end])))
        pos = end + 2
    return found, False


class Parser(StreamParser):
    header = b"\xff\xff\xfd"

    def _try_frame(self) -> FrameResult:
        buf = self._buffer
        if len(buf) < 7:
            return None
        if buf[3] != 0x00 or buf[4] in (0xFD, 0xFF):
            return False
        length = buf[5] | (buf[6] << 8)
        if not 3 <= length <= MAX_LENGTH:
            return False
        size = length + 7
        if len(buf) < size:
            return None
        crc = buf[size - 2] | (buf[size - 1] << 8)
        if crc16(buf[:size - 2]) != crc:
            return self._reject(buf[4], size)
        body = unstuff(bytes(buf[7:size - 2]))
        return Frame(buf[4], body[0], body[1:]), size


class Protocol2(Protocol):
    version = 2
    max_id = 252
    instructions = INSTRUCTIONS
    field_size = 2
    error_bits: ClassVar[dict[int, str]] = {}  # 2.0 numbers its errors: see error_names

    def encode_instruction(self, packet: Instruction) -> bytes:
        return encode(packet.id, packet.instruction, packet.params)

    def encode_status(self, packet: Status) -> bytes:
        return encode(packet.id, STATUS, bytes((packet.error,)) + packet.params)

    def parser(self, *, keep_rejected: bool = False) -> Parser:
        return Parser(keep_rejected=keep_rejected)

    def as_status(self, frame: Frame) -> Status:
        if frame.code != STATUS or not frame.params:
            raise PacketError(f"protocol 2.0: packet from ID {frame.id} is not a status packet "
                              f"(instruction 0x{frame.code:02X})")
        return Status(frame.id, frame.params[0], frame.params[1:])

    def status_size(self, n_params: int) -> int:
        return 11 + n_params

    # -- status packets checked in place ----------------------------------------------------------
    error_at = 8
    params_at = 9

    def status_prefix(self, motor_id: int, n_params: int) -> bytes:
        length = n_params + 4  # instruction, error, parameters, CRC
        return HEADER + bytes((motor_id, length & 0xFF, length >> 8, STATUS))

    def prefix_state(self, prefix: bytes) -> int:
        return crc16(prefix)

    def match_status_at(self, buf: bytes, start: int, size: int, prefix: bytes,
                        state: int) -> int:
        end = start + size
        if (buf.startswith(prefix, start) and crc16_at(buf, start + 8, end - 2, state)
                == buf[end - 2] | buf[end - 1] << 8):
            return buf[start + 8]
        return -1

    def failed(self, error: int) -> int:
        # "Error Number: When there has been an Error in the processing of the Instruction
        # Packet" (e-Manual, Protocol 2.0, Status Packet, Error): bits 0-6.
        return error & 0x7F

    def alert(self, error: int) -> int:
        # "Alert: When there has been a problem in the Device, this field is set as 1.
        # Checking the Hardware error status value of the Control Table can indicate the
        # cause of the problem" (ibid.): bit 7, which says nothing about the instruction.
        return error & ALERT

    def implausible_error(self, error: int) -> str | None:
        # e-Manual, Protocol 2.0, "Status Packet", Error: the numbers 0x01-0x07 are defined.
        number = error & 0x7F
        return (f"error number {number}, which Protocol 2.0 does not define"
                if number > ACCESS else None)

    def error_names(self, error: int) -> tuple[str, ...]:
        names = []
        number = error & 0x7F
        if number:
            names.append(ERROR_NUMBERS.get(number, f"error {number}"))
        if error & ALERT:
            names.append("hardware error alert")
        return tuple(names)

    # -- builders ------------------------------------------------------------------------------
    def factory_reset(self, motor_id: int, option: int = FACTORY_RESET_ALL) -> Instruction:
        self.check_id(motor_id, broadcast=True)
        if option not in (FACTORY_RESET_ALL, FACTORY_RESET_EXCEPT_ID,
                          FACTORY_RESET_EXCEPT_ID_BAUD):
            raise PacketError(f"protocol 2.0: factory reset option 0x{option:02X} is not "
                              "0xFF (all), 0x01 (keep ID) or 0x02 (keep ID and baud)")
        return Instruction(motor_id, FACTORY_RESET, bytes((option,)))

    def reboot(self, motor_id: int) -> Instruction:
        self.check_id(motor_id, broadcast=True)
        return Instruction(motor_id, REBOOT)

    def sync_read(self, address: int, length: int, ids: Sequence[int], *,
                  fast: bool = False) -> Instruction:
        """SYNC_READ, or FAST_SYNC_READ (the same parameters) when ``fast``."""
        self.check_address(address, length)
        for motor_id in ids:
            self.check_id(motor_id)
        params = self.field(address) + self.field(length) + bytes(ids)
        return Instruction(BROADCAST_ID, FAST_SYNC_READ if fast else SYNC_READ, params)

    def bulk_read(self, requests: Sequence[tuple[int, int, int]], *,
                  fast: bool = False) -> Instruction:
        """BULK_READ, or FAST_BULK_READ (the same parameters) when ``fast``."""
        params = bytearray()
        for motor_id, address, length in requests:
            self.check_id(motor_id)
            self.check_address(address, length)
            params += bytes((motor_id,)) + self.field(address) + self.field(length)
        return Instruction(BROADCAST_ID, FAST_BULK_READ if fast else BULK_READ, bytes(params))

    def fast_sync_read(self, address: int, length: int, ids: Sequence[int]) -> Instruction:
        return self.sync_read(address, length, ids, fast=True)

    def fast_bulk_read(self, requests: Sequence[tuple[int, int, int]]) -> Instruction:
        return self.bulk_read(requests, fast=True)

    def bulk_write(self, blocks: Sequence[tuple[int, int, bytes]]) -> Instruction:
        """``blocks`` are (id, address, data) triples."""
        params = bytearray()
        for motor_id, address, data in blocks:
            self.check_id(motor_id)
            self.check_address(address, len(data))
            params += bytes((motor_id,)) + self.field(address) + self.field(len(data)) + bytes(data)
        return Instruction(BROADCAST_ID, BULK_WRITE, bytes(params))


PROTOCOL2 = Protocol2()
