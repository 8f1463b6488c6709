"""The bus's ground floor: its fields, the parts it owns, the protocol it speaks now.

:class:`BusCore` is the dataclass every part of :class:`~.Bus` (discovery, status return
level, guard, reads, writes, commissioning, raw access) builds on. What has state of its own
is an object it owns: the :class:`~.link.Link` (lock, late-answer window), the
:class:`~.memory.MotorMemory` (what it learnt of each motor), the :class:`~.plans.PlanCache`.
"""

from __future__ import annotations

import contextlib
import errno
import os
import threading
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, Self

from ..errors import ConfigError, PortError
from ..models import Model
from ..packets import Instruction, Protocol, Status
from ..ports import Port, open_port
from ..protocol import protocol as protocol_for
from .common import NameList, Value
from .link import BusStats, Link
from .memory import MotorMemory
from .plans import PlanCache


def permission_hint(url: str, exc: BaseException) -> str | None:
    """What to do when opening ``url`` failed for want of permission (EACCES, EPERM): on
    Linux a serial device belongs to the group dialout (uucp on Arch), which a user must
    join; None for any other failure."""
    seen: set[int] = set()
    chain: list[BaseException | None] = [exc]
    denied = False
    while chain:
        error = chain.pop()
        if error is None or id(error) in seen:
            continue
        seen.add(id(error))
        if isinstance(error, OSError) and error.errno in (errno.EACCES, errno.EPERM):
            denied = True
            break
        if "[Errno 13]" in str(error) or "Permission denied" in str(error):
            denied = True
            break
        chain += [error.__cause__, error.__context__]
    if not denied or os.name != "posix":
        return None
    group = "dialout"
    try:
        import grp

        if grp.getgrgid(os.stat(url).st_gid).gr_name == "uucp":
            group = "uucp"
    except (ImportError, OSError, KeyError):
        pass
    return (f"you may not open {url}: join the {group} group (sudo usermod -aG {group} "
            "$USER), then log out and in again")


@dataclass
class BusCore:
    """Motors on one port, one protocol, one baud rate: what every part of :class:`~.Bus`
    stands on (its fields, its link, what it knows of each motor, its plans, the protocol
    it speaks now).

    ``protocol`` None means the port's own (an emulated bus knows its models'), else 2.
    ``retries`` is how many times a transaction that got no valid answer is sent again.
    ``timeout`` (s), when given, replaces the computed wait for a reply (wire time of the
    expected bytes + return delays + twice the adapter latency + 2 ms); a broadcast ping
    listens at least :meth:`broadcast_ping_wait` all the same.

    ``confirm_reads``: a read (:meth:`read`, :meth:`sync_read`, :meth:`bulk_read` and the
    fast forms) returns only data that two replies in a row brought alike, at the price of
    a second transaction. Every reply is checked for what it cannot hold (a value outside
    its register's range: :class:`~.link.Link`), but a corrupt Protocol 1.0 reply whose
    paired flips cancel in its 8-bit checksum and leave a value in range cannot be told
    from a good one; two alike can. For values that hold still between two reads (settings,
    a motor at rest): a moving motor's present values may differ from one read to the next,
    and such a read fails with :class:`CorruptResponse` when no two agree.
    """

    port: Port
    protocol: Protocol | int | None = None
    retries: int = 2
    timeout: float | None = None
    motors: dict[int, Model] = field(default_factory=dict)
    stats: BusStats = field(default_factory=BusStats)
    confirm_reads: bool = False

    def __post_init__(self) -> None:
        if self.protocol is None:
            self.protocol = self.port.protocol or 2
        if not isinstance(self.protocol, Protocol):
            self.protocol = protocol_for(self.protocol)
        self._proto: Protocol = self.protocol
        #: (thread, protocol): the thread holding the bus speaks that protocol meanwhile
        #: (:meth:`_in_protocol`); other threads see :attr:`protocol` all along
        self._speaking_as: tuple[int, Protocol] | None = None
        if self.retries < 0:
            raise ConfigError(f"retries {self.retries} must be 0 or more")
        if self.timeout is not None and self.timeout <= 0:
            raise ConfigError(f"timeout {self.timeout} s must be positive")
        self._memory = MotorMemory()
        self._link = Link(self, self._memory.alerts)
        #: the link's lock: held, the bus is this thread's (a transaction, a scan, a
        #: MixedBus speaking another protocol)
        self._lock = self._link.lock
        self._plans = PlanCache()

    # -- construction ----------------------------------------------------------------------------
    @classmethod
    def open(cls, url: str, *, protocol: int | None = None, baudrate: int | None = None,
             retries: int = 2, timeout: float | None = None, **port_options: Any) -> Self:
        """A bus on a port named by ``url``: a serial device (``/dev/ttyUSB0``, ``COM3``, the
        pty ``servolab sim`` printed; ``baudrate`` default 57600) or emulated motors
        (``emu://rx28:11-16``, in a simulation of their own unless ``simulation=`` names one;
        see :mod:`servolab.sim.emulated` for which baud rate they run at). ``protocol`` None:
        the emulated models', or 2 on a serial port. ``port_options`` go to
        :func:`~.ports.open_port`.

        A port the user may not open (EACCES: on Linux, not in the group ``dialout``) says
        how to join the group, in the one line of its error."""
        try:
            port = open_port(url, baudrate, **port_options)
        except (ConfigError, PortError) as exc:
            hint = permission_hint(url, exc)
            if hint is None:
                raise
            kind = type(exc) if type(exc) in (ConfigError, PortError) else ConfigError
            raise kind(f"{exc}; {hint}") from exc
        return cls(port, protocol, retries, timeout)

    @property
    def proto(self) -> Protocol:
        """The protocol object (``protocol`` as given may be a version number); to the
        thread that holds the bus to speak another one for a while (a scan of both protocols,
        a :class:`MixedBus`), that one."""
        speaking = self._speaking_as
        if speaking is not None and speaking[0] == threading.get_ident():
            return speaking[1]
        if self.protocol is not self._proto:  # reassigned since: decode it again
            self._proto = (self.protocol if isinstance(self.protocol, Protocol)
                           else protocol_for(self.protocol or 2))
        return self._proto

    @property
    def baudrate(self) -> int:
        return self.port.baudrate

    @property
    def emulator(self) -> Any:
        """The emulated bus behind the port, or None on a real one (for tests and worlds;
        the driver itself never looks)."""
        return getattr(self.port, "emulator", None)

    def close(self) -> None:
        self.port.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- the link ------------------------------------------------------------------------------
    def transact(self, inst: Instruction, expect: Mapping[int, int] | None = None, *,
                 check: bool = True, retries: int | None = None) -> dict[int, Status]:
        """Send ``inst`` and collect status packets from the IDs in ``expect`` (ID -> number of
        parameters each answer carries). Retries on silence or corruption; raises
        :class:`NoResponse` / :class:`CorruptResponse` when they run out, and
        :class:`MotorError` when ``check`` and a status says the instruction failed (a
        hardware error alone does not: it is recorded in :attr:`alerts`)."""
        return self._link.transact(inst, expect, check=check, retries=retries)

    @property
    def alerts(self) -> Mapping[int, int]:
        """Motors whose last status reported a hardware error: ID -> those error bits (a
        read-only view, kept up to date by the bus).

        A hardware error is the motor's state, not a failed instruction: the instruction was
        carried out and its data is valid (e-Manual, Protocol 1.0 "Status Packet" and Protocol
        2.0 "Error"). On 1.0 the bits say which (0x01 input voltage, 0x04 overheating, 0x20
        overload); on 2.0 only the alert bit 0x80 comes, and the motor's
        ``hardware_error_status`` register says which (:meth:`hardware_errors` reads it).
        Every status the bus takes updates it; a motor leaves it with its first status
        without them (on 2.0 after a REBOOT)."""
        return MappingProxyType(self._memory.alerts)

    # -- which protocol it speaks --------------------------------------------------------------
    def _switch_protocol(self, version: int | None) -> None:
        """Speak protocol ``version`` from this thread (None: the bus's own again); only
        while holding the bus."""
        self._speaking_as = (None if version is None
                             else (threading.get_ident(), protocol_for(version)))

    @contextlib.contextmanager
    def _in_protocol(self, version: int) -> Iterator[None]:
        """Hold the bus and speak protocol ``version`` until the block ends."""
        with self._lock:
            before = self._speaking_as
            self._switch_protocol(version)
            try:
                yield
            finally:
                self._speaking_as = before

    # -- what a part calls on a part above it (defined there; declared for the type checker) -
    if TYPE_CHECKING:
        def read(self, motor_id: int, names: NameList, *, raw: bool = False,
                 check: bool = True, retries: int | None = None) -> dict[str, Value]: ...

        def _remember_level(self, motor_id: int, level: int) -> None: ...

        def _read_goal_limits(self, motor_id: int, m: Model) -> None: ...

        def _commission_by_write(self, motor_id: int, name: str, value: Value, *, raw: bool,
                                 registered: bool) -> None: ...
