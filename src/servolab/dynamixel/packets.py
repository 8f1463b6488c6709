"""What both protocol versions share: packet values, the protocol interface, the stream parser.

A packet on the wire is framed the same way in either direction; what differs is whether its
code byte is an instruction (host to device) or an error (device to host). Host and device code
therefore share one parser and one encoder per protocol, and the emulator is simply the device
side of the same code the driver uses.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar, Literal, TypeAlias

from .errors import ConfigError, PacketError

BROADCAST_ID = 0xFE


@dataclass(frozen=True)
class Instruction:
    """An instruction packet, host to device."""

    id: int
    instruction: int
    params: bytes = b""

    def __init__(self, id: int, instruction: int, params: bytes = b"") -> None:
        # The dataclass's own __init__ (it keeps one written here), with the fields stored
        # straight into the instance's dict: the frozen one calls object.__setattr__ for each,
        # and the emulated bus makes a few of these per transaction.
        fields = self.__dict__
        fields["id"], fields["instruction"], fields["params"] = id, instruction, params


@dataclass(frozen=True)
class Status:
    """A status packet, device to host. ``error`` is the raw error byte."""

    id: int
    error: int
    params: bytes = b""

    def __init__(self, id: int, error: int, params: bytes = b"") -> None:
        # (as Instruction's)
        fields = self.__dict__
        fields["id"], fields["error"], fields["params"] = id, error, params


@dataclass(frozen=True)
class Frame:
    """A packet found by a :class:`StreamParser`, before it is read as instruction or status.

    ``code`` is the byte after the length: an instruction, or (1.0 only) a status error byte;
    2.0 status packets carry ``code == 0x55`` and their error byte as ``params[0]``.
    """

    id: int
    code: int
    params: bytes

    def __init__(self, id: int, code: int, params: bytes) -> None:
        # (as Instruction's)
        fields = self.__dict__
        fields["id"], fields["code"], fields["params"] = id, code, params


#: What :meth:`StreamParser._try_frame` finds at the start of its buffer: a whole packet and its
#: size on the wire, None when the packet is not complete yet, False when the candidate is corrupt.
FrameResult: TypeAlias = tuple[Frame, int] | Literal[False] | None


class StreamParser(ABC):
    """Finds packets in a byte stream that may hold noise, partial packets and bad checksums.

    Feed it bytes as they arrive; it returns every complete, valid packet and keeps the rest.
    A corrupt candidate is dropped one byte at a time, so the parser resynchronises on the next
    header even when the corrupt bytes hid one. ``dropped`` counts the bytes thrown away.
    """

    def __init__(self, *, keep_rejected: bool = False) -> None:
        self._buffer = bytearray()
        self.dropped = 0
        #: complete packets whose checksum/CRC failed (kept only with ``keep_rejected``, for the
        #: device side: a real motor answers such a packet with a checksum/CRC error)
        self.rejected: list[Frame] = []
        self._keep_rejected = keep_rejected
        self._skip = 0   # bytes of a rejected packet the device side skips in one go

    def reset(self) -> None:
        self.dropped += len(self._buffer)
        self._buffer.clear()

    @property
    def pending(self) -> int:
        """Bytes held that are not yet a whole packet."""
        return len(self._buffer)

    def feed(self, data: bytes) -> list[Frame]:
        buffer = self._buffer   # (the one bytearray, changed in place)
        buffer += data
        frames: list[Frame] = []
        while True:
            start = buffer.find(self.header)
            if start < 0:
                if buffer:  # (an empty buffer has no tail to keep or drop)
                    # Keep a tail that may be the beginning of a header.
                    keep = len(self.header) - 1
                    cut = max(0, len(buffer) - keep)
                    while cut < len(buffer) and not self.header.startswith(bytes(buffer[cut:])):
                        cut += 1
                    self._drop(cut)
                return frames
            if start:
                self._drop(start)
            result = self._try_frame()
            if result is None:          # incomplete: wait for more bytes
                return frames
            if result is False:         # corrupt: skip this header byte and search again
                self._drop(self._skip or 1)
                self._skip = 0
                continue
            frame, size = result
            del buffer[:size]
            frames.append(frame)

    def _reject(self, motor_id: int, size: int) -> Literal[False]:
        """A whole packet of ``size`` bytes whose checksum/CRC failed. The host side looks
        for a header again from its second byte (an answer may hide inside noise); the device
        side, like a servo's receiver, takes the bytes as that packet and looks for the next
        header after its end (ROBOTIS's device-side parser, Dynamixel2Arduino protocol.cpp,
        goes back to idle once the packet's length is in), so an instruction that a corrupt
        header swallowed is lost as it is on a real bus."""
        if self._keep_rejected:
            self.rejected.append(Frame(motor_id, -1, b""))
            self._skip = size
        return False

    def _drop(self, n: int) -> None:
        if n:
            del self._buffer[:n]
            self.dropped += n

    header: ClassVar[bytes] = b""

    @abstractmethod
    def _try_frame(self) -> FrameResult:
        """Read one packet at the start of the buffer: (frame, size), None if it is not
        complete yet, or False if it is corrupt."""


class Protocol(ABC):
    """One version of the Dynamixel protocol, both host and device side."""

    version: ClassVar[int]
    broadcast_id: ClassVar[int] = BROADCAST_ID
    max_id: ClassVar[int]
    #: instruction name -> code, for the instructions this version defines
    instructions: ClassVar[dict[str, int]]
    #: error bit -> name, as the e-Manual calls it
    error_bits: ClassVar[dict[int, str]]

    # -- framing -----------------------------------------------------------------------------
    @abstractmethod
    def encode_instruction(self, packet: Instruction) -> bytes: ...

    @abstractmethod
    def encode_status(self, packet: Status) -> bytes: ...

    @abstractmethod
    def parser(self, *, keep_rejected: bool = False) -> StreamParser: ...

    @abstractmethod
    def as_status(self, frame: Frame) -> Status: ...

    def as_instruction(self, frame: Frame) -> Instruction:
        return Instruction(frame.id, frame.code, frame.params)

    @abstractmethod
    def status_size(self, n_params: int) -> int:
        """Bytes on the wire of a status packet with ``n_params`` parameters (no stuffing)."""

    # -- status packets checked in place (the driver's fast path) ----------------------------
    #: index of the error byte in a status packet, and of its first parameter
    error_at: ClassVar[int]
    params_at: ClassVar[int]

    @abstractmethod
    def status_prefix(self, motor_id: int, n_params: int) -> bytes:
        """The bytes a status packet from ``motor_id`` with ``n_params`` parameters starts
        with, up to its error byte: what the driver expects before it reads the packet."""

    @abstractmethod
    def match_status_at(self, buf: bytes, start: int, size: int, prefix: bytes,
                        state: int) -> int:
        """The error byte of the status packet the driver expects at ``buf[start:start +
        size]``, starting with ``prefix`` (``state`` is what the checksum/CRC of the prefix
        leaves, see :meth:`prefix_state`), checked without copying it out; -1 when it is not
        exactly as expected."""

    def match_statuses(self, buf: bytes, starts: Sequence[int], sizes: Sequence[int],
                       prefixes: Sequence[bytes], states: Sequence[int]
                       ) -> list[int] | tuple[()] | None:
        """Check status packets laid end to end in ``buf`` where the driver expects them
        (packet k at ``starts[k]``, ``sizes[k]`` bytes, see :meth:`match_status_at`).
        Returns their error bytes (``()`` when all are 0), or None when any packet is not
        exactly as expected: then the driver's stream parser reads the bytes instead."""
        errors: list[int] | None = None
        match = self.match_status_at
        for k, (start, size, prefix, state) in enumerate(zip(starts, sizes, prefixes, states,
                                                             strict=True)):
            error = match(buf, start, size, prefix, state)
            if error < 0:
                return None
            if error:
                if errors is None:
                    errors = [0] * len(starts)
                errors[k] = error
        return () if errors is None else errors

    def match_status(self, buf: bytes, prefix: bytes, state: int) -> int:
        """:meth:`match_status_at` for one status packet that is the whole of ``buf``."""
        return self.match_status_at(buf, 0, len(buf), prefix, state)

    def prefix_state(self, prefix: bytes) -> int:
        """The running checksum/CRC after ``prefix`` (the part of a status packet the driver
        knows in advance), so that :meth:`match_statuses` checks only the rest."""
        return 0

    @abstractmethod
    def failed(self, error: int) -> int:
        """The bits of a status error byte that say the instruction itself failed (nothing
        was read or written); 0 when it was carried out."""

    @abstractmethod
    def alert(self, error: int) -> int:
        """The bits of a status error byte that report the motor's hardware state (overload,
        overheating, ...): they come with an instruction carried out and valid data."""

    def implausible_error(self, error: int) -> str | None:
        """What no motor sends in a status error byte, said in words (a bit the protocol
        keeps at 0, an error number it does not define), or None: a status that carries it
        passed its checksum/CRC by chance and is corrupt."""
        return None

    def decode_instruction(self, data: bytes) -> Instruction:
        return self.as_instruction(self._one_frame(data))

    def decode_status(self, data: bytes) -> Status:
        return self.as_status(self._one_frame(data))

    def _one_frame(self, data: bytes) -> Frame:
        parser = self.parser()
        frames = parser.feed(bytes(data))
        if len(frames) != 1 or parser.pending or parser.dropped:
            raise PacketError(f"protocol {self.version}: not exactly one valid packet: "
                              f"{bytes(data).hex(' ')}")
        return frames[0]

    # -- names ---------------------------------------------------------------------------------
    #: code -> instruction name, built from ``instructions`` with the class (the first name
    #: of a code wins)
    _names_by_code: ClassVar[dict[int, str]] = {}

    def __init_subclass__(cls, **kwargs: object) -> None:
        super().__init_subclass__(**kwargs)
        instructions = getattr(cls, "instructions", None)
        if instructions is not None:
            cls._names_by_code = {v: k for k, v in reversed(instructions.items())}

    def instruction_name(self, code: int) -> str:
        name = self._names_by_code.get(code)
        return name if name is not None else f"0x{code:02X}"

    def error_names(self, error: int) -> tuple[str, ...]:
        """Names of the error bits set in a status packet's error byte."""
        return tuple(name for bit, name in sorted(self.error_bits.items()) if error & bit)

    def check_id(self, motor_id: int, *, broadcast: bool = False) -> None:
        if not isinstance(motor_id, int) or isinstance(motor_id, bool):
            raise ConfigError(f"motor ID {motor_id!r} is not an integer")
        if broadcast and motor_id == self.broadcast_id:
            return
        if not 0 <= motor_id <= self.max_id:
            raise ConfigError(f"motor ID {motor_id} is outside protocol {self.version}'s "
                              f"range 0..{self.max_id}")

    # -- instruction builders (host side) ------------------------------------------------------
    def ping(self, motor_id: int) -> Instruction:
        self.check_id(motor_id, broadcast=True)
        return Instruction(motor_id, self.instructions["PING"])

    def action(self, motor_id: int = BROADCAST_ID) -> Instruction:
        self.check_id(motor_id, broadcast=True)
        return Instruction(motor_id, self.instructions["ACTION"])

    def read(self, motor_id: int, address: int, length: int) -> Instruction:
        self.check_id(motor_id)
        self.check_address(address, length)
        return Instruction(motor_id, self.instructions["READ"],
                           self.field(address) + self.field(length))

    def write(self, motor_id: int, address: int, data: bytes, *,
              registered: bool = False) -> Instruction:
        """WRITE, or REG_WRITE (applied at the next ACTION) when ``registered``."""
        self.check_id(motor_id, broadcast=True)
        self.check_address(address, len(data))
        code = self.instructions["REG_WRITE" if registered else "WRITE"]
        return Instruction(motor_id, code, self.field(address) + bytes(data))

    def sync_write(self, address: int, length: int,
                   data: Sequence[tuple[int, bytes]]) -> Instruction:
        """``data`` holds (id, block) pairs, every block ``length`` bytes long."""
        self.check_address(address, length)
        params = bytearray(self.field(address) + self.field(length))
        for motor_id, block in data:
            self.check_id(motor_id)
            if len(block) != length:
                raise PacketError(f"motor {motor_id}: {len(block)} data bytes, expected {length}")
            params.append(motor_id)
            params += block
        return Instruction(self.broadcast_id, self.instructions["SYNC_WRITE"], bytes(params))

    @abstractmethod
    def bulk_read(self, requests: Sequence[tuple[int, int, int]]) -> Instruction:
        """``requests`` are (id, address, length) triples."""

    # -- address and length fields ----------------------------------------------------------
    #: bytes of an address or length field: 1 on 1.0, 2 (little-endian) on 2.0
    field_size: ClassVar[int]

    def field(self, value: int) -> bytes:
        return int(value).to_bytes(self.field_size, "little")

    def check_address(self, address: int, length: int) -> None:
        top = (1 << (8 * self.field_size)) - 1
        if not 0 <= address <= top:
            raise PacketError(f"protocol {self.version}.0: address {address} is outside 0..{top}")
        if not 0 < length <= top:
            raise PacketError(f"protocol {self.version}.0: length {length} is outside 1..{top}")
