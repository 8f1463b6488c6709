"""The Zenoh transport: the same topics, services and parameters between processes and
machines, laid out as ROS 2's ``rmw_zenoh`` lays them out.

Each message is one Zenoh ``put`` of its CDR bytes on the key
``<domain>/<topic>/<dds type>/<RIHS01 hash>`` with rmw_zenoh's 33-byte attachment (sequence
number, source timestamp, GID); each service is a queryable on the same kind of key; each node
and endpoint declares rmw_zenoh's liveliness token, which is how ``topic list`` and
``param list`` see the graph (see :mod:`.rmw_zenoh`).

The session is a peer that never takes the ROS router's port (``tcp/*:7447``, where
``rmw_zenohd`` listens): as rmw_zenoh's default session config does, it listens on a free
loopback port (``tcp/127.0.0.1:0``) and, unless ``--connect`` names other endpoints, connects to
the router at ``tcp/localhost:7447`` (``$SERVOLAB_ZENOH_ROUTER`` names another; empty: none).
A router that is not there is no error: Zenoh keeps retrying in the background, and links the
session to the other peers the router tells it about (gossip). No multicast scouting.
``--listen tcp/0.0.0.0:PORT`` or ``--connect tcp/robot.local:7447`` open it to a network.
``servolab router`` (:mod:`.router`) is such a router.

Two of rmw_zenoh's environment variables are honoured (:mod:`.zenoh_config`):
``$ZENOH_SESSION_CONFIG_URI`` names a json5 session configuration used as the base
(:func:`session_config` says what servolab still sets on top), and
``$ZENOH_ROUTER_CHECK_ATTEMPTS`` makes the session check for a router once open, as rmw_zenoh
does, saying rmw_zenoh's message while it waits (unset: no check, see
:func:`.zenoh_config.router_check` for why servolab's default differs).

As in rmw_zenoh, an entity is declared before its liveliness token (and its token undeclared
first), so a publisher that has seen a subscription's token loses none of what it then
publishes. Congestion control is rmw_zenoh's: DROP, except RELIABLE + KEEP_ALL (depth 0)
which BLOCKs; a stopped subscriber therefore never stalls a KEEP_LAST publisher.
"""

from __future__ import annotations

import contextlib
import itertools
import json
import os
import re
import threading
import time
import weakref
from collections.abc import Callable, Mapping
from concurrent.futures import Future
from typing import Any

import zenoh
import zenoh.ext

from .errors import MessageError, ServiceError, TransportError
from .inbox import Wake
from .messages import MessageTypes, ServiceType
from .qos import QoSProfile
from .rmw_zenoh import (
    ADMIN_SPACE,
    ATTACHMENT,
    GID_SIZE,
    EntityKind,
    decode_attachment,
    encode_attachment,
    entity_token,
    error_encoding,
    error_reason,
    gid_from,
    node_token,
    parse_token,
    topic_keyexpr,
)
from .transport import (
    Closeable,
    Endpoint,
    Handler,
    NodeInfo,
    Transport,
    TransportOptions,
    TransportPublisher,
)
from .zenoh_config import (
    OVERRIDE_ENV,
    SESSION_CONFIG_ENV,
    apply_override,
    config_file_from_env,
    load_config_file,
    overridden_keys,
    router_check,
    wait_for_router,
    zenoh_error_text,
)
from .zenoh_inbox import ChannelInbox, channel_for

#: Where rmw_zenoh's sessions look for the ROS router (``rmw_zenohd``) by default.
DEFAULT_ROUTER = "tcp/localhost:7447"
#: The environment variable naming another router endpoint ("" for none).
ROUTER_ENV = "SERVOLAB_ZENOH_ROUTER"
#: How many liveliness declarations a graph query keeps while it listens (a fleet of 200 nodes
#: declares about 2 000 tokens; a ring: more drop the oldest, never block Zenoh, and the
#: query's own answer still has them).
_GRAPH_CHANNEL = 4096
#: s a graph query waits beyond its timeout for Zenoh to say it is over
_QUERY_GRACE_S = 0.5
#: What a session listens on unless ``--listen`` says otherwise: a free loopback port.
DEFAULT_LISTEN = "tcp/127.0.0.1:0"
_ENDPOINT = re.compile(r"(tcp|udp|tls|quic|ws|unixsock-stream)/.+")


def check_endpoint(endpoint: str) -> str:
    """A Zenoh locator such as ``tcp/127.0.0.1:7447``, or a one-line error naming it."""
    if not _ENDPOINT.fullmatch(endpoint) or (endpoint.startswith(("tcp/", "udp/"))
                                             and not re.fullmatch(r".+:\d+", endpoint)):
        raise TransportError(f"Zenoh endpoint {endpoint!r} is not <protocol>/<host>:<port>, "
                             "e.g. tcp/127.0.0.1:7447")
    return endpoint


def router_endpoints() -> list[str]:
    """The router a session connects to when ``--connect`` names none: ``$SERVOLAB_ZENOH_ROUTER``
    if set (empty: none), else rmw_zenoh's ``tcp/localhost:7447``."""
    text = os.environ.get(ROUTER_ENV, DEFAULT_ROUTER).strip()
    return [check_endpoint(e) for e in text.split(",") if e.strip()]


def session_endpoints(options: TransportOptions) -> tuple[list[str], list[str]]:
    """``(listen, connect)`` of the session the options ask for (see the module docstring)."""
    listen = [check_endpoint(e) for e in options.listen] or [DEFAULT_LISTEN]
    connect = [check_endpoint(e) for e in options.connect] or router_endpoints()
    return listen, connect


def _config(listen: list[str], connect: list[str]) -> zenoh.Config:
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("listen/endpoints", json.dumps(listen))
    config.insert_json5("connect/endpoints", json.dumps(connect))
    _retry_in_background(config)
    _timestamped(config)
    return config


def _retry_in_background(config: zenoh.Config) -> None:
    """A peer's endpoint that does not answer (no router yet) is retried in the background,
    as rmw_zenoh's peers do, rather than failing the session."""
    config.insert_json5("connect/exit_on_failure", "false")
    config.insert_json5("connect/timeout_ms", "-1")


def _timestamped(config: zenoh.Config) -> None:
    """Timestamped samples, as rmw_zenoh's session config has them: TRANSIENT_LOCAL's
    AdvancedPublisher orders its cache by timestamp."""
    config.insert_json5("timestamping/enabled", "true")


def left_unset(config: zenoh.Config, key: str) -> bool:
    """Whether a configuration read from a file leaves ``key`` as Zenoh would have it alone
    (a key the file sets to Zenoh's own default counts as unset: the same either way)."""
    return bool(config.get_json(key) == zenoh.Config().get_json(key))


def session_config(options: TransportOptions,
                   environ: Mapping[str, str] | None = None) -> zenoh.Config:
    """The session's configuration: servolab's own (module docstring), or the json5 file
    ``$ZENOH_SESSION_CONFIG_URI`` names, as rmw_zenoh takes it, with on top of it

    * always: timestamping on, which servolab needs (TRANSIENT_LOCAL's publisher cache);
    * ``--listen`` / ``--connect`` when given: they replace the file's endpoints, as rmw_zenoh's
      ``$ZENOH_CONFIG_OVERRIDE`` goes on top of its file (the command line is the user's
      latest word);

    and where the file leaves a key unset, servolab's default rather than Zenoh's: a peer
    listens on ``tcp/127.0.0.1:0`` (Zenoh's own default, ``tcp/[::]:0``, would open the session
    to every network; a client listens on nothing), connects to the router
    (:func:`router_endpoints`), scouts by no multicast, and retries an endpoint in the
    background. The file's ``mode`` is kept: ``"client"`` makes the session a client of its
    router, which then carries all its traffic (``docs/fleets.md``); a client needs its
    router at start, as Zenoh's clients do, and says so in one line."""
    found = config_file_from_env(SESSION_CONFIG_ENV, environ)
    if found is None:
        listen, connect = session_endpoints(options)
        config = _config(listen, connect)
        apply_override(config, environ)
        if _check_mode(config, f"${OVERRIDE_ENV}") == "client" and not overridden_keys(
                environ) & {"connect/exit_on_failure", "connect/timeout_ms"}:
            # a client made so by the override fails at start without its router, as Zenoh's
            # clients do (servolab's peers retry in the background instead)
            config.insert_json5("connect/exit_on_failure", "true")
            config.insert_json5("connect/timeout_ms", "0")
        if options.listen:      # the command line is the user's latest word
            config.insert_json5("listen/endpoints", json.dumps(listen))
        if options.connect:
            config.insert_json5("connect/endpoints", json.dumps(connect))
        return config
    config = load_config_file(found, f"${SESSION_CONFIG_ENV}")
    apply_override(config, environ)
    mode = _check_mode(config, str(found))
    listen = [check_endpoint(e) for e in options.listen]
    if not listen and mode == "peer" and left_unset(config, "listen/endpoints"):
        listen = [DEFAULT_LISTEN]
    if listen:
        config.insert_json5("listen/endpoints", json.dumps(listen))
    connect = [check_endpoint(e) for e in options.connect]
    if not connect and left_unset(config, "connect/endpoints"):
        connect = router_endpoints()
    if connect:
        config.insert_json5("connect/endpoints", json.dumps(connect))
    if left_unset(config, "scouting/multicast/enabled"):
        config.insert_json5("scouting/multicast/enabled", "false")
    if mode == "peer" and left_unset(config, "connect/exit_on_failure") \
            and left_unset(config, "connect/timeout_ms"):
        _retry_in_background(config)
    _timestamped(config)
    return config


def _check_mode(config: zenoh.Config, source: str) -> str:
    mode = json.loads(config.get_json("mode")) or "peer"
    if mode not in ("peer", "client"):
        raise TransportError(f"{source}: mode {mode!r}: a servolab session is a peer or a "
                             "client (a router is servolab router's, on its own)")
    return str(mode)


def open_session(options: TransportOptions) -> zenoh.Session:
    """Open the session the options ask for (:func:`session_config`)."""
    config = session_config(options)
    try:
        return zenoh.open(config)
    except zenoh.ZError as exc:
        mode = json.loads(config.get_json("mode")) or "peer"
        hint = (" (a client needs its router running: start it, or check the endpoint)"
                if mode == "client" else "")
        raise TransportError(f"cannot open a Zenoh {mode} session: {zenoh_error_text(exc)}"
                             f"{hint}") from None


class _Declared:
    """Zenoh declarations released together, given in the order they were declared (entity,
    then its liveliness token) and undeclared in reverse: the token leaves the graph first,
    as rmw_zenoh shuts an entity down, so nobody sees a token whose entity is gone."""

    def __init__(self, *items: Any) -> None:
        self._items = list(items)

    def close(self) -> None:
        for item in reversed(self._items):
            with contextlib.suppress(zenoh.ZError):  # the session is already closed
                item.undeclare()
        self._items.clear()


#: Every open Zenoh transport of this process, for :func:`_close_sessions_at_exit`.
_OPEN: weakref.WeakSet[ZenohTransport] = weakref.WeakSet()


def _close_sessions_at_exit() -> None:
    """Close the sessions a program left open, once its own threads have ended (issue 32,
    D2). zenoh-python runs its callbacks on non-daemon threads ("pyo3-closure") that end only
    when their session closes (zenoh-python #434), and Python waits for such threads before
    it runs ``atexit`` handlers: a program that never closed its context would never exit.
    This runs when the main thread ends (``threading._register_atexit``, the hook
    concurrent.futures uses), waits for the program's other non-daemon threads as Python
    would, then closes the sessions, which ends Zenoh's."""
    me = threading.current_thread()
    for thread in threading.enumerate():
        if thread is not me and not thread.daemon and "pyo3" not in thread.name:
            thread.join()
    for transport in list(_OPEN):
        transport.close()


threading._register_atexit(_close_sessions_at_exit)  # type: ignore[attr-defined]


def congestion_control(reliable: bool, depth: int) -> zenoh.CongestionControl:
    """rmw_zenoh's choice (``rmw_publisher_data.cpp``): BLOCK only for RELIABLE + KEEP_ALL
    (``depth`` 0), DROP otherwise, so that a stalled subscriber never stalls a KEEP_LAST
    publisher's ``publish()`` (and the control loop that calls it) for more than Zenoh's
    wait before dropping."""
    if reliable and depth == 0:
        return zenoh.CongestionControl.BLOCK
    return zenoh.CongestionControl.DROP


class ZenohPublisher(TransportPublisher):
    def __init__(self, transport: ZenohTransport, key: str, type_name: str, gid: bytes,
                 qos: QoSProfile) -> None:
        self._type_name = type_name
        self._write = transport.types.writer(type_name)  # CDR per message, looked up once
        self._session = transport.session
        self._key = key
        encode_attachment(0, 0, gid)  # the GID checked once here, packed as it is per put
        self._gid = bytes(gid)
        self._next = itertools.count(1).__next__  # the attachment's sequence number
        self._pack = ATTACHMENT.pack
        options: dict[str, Any] = {
            "congestion_control": congestion_control(qos.reliable, qos.queue_depth),
            "reliability": (zenoh.Reliability.RELIABLE if qos.reliable
                            else zenoh.Reliability.BEST_EFFORT)}
        self._publisher: zenoh.Publisher | zenoh.ext.AdvancedPublisher
        if qos.transient_local:
            # rmw_zenoh's TRANSIENT_LOCAL: an AdvancedPublisher that caches the last depth
            # samples (attachments included) and answers late AdvancedSubscribers' queries
            self._publisher = zenoh.ext.declare_advanced_publisher(
                transport.session, key,
                cache=zenoh.ext.CacheConfig(max_samples=qos.history_depth),
                publisher_detection=True, **options)
        else:
            self._publisher = transport.session.declare_publisher(key, **options)
        self._put = self._publisher.put
        self._declared = _Declared(self._publisher)

    def _add_token(self, token: Any) -> None:
        self._declared = _Declared(self._publisher, token)

    def publish(self, msg: Any) -> None:
        self.publish_serialized(self._write(msg))

    def sender(self) -> Callable[[Any], None]:
        """:meth:`publish` with everything it uses bound: no attribute lookups per message,
        which a control loop or a flood pays per message."""
        put, write, pack, sequence, gid = (self._put, self._write, self._pack, self._next,
                                           self._gid)
        time_ns = time.time_ns

        def publish(msg: Any) -> None:
            put(write(msg), attachment=pack(sequence(), time_ns(), GID_SIZE, gid))
        return publish

    def publish_serialized(self, cdr: bytes) -> None:
        self._put(cdr, attachment=self._pack(self._next(), time.time_ns(), GID_SIZE, self._gid))

    def wait_for_subscription(self, timeout: float) -> bool:
        """Zenoh's matching status of a publisher on the key: true once this session routes
        the key to a subscriber, which for a subscriber in another process may come a moment
        after its liveliness token. (An AdvancedPublisher has no matching status: a plain
        publisher on its key stands in for it.)"""
        probe = (self._publisher if isinstance(self._publisher, zenoh.Publisher)
                 else self._session.declare_publisher(self._key))
        matched = threading.Event()
        listener = probe.declare_matching_listener(
            lambda status: matched.set() if status.matching else None)
        try:
            # (the stubs say bool; it is a MatchingStatus, as the listener gets)
            status: Any = probe.matching_status
            return bool(status.matching) or matched.wait(timeout)
        finally:
            listener.undeclare()
            if probe is not self._publisher:
                probe.undeclare()

    def close(self) -> None:
        self._declared.close()


class ZenohTransport(Transport):
    """See the module docstring."""

    carries_bytes = True

    def __init__(self, types: MessageTypes, options: TransportOptions | None = None) -> None:
        super().__init__(types)
        self.options = options or TransportOptions(kind="zenoh")
        self.domain_id = self.options.domain_id
        attempts = router_check()  # a bad value is refused before anything opens
        self.session = open_session(self.options)
        if attempts is not None:
            try:
                wait_for_router(self.session, attempts)
            except BaseException:  # a stop signal while it waits
                self.session.close()
                raise
        self.session_id = str(self.session.zid())
        self._entity_ids = itertools.count(1000)  # above node ids, which count from 0
        self._lock = threading.Lock()
        self._closed = False
        self._inboxes: weakref.WeakSet[ChannelInbox] = weakref.WeakSet()
        _OPEN.add(self)

    # -- helpers -----------------------------------------------------------------------------

    def _key(self, name: str, type_name: str) -> str:
        return topic_keyexpr(self.domain_id, name, type_name, self.types.rihs01(type_name))

    def _token(self, node: NodeInfo, kind: EntityKind, name: str, type_name: str,
               qos: QoSProfile, entity_id: int) -> Any:
        """Declare the entity's liveliness token: always *after* the entity itself, as
        rmw_zenoh does, so that whoever sees the token (a publisher waiting for a
        subscriber, a client for a service) can rely on the entity already being there."""
        key = entity_token(self.domain_id, self.session_id, node.node_id, entity_id, kind,
                           node.name, name, type_name, self.types.rihs01(type_name),
                           namespace=node.namespace,
                           qos=qos)
        return self.session.liveliness().declare_token(key)

    # -- topics ------------------------------------------------------------------------------

    def advertise(self, node: NodeInfo, topic: str, type_name: str,
                  qos: QoSProfile) -> ZenohPublisher:
        entity_id = next(self._entity_ids)
        publisher = ZenohPublisher(self, self._key(topic, type_name), type_name,
                                   gid_from(self.session_id, entity_id), qos)
        publisher._add_token(self._token(node, EntityKind.PUBLISHER, topic, type_name, qos,
                                         entity_id))
        return publisher

    def subscribe(self, node: NodeInfo, topic: str, type_name: str, qos: QoSProfile,
                  wake: Wake, *, raw: bool = False) -> ChannelInbox:
        key = self._key(topic, type_name)
        subscriber: zenoh.Subscriber[Any] | zenoh.ext.AdvancedSubscriber[Any]
        if qos.transient_local:
            # rmw_zenoh's TRANSIENT_LOCAL: an AdvancedSubscriber that asks publishers' caches
            # for their history, now and whenever a new (late) publisher appears
            subscriber = zenoh.ext.declare_advanced_subscriber(
                self.session, key, channel_for(qos), history=zenoh.ext.HistoryConfig(
                    detect_late_publishers=True,
                    max_samples=qos.history_depth))
        else:
            subscriber = self.session.declare_subscriber(key, channel_for(qos))
        token = self._token(node, EntityKind.SUBSCRIPTION, topic, type_name, qos,
                            next(self._entity_ids))
        inbox = ChannelInbox(subscriber, wake, name=topic, depth=qos.queue_depth,
                             token=token)
        self._inboxes.add(inbox)
        return inbox

    # -- services ----------------------------------------------------------------------------

    def serve(self, node: NodeInfo, name: str, srv: ServiceType, handler: Handler) -> Closeable:
        """A queryable on the service's key, then its SS token (rmw_service_data.cpp's order).

        Every request with rmw_zenoh's attachment gets exactly one OK reply on the service's
        key, with the attachment's sequence number and GID echoed (a fresh timestamp), as
        ``ServiceData::send_response`` writes it. When the handler fails (raises, returns a
        wrong type, or its response does not serialize) the reply is still OK, carrying a
        default response, and is marked by its encoding (:func:`.rmw_zenoh.error_encoding`):
        rmw_zenoh's client drops error replies and would never learn of the failure. A query
        without that attachment is no ROS client's: it gets a Zenoh error reply."""

        key = self._key(name, srv.name)

        def on_query(query: zenoh.Query) -> None:
            request = query.payload.to_bytes() if query.payload is not None else b""
            try:
                if query.attachment is None:
                    raise MessageError("no attachment")
                asked = decode_attachment(query.attachment.to_bytes())
            except MessageError as exc:
                try:
                    with contextlib.suppress(zenoh.ZError):
                        query.reply_err(f"request without rmw_zenoh's attachment ({exc}): a "
                                        "ROS client attaches its sequence number and GID"
                                        .encode())
                finally:
                    with contextlib.suppress(zenoh.ZError):
                        query.drop()
                return

            def reply(response: Any) -> None:
                encoding = None
                if not isinstance(response, Exception):
                    try:
                        payload = self.types.serialize(response, srv.response)
                    except Exception as exc:  # answered below, as a failed handler
                        response = exc
                if isinstance(response, Exception):
                    payload = self.types.serialize(self.types.default(srv.response),
                                                   srv.response)
                    encoding = zenoh.Encoding(error_encoding(
                        str(response) or type(response).__name__))
                attachment = encode_attachment(asked.sequence_number, time.time_ns(), asked.gid)
                # then drop the query at once, which ends the client's get: whatever still
                # refers to it (an exception's traceback, a log record) would keep it open
                try:
                    with contextlib.suppress(zenoh.ZError):  # session closed, or answered
                        query.reply(key, payload, encoding=encoding, attachment=attachment)
                finally:
                    with contextlib.suppress(zenoh.ZError):
                        query.drop()

            try:
                handler(request, reply)
            except Exception as exc:  # never leave a ROS client waiting for ever
                reply(exc)

        queryable = self.session.declare_queryable(key, on_query, complete=True)
        token = self._token(node, EntityKind.SERVICE, name, srv.name, QoSProfile(),
                            next(self._entity_ids))
        return _Declared(queryable, token)

    def call(self, name: str, srv: ServiceType, request: Any, timeout: float) -> Future[Any]:
        """A Zenoh ``get`` as rmw_zenoh's client sends it (``rmw_client_data.cpp``: target
        ALL_COMPLETE, rmw_zenoh's attachment); the first reply decides. A reply marked as a
        failed handler's (:func:`.rmw_zenoh.error_reason`) or a Zenoh error reply is a
        :class:`ServiceError` naming the reason."""

        future: Future[Any] = Future()
        payload = self.types.serialize(request, srv.request)
        entity_id = next(self._entity_ids)
        attachment = encode_attachment(entity_id, time.time_ns(),
                                       gid_from(self.session_id, entity_id))
        key = self._key(name, srv.name)

        def run() -> None:
            try:
                replies = self.session.get(key, payload=payload, attachment=attachment,
                                           target=zenoh.QueryTarget.ALL_COMPLETE,
                                           timeout=timeout)
                for reply in replies:
                    if reply.ok is not None:
                        why = error_reason(str(reply.ok.encoding))
                        if why is not None:
                            future.set_exception(ServiceError(f"service {name} failed: {why}"))
                        else:
                            future.set_result(self.types.deserialize(
                                reply.ok.payload.to_bytes(), srv.response))
                    elif reply.err is not None:
                        why = reply.err.payload.to_bytes().decode(errors="replace")
                        future.set_exception(ServiceError(f"service {name} failed: {why}"))
                    else:  # Zenoh sets exactly one of ok and err; never hang on a third case
                        future.set_exception(TransportError(
                            f"service {name}: Zenoh reply carries neither a response nor an "
                            "error"))
                    return
                future.set_exception(ServiceError(
                    f"no service {name} answered within {timeout:g} s (is its node running, "
                    "and are the Zenoh endpoints connected?)"))
            except Exception as exc:  # never leave the caller waiting
                if not future.done():
                    future.set_exception(ServiceError(f"service {name}: {exc}"))

        threading.Thread(target=run, daemon=True, name=f"call {name}").start()
        return future

    def declare_client(self, node: NodeInfo, name: str, srv: ServiceType) -> Closeable:
        """The client's SC liveliness token, as rmw_zenoh's ``ClientData`` declares it when
        the client is created (``rmw_client_data.cpp``) and undeclares it at shutdown. A
        client needs nothing else declared: each call is a plain ``get``."""
        token = self._token(node, EntityKind.CLIENT, name, srv.name, QoSProfile(),
                            next(self._entity_ids))
        return _Declared(token)

    # -- graph -------------------------------------------------------------------------------

    def announce_node(self, node: NodeInfo) -> Closeable:
        key = node_token(self.domain_id, self.session_id, node.node_id, node.name,
                         node.namespace)
        return _Declared(self.session.liveliness().declare_token(key))

    def graph(self, timeout: float = 0.5) -> list[Endpoint]:
        """Every entity's liveliness token, asked for (``get``) as ``ros2 node list`` asks.

        A session whose only link is a router just reached may ask before the router has
        told it of the others' tokens: its query then has nowhere to go and comes back
        empty, though the graph is not (a peer's ``servolab topic list`` through a fleet's
        router, docs/fleets.md), or find part of it. So the tokens are also listened for (a
        liveliness subscriber with history, as rmw_zenoh's graph cache takes them), and when
        the query found no other session's token while the session is linked to a router or
        a peer, the rest of ``timeout`` is spent listening for the others' declarations
        before asking again (a session alone, or cut off, answers at once)."""
        key = f"{ADMIN_SPACE}/{self.domain_id}/**"
        ours = f"{ADMIN_SPACE}/{self.domain_id}/{self.session_id}/"
        start = time.monotonic()
        # a ring channel drained here: nothing of this runs on Zenoh's threads, and a full
        # ring drops the oldest rather than block Zenoh
        listener = self.session.liveliness().declare_subscriber(
            key, zenoh.handlers.RingChannel(_GRAPH_CHANNEL), history=True)
        try:
            keys = set(self._tokens(key, timeout))
            if not any(not k.startswith(ours) for k in keys) and self._linked():
                # linked, but nothing of the others yet: listen out the window, ask again
                time.sleep(max(0.0, timeout - (time.monotonic() - start)))
                keys |= set(self._tokens(key, timeout))
            while (sample := listener.try_recv()) is not None:
                if sample.kind == zenoh.SampleKind.PUT:
                    keys.add(str(sample.key_expr))
                else:
                    keys.discard(str(sample.key_expr))
        finally:
            listener.undeclare()
        endpoints = []
        for token in sorted(keys):
            try:
                entity = parse_token(token)
            except MessageError:
                continue  # a token of another rmw version or tool: not ours to judge
            fqn = f"{entity.namespace.rstrip('/')}/{entity.node_name}"
            endpoints.append(Endpoint(str(entity.kind), fqn, entity.topic or "",
                                      entity.type_name or "", entity.qos))
        return endpoints

    def _linked(self) -> bool:
        return bool(list(self.session.info.routers_zid()) or list(self.session.info.peers_zid()))

    def _tokens(self, key: str, timeout: float) -> list[str]:
        """The tokens a liveliness query for ``key`` finds within ``timeout`` s.

        The replies are taken by a callback and this thread waits on an event, with a
        deadline of its own: iterating the query's handler instead was seen to block for
        minutes in a router's client on a loaded machine (three Waffles, their navigators
        and the rest of the suite on two cores), the query never finalised though its
        timeout had passed."""
        found: list[str] = []
        done = threading.Event()

        def reply(answer: Any) -> None:
            if answer.ok is not None:
                found.append(str(answer.ok.key_expr))

        self.session.liveliness().get(key, zenoh.handlers.Callback(reply, done.set),
                                      timeout=timeout)
        done.wait(timeout + _QUERY_GRACE_S)
        return list(found)

    def check_reachable(self, timeout: float = 2.0) -> None:
        if not self.options.connect:
            return  # the router is optional: peers on this machine may meet without it
        end = time.monotonic() + timeout
        while True:
            if list(self.session.info.peers_zid()) or list(self.session.info.routers_zid()):
                return
            if time.monotonic() >= end:
                raise TransportError(
                    f"no Zenoh peer or router answers at {', '.join(self.options.connect)} "
                    f"(waited {timeout:g} s): is it running, and is the endpoint right?")
            time.sleep(0.05)

    def close(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
        for inbox in list(self._inboxes):
            inbox.close()  # their watcher threads leave
        self.session.close()
