"""Raw access: any bytes at any address of a motor's control table.

For a model servolab has no table for, or registers it does not name. The address and size
are checked against the protocol (:func:`raw_access_limits`); where the bus knows the model,
the bytes are checked as a write by name is (:mod:`.guard`), and ``id`` and ``baud_rate``
go through :mod:`.commissioning`.
"""

from __future__ import annotations

from .. import models as _models
from ..errors import ConfigError, PacketError
from ..packets import Protocol
from ..protocol2 import MAX_LENGTH
from .commissioning import Commissioning
from .model_checks import refuse_commissioning


def raw_access_limits(proto: Protocol) -> tuple[int, int, int]:
    """(address space, longest READ, longest WRITE) in bytes for raw access in ``proto``.

    Protocol 1.0: addresses and lengths are one byte, and a packet holds at most 253
    parameters (LENGTH is one byte, parameters + 2), a WRITE's address among them. Protocol
    2.0: two-byte fields, and a packet's LENGTH (instruction, parameters, CRC; a status's
    error byte among its parameters) at most :data:`.protocol2.MAX_LENGTH`, as the ROBOTIS
    SDK's buffers bound it."""
    if proto.version == 1:
        return 256, 253, 252
    return 1 << 16, MAX_LENGTH - 4, MAX_LENGTH - 5


class RawAccess(Commissioning):
    """READ and WRITE by address and size (see the module's docstring)."""

    def _check_raw_span(self, address: int, size: int, *, write: bool) -> None:
        """Refuse an address or a size the protocol cannot carry (:func:`raw_access_limits`)."""
        proto = self.proto
        space, most_read, most_write = raw_access_limits(proto)
        most = most_write if write else most_read
        what = "WRITE" if write else "READ"
        for label, number in (("address", address), ("size", size)):
            if isinstance(number, bool) or not isinstance(number, int):
                raise ConfigError(f"{label} {number!r} is not an integer")
        if not 0 <= address < space:
            raise ConfigError(f"address {address} is outside protocol {proto.version}.0's "
                              f"0..{space - 1}")
        if not 1 <= size <= most:
            raise ConfigError(f"size {size}: one {what} of protocol {proto.version}.0 carries "
                              f"1..{most} bytes")
        if address + size > space:
            raise ConfigError(f"address {address} and {size} bytes run past {space - 1}, the "
                              f"last address of protocol {proto.version}.0")

    def read_address(self, motor_id: int, address: int, size: int) -> bytes:
        """``size`` raw bytes of ``motor_id``'s control table from ``address`` (one READ),
        whatever registers are there, or none servolab knows (a model it has no table for).
        The address and size are checked against the protocol first
        (:func:`raw_access_limits`); the motor answers for the rest. The bytes come as the
        status brought them, checksum/CRC checked but not held to any register's range (as
        :meth:`read` holds them): the way to see a value that :meth:`read` refuses as
        implausible time after time."""
        self._check_raw_span(address, size, write=False)
        self.proto.check_id(motor_id)
        if 0 in self._memory.levels.values():
            self._refuse_reads_at_level_0((motor_id,))
        status = self.transact(self.proto.read(motor_id, address, size),
                               {motor_id: size})[motor_id]
        return bytes(status.params)

    def write_address(self, motor_id: int, address: int, data: bytes) -> None:
        """Write raw ``data`` at ``address`` of ``motor_id``'s control table (one WRITE;
        ``motor_id`` may be the broadcast ID).

        Where the bus knows the motor's model, the bytes are checked as a write by name is:
        every register they touch they cover whole, each value writable and in range and
        allowed by the motor's mode and limits, EEPROM with torque off; ``id`` and
        ``baud_rate`` alone go through :meth:`change_id` and :meth:`change_baud`. Bytes where
        servolab's table has no register, and every byte to a model it does not know, go as
        they are: the motor answers for them."""
        data = bytes(data)
        self._check_raw_span(address, len(data), write=True)
        proto = self.proto
        broadcast = motor_id == proto.broadcast_id
        proto.check_id(motor_id, broadcast=True)
        m = None if broadcast else self.known_model(motor_id)
        try:
            inst = proto.write(motor_id, address, data)
            proto.encode_instruction(inst)
        except PacketError as exc:
            raise ConfigError(str(exc)) from None
        end = address + len(data)
        if broadcast:  # every motor of the protocol: none may get one ID or a lost rate
            for other in _models.MODELS.values():
                if other.protocol != proto.version:
                    continue
                for name in ("id", "baud_rate"):
                    reg = other.register(name)
                    if address < reg.address + reg.size and reg.address < end:
                        raise ConfigError(f"a raw broadcast WRITE of bytes {address}..{end - 1} "
                                          f"covers {name} on the {other.name} (address "
                                          f"{reg.address}): every motor would take it; set "
                                          "IDs and rates one motor at a time (servolab id, "
                                          "servolab baud)")
        if m is None:
            level = 0 if broadcast else self._memory.levels.get(motor_id, 2)
            self.transact(inst, {motor_id: 0} if level >= 2 else None)
            return
        regs = [r for r in m.registers if address < r.address + r.size and r.address < end]
        for reg in regs:
            if reg.address < address or reg.address + reg.size > end:
                raise ConfigError(f"{m.name}: bytes {address}..{end - 1} cover part of "
                                  f"{reg.name} ({reg.address}..{reg.address + reg.size - 1}): "
                                  f"write its {reg.size} bytes from address {reg.address}")
        special = [r for r in regs if r.name in ("id", "baud_rate")]
        if special:
            if len(regs) > 1:
                refuse_commissioning([r.name for r in regs], "a raw WRITE")
            reg = special[0]
            self._commission_by_write(motor_id, reg.name, reg.decode(data), raw=True,
                                      registered=False)
            return
        for reg in regs:
            self._checked_encoding(motor_id, m, reg, reg.decode(data[reg.address - address:]), True)
        self._write_block(motor_id, m, address, data)
