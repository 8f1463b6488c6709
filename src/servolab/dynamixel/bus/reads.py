"""Reads: one motor's registers by name, many motors' by SYNC_READ, BULK_READ or their fast
forms (one status packet for all, X-series firmware 46 and later), else one READ each.

Each read goes through a plan (:mod:`.plans`) worked out the first time and kept; the
motors' mode decides the SI unit of 1.0 wheel speeds (:meth:`~.guard.Guard.wheel_mode`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any, overload

from ..protocol2 import HARDWARE_ERRORS
from .common import NameList, Names, Value
from .guard import Guard
from .plans import Fields, MultiRead, Read, SyncWrite

#: the type of a plain motor ID (``True`` is no ID, though it hashes as 1)
_INT = frozenset((int,))


class Reads(Guard):
    """Reading registers by name, of one motor or many (see the module's docstring)."""

    def hardware_errors(self, motor_id: int) -> tuple[str, ...]:
        """The hardware errors ``motor_id`` reports now, by name (``()`` for none): on 2.0 from
        its ``hardware_error_status`` register, on 1.0 from the error byte of a PING's
        status."""
        m = self.model_of(motor_id)
        if self.proto.version == 2 and m.has("hardware_error_status"):
            bits = int(self.read(motor_id, "hardware_error_status", raw=True))
            return tuple(name for bit, name in sorted(HARDWARE_ERRORS.items()) if bits & bit)
        v1 = self.proto.version == 1
        status = self.transact(self.proto.ping(motor_id), {motor_id: 0 if v1 else 3},
                               check=False)[motor_id]
        return self.proto.error_names(self.proto.alert(status.error))

    # -- plans -----------------------------------------------------------------------------
    def _plan_read(self, motor_id: int, names: Names, key: Any) -> Read:
        m = self.model_of(motor_id)
        plan = Read(self.proto, motor_id, m, Fields(m, names))
        self._plans.keep(key, plan)
        return plan

    def _plan_multi_read(self, requests: Sequence[tuple[int, Names]], key: Any, *,
                         allow_sync: bool, fast: bool | None = False) -> MultiRead:
        """The plan of a read of many motors, each model learnt and each name checked."""
        ids = tuple(i for i, _ in requests)
        models = [self.model_of(i) for i in ids]
        fields = [Fields(m, names) for m, (_, names) in zip(models, requests, strict=True)]
        plan = MultiRead(self.proto, ids, models, fields, allow_sync=allow_sync, fast=fast)
        self._plans.keep(key, plan)
        return plan

    def _plan_holds(self, plan: MultiRead | SyncWrite | None, ids: tuple[int, ...]) -> bool:
        """Whether a plan still holds: same protocol, every motor still the same model, and
        the IDs plain ints (``True`` would find motor 1's plan)."""
        return (plan is not None and plan.proto is self.proto
                and list(map(self.motors.get, ids)) == plan.models
                and set(map(type, ids)) <= _INT)

    @overload
    def read(self, motor_id: int, names: str, *, raw: bool = False,
             check: bool = True, retries: int | None = None) -> Value: ...

    @overload
    def read(self, motor_id: int, names: NameList, *, raw: bool = False,
             check: bool = True, retries: int | None = None) -> dict[str, Value]: ...

    def read(self, motor_id: int, names: Names, *, raw: bool = False,
             check: bool = True, retries: int | None = None) -> Value | dict[str, Value]:
        """Read one register (returns its value) or several (returns a dict), in SI units
        unless ``raw``. Several registers go out as one contiguous READ. (Moving and present
        speed of an RX-28 or EX-106+ in wheel mode: the unloaded speed, see :meth:`write`.)
        ``retries`` replaces the bus's own for this read."""
        if not isinstance(names, str | list | tuple):
            names = list(names)  # any other iterable: read it once
        key = (motor_id, names if isinstance(names, str) else tuple(names))
        plan = self._plans.get(key)
        if (plan is None or type(motor_id) is not int or plan.proto is not self.proto
                or self.motors.get(motor_id) is not plan.model):
            plan = self._plan_read(motor_id, names, key)
        if 0 in self._memory.levels.values():
            self._refuse_reads_at_level_0((motor_id,))
        # moving/present speed in wheel mode on AX/RX/EX: the motor's mode decides the unit
        wheel = not raw and plan.fields.moded and self._in_wheel_mode(motor_id)
        buf, data_at, _ = self._link.exchange(plan.request, "READ", plan.replies, check, retries,
                                              plausible=plan.plausible,
                                              confirm=self.confirm_reads)
        return plan.fields.values(buf, data_at[0], raw, wheel)  # type: ignore[no-any-return]

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
        """The same register(s) of many motors: one SYNC_READ on 2.0, one BULK_READ on 1.0
        models that have it, else one READ each. Returns {id: value} for one register name,
        {id: {name: value}} for a list of names. Motors that report a hardware error answer
        all the same: their data is returned and they are named in :attr:`alerts`.

        ``fast``: True sends FAST_SYNC_READ, one status packet for all the motors (see
        :meth:`fast_sync_read`), and raises :class:`ConfigError` before sending anything
        where a motor's model lacks it; None sends it where every motor has it and the plain
        instruction otherwise; False, the default, never. (Not None by default: the packets
        this method sends are those of the ROBOTIS SDK's GroupSyncRead.txRxPacket, which the
        bus_cycle benchmark replays byte for byte to both drivers, and what existing users
        of SYNC_READ count on; a motor on old firmware stays silent to 0x8A, and a declared
        model cannot tell the firmware a real motor runs.)"""
        ids_t = tuple(dict.fromkeys(ids))
        if not ids_t:
            return {}
        if not isinstance(names, str):
            names = tuple(names)
        key = ("sync_read", names, ids_t, fast)
        plan = self._plans.get(key)
        if not self._plan_holds(plan, ids_t):
            plan = self._plan_multi_read([(i, names) for i in ids_t], key, allow_sync=True,
                                         fast=fast)
        return self._run_multi_read(plan, raw, check)

    def bulk_read(self, requests: Mapping[int, Names], *, raw: bool = False,
                  check: bool = True, fast: bool | None = False
                  ) -> dict[int, dict[str, Value]]:
        """Different registers of different motors: {id: names} -> {id: {name: value}}.
        One BULK_READ where every model has it, else one contiguous READ per motor.
        ``fast`` as in :meth:`sync_read`, for FAST_BULK_READ."""
        if not requests:
            return {}
        pairs = [(i, [n] if isinstance(n, str) else list(n)) for i, n in requests.items()]
        ids = tuple(i for i, _ in pairs)
        key = ("bulk_read", tuple((i, tuple(n)) for i, n in pairs), fast)
        plan = self._plans.get(key)
        if not self._plan_holds(plan, ids):
            plan = self._plan_multi_read(pairs, key, allow_sync=False, fast=fast)
        return self._run_multi_read(plan, raw, check)

    @overload
    def fast_sync_read(self, names: str, ids: Iterable[int], *, raw: bool = False,
                       check: bool = True) -> dict[int, Value]: ...

    @overload
    def fast_sync_read(self, names: NameList, ids: Iterable[int], *, raw: bool = False,
                       check: bool = True) -> dict[int, dict[str, Value]]: ...

    def fast_sync_read(self, names: Names, ids: Iterable[int], *, raw: bool = False,
                       check: bool = True) -> dict[int, Value] | dict[int, dict[str, Value]]:
        """:meth:`sync_read` with FAST_SYNC_READ (0x8A): the motors answer with one status
        packet between them, each after the first appending its block at once, which saves
        the header and the return delay of every status packet but one. X-series firmware
        46 and later only (:data:`.models.FAST_READ_FIRMWARE`): other models are refused
        with :class:`ConfigError` before anything is sent. A motor that does not answer
        stops the chain: the :class:`NoResponse` names it, and the motors after it."""
        if isinstance(names, str):
            return self.sync_read(names, ids, raw=raw, check=check, fast=True)
        return self.sync_read(tuple(names), ids, raw=raw, check=check, fast=True)

    def fast_bulk_read(self, requests: Mapping[int, Names], *, raw: bool = False,
                       check: bool = True) -> dict[int, dict[str, Value]]:
        """:meth:`bulk_read` with FAST_BULK_READ (0x9A), as :meth:`fast_sync_read`."""
        return self.bulk_read(requests, raw=raw, check=check, fast=True)

    def _run_multi_read(self, plan: MultiRead, raw: bool, check: bool) -> dict[int, Any]:
        if 0 in self._memory.levels.values():
            self._refuse_reads_at_level_0(plan.ids)
        # the motors whose speeds convert as in wheel mode (see read)
        wheel = ({i for i in plan.moded if self._in_wheel_mode(i)} if plan.moded and not raw
                 else None)
        if plan.reads:
            out = {}
            for read in plan.reads:
                buf, data_at, _ = self._link.exchange(read.request, "READ", read.replies, check,
                                                      None, plausible=read.plausible,
                                                      confirm=self.confirm_reads)
                out[read.motor_id] = read.fields.values(
                    buf, data_at[0], raw, wheel is not None and read.motor_id in wheel)
            return out
        buf, data_at, _ = self._link.exchange(plan.request, plan.name, plan.replies, check, None,
                                              plausible=plan.plausible,
                                              confirm=self.confirm_reads)
        if wheel:
            return {i: f.values(buf, at, raw, i in wheel)
                    for i, f, at in zip(plan.ids, plan.fields, data_at, strict=True)}
        return {i: f.values(buf, at, raw)
                for i, f, at in zip(plan.ids, plan.fields, data_at, strict=True)}
