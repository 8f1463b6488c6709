"""One bus whose motors speak Protocol 1.0 and 2.0 (:class:`MixedBus`), as DynamixelSDK's
``protocol_combined`` example drives them: the driver of :mod:`.bus`, each motor spoken to in
its own protocol. A module of its own because nothing else needs it: a bus of one protocol is
:class:`~.bus.Bus`.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, overload

from .bus import Bus, Contact, NameList, Names, PingResult, Value, log
from .errors import ConfigError, NoResponse
from .models import Model, model
from .packets import BROADCAST_ID
from .protocol import protocol as protocol_for
from .protocol1 import PROTOCOL1


def _group(ids: Iterable[int], version_of: Callable[[int], int]) -> dict[int, list[int]]:
    """``ids`` by protocol version, 2.0 first, each group in the order given."""
    groups: dict[int, list[int]] = {}
    for motor_id in ids:
        groups.setdefault(version_of(motor_id), []).append(motor_id)
    return {v: groups[v] for v in sorted(groups, reverse=True)}


@dataclass
class MixedBus(Bus):
    """One port whose motors speak Protocol 1.0 and 2.0, as DynamixelSDK's
    ``protocol_combined`` example drives them (one port, a packet handler per protocol): each
    motor is spoken to in its own protocol, the one it answered in (:meth:`scan` looks in
    both and keeps every motor it finds), its declared model's (:meth:`declare`), or, for a
    motor not met yet, the one it answers a PING in (2.0 tried first, then 1.0).

    Everything :class:`Bus` does, motor by motor, in that motor's protocol; what addresses
    several motors (sync and bulk reads and writes, :meth:`broadcast_write`, :meth:`action`)
    goes out as one instruction per protocol, 2.0 first. IDs are one set across the two
    protocols: a 1.0 and a 2.0 motor at one ID are both found by a scan, with a warning, and
    the bus then speaks to the first (2.0). ``protocol`` is what it speaks where no motor
    decides (a broadcast PING, a raw :meth:`transact`): 2.0 unless given.

    A 1.0 motor takes a 2.0 packet for noise and the other way round (a 2.0 packet,
    ``FF FF FD 00 ...``, would be a 1.0 packet for ID 253 with LENGTH 0, which no motor
    takes; a 1.0 packet lacks the 2.0 header), which is what lets one wire carry both.
    """

    def __post_init__(self) -> None:
        super().__post_init__()
        #: each motor's protocol version as found or declared (also where its model is not
        #: one servolab knows)
        self.versions: dict[int, int] = {}

    def version_of(self, motor_id: int) -> int:
        """The protocol ``motor_id`` speaks: as found or declared, else the one it answers a
        PING in (2.0 first); :class:`NoResponse` when it answers in neither."""
        m = self.motors.get(motor_id)
        if m is not None:
            return m.protocol
        known = self.versions.get(motor_id)
        if known is not None:
            return known
        if isinstance(motor_id, bool) or not isinstance(motor_id, int):
            return self.proto.version          # (the call it came from refuses it)
        for version in (2, 1):
            proto = protocol_for(version)
            if not 0 <= motor_id <= proto.max_id:
                continue
            with self._in_protocol(version):
                try:
                    Bus.ping(self, motor_id)
                except NoResponse:
                    continue
            self.versions[motor_id] = version
            return version
        if not 0 <= motor_id <= PROTOCOL1.max_id:
            return self.proto.version          # (refused there, naming the range)
        raise NoResponse(f"motor {motor_id}: no answer to PING in protocol 2.0 or 1.0 at "
                         f"{self.baudrate} bps (is it powered, at this baud rate and ID?)",
                         motor_id=motor_id, instruction="PING")

    @contextlib.contextmanager
    def _in_protocol_of(self, motor_id: int) -> Iterator[None]:
        with self._lock, self._in_protocol(self.version_of(motor_id)):
            yield

    # -- discovery ---------------------------------------------------------------------------
    def scan(self, ids: Iterable[int] | None = None, baudrates: Iterable[int] | None = None,
             *, protocols: Iterable[int] | None = (1, 2),
             progress: Callable[[int, int], None] | None = None,
             broadcast: bool | None = None) -> list[PingResult]:
        """:meth:`Bus.scan`, in both protocols unless told, keeping every motor found (its
        model in :attr:`motors`, its protocol in :attr:`versions`)."""
        found = super().scan(ids, baudrates, protocols=protocols, progress=progress,
                             broadcast=broadcast)
        seen: dict[int, int] = {}
        first = {r.id: r for r in reversed(found)}  # each ID's first result: 2.0 goes first
        for result in found:
            version = result.protocol or self.proto.version
            if result.id in seen and seen[result.id] != version:
                kept = first[result.id]
                if kept.model is not None:  # the model the bus speaks to is the 2.0 one's
                    self.motors[result.id] = kept.model
                log.warning("ID %d answers in protocol 2.0 and in 1.0: two motors, which a "
                            "bus addresses by ID alone; this one speaks to the 2.0 motor: give "
                            "one of them another ID", result.id)
                continue
            seen[result.id] = version
            self.versions[result.id] = version
        return found

    def _scan_keeps(self, version: int, own: int) -> bool:
        return True

    def ping(self, motor_id: int, *, retries: int | None = None) -> PingResult:
        with self._in_protocol_of(motor_id):
            return super().ping(motor_id, retries=retries)

    def broadcast_ping(self, ids: Iterable[int] | None = None) -> list[PingResult]:
        with self._in_protocol(2):
            return super().broadcast_ping(ids)

    def model_of(self, motor_id: int) -> Model:
        with self._in_protocol_of(motor_id):
            return super().model_of(motor_id)

    def known_model(self, motor_id: int) -> Model | None:
        with self._in_protocol_of(motor_id):
            return super().known_model(motor_id)

    def declare(self, motor_id: int, model_name: str | Model, *,
                wheel_mode: bool | None = None) -> None:
        m = model_name if isinstance(model_name, Model) else model(model_name)
        with self._in_protocol(m.protocol):
            super().declare(motor_id, m, wheel_mode=wheel_mode)
        self.versions[motor_id] = m.protocol

    def hardware_errors(self, motor_id: int) -> tuple[str, ...]:
        with self._in_protocol_of(motor_id):
            return super().hardware_errors(motor_id)

    def wheel_mode(self, motor_id: int) -> bool:
        with self._in_protocol_of(motor_id):
            return super().wheel_mode(motor_id)

    def to_si(self, motor_id: int, name: str, raw: int) -> Value:
        with self._in_protocol_of(motor_id):
            return super().to_si(motor_id, name, raw)

    def from_si(self, motor_id: int, name: str, value: float) -> int:
        with self._in_protocol_of(motor_id):
            return super().from_si(motor_id, name, value)

    def contact(self, motor_id: int) -> Contact:
        with self._in_protocol_of(motor_id):
            return super().contact(motor_id)

    def reboot(self, motor_id: int) -> None:
        with self._in_protocol(2) if motor_id == BROADCAST_ID else self._in_protocol_of(motor_id):
            super().reboot(motor_id)

    def factory_reset(self, motor_id: int, *, keep_id: bool = True,
                      keep_baud: bool = True) -> None:
        if motor_id == BROADCAST_ID:
            raise ConfigError("a mixed bus resets its motors one at a time (factory_reset of "
                              "each ID): a broadcast reaches one protocol's motors only")
        with self._in_protocol_of(motor_id):
            super().factory_reset(motor_id, keep_id=keep_id, keep_baud=keep_baud)

    def change_id(self, motor_id: int, new_id: int) -> PingResult:
        """:meth:`Bus.change_id`: refused where a motor of either protocol answers at
        ``new_id`` (its PING there is this bus's, which tries both)."""
        version = self.version_of(motor_id)
        with self._in_protocol(version):
            found = super().change_id(motor_id, new_id)
        if new_id != motor_id:
            self.versions.pop(motor_id, None)
            self.versions[new_id] = version
        return found

    def change_baud(self, motor_id: int, baudrate: int, *, follow: bool = True) -> PingResult:
        with self._in_protocol_of(motor_id):
            return super().change_baud(motor_id, baudrate, follow=follow)

    def read_address(self, motor_id: int, address: int, size: int) -> bytes:
        with self._in_protocol_of(motor_id):
            return super().read_address(motor_id, address, size)

    def write_address(self, motor_id: int, address: int, data: bytes) -> None:
        if motor_id == BROADCAST_ID:
            raise ConfigError("a raw broadcast reaches one protocol's motors only: on a mixed "
                              "bus use broadcast_write (by register name, each protocol's "
                              "motors in their own)")
        with self._in_protocol_of(motor_id):
            super().write_address(motor_id, address, data)

    # -- one motor ---------------------------------------------------------------------------
    @overload
    def read(self, motor_id: int, names: str, *, raw: bool = False,
             check: bool = True, retries: int | None = None) -> Value: ...

    @overload
    def read(self, motor_id: int, names: NameList, *, raw: bool = False,
             check: bool = True, retries: int | None = None) -> dict[str, Value]: ...

    def read(self, motor_id: int, names: Names, *, raw: bool = False,
             check: bool = True, retries: int | None = None) -> Value | dict[str, Value]:
        with self._in_protocol_of(motor_id):
            if isinstance(names, str):
                return super().read(motor_id, names, raw=raw, check=check, retries=retries)
            return super().read(motor_id, list(names), raw=raw, check=check,
                                retries=retries)

    def write(self, motor_id: int, name: str | Mapping[str, Value], value: Value | None = None,
              *, raw: bool = False, registered: bool = False) -> None:
        with self._in_protocol_of(motor_id):
            super().write(motor_id, name, value, raw=raw, registered=registered)

    # -- several motors: one instruction per protocol ----------------------------------------
    def _groups(self, ids: Iterable[int]) -> dict[int, list[int]]:
        return _group(ids, self.version_of)

    def action(self) -> None:
        """ACTION in both protocols (one broadcast each): every motor applies its
        REG_WRITE."""
        with self._lock:
            waiting = self._memory.registered
            pending = dict(waiting)
            for version in (2, 1):
                waiting.clear()
                waiting.update({i: w for i, w in pending.items()
                                if self.version_of(i) == version})
                with self._in_protocol(version):
                    super().action()

    def broadcast_write(self, name: str | Mapping[str, Value], value: Value | None = None, *,
                        raw: bool = False, models: Iterable[str | Model] | None = None
                        ) -> list[int]:
        """:meth:`Bus.broadcast_write` in each protocol that has motors the bus knows (or
        among ``models``): one WRITE to the broadcast ID in each, checked against the tables
        of that protocol's motors."""
        given = None if models is None else [m if isinstance(m, Model) else model(m)
                                             for m in models]
        versions = sorted({m.protocol for m in (given if given is not None
                                                else self.motors.values())}, reverse=True)
        if not versions:
            versions = [self.proto.version]    # (refused there: no motor known)
        ids: list[int] = []
        with self._lock:
            plans = []
            for version in versions:          # all checked before anything is sent
                with self._in_protocol(version):
                    mine = None if given is None else [m for m in given
                                                       if m.protocol == version]
                    plans.append((version, self._check_broadcast_write(name, value, raw, mine)))
            for version, blocks in plans:
                with self._in_protocol(version):
                    ids += self._send_broadcast_write(blocks)
        return sorted(ids)

    @overload
    def sync_write(self, names: str, values: Mapping[int, Value], *,
                   raw: bool = False) -> None: ...

    @overload
    def sync_write(self, names: NameList, values: Mapping[int, Sequence[Value]], *,
                   raw: bool = False) -> None: ...

    def sync_write(self, names: Names, values: Mapping[int, Value | Sequence[Value]], *,
                   raw: bool = False) -> None:
        with self._lock:
            groups = self._groups(values)
            if len(groups) > 1:                      # all checked before anything is sent
                for i, v in values.items():
                    if isinstance(names, str):
                        self._precheck(i, {names: v}, raw)  # type: ignore[dict-item]
                    elif isinstance(v, Sequence) and len(v) == len(names):
                        self._precheck(i, dict(zip(names, v, strict=True)), raw)
            for version, ids in groups.items():
                with self._in_protocol(version):
                    if isinstance(names, str):
                        super().sync_write(names, {i: values[i] for i in ids},  # type: ignore[misc]
                                           raw=raw)
                    else:
                        super().sync_write(list(names), {i: values[i] for i in ids},  # type: ignore[misc]
                                           raw=raw)

    @overload
    def sync_read(self, names: str, ids: Iterable[int], *, raw: bool = False,
                  check: bool = True, fast: bool | None = False) -> dict[int, Value]: ...

    @overload
    def sync_read(self, names: NameList, ids: Iterable[int], *, raw: bool = False,
                  check: bool = True, fast: bool | None = False
                  ) -> dict[int, dict[str, Value]]: ...

    def sync_read(self, names: Names, ids: Iterable[int], *, raw: bool = False,
                  check: bool = True, fast: bool | None = False
                  ) -> dict[int, Value] | dict[int, dict[str, Value]]:
        ids = list(ids)
        got: dict[int, Any] = {}
        with self._lock:
            for version, group in self._groups(ids).items():
                with self._in_protocol(version):
                    if isinstance(names, str):
                        got.update(super().sync_read(names, group, raw=raw, check=check,
                                                     fast=fast))
                    else:
                        got.update(super().sync_read(list(names), group, raw=raw,
                                                     check=check, fast=fast))
        return {i: got[i] for i in ids}

    def bulk_read(self, requests: Mapping[int, Names], *, raw: bool = False,
                  check: bool = True, fast: bool | None = False
                  ) -> dict[int, dict[str, Value]]:
        got: dict[int, dict[str, Value]] = {}
        with self._lock:
            for version, group in self._groups(requests).items():
                with self._in_protocol(version):
                    got.update(super().bulk_read({i: requests[i] for i in group}, raw=raw,
                                                 check=check, fast=fast))
        return {i: got[i] for i in requests}

    @overload
    def fast_sync_read(self, names: str, ids: Iterable[int], *, raw: bool = False,
                       check: bool = True) -> dict[int, Value]: ...

    @overload
    def fast_sync_read(self, names: NameList, ids: Iterable[int], *, raw: bool = False,
                       check: bool = True) -> dict[int, dict[str, Value]]: ...

    def fast_sync_read(self, names: Names, ids: Iterable[int], *, raw: bool = False,
                       check: bool = True) -> dict[int, Value] | dict[int, dict[str, Value]]:
        if isinstance(names, str):
            return self.sync_read(names, ids, raw=raw, check=check, fast=True)
        return self.sync_read(list(names), ids, raw=raw, check=check, fast=True)

    def _precheck(self, motor_id: int, values: Mapping[str, Value], raw: bool) -> None:
        """Check a write of ``values`` to ``motor_id`` as :meth:`write` does, sending nothing
        (but what finding out its model, mode and limits takes)."""
        with self._in_protocol_of(motor_id):
            self._checked_block(motor_id, self.model_of(motor_id), values, raw)

    def bulk_write(self, values: Mapping[int, Mapping[str, Value]], *,
                   raw: bool = False) -> None:
        with self._lock:
            groups = self._groups(values)
            if len(groups) > 1:                      # all checked before anything is sent
                for motor_id, written in values.items():
                    self._precheck(motor_id, written, raw)
            for version, group in groups.items():
                with self._in_protocol(version):
                    super().bulk_write({i: values[i] for i in group}, raw=raw)
