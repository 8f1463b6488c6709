"""The DDS transport: servolab's topics, services and graph on DDS, laid out as ROS 2's DDS
middlewares lay them out (:mod:`.rmw_dds`), so that a stock ROS 2 system on its default
middleware sees servolab's nodes and servolab sees its.

It runs on Eclipse Cyclone DDS (the ``cyclonedds`` binding, one domain participant per
transport). Messages travel as the CDR servolab already writes (rosbags' codec), written and
taken as bytes through the binding's C layer (``ddspy_write`` / ``ddspy_take``), so no message
is converted twice; the topic's DDS type (:mod:`.dds_types`) only names and describes it.

What interoperates with Fast DDS (``rmw_fastrtps_cpp``, Jazzy's default), as the tests show
(``tests/middleware/test_dds_rclpy.py``): topics both ways with their QoS, the graph both ways
(nodes, topics, services, through ``ros_discovery_info``), and a servolab client calling a
Fast DDS service. What does not: a Fast DDS *client* calling a servolab service. rmw_fastrtps
matches a reply to its request by the RTPS inline QoS ``related_sample_identity``
(``rmw_fastrtps_shared_cpp/src/rmw_response.cpp``: a reply whose related writer GUID is not
the client's own is dropped), and the Cyclone DDS API can neither read nor write inline QoS.
So a servolab server does not answer a Fast DDS client (it logs why, once; the ROS 2
transport, :mod:`.ros2_transport`, does, where ROS 2 is installed); between Cyclone
DDS peers (servolab, rmw_cyclonedds) requests carry rmw_cyclonedds' 16-byte header, the client
id and sequence number, which the reply echoes. A servolab client calling a Fast DDS server
sends the bare request (the server takes the request's own sample identity as its id) and, as
it cannot tell one client's reply from another's, has one call in flight per service: another
client of the same Fast DDS service calling at the same moment could have its reply taken for
ours.
"""

from __future__ import annotations

import itertools
import logging
import struct
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future
from typing import Any

import numpy as np
from cyclonedds import _clayer
from cyclonedds.builtin import (
    BuiltinDataReader,
    BuiltinTopicDcpsParticipant,
    BuiltinTopicDcpsPublication,
    BuiltinTopicDcpsSubscription,
)
from cyclonedds.core import (
    DDSException,
    GuardCondition,
    InstanceState,
    Policy,
    Qos,
    ReadCondition,
    SampleState,
    ViewState,
    WaitSet,
)
from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from ..listening import ListeningSocket, beyond_loopback, listening
from .dds_types import DdsTypes
from .errors import ServiceError, TransportError
from .inbox import QueueInbox, Wake
from .messages import MessageTypes, ServiceType
from .qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from .rmw_dds import (
    DISCOVERY_TOPIC,
    DISCOVERY_TYPE,
    VENDOR_EPROSIMA,
    cyclone_config,
    discovery_from_environment,
    reply_topic,
    request_topic,
    ros_name,
    topic_name,
    type_hash_user_data,
)
from .transport import (
    Closeable,
    Declared,
    Endpoint,
    Handler,
    MessageInfo,
    NodeInfo,
    Transport,
    TransportOptions,
    TransportPublisher,
    wait_for,
)

log = logging.getLogger(__name__)

#: DDS's QoS policy ids (DDS 1.4, 2.2.3: DURABILITY 2, DEADLINE 4, LIVELINESS 8, RELIABILITY
#: 11, HISTORY 13, LIFESPAN 21) by the name rclpy gives the policy (``QoSPolicyKind``), as
#: rmw_cyclonedds maps them (``dds_qos_policy_to_rmw_qos_policy``); any other is INVALID
POLICY_NAMES = {2: "DURABILITY", 4: "DEADLINE", 8: "LIVELINESS", 11: "RELIABILITY",
                13: "HISTORY", 21: "LIFESPAN"}

_ANY = SampleState.Any | ViewState.Any | InstanceState.Any
#: rmw_cyclonedds' request header: client id (uint64), sequence number (int64), little-endian
#: after the encapsulation header, as the CDR stream it is part of.
_REQUEST_HEADER = struct.Struct("<Qq")
_ENCAPSULATION = 4
#: rmw's default profile for services (rmw_qos_profile_services_default)
SERVICE_QOS = QoSProfile(depth=10)
#: How long a Fast DDS server must have been matched before a bare request goes to it. Its
#: reply writer answers only the reply readers it has matched itself, which a Cyclone DDS
#: client cannot observe (rmw_fastrtps waits for that match only when the request's inline
#: QoS names the client's reader: rmw_response.cpp, check_for_subscription); discovery's two
#: halves come milliseconds apart on one machine, so half a second covers a busy one.
FAST_DDS_SETTLE_S = 0.5
#: How long after opening a first graph may wait for the participants it met to say what
#: nodes they hold (see :meth:`DdsTransport.graph`).
FIRST_GRAPH_S = 5.0
#: How often the dispatch thread looks for what no condition signals (Fast DDS clients).
DISPATCH_CHECK_S = 0.5
#: How long a reliable writer may block when a reader's queue is full: Fast DDS's default
#: (rmw_cyclonedds waits without bound). The binding's write holds Python's GIL meanwhile.
MAX_BLOCKING_S = 0.1


def dds_qos(qos: QoSProfile, rihs01: str | None = None) -> Qos:
    """A ROS profile as DDS QoS, with the type hash in USER_DATA (as a Jazzy rmw announces)."""
    history = Policy.History.KeepAll if qos.keep_all else Policy.History.KeepLast(qos.depth)
    policies: list[Any] = [
        Policy.Reliability.Reliable(duration(seconds=MAX_BLOCKING_S)) if qos.reliable
        else Policy.Reliability.BestEffort,
        Policy.Durability.TransientLocal if qos.transient_local else Policy.Durability.Volatile,
        history,
        Policy.DataRepresentation(use_cdrv0_representation=True),
    ]
    if qos.transient_local:
        # what a late reader gets is the durability service's history, not the writer's
        # (rmw_cyclonedds sets both alike, rmw_node.cpp create_readwrite_qos)
        policies.append(Policy.DurabilityService(
            0, Policy.History.KeepLast(qos.history_depth), -1, -1, -1))
    if rihs01:
        policies.append(Policy.Userdata(type_hash_user_data(rihs01)))
    return Qos(*policies)


def ros_qos(qos: Qos | None) -> QoSProfile | None:
    """What a discovered endpoint offers or requests, as a ROS profile."""
    if qos is None:
        return None
    reliability = qos[Policy.Reliability]
    durability = qos[Policy.Durability]
    history = qos[Policy.History]
    keep_all = isinstance(history, type(Policy.History.KeepAll)) and history is not None \
        and not hasattr(history, "depth")
    depth = getattr(history, "depth", 0) if history is not None else 1
    return QoSProfile(
        history=HistoryPolicy.KEEP_ALL if keep_all else HistoryPolicy.KEEP_LAST,
        depth=max(int(depth), 1) if not keep_all else 0,
        reliability=(ReliabilityPolicy.RELIABLE
                     if reliability is not None and hasattr(reliability, "max_blocking_time")
                     else ReliabilityPolicy.BEST_EFFORT),
        durability=(DurabilityPolicy.TRANSIENT_LOCAL
                    if durability is Policy.Durability.TransientLocal
                    else DurabilityPolicy.VOLATILE))


class _Domains:
    """Cyclone DDS configures a domain once per process (a second ``Domain`` of the same id
    fails): the transports of one process that share a domain share its configuration, and
    the domain is deleted with the last of them, so that a later one may configure it anew.
    Process-wide, as the library's domains are."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._open: dict[int, tuple[Domain, str, int]] = {}

    def acquire(self, domain_id: int, config: str) -> Domain:
        with self._lock:
            held = self._open.get(domain_id)
            if held is None:
                try:
                    domain = Domain(domain_id, config)
                except DDSException as exc:
                    raise TransportError(f"DDS domain {domain_id} could not be opened: "
                                         f"{exc}") from None
                self._open[domain_id] = (domain, config, 1)
                return domain
            domain, current, users = held
            if current != config:
                raise TransportError(
                    f"ROS domain {domain_id} is already open in this process with other "
                    "discovery settings (ROS_AUTOMATIC_DISCOVERY_RANGE, ROS_STATIC_PEERS, "
                    "--connect): one process has one DDS configuration per domain")
            self._open[domain_id] = (domain, current, users + 1)
            return domain

    def release(self, domain_id: int) -> None:
        with self._lock:  # deleted under the lock: a new one of the same id must wait for it
            domain, config, users = self._open[domain_id]
            if users > 1:
                self._open[domain_id] = (domain, config, users - 1)
                return
            del self._open[domain_id]
            domain.__del__()


_DOMAINS = _Domains()


def _write(writer: DataWriter[Any], data: bytes) -> None:
    ret = _clayer.ddspy_write(writer._ref, data)
    if ret < 0:
        raise TransportError(f"DDS write on {writer.topic.name} failed (code {ret})")


def _take(reader: DataReader[Any], batch: int = 256) -> list[tuple[bytes, Any]]:
    """Everything the reader holds, oldest first (valid samples only)."""
    samples: list[tuple[bytes, Any]] = []
    while True:
        taken = _clayer.ddspy_take(reader._ref, _ANY, batch)
        if isinstance(taken, int):
            return samples  # the reader is gone (closed while its data was queued)
        samples.extend((data, info) for data, info in taken if info.valid_data)
        if len(taken) < batch:
            return samples


def _say_sockets(domain_id: int, range_: str, opened: list[ListeningSocket]) -> None:
    """Name the sockets a new DDS domain opened, as the kernel lists them. Cyclone DDS binds
    its unicast discovery and data ports to every interface when it uses one interface
    (``ddsi_init.c``, ``make_uc_sockets``: ``m_bind_to_any = !per_interface_uc``), and no
    setting of its configuration changes that: in LOCALHOST it announces and sends on
    127.0.0.1 only, but another computer that knows the port can still send to it. Said, not
    hidden (docs/middleware.md)."""
    if not opened:
        return
    wide = beyond_loopback(opened)
    caveat = ""
    if wide and range_ == "LOCALHOST":
        caveat = (f" ({', '.join(map(str, wide))} on every interface: Cyclone DDS cannot bind "
                  "one interface's unicast ports alone; it announces and sends on 127.0.0.1 "
                  "only; a firewall keeps other computers from sending to them)")
    log.info("DDS domain %d listens on %s%s", domain_id, ", ".join(map(str, opened)), caveat)


class _WriterGids:
    """The GUID of the writer behind a sample's ``publication_handle``, what rmw_cyclonedds
    gives as a message's ``publisher_gid``: asked of DDS once per writer (the matched
    publication's key), then kept. A subscription names the publisher of a malformed message
    with it (:mod:`.malformed`)."""

    def __init__(self) -> None:
        self._known: dict[int, bytes] = {}

    def of(self, reader: DataReader[Any], handle: int) -> bytes:
        gid = self._known.get(handle)
        if gid is None:
            try:
                endpoint = reader.get_matched_publication_data(handle)
            except Exception:  # the writer left between the sample and the question
                endpoint = None
            gid = b"" if endpoint is None else endpoint.key.bytes
            if gid:
                self._known[handle] = gid
        return gid


class DdsPublisher(TransportPublisher):
    def __init__(self, transport: DdsTransport, writer: DataWriter[Any], type_name: str,
                 done: Callable[[], None]) -> None:
        self._type_name = type_name
        self._write = transport.types.writer(type_name)  # CDR per message, looked up once
        self._writer = writer
        self._done = done

    def publish(self, msg: Any) -> None:
        self.publish_serialized(self._write(msg))

    def publish_serialized(self, cdr: bytes) -> None:
        _write(self._writer, bytes(cdr))

    def wait_for_subscription(self, timeout: float) -> bool:
        """DDS's publication-matched status: a reader of the topic, here or in another
        participant, whose QoS the writer's offer satisfies."""
        return wait_for(
            lambda: self._writer.get_publication_matched_status().current_count > 0, timeout)

    def close(self) -> None:
        self._done()



def _nothing() -> None:
    pass


class _Client:
    """One service's request writer and reply reader, shared by the calls made through it.

    Towards Cyclone DDS servers (servolab, rmw_cyclonedds) each request carries the client id
    and a sequence number, and any number of calls may be in flight. Towards a Fast DDS server
    the request goes bare from a second participant (:meth:`DdsTransport.bare_participant`)
    and one call is in flight at a time (see the module docstring)."""

    def __init__(self, transport: DdsTransport, name: str, srv: ServiceType) -> None:
        self.transport = transport
        self.name = name
        self.srv = srv
        self.writer = transport._writer(request_topic(name), srv.request, SERVICE_QOS,
                                        request_header=True)
        self.reader = transport._reader(reply_topic(name), srv.response, SERVICE_QOS,
                                        self._on_reply, request_header=True)
        self.client_id = self.writer.get_instance_handle() & 0xFFFF_FFFF_FFFF_FFFF  # uint64
        self._sequence = itertools.count(1)
        self._pending: dict[int, Future[Any]] = {}
        self._lock = threading.Lock()
        self._bare_writer: DataWriter[Any] | None = None
        self._bare_reader: DataReader[Any] | None = None
        self._bare: Future[Any] | None = None
        self._bare_lock = threading.Lock()  # one call in flight to a Fast DDS server
        #: the clients declared on it and not yet closed, by node, with what undoes that
        #: node's claim on its endpoints in ros_discovery_info (DdsTransport.declare_client):
        #: a node's last one closed undoes it, the last one of all deletes the endpoints
        self.users: dict[int, tuple[int, Callable[[], None]]] = {}
        self._closed = False
        self._bare_since: float | None = None
        self._bare_sent_ns = 0

    def close(self) -> None:
        """Delete its endpoints, as rclpy's ``destroy_client`` does, so that the servers'
        graphs (``count_clients``) no longer count it; a call still waiting fails."""
        with self._lock:  # no bare endpoints opened after this (see _open_bare)
            self._closed = True
            pending, self._pending = list(self._pending.values()), {}
            readers = [r for r in (self.reader, self._bare_reader) if r is not None]
            writers = [w for w in (self.writer, self._bare_writer) if w is not None]
        for future in [*pending, *([self._bare] if self._bare is not None else [])]:
            if not future.done():
                future.set_exception(ServiceError(f"service {self.name}: the client was "
                                                  "destroyed before the answer came"))
        for reader in readers:
            self.transport._unwatch(reader)
        self.transport._delete(*readers, *writers)

    @staticmethod
    def _matched(writer: DataWriter[Any] | None, reader: DataReader[Any] | None) -> bool:
        """rmw's service_is_available: the request writer and the reply reader both match."""
        return (writer is not None and reader is not None
                and writer.get_publication_matched_status().current_count > 0
                and reader.get_subscription_matched_status().current_count > 0)

    def available(self) -> bool:
        """Whether a call can go now: to a Fast DDS server bare, once its endpoints have
        matched and settled; else to a Cyclone DDS server with the header. (Never the
        header to Fast DDS: its reader would take the header for the request.)"""
        if self.transport.fast_dds_serves(self.name):
            self._open_bare()
            if not self._matched(self._bare_writer, self._bare_reader):
                self._bare_since = None
                return False
            now = time.monotonic()
            if self._bare_since is None:
                self._bare_since = now
            return now - self._bare_since >= FAST_DDS_SETTLE_S
        return self._matched(self.writer, self.reader)

    def _open_bare(self) -> None:
        with self._lock:
            if self._closed:
                raise ServiceError(f"service {self.name}: the client was destroyed")
            if self._bare_writer is None:
                participant = self.transport.bare_participant()
                self._bare_reader = self.transport._reader(
                    reply_topic(self.name), self.srv.response, SERVICE_QOS, self._on_bare_reply,
                    participant=participant)
                self._bare_writer = self.transport._writer(
                    request_topic(self.name), self.srv.request, SERVICE_QOS,
                    participant=participant)

    def _on_reply(self, reader: DataReader[Any]) -> None:
        for data, _info in _take(reader):
            if len(data) < _ENCAPSULATION + _REQUEST_HEADER.size:
                continue
            client_id, sequence = _REQUEST_HEADER.unpack_from(data, _ENCAPSULATION)
            if client_id != self.client_id:
                continue  # another client's answer
            with self._lock:
                pending = self._pending.pop(sequence, None)
            if pending is not None and not pending.done():
                self._resolve(pending, data[:_ENCAPSULATION]
                              + data[_ENCAPSULATION + _REQUEST_HEADER.size:])

    def _on_bare_reply(self, reader: DataReader[Any]) -> None:
        for data, info in _take(reader):
            if info.source_timestamp < self._bare_sent_ns:
                continue  # the late answer to a call that timed out, not to this one
            future, self._bare = self._bare, None
            if future is not None and not future.done():
                self._resolve(future, data)

    def _resolve(self, future: Future[Any], cdr: bytes) -> None:
        try:
            future.set_result(self.transport.types.deserialize(cdr, self.srv.response))
        except Exception as exc:
            future.set_exception(ServiceError(f"service {self.name}: bad response ({exc})"))

    def call(self, request: Any, timeout: float) -> Future[Any]:
        future: Future[Any] = Future()
        cdr = self.transport.types.serialize(request, self.srv.request)

        def run() -> None:
            try:
                end = time.monotonic() + timeout
                pause = 0.005  # discovery takes milliseconds; a missing server, maybe hours
                while not self.available():
                    if time.monotonic() >= end:
                        raise ServiceError(
                            f"no service {self.name} answered within {timeout:g} s (is its "
                            "node running, in the same ROS_DOMAIN_ID and discovery range?)")
                    time.sleep(pause)
                    pause = min(pause * 1.5, 0.1)
                if self._bare_since is not None and self.transport.fast_dds_serves(self.name):
                    self._call_bare(future, cdr, end)
                else:
                    self._call_with_header(future, cdr, end)
            except Exception as exc:  # never leave the caller waiting
                if not future.done():
                    future.set_exception(exc if isinstance(exc, ServiceError)
                                         else ServiceError(f"service {self.name}: {exc}"))

        threading.Thread(target=run, daemon=True, name=f"call {self.name}").start()
        return future

    def _call_with_header(self, future: Future[Any], cdr: bytes, end: float) -> None:
        sequence = next(self._sequence)
        with self._lock:
            self._pending[sequence] = future
        try:
            _write(self.writer, cdr[:_ENCAPSULATION]
                   + _REQUEST_HEADER.pack(self.client_id, sequence) + cdr[_ENCAPSULATION:])
            self._wait(future, end)
        finally:
            with self._lock:
                self._pending.pop(sequence, None)

    def _call_bare(self, future: Future[Any], cdr: bytes, end: float) -> None:
        assert self._bare_writer is not None
        if not self._bare_lock.acquire(timeout=max(0.0, end - time.monotonic())):
            raise ServiceError(f"service {self.name} did not answer within the timeout "
                               "(an earlier call to its Fast DDS server is still waiting)")
        try:
            self._bare = future
            self._bare_sent_ns = time.time_ns()
            _write(self._bare_writer, cdr)
            self._wait(future, end)
        finally:
            self._bare = None
            self._bare_lock.release()

    def _wait(self, future: Future[Any], end: float) -> None:
        try:
            future.exception(timeout=max(0.0, end - time.monotonic()))
        except TimeoutError:
            if not future.done():
                future.set_exception(ServiceError(
                    f"service {self.name} did not answer within the timeout"))


class DdsTransport(Transport):
    """See the module docstring."""

    carries_bytes = True

    def __init__(self, types: MessageTypes, options: TransportOptions | None = None) -> None:
        super().__init__(types)
        self.options = options or TransportOptions(kind="dds")
        self.domain_id = self.options.domain_id
        if self.options.listen:
            raise TransportError("--listen is Zenoh's: a DDS participant listens on the ports "
                                 "its domain (ROS_DOMAIN_ID) gives it")
        range_, peers = discovery_from_environment(self.options.connect)
        before = set(listening())
        domain = _DOMAINS.acquire(self.domain_id, cyclone_config(range_, peers))
        try:
            self.participant = DomainParticipant(self.domain_id)
        except BaseException:
            _DOMAINS.release(self.domain_id)
            raise
        _say_sockets(self.domain_id, range_, [s for s in listening() if s not in before])
        try:
            self._open(types, domain)
        except BaseException:  # leave nothing running: the thread, the participant, the domain
            self._closed = True
            if hasattr(self, "_guard"):
                self._guard.set(True)
            if hasattr(self, "_dispatcher") and self._dispatcher.is_alive():
                self._dispatcher.join(5.0)
            self.participant.__del__()
            _DOMAINS.release(self.domain_id)
            raise

    def _open(self, types: MessageTypes, domain: Domain) -> None:
        self.gid = self.participant.get_guid().bytes
        self._opened = time.monotonic()
        self._dds_types = DdsTypes(types)
        self._lock = threading.RLock()
        self._closed = False
        self._topics: dict[tuple[int, str], Topic[Any]] = {}
        self._watched: dict[int, tuple[DataReader[Any], ReadCondition, Callable[
            [DataReader[Any]], None]]] = {}
        self._checks: list[Callable[[], None]] = []
        self._failed_checks: list[Callable[[], None]] = []  # logged once each
        # owned by the domain, so that both participants' readers may be attached
        self._waitset = WaitSet(domain)  # type: ignore[arg-type]
        self._guard = GuardCondition(domain)  # type: ignore[arg-type]
        self._waitset.attach(self._guard)
        self._dispatcher = threading.Thread(target=self._dispatch, daemon=True,
                                            name=f"dds dispatch {self.domain_id}")
        self._dispatcher.start()
        self._bare_participant: DomainParticipant | None = None
        self._nodes: dict[int, NodeInfo] = {}
        self._readers: dict[int, set[bytes]] = {}
        self._writers: dict[int, set[bytes]] = {}
        self._clients: dict[str, _Client] = {}
        self._warned: set[str] = set()
        # the graph: every participant's nodes (ros_discovery_info), and DDS's own discovery
        self._peers: dict[bytes, Any] = {}
        self._discovery_writer = self._writer(DISCOVERY_TOPIC, DISCOVERY_TYPE, QoSProfile(
            depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL), ros=False)
        self._discovery_reader = self._reader(
            DISCOVERY_TOPIC, DISCOVERY_TYPE,
            QoSProfile(depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL),
            self._on_discovery, ros=False)
        self._builtin_lock = threading.Lock()
        self._builtin = {
            "participant": BuiltinDataReader(self.participant, BuiltinTopicDcpsParticipant),
            "publication": BuiltinDataReader(self.participant, BuiltinTopicDcpsPublication),
            "subscription": BuiltinDataReader(self.participant, BuiltinTopicDcpsSubscription),
        }
        self._alive = {key: ReadCondition(reader, SampleState.Any | ViewState.Any
                                          | InstanceState.Alive)
                       for key, reader in self._builtin.items()}
        self._publish_graph()

    # -- entities ----------------------------------------------------------------------------

    def _topic(self, participant: DomainParticipant, name: str, type_name: str,
               request_header: bool) -> Topic[Any]:
        key = (participant.get_instance_handle(), name)
        with self._lock:
            topic = self._topics.get(key)
            if topic is None:
                topic = Topic(participant, name,
                              self._dds_types.get(type_name, request_header=request_header))
                self._topics[key] = topic
            return topic

    def _writer(self, name: str, type_name: str, qos: QoSProfile, *, ros: bool = True,
                request_header: bool = False,
                participant: DomainParticipant | None = None) -> DataWriter[Any]:
        rihs01 = self.types.rihs01(type_name) if ros else None
        participant = participant or self.participant
        return DataWriter(participant, self._topic(participant, name, type_name, request_header),
                          dds_qos(qos, rihs01))

    def _reader(self, name: str, type_name: str, qos: QoSProfile,
                on_data: Callable[[DataReader[Any]], None], *, ros: bool = True,
                request_header: bool = False, participant: DomainParticipant | None = None,
                ) -> DataReader[Any]:
        """A reader whose data ``on_data`` takes on the transport's dispatch thread.

        No listener: Cyclone DDS would call it on its own receive thread, which would then
        wait for Python's GIL while holding the reader's lock, and the binding's write and
        take hold the GIL while they wait for that lock (a deadlock, seen here). Instead the
        dispatch thread waits on a wait set (which lets go of the GIL) for any reader's
        condition, and takes."""
        rihs01 = self.types.rihs01(type_name) if ros else None
        participant = participant or self.participant
        reader = DataReader(participant,
                            self._topic(participant, name, type_name, request_header),
                            dds_qos(qos, rihs01))
        condition = ReadCondition(reader, SampleState.Any | ViewState.Any | InstanceState.Any)
        with self._lock:
            self._watched[id(reader)] = (reader, condition, on_data)
        self._waitset.attach(condition)
        self._guard.set(True)  # wake the dispatch thread: it takes what is there already
        return reader

    def _unwatch(self, reader: DataReader[Any]) -> None:
        with self._lock:
            watched = self._watched.pop(id(reader), None)
        if watched is not None and not self._closed:
            self._waitset.detach(watched[1])

    def _dispatch(self) -> None:
        """The dispatch thread: every reader's data, and the periodic checks."""
        next_check = 0.0
        while not self._closed:
            self._waitset.wait(duration(seconds=DISPATCH_CHECK_S))
            if self._closed:
                return
            self._guard.set(False)
            with self._lock:
                watched = list(self._watched.values())
            for reader, condition, on_data in watched:
                try:
                    if condition.triggered:
                        on_data(reader)
                except Exception:  # one bad sample or handler must not stop every reader
                    with self._lock:
                        gone = self._closed or id(reader) not in self._watched
                    if not gone:  # (a reader deleted meanwhile has nothing more to say)
                        log.exception("DDS transport: handling data on %s failed",
                                      reader.topic.name)
            if time.monotonic() >= next_check:
                next_check = time.monotonic() + DISPATCH_CHECK_S
                for check in list(self._checks):
                    try:
                        check()
                    except Exception:  # a failed check must not stop every reader either
                        # (a service closed since the list was copied has deleted the reader
                        # its check looks at: Cyclone says BAD_PARAMETER, seen in CI)
                        if (not self._closed and check in self._checks
                                and check not in self._failed_checks):
                            self._failed_checks.append(check)  # told once, not every 0.5 s
                            log.exception("DDS transport: a periodic check failed")

    def _read_builtin(self, kind: str) -> list[Any]:
        """The alive samples of one of DDS's own discovery topics.

        One thread at a time: cyclonedds-python's builtin readers are not safe to read from
        several threads at once (eight concurrent service calls each asking
        :meth:`fast_dds_serves` failed with "Callfunc endpoint constructor errored", seen in
        CI and reproduced by ``test_builtin_reads_from_many_threads``)."""
        with self._builtin_lock:
            return list(self._builtin[kind].read(N=100_000, condition=self._alive[kind]))

    def bare_participant(self) -> DomainParticipant:
        """A second participant for calling Fast DDS servers: their request and reply topics
        carry the bare request and response, which this participant's types describe (the
        first one's service topics carry rmw_cyclonedds' header; a participant has one type
        per topic)."""
        with self._lock:
            if self._bare_participant is None:
                self._bare_participant = DomainParticipant(self.domain_id)
            return self._bare_participant

    def fast_dds_serves(self, name: str) -> bool:
        """Whether a Fast DDS participant has a reader of the service's requests."""
        wanted = request_topic(name)
        return any(ep.topic_name == wanted and ep.participant_key.bytes[:2] == VENDOR_EPROSIMA
                   for ep in self._read_builtin("subscription"))

    def _own(self, node: NodeInfo, *, readers: tuple[Any, ...] = (),
             writers: tuple[Any, ...] = ()) -> Callable[[], None]:
        """Count the entities as the node's in ``ros_discovery_info``; the function undoes it
        and deletes them."""
        reader_gids = {r.get_guid().bytes for r in readers}
        writer_gids = {w.get_guid().bytes for w in writers}
        with self._lock:
            self._readers.setdefault(node.node_id, set()).update(reader_gids)
            self._writers.setdefault(node.node_id, set()).update(writer_gids)
        self._publish_graph()

        def undo() -> None:
            with self._lock:
                self._readers.get(node.node_id, set()).difference_update(reader_gids)
                self._writers.get(node.node_id, set()).difference_update(writer_gids)
            for reader in readers:
                self._unwatch(reader)
            self._delete(*readers, *writers)
            self._publish_graph()
        return undo

    def _delete(self, *entities: Any) -> None:
        if self._closed:
            return
        for entity in entities:
            entity.__del__()  # dds_delete now, not when the garbage collector gets to it

    # -- topics ------------------------------------------------------------------------------

    def advertise(self, node: NodeInfo, topic: str, type_name: str,
                  qos: QoSProfile) -> DdsPublisher:
        writer = self._writer(topic_name(topic), type_name, qos)
        return DdsPublisher(self, writer, type_name, self._watch_qos(
            node, topic, writer, self._own(node, writers=(writer,))))

    def subscribe(self, node: NodeInfo, topic: str, type_name: str, qos: QoSProfile,
                  wake: Wake, *, raw: bool = False) -> QueueInbox:
        inbox = QueueInbox(qos.queue_depth, wake)
        gids = _WriterGids()

        def on_data(reader: DataReader[Any]) -> None:
            now = time.time_ns()
            for data, info in _take(reader):
                inbox.put(data, MessageInfo(info.source_timestamp, now, 0,
                                            gids.of(reader, info.publication_handle)))

        reader = self._reader(topic_name(topic), type_name, qos, on_data)
        inbox.on_close(self._watch_qos(node, topic, reader, self._own(node, readers=(reader,))))
        return inbox

    def _watch_qos(self, node: NodeInfo, topic: str, entity: DataReader[Any] | DataWriter[Any],
                   undo: Callable[[], None]) -> Callable[[], None]:
        """Say on the node's logger, as rclpy's default incompatible-QoS callbacks say it
        (rclpy ``event_handler.py``, Jazzy), each time an endpoint of the topic is found
        whose QoS cannot match this one's (a reliable subscription and a best-effort
        publisher, transient local asked of a volatile one): DDS then carries nothing
        between them, and without a word a user sees only silence. Checked with the
        transport's periodic checks; ``undo`` (the entity's) also stops the watching."""
        status: Callable[[], Any]
        if isinstance(entity, DataReader):
            status = entity.get_requested_incompatible_qos_status
            text = ("New publisher discovered on topic '{}', offering incompatible QoS. No "
                    "messages will be received from it. Last incompatible policy: {}")
        else:
            status = entity.get_offered_incompatible_qos_status
            text = ("New subscription discovered on topic '{}', requesting incompatible QoS. "
                    "No messages will be sent to it. Last incompatible policy: {}")
        logger = logging.getLogger(node.logger_name)

        def incompatible() -> None:
            found = status()  # type: ignore[no-untyped-call]
            if found.total_count_change > 0:
                logger.warning(text.format(
                    topic, POLICY_NAMES.get(found.last_policy_id, "INVALID")))

        self._checks.append(incompatible)

        def close() -> None:  # as undo, harmless twice (a publisher, then its node)
            if incompatible in self._checks:
                self._checks.remove(incompatible)
            undo()
        return close

    # -- services ----------------------------------------------------------------------------

    def serve(self, node: NodeInfo, name: str, srv: ServiceType, handler: Handler) -> Closeable:
        """The request reader and reply writer of rmw's service. A request from a Cyclone
        DDS client has rmw_cyclonedds' header, which the reply echoes; one from a Fast DDS
        client cannot be answered (see the module docstring) and is logged once."""
        writer = self._writer(reply_topic(name), srv.response, SERVICE_QOS, request_header=True)

        def on_request(reader: DataReader[Any]) -> None:
            for data, info in _take(reader):
                if self._vendor_of_publication(reader, info.publication_handle) \
                        == VENDOR_EPROSIMA:
                    continue  # never run a request read with a layout it was not written in
                if len(data) < _ENCAPSULATION + _REQUEST_HEADER.size:
                    continue
                header = data[_ENCAPSULATION:_ENCAPSULATION + _REQUEST_HEADER.size]
                request = data[:_ENCAPSULATION] + data[_ENCAPSULATION + _REQUEST_HEADER.size:]
                self._handle(name, srv, handler, writer, header, request)

        def fast_dds_clients() -> None:
            for handle in reader.get_matched_publications():
                if self._vendor_of_publication(reader, handle) == VENDOR_EPROSIMA:
                    self._warn_once(name, f"a Fast DDS (rmw_fastrtps) client of {name} appeared: "
                                    "servolab on Cyclone DDS cannot answer it (Fast DDS matches "
                                    "a reply to its request by RTPS inline QoS, which Cyclone "
                                    "DDS's API cannot write); where ROS 2 is installed, run "
                                    "servolab with --transport ros2, or call from a servolab, "
                                    "rmw_cyclonedds or Zenoh node")

        reader = self._reader(request_topic(name), srv.request, SERVICE_QOS, on_request,
                              request_header=True)
        self._checks.append(fast_dds_clients)
        undo = self._own(node, readers=(reader,), writers=(writer,))

        def close() -> None:
            self._checks.remove(fast_dds_clients)
            undo()
        return Declared(close)

    def _handle(self, name: str, srv: ServiceType, handler: Handler, writer: DataWriter[Any],
                header: bytes, request: bytes) -> None:
        def reply(response: Any) -> None:
            if isinstance(response, Exception):
                # DDS has no error reply: the client's wait ends at its timeout
                log.error("service %s failed: %s", name, response)
                return
            cdr = self.types.serialize(response, srv.response)
            if not self._closed:
                _write(writer, cdr[:_ENCAPSULATION] + header + cdr[_ENCAPSULATION:])

        try:
            handler(request, reply)
        except Exception as exc:
            reply(exc)

    def call(self, name: str, srv: ServiceType, request: Any, timeout: float) -> Future[Any]:
        with self._lock:
            client = self._clients.get(name)
            if client is None or client.srv.name != srv.name:
                client = self._clients[name] = _Client(self, name, srv)
        return client.call(request, timeout)

    def declare_client(self, node: NodeInfo, name: str, srv: ServiceType) -> Closeable:
        """A client in the graph: its request writer and reply reader, owned by the node.
        The clients of one service share them; the last one closed deletes them."""
        with self._lock:
            client = self._clients.get(name)
            if client is None or client.srv.name != srv.name:
                client = self._clients[name] = _Client(self, name, srv)
            count, undo_gids = client.users.get(node.node_id, (0, _nothing))
            client.users[node.node_id] = (count + 1, undo_gids)
        if count == 0:  # the node's first: its claim, made outside the lock as before
            undo_gids = self._own_gids(node, client)
            with self._lock:
                now, _ = client.users.get(node.node_id, (0, _nothing))
                if now:
                    client.users[node.node_id] = (now, undo_gids)

        def close() -> None:
            with self._lock:
                count, undo_gids = client.users.pop(node.node_id)
                if count > 1:
                    client.users[node.node_id] = (count - 1, undo_gids)
                last = not client.users
                if last and self._clients.get(name) is client:
                    del self._clients[name]
            if count == 1:
                undo_gids()
            if last and not self._closed:
                client.close()
        return Declared(close)

    def _own_gids(self, node: NodeInfo, client: _Client) -> Callable[[], None]:
        reader_gid = client.reader.get_guid().bytes
        writer_gid = client.writer.get_guid().bytes
        with self._lock:
            self._readers.setdefault(node.node_id, set()).add(reader_gid)
            self._writers.setdefault(node.node_id, set()).add(writer_gid)
        self._publish_graph()

        def undo() -> None:
            with self._lock:
                self._readers.get(node.node_id, set()).discard(reader_gid)
                self._writers.get(node.node_id, set()).discard(writer_gid)
            self._publish_graph()
        return undo

    def _warn_once(self, key: str, text: str) -> None:
        if key not in self._warned:
            self._warned.add(key)
            log.warning(text)

    def _vendor_of_publication(self, reader: DataReader[Any], handle: int) -> bytes:
        try:
            data = reader.get_matched_publication_data(handle)
        except Exception:
            return b""
        return data.participant_key.bytes[:2] if data is not None else b""

    # -- graph -------------------------------------------------------------------------------

    def announce_node(self, node: NodeInfo) -> Closeable:
        with self._lock:
            self._nodes[node.node_id] = node
        self._publish_graph()

        def forget() -> None:
            with self._lock:
                self._nodes.pop(node.node_id, None)
                self._readers.pop(node.node_id, None)
                self._writers.pop(node.node_id, None)
            self._publish_graph()
        return Declared(forget)

    def _publish_graph(self) -> None:
        """This participant's ``ParticipantEntitiesInfo``: its nodes and their endpoints'
        GIDs, written whenever they change (rmw_dds_common's ``GraphCache``)."""
        if self._closed:
            return
        types = self.types
        gid_type = types.get("rmw_dds_common/msg/Gid")
        node_type = types.get("rmw_dds_common/msg/NodeEntitiesInfo")

        def gid(raw: bytes) -> Any:
            return gid_type(data=np.frombuffer(raw.ljust(16, b"\0")[:16], dtype=np.uint8).copy())

        with self._lock:
            nodes = [node_type(node_namespace=node.namespace, node_name=node.name,
                               reader_gid_seq=[gid(g) for g in sorted(
                                   self._readers.get(node_id, ()))],
                               writer_gid_seq=[gid(g) for g in sorted(
                                   self._writers.get(node_id, ()))])
                     for node_id, node in sorted(self._nodes.items())]
            info = types.get(DISCOVERY_TYPE)(gid=gid(self.gid), node_entities_info_seq=nodes)
            _write(self._discovery_writer, types.serialize(info, DISCOVERY_TYPE))

    def _on_discovery(self, reader: DataReader[Any]) -> None:
        for data, _info in _take(reader):
            try:
                info = self.types.deserialize(data, DISCOVERY_TYPE)
            except Exception:
                continue  # not ours to judge another rmw's malformed announcement
            key = bytes(info.gid.data[:16])
            with self._lock:
                self._peers[key] = info

    def graph(self, timeout: float = 0.5) -> list[Endpoint]:
        """Nodes from ``ros_discovery_info``; their topics, services and clients from DDS's
        built-in publication and subscription topics, each endpoint attributed to the node
        whose GIDs list it (as ``rmw_dds_common``'s graph cache does).

        Soon after the transport opened (a command that lists the graph at once), it first
        lets discovery run for ``timeout`` s, and then until every participant it has met
        has told it its nodes, up to :data:`FIRST_GRAPH_S` after opening: a Fast DDS peer
        resends its transient-local ``ros_discovery_info`` to a new reader only at its next
        heartbeat (every 3 s by default)."""
        while True:
            now = time.monotonic()
            if now >= self._opened + FIRST_GRAPH_S:
                break
            if now >= self._opened + timeout:
                own = {self.gid} | ({self._bare_participant.get_guid().bytes}
                                    if self._bare_participant is not None else set())
                met = {p.key.bytes for p in self._read_builtin("participant")} - own
                with self._lock:
                    if met <= set(self._peers):
                        break
            time.sleep(0.02)
        alive = {p.key.bytes for p in self._read_builtin("participant")}
        owner: dict[bytes, str] = {}
        endpoints: list[Endpoint] = []
        with self._lock:
            peers = [info for key, info in self._peers.items() if key in alive or key == self.gid]
        for info in peers:
            for node in info.node_entities_info_seq:
                fqn = f"{node.node_namespace.rstrip('/')}/{node.node_name}"
                endpoints.append(Endpoint("NN", fqn))
                for gid in (*node.reader_gid_seq, *node.writer_gid_seq):
                    owner[bytes(gid.data[:16])] = fqn
        for kind in ("publication", "subscription"):
            for ep in self._read_builtin(kind):
                owned_by = owner.get(ep.key.bytes)
                name = ros_name(ep.topic_name, ep.type_name)
                if owned_by is None or name is None:
                    continue
                if name.role == "topic":
                    entity = "MP" if kind == "publication" else "MS"
                elif name.role == "request":
                    entity = "SC" if kind == "publication" else "SS"
                else:
                    continue  # the reply half names the same service again
                endpoints.append(Endpoint(entity, owned_by, name.name, name.type_name,
                                          ros_qos(ep.qos) if name.role == "topic" else None))
        return endpoints

    def check_reachable(self, timeout: float = 2.0) -> None:
        """With ``--connect`` peers named: some other participant must appear."""
        if not self.options.connect:
            return
        if not wait_for(lambda: any(p.key.bytes != self.gid
                                    for p in self._read_builtin("participant")),
                        timeout, pause=0.05):
            raise TransportError(
                f"no DDS participant answers at {', '.join(self.options.connect)} (waited "
                f"{timeout:g} s, domain {self.domain_id}): is it running, in this "
                "ROS_DOMAIN_ID?")

    def close(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
        self._guard.set(True)
        if threading.current_thread() is not self._dispatcher:
            self._dispatcher.join(5.0)
        if self._bare_participant is not None:
            self._bare_participant.__del__()
        self._waitset.__del__()
        self._guard.__del__()
        self.participant.__del__()  # deletes every entity of the participant
        _DOMAINS.release(self.domain_id)
