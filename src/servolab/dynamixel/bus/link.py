"""The link: one instruction out, its status packets in, checked, on a port shared by threads.

A :class:`Link` is what every other part of the bus sends through. It owns the lock that
makes a transaction atomic, the window after a silent transaction in which a late answer
may still come (waited out before the next request, so that a late answer is never read as
the answer to the next one), and the recording of the hardware errors statuses report. The
port, protocol, retries and timeout it reads from its owner, the :class:`~.facade.Bus`, whose
public fields they are (a caller may reassign them: the controller manager raises
``retries`` for a start-up ping, a benchmark swaps the ``port``).
"""

from __future__ import annotations

import itertools
import threading
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol as TypingProtocol

from ..errors import CommError, CorruptResponse, MotorError, NoResponse
from ..packets import Instruction, Protocol, Status, StreamParser
from ..ports import Port
from ..protocol2 import (
    FAST_HEAD,
    crc16_at,
    fast_status_head,
    fast_status_length,
    match_fast_status,
    read_fast_status,
)
from .common import MAX_RETURN_DELAY, log


@dataclass
class BusStats:
    """Counters a user can print to see how healthy the wire is.

    ``corrupt`` counts the replies that failed their checksum/CRC or their framing,
    ``implausible`` those that passed it but could not be true (see :class:`Link`); both
    are retried, so a read that ends well may have counted some."""

    transactions: int = 0
    retries: int = 0
    timeouts: int = 0
    corrupt: int = 0
    bytes_out: int = 0
    bytes_in: int = 0
    #: status packets thrown away: late answers to an earlier instruction, answers from a
    #: motor not asked or of the wrong length
    stale: int = 0
    #: replies whose checksum/CRC was right but whose content no motor sends: a read value
    #: outside what its register can hold, an error byte with a bit its protocol keeps at 0
    implausible: int = 0


#: What a read checks of the reply's data: given the reply bytes, where each motor's data
#: starts and the error bytes, None, or the motor whose data cannot be true and a sentence
#: that says why.
Plausible = Callable[[bytes, Sequence[int], Sequence[int]], "tuple[int, str] | None"]


def statuses_in(chunk: bytes, parser: StreamParser, proto: Protocol, stats: BusStats
                ) -> Iterator[Status]:
    """The status packets in ``chunk``, fed to ``parser`` after what came before it; a frame
    that is no status (an instruction echoed, a bad length) is counted stale and skipped."""
    for frame in parser.feed(chunk):
        try:
            yield proto.as_status(frame)
        except ValueError:
            stats.stale += 1


class LinkOwner(TypingProtocol):
    """What a :class:`Link` reads of the bus that owns it, at each transaction."""

    port: Port
    retries: int
    timeout: float | None
    stats: BusStats

    @property
    def proto(self) -> Protocol: ...


class Replies:
    """The status packets that answer one instruction, in the order they come (ID -> number of
    data bytes), and where each sits in the reply when every one comes as expected."""

    __slots__ = ("counts", "data_at", "delays", "ends", "expect", "fast", "ids", "prefixes",
                 "single", "sizes", "starts", "states", "total")

    def __init__(self, proto: Protocol, expect: Mapping[int, int], *,
                 fast: bool = False) -> None:
        self.expect = dict(expect)
        self.ids = tuple(self.expect)
        self.counts = tuple(self.expect.values())
        #: one fast status packet (FAST_SYNC_READ / FAST_BULK_READ, protocol 2.0) for all
        self.fast = fast
        self.ends: tuple[int, ...] = ()
        if fast:
            # The packet's 8-byte head, then per motor a block ERR ID DATA CRC (4 + n bytes)
            # ending with the running CRC at ``ends[k]`` (protocol2.fast_block). Only the
            # first motor waits its return delay; the others append their block at once.
            self.sizes = tuple(4 + n for n in self.counts)
            starts = list(itertools.accumulate(self.sizes, initial=FAST_HEAD))
            self.total = starts.pop()
            self.starts = tuple(starts)
            self.data_at = tuple(start + 2 for start in starts)
            self.ends = tuple(at + n for at, n in zip(self.data_at, self.counts, strict=True))
            head = fast_status_head(fast_status_length(self.counts))
            self.prefixes: tuple[bytes, ...] = (head,)
            self.states: tuple[int, ...] = (crc16_at(head, 0, FAST_HEAD),)
            self.single = False
            self.delays = MAX_RETURN_DELAY
            return
        self.sizes = tuple(proto.status_size(n) for n in self.counts)
        starts = list(itertools.accumulate(self.sizes, initial=0))
        self.total = starts.pop()
        self.starts = tuple(starts)
        self.data_at = tuple(start + proto.params_at for start in starts)
        self.prefixes = tuple(proto.status_prefix(i, n) for i, n in self.expect.items())
        self.states = tuple(proto.prefix_state(prefix) for prefix in self.prefixes)
        self.single = len(self.ids) == 1
        self.delays = len(self.ids) * MAX_RETURN_DELAY  # the longest each answer may wait


class Link:
    """One port's transactions for the bus that owns it (see the module's docstring).

    ``alerts`` is the bus's record of motors reporting a hardware error (ID -> error bits),
    which every status taken here updates.

    **Only plausible replies.** A status is taken only from a motor asked, with the length
    asked for (else it is stale), and only when its checksum/CRC is right. That is not
    enough on Protocol 1.0: its checksum is the complement of an 8-bit *sum* (e-Manual,
    Protocol 1.0, Status Packet: ``~(ID + Length + Error + Parameter1 + ... + Parameter N)``),
    so two flips that cancel in the sum pass it: a bit k set in one byte and cleared in
    another, bit 7 set in two bytes (+256 = 0), or a data bit and the same bit of the
    checksum itself. Protocol 2.0's CRC-16 (polynomial 0x8005) catches every such pair and
    any burst of up to 16 bits, so far fewer corrupt replies get through. A reply whose
    checksum/CRC passed is therefore still checked for what no motor sends: an error byte
    with a bit its protocol keeps at 0 (:meth:`~.packets.Protocol.implausible_error`), and
    for a read, each value against what its register can hold (``plausible``, see
    :func:`~..models.read_limits`). Such a reply is counted in
    :attr:`BusStats.implausible` and retried as a checksum failure is; when the retries run
    out, :class:`CorruptResponse` is raised, and the value is never returned. What this
    cannot catch is a corrupt value that is still one the register can hold: paired flips in
    a Protocol 1.0 reply that stay in range come through (docs/dynamixel.md, "Corrupt
    replies")."""

    def __init__(self, owner: LinkOwner, alerts: dict[int, int]) -> None:
        self._owner = owner
        self.alerts = alerts
        self.lock = threading.RLock()
        #: after a transaction that got no valid answer: until when a late one may still come
        self.quiet_until: float | None = None

    def wait_out_late_answers(self) -> None:
        """The last transaction got no valid answer: let the time in which its answer could
        still come pass, and throw away whatever came meanwhile, so that a late answer is
        never taken for the answer to the next request. (Costs nothing after a transaction
        that went well: :attr:`quiet_until` is None then.)"""
        until, self.quiet_until = self.quiet_until, None
        if until is None:
            return
        port = self._owner.port
        clock = port.clock
        left = until - clock.now()
        if left > 0:
            late = port.read(1 << 16, left)
            self._owner.stats.bytes_in += len(late)
            left = until - clock.now()
            if left > 0:
                clock.sleep(left)
        port.reset_input()

    def send_unanswered(self, data: bytes) -> None:
        """A transaction that no status answers (broadcast, or status return level < 2)."""
        port, stats = self._owner.port, self._owner.stats
        with self.lock:
            if self.quiet_until is not None:
                self.wait_out_late_answers()
            stats.transactions += 1
            port.reset_input()
            port.write(data)
            stats.bytes_out += len(data)

    def transact(self, inst: Instruction, expect: Mapping[int, int] | None = None, *,
                 check: bool = True, retries: int | None = None) -> dict[int, Status]:
        """:meth:`.Bus.transact`: ``inst`` out, the statuses of the IDs in ``expect`` in."""
        proto = self._owner.proto
        data = proto.encode_instruction(inst)
        if not expect:
            self.send_unanswered(data)
            return {}
        replies = Replies(proto, expect)
        statuses: dict[int, Status] = {}
        buf, data_at, errors = self.exchange(data, proto.instruction_name(inst.instruction),
                                             replies, check, retries, statuses)
        if statuses:  # the stream parser found them: as they came
            return statuses
        return {i: Status(i, errors[k] if errors else 0, buf[at:at + n])
                for k, (i, n, at) in enumerate(zip(replies.ids, replies.counts, data_at,
                                                   strict=True))}

    def exchange(self, data: bytes, name: str, replies: Replies, check: bool,
                 retries: int | None, statuses: dict[int, Status] | None = None, *,
                 alerts: bool = True, plausible: Plausible | None = None,
                 confirm: bool = False) -> tuple[bytes, Sequence[int], Sequence[int]]:
        """Send ``data`` and take the status packets ``replies`` describes: returns the reply
        bytes, where each motor's data starts in them, and the error bytes (``()`` when all
        are 0). The fast path reads exactly the bytes expected and checks them in place; when
        they are not as expected, the stream parser looks for the packets until the timeout
        (``statuses``, when given, receives them as found). ``alerts`` False: the statuses'
        hardware-error bits are not the motors' state now (see :meth:`.Bus.reboot`).
        ``plausible``: what a read checks of its data (see the class docstring); a reply it
        refuses is retried, and raises :class:`CorruptResponse` when the retries run out.
        ``confirm``: a reply is taken only when the next one brings the same data and error
        bytes (:attr:`.Bus.confirm_reads`); one more transaction than ``retries`` allows
        for it, and a pair that differs counts as implausible and is retried."""
        owner = self._owner
        port, stats, proto = owner.port, owner.stats, owner.proto
        total = replies.total
        attempts = 1 + (owner.retries if retries is None else retries) + confirm
        kept: tuple[tuple[bytes, ...], tuple[int, ...]] | None = None  # to be confirmed
        doubts: set[tuple[int, str]] = set()  # what the implausible replies said
        with self.lock:
            # How long after sending the answers can take at most: the wire time of the bytes
            # both ways, each answer's longest return delay (254 x 2 us), twice the adapter's
            # latency, and 2 ms. The timeout unless one is set; the late-answer window always.
            # Under the lock: another thread's scan may have the port at another rate.
            longest = ((len(data) + total) * 10.0 / port.baudrate + replies.delays
                       + 2 * port.latency + 0.002)
            timeout = longest if owner.timeout is None else owner.timeout
            for attempt in range(attempts):
                if self.quiet_until is not None:
                    self.wait_out_late_answers()
                port.reset_input()
                port.write(data)
                sent = port.clock.now()
                buf = port.read(total, timeout)
                stats.transactions += 1
                stats.bytes_out += len(data)
                stats.bytes_in += len(buf)
                if attempt and kept is None:
                    stats.retries += 1
                errors: Sequence[int] | None = None
                if len(buf) == total:
                    if replies.fast:
                        errors = match_fast_status(buf, replies.prefixes[0], replies.states[0],
                                                   replies.ids, replies.ends)
                    elif replies.single:
                        error = proto.match_status(buf, replies.prefixes[0], replies.states[0])
                        errors = () if not error else None if error < 0 else [error]
                    else:
                        errors = proto.match_statuses(buf, replies.starts, replies.sizes,
                                                      replies.prefixes, replies.states)
                if errors is None:
                    collect = self._collect_fast_status if replies.fast else self._collect_statuses
                    try:
                        found = collect(buf, name, replies, sent, timeout)
                    except CommError:
                        # its answer may still be on its way: keep it from the next request
                        self.quiet_until = sent + longest
                        kept = None
                        if attempt + 1 == attempts:
                            raise
                        continue
                    buf, errors = self._lay_out(found, replies)
                    if statuses is not None:
                        statuses.clear()
                        statuses.update(found)
                doubt = self._implausible(replies, errors) if errors else None
                if doubt is None and plausible is not None:
                    doubt = plausible(buf, replies.data_at, errors)
                if doubt is not None:
                    kept = None
                    stats.implausible += 1
                    doubts.add(doubt)
                    log.debug("%s: motor %d: %s (attempt %d of %d)", name, *doubt,
                              attempt + 1, attempts)
                    if attempt + 1 == attempts:
                        # The same each time is no noise: the motor holds it, beyond what
                        # its model file says it can.
                        same = (f"; the same {attempts} times: if motor {doubt[0]} does hold "
                                "it, its model file's range is narrower than the motor's "
                                "(read_address reads it unchecked)"
                                if len(doubts) == 1 and attempts > 1 else "")
                        raise CorruptResponse(
                            f"motor {doubt[0]}: {name} got {doubt[1]}: a corrupt status that "
                            f"passed its {'checksum' if proto.version == 1 else 'CRC'} at "
                            f"{port.baudrate} bps{same}", motor_id=doubt[0], instruction=name)
                    continue
                if confirm:
                    reply = (tuple(buf[at:at + n] for at, n in zip(replies.data_at,
                                                                   replies.counts,
                                                                   strict=True)),
                             tuple(errors))
                    if reply != kept:
                        if kept is not None:
                            stats.implausible += 1  # one of the two was corrupt
                        kept = reply
                        if attempt + 1 == attempts:
                            raise CorruptResponse(
                                f"motor {', '.join(map(str, replies.ids))}: {name} got no two "
                                f"replies alike in {attempts} (confirm_reads) at "
                                f"{port.baudrate} bps: corrupt replies, or data that changes "
                                "from one read to the next", motor_id=replies.ids[0],
                                instruction=name)
                        continue
                if errors or self.alerts:
                    self._record_hardware_errors(replies.ids, errors, name, check, alerts)
                return buf, replies.data_at, errors
        raise AssertionError("unreachable")  # pragma: no cover

    def _implausible(self, replies: Replies, errors: Sequence[int]) -> tuple[int, str] | None:
        """An error byte no motor sends in a reply that passed its checksum/CRC: the motor
        and what, or None."""
        proto = self._owner.proto
        for motor_id, error in zip(replies.ids, errors, strict=True):
            doubt = proto.implausible_error(error)
            if doubt is not None:
                return motor_id, doubt
        return None

    def _record_hardware_errors(self, ids: Sequence[int], errors: Sequence[int], name: str,
                                check: bool, record: bool = True) -> None:
        """Record the hardware errors the statuses report (:attr:`alerts`), unless not
        ``record``, and raise :class:`MotorError` for an instruction that failed, when
        ``check``."""
        proto, alerts = self._owner.proto, self.alerts
        for k, motor_id in enumerate(ids if record else ()):
            bits = proto.alert(errors[k]) if errors else 0
            if bits:
                if alerts.get(motor_id) != bits:  # once, when it starts or changes
                    log.warning(
                        "motor %d reports a hardware error (%s) in its %s status; the "
                        "instruction was carried out%s", motor_id,
                        "alert bit" if proto.version == 2 else ", ".join(
                            proto.error_names(bits)), name,
                        "; its hardware_error_status says which, REBOOT clears it"
                        if proto.version == 2 else "")
                alerts[motor_id] = bits
            else:
                alerts.pop(motor_id, None)
        if check and errors:
            for motor_id, error in zip(ids, errors, strict=True):
                if proto.failed(error):
                    raise MotorError(motor_id, name, proto.error_names(error), error)

    def _lay_out(self, found: dict[int, Status], replies: Replies
                   ) -> tuple[bytes, list[int] | tuple[()]]:
        """Statuses found by the parser, laid out as the fast path lays them: each motor's
        data at ``replies.data_at`` (zeros where a failed instruction brought none)."""
        buf = bytearray(replies.total)
        errors = [0] * len(replies.ids)
        for k, (motor_id, n, at) in enumerate(zip(replies.ids, replies.counts,
                                                  replies.data_at, strict=True)):
            status = found[motor_id]
            buf[at:at + len(status.params)] = status.params[:n]
            errors[k] = status.error
        return bytes(buf), errors if any(errors) else ()

    def _collect_statuses(self, first: bytes, name: str, replies: Replies, sent: float,
                          timeout: float) -> dict[int, Status]:
        """The slow path: find the expected statuses in ``first`` and whatever else comes
        before ``deadline``. A status counts only from a motor asked (and not yet answered)
        with the data length asked for, or none when its error byte says the instruction
        failed; others are late answers to an earlier instruction or strays, and are
        dropped."""
        owner = self._owner
        proto, port, stats = owner.proto, owner.port, owner.stats
        clock = port.clock
        expect = replies.expect
        sizes = dict(zip(replies.ids, replies.sizes, strict=True))
        deadline = sent + timeout
        parser = proto.parser()
        got: dict[int, Status] = {}
        wrong: dict[int, int] = {}  # motor asked -> data length of a status that did not fit
        chunk = first
        while True:
            for status in statuses_in(chunk, parser, proto, stats):
                n = expect.get(status.id)
                if n is None or status.id in got:
                    stats.stale += 1
                elif len(status.params) == n or (not status.params
                                                 and proto.failed(status.error)):
                    got[status.id] = status
                else:
                    stats.stale += 1
                    wrong[status.id] = len(status.params)
            if len(got) == len(expect):
                return got
            remaining = deadline - clock.now()
            if remaining <= 0:
                break
            want = max(1, sum(s for i, s in sizes.items() if i not in got) - parser.pending)
            chunk = port.read(want, remaining)
            stats.bytes_in += len(chunk)
        missing = [i for i in replies.ids if i not in got]
        who = ", ".join(str(i) for i in missing)
        if parser.dropped or parser.pending or any(i in wrong for i in missing):
            stats.corrupt += 1
            detail = (f"({parser.dropped + parser.pending} bad bytes)"
                      if parser.dropped or parser.pending else
                      "(a status of " + ", ".join(f"{wrong[i]} data bytes from motor {i}"
                                                  for i in missing if i in wrong)
                      + f", expected {expect[missing[0]]}: a late answer?)")
            raise CorruptResponse(f"motor {who}: {name} got a corrupt status packet {detail} "
                                  f"at {port.baudrate} bps", motor_id=missing[0],
                                  instruction=name)
        stats.timeouts += 1
        raise NoResponse(f"motor {who}: no answer to {name} within {timeout * 1000:.1f} ms "
                         f"at {port.baudrate} bps (is it powered, at this baud rate and ID?)",
                         motor_id=missing[0], instruction=name)

    def _collect_fast_status(self, first: bytes, name: str, replies: Replies, sent: float,
                             timeout: float) -> dict[int, Status]:
        """The slow path of a FAST_SYNC_READ / FAST_BULK_READ: find the one status packet
        (its head as expected, LEN included) in ``first`` and whatever else comes before the
        deadline, and take its blocks as far as they came whole and valid. The motors build
        the packet along the chain, so when one of them does not answer, the ones after it
        (which wait for its block) do not either: all are named, the first one as the cause."""
        port, stats = self._owner.port, self._owner.stats
        clock = port.clock
        deadline = sent + timeout
        head, total = replies.prefixes[0], replies.total
        buf = bytearray(first)
        while True:
            at = buf.find(head)
            if at >= 0 and len(buf) - at >= total:
                break
            remaining = deadline - clock.now()
            if remaining <= 0:
                break
            chunk = port.read(max(1, total - (len(buf) - at if at >= 0 else 0)), remaining)
            stats.bytes_in += len(chunk)
            buf += chunk
        got: list[Status] = []
        broken = bool(buf)  # bytes came, but no head as expected among them
        while at >= 0:  # the head's first occurrence may be data: take the best one
            blocks, cut = read_fast_status(bytes(buf), at, replies.ids, replies.counts)
            if len(blocks) > len(got) or at == buf.find(head):
                got, broken = blocks, cut
            at = buf.find(head, at + 1)
        if len(got) == len(replies.ids):
            return {status.id: status for status in got}
        missing = replies.ids[len(got):]
        who = ", ".join(str(i) for i in missing)
        rest = ", ".join(str(i) for i in missing[1:])
        after = (f"; {'motors' if len(missing) > 2 else 'motor'} {rest} after it in the "
                 f"chain send only after its block" if rest else "")
        if broken:
            stats.corrupt += 1
            raise CorruptResponse(f"motor {who}: {name} got a corrupt status packet (the block "
                                  f"of motor {missing[0]} cut short or failing its CRC) at "
                                  f"{port.baudrate} bps{after}", motor_id=missing[0],
                                  instruction=name)
        stats.timeouts += 1
        raise NoResponse(f"motor {who}: no block in the {name} status within "
                         f"{timeout * 1000:.1f} ms at {port.baudrate} bps (is motor "
                         f"{missing[0]} powered, at this baud rate and ID?){after}",
                         motor_id=missing[0], instruction=name)
