"""``ViewServer``: a servolab graph seen from Foxglove or Lichtblick, over the Foxglove
WebSocket protocol v1 (:mod:`.protocol`), as foxglove_bridge serves a ROS 2 graph.

The server joins the graph as one node of the context it is given (``servolab_view``), so it
works with whichever transport the context has (in-process, Zenoh, DDS): it only uses what any
node may use (the graph, raw subscriptions, service clients).

Two threads meet here, and never wait on each other:

- the **asyncio loop** (a daemon thread of the server's own) owns the sockets and every piece
  of the server's state: channels, clients, subscriptions;
- the **executor** (whoever spins the context) runs the subscription callbacks. A callback only
  stamps the message and hands it to the loop with ``call_soon_threadsafe``, so a slow viewer
  never slows the robot's callbacks. Each viewer has a bounded queue of data frames; when it
  is full the oldest frame is dropped and counted (:attr:`ViewServer.dropped`), as a
  KEEP_LAST subscription would.

Nothing a client sends makes the server hold more than a bound (:class:`ViewConfig`): a data
queue drops its oldest frames past ``send_queue`` frames or ``send_bytes`` bytes; frames that
must arrive (answers, advertisements) are never dropped, so a client that owes more than
``control_queue`` of them or ``control_bytes`` bytes is disconnected (close code 1008 with the
reason), as foxglove-sdk disconnects a client whose control-plane queue fills (its
``message_backlog_size``, 1024 by default): dropping an answer or an advertisement would leave
the app with a wrong picture of the graph, and a client that stopped reading gets it whole
again when it reconnects. An answer quotes at most 200 characters of the request
(:func:`.protocol.echo`); a client may have ``in_flight`` requests served at once (foxglove-sdk:
32 service calls), the rest are refused; a bad message is logged once per client, the rest
counted. Who may connect and who may control: :mod:`.access`.

The graph is polled (``transport.graph``): topics with a publisher become channels as they
appear and are unadvertised as they go; servers become services. Parameters go through each
node's rclpy-style parameter services, named ``/<node>.<param>`` as foxglove_bridge names them.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import logging
import math
import os
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable
from concurrent.futures import Future
from dataclasses import dataclass, field
from types import TracebackType
from typing import TYPE_CHECKING, Any, Protocol

from websockets.asyncio.server import Server, ServerConnection, serve
from websockets.exceptions import ConnectionClosed
from websockets.frames import CloseCode
from websockets.http11 import Request, Response
from websockets.typing import Subprotocol

from ..errors import MiddlewareError
from ..node import Node
from ..parameters import from_parameter_value, to_parameter_value
from ..qos import QoSProfile, adapted_policies
from . import access as a
from . import protocol as p
from .defaults import DEFAULT_HOST, DEFAULT_PORT
from .pacing import MAX_SPEED, MIN_SPEED, Pacer

if TYPE_CHECKING:
    from ..client import Client
    from ..context import Context
    from ..subscription import Subscription
    from ..transport import Endpoint

_log = logging.getLogger("servolab.view")


class PlaybackState(Protocol):
    @property
    def status(self) -> str: ...      # "playing", "paused" or "ended"
    @property
    def current_ns(self) -> int: ...
    @property
    def start_ns(self) -> int: ...
    @property
    def end_ns(self) -> int: ...
    @property
    def rate(self) -> float: ...


class Playback(Protocol):
    """What the server needs of a player of recorded data for the app's playback controls
    (:class:`.player.BagPlayer` is one)."""

    def state(self) -> PlaybackState: ...
    def pause(self) -> None: ...
    def resume(self) -> None: ...
    def seek(self, t_ns: int) -> None: ...
    def set_rate(self, rate: float) -> None: ...
    def sync(self, timeout: float = ...) -> bool: ...


#: A player's status as the protocol numbers it.
_STATUS = {"playing": p.PLAYING, "paused": p.PAUSED, "ended": p.ENDED}


@dataclass(frozen=True)
class ViewConfig:
    """Where the server listens and how it paces itself."""

    host: str = DEFAULT_HOST
    port: int = DEFAULT_PORT                  # 0: a free port (then read ViewServer.port)
    name: str = "servolab view"       # serverInfo's name, shown by the viewer
    node_name: str = "servolab_view"  # the server's node in the graph
    graph_period: float = 0.25        # s between two looks at the graph
    graph_timeout: float = 0.2        # s a look at the graph may listen (Zenoh, DDS)
    time_period: float = 0.05         # s between time ops (virtual clocks only)
    parameter_period: float = 0.5     # s between looks at subscribed parameters
    send_queue: int = 1000            # data frames a viewer may owe before the oldest drops
    send_bytes: int = 32 * 2**20      # ... and their bytes (one frame larger still goes)
    #: frames that must arrive (answers, advertisements) a viewer may owe, and their bytes:
    #: one more and it is disconnected, as foxglove-sdk does (see the module's docstring)
    control_queue: int = 1000
    control_bytes: int = 32 * 2**20
    in_flight: int = 32               # requests of one viewer served at once (foxglove-sdk's)
    max_message: int = 16 * 2**20     # the largest message a client may send, bytes
    #: pages let in besides :data:`.access.DEFAULT_ORIGINS` and localhost's ("null": a local
    #: file's page may control too; "*": any page)
    allow_origins: tuple[str, ...] = ()
    read_only: bool = False           # every client may watch only
    #: the token that gives control; None: $SERVOLAB_VIEW_TOKEN, else a random one made at
    #: start when one is needed
    token: str | None = None
    #: whether control needs the token; None: when the host is not a loopback address (or a
    #: token was given)
    require_token: bool | None = None
    call_timeout: float = 5.0         # s a service or parameter call may take
    include_hidden: bool = False      # also show nodes, topics, services named _...
    start_timeout: float = 10.0       # s to wait for the socket to listen
    close_timeout: float = 1.0        # s a viewer that reads nothing may hold up close()
    #: a topic is read with the history its publishers keep, as foxglove_bridge reads it: the
    #: sum of their depths (each at least 1), within these bounds (foxglove_bridge's
    #: parameters of the same names, and their defaults; see subscription_qos)
    min_qos_depth: int = 1
    max_qos_depth: int = 25

    def __post_init__(self) -> None:
        if not 1 <= self.min_qos_depth <= self.max_qos_depth:
            raise MiddlewareError(f"min_qos_depth {self.min_qos_depth} and max_qos_depth "
                                  f"{self.max_qos_depth}: need 1 <= min_qos_depth <= "
                                  "max_qos_depth")


@dataclass(eq=False)
class _Viewer:
    """One connected client: its queues, its subscriptions, its parameter subscriptions,
    what it may do."""

    ws: ServerConnection
    limits: ViewConfig
    #: called once when the control queue overflows: the server disconnects the viewer
    on_overflow: Callable[[_Viewer], None]
    address: str = "?"
    #: why this client may only watch; "": it may control too
    watch_only: str = ""
    control: deque[str | bytes] = field(default_factory=deque)
    control_bytes: int = 0
    data: deque[bytes] = field(default_factory=deque)
    data_bytes: int = 0
    wake: asyncio.Event = field(default_factory=asyncio.Event)
    subscriptions: dict[int, int] = field(default_factory=dict)  # subscription id -> channel
    parameters: set[str] = field(default_factory=set)
    dropped: int = 0
    last_time: int = -1               # the last time op's value it was sent
    in_flight: int = 0                # its requests being served
    bad_messages: int = 0             # messages the protocol does not allow (logged once)
    failures: int = 0                 # messages the server failed on (logged once)
    #: why the server is dropping it ("": it is not); then nothing more is queued
    closing: str = ""

    def send(self, frame: str | bytes) -> None:
        """A frame that must arrive (advertisements, answers): never dropped. One past the
        limits (with something queued already: one large answer still goes) and the viewer
        is disconnected instead."""
        if self.closing:
            return
        size = len(frame)  # JSON is ASCII here (json.dumps escapes the rest): bytes
        if self.control and (len(self.control) >= self.limits.control_queue
                             or self.control_bytes + size > self.limits.control_bytes):
            self.closing = (f"it reads too slowly: it owes {len(self.control)} frames "
                            f"({self.control_bytes} bytes) that must arrive (limits "
                            f"{self.limits.control_queue} frames, "
                            f"{self.limits.control_bytes} bytes)")
            self.control.clear()
            self.data.clear()
            self.control_bytes = self.data_bytes = 0
            self.on_overflow(self)
            return
        self.control.append(frame)
        self.control_bytes += size
        self.wake.set()

    def send_data(self, frame: bytes) -> int:
        """A data frame; how many older ones were dropped to keep to the queue's limits."""
        if self.closing:
            return 0
        dropped = 0
        while self.data and (len(self.data) >= self.limits.send_queue
                             or self.data_bytes + len(frame) > self.limits.send_bytes):
            self.data_bytes -= len(self.data.popleft())
            dropped += 1
        self.dropped += dropped
        self.data.append(frame)
        self.data_bytes += len(frame)
        self.wake.set()
        return dropped

    def next_frame(self) -> str | bytes | None:
        """The next frame to send, control frames first; None when nothing is owed."""
        if self.control:
            frame: str | bytes = self.control.popleft()
            self.control_bytes -= len(frame)
            return frame
        if self.data:
            data = self.data.popleft()
            self.data_bytes -= len(data)
            return data
        return None


@dataclass(eq=False)
class _TopicFeed:
    """The one servolab subscription behind a channel, shared by every viewer of it."""

    channel_id: int
    subscription: Subscription | None = None
    receivers: dict[_Viewer, int] = field(default_factory=dict)  # viewer -> subscription id
    #: a latched topic's last messages (stamp, CDR), up to its depth: the subscription's
    #: TRANSIENT_LOCAL replay reaches the first viewer only, a later one gets them from here
    kept: deque[tuple[int, bytes]] | None = None


def subscription_qos(offers: Iterable[QoSProfile | None], *, min_depth: int = 1,
                     max_depth: int = 25) -> tuple[QoSProfile, int]:
    """The QoS to subscribe with, and the depth wanted before ``max_depth`` bounded it.

    Adapted to the publishers as ``ros2 topic echo`` adapts it: RELIABLE if every publisher
    is, else BEST_EFFORT; TRANSIENT_LOCAL if every publisher is, so a latched
    ``/robot_description`` or map reaches a viewer that connects late. The depth is
    foxglove_bridge's (``ros2_foxglove_bridge.cpp``): the sum of the publishers' depths, each
    at least 1 (three ``/tf_static`` broadcasters of depth 1 keep three), no less than
    ``min_depth`` and no more than ``max_depth`` (its ``min_qos_depth``/``max_qos_depth``), so
    a burst a publisher keeps reaches a viewer that keeps up. A publisher whose depth is
    unknown counts 1, as foxglove_bridge counts a depth the middleware does not report (DDS
    discovery carries none); a KEEP_ALL one counts what it would keep of its history
    (:data:`~..qos.KEEP_ALL_HISTORY`), so that the bound applies and is said, a rule
    foxglove_bridge does not have."""
    offers = list(offers)
    reliability, durability = adapted_policies(offers)
    wanted = max(min_depth, sum(1 if q is None else max(1, q.history_depth) for q in offers))
    return (QoSProfile(depth=min(wanted, max_depth), reliability=reliability,
                       durability=durability), wanted)


def _hidden(name: str) -> bool:
    """rclpy's rule: a name any part of which starts with ``_`` is hidden."""
    return any(part.startswith("_") for part in name.split("/"))


class ViewServer:
    """A Foxglove WebSocket server over a context's graph. Listening once constructed;
    :meth:`close` (or leaving a ``with`` block) stops it. Callbacks reach it only while the
    context is spun, as any node's do."""

    def __init__(self, context: Context, config: ViewConfig | None = None, *,
                 pacer: Pacer | None = None, playback: Playback | None = None) -> None:
        self.context = context
        self.config = config or ViewConfig()
        #: held while a viewer is connected: a virtual run then keeps to the wall clock
        self.pacer = pacer
        #: the player of recorded data the app's play, pause and seek controls drive
        self.playback = playback
        self._last_status: str | None = None
        config = self.config
        for origin in config.allow_origins:
            a.check_origin(origin)
        token = config.token if config.token is not None else os.environ.get(a.TOKEN_ENV) or None
        if token is not None:
            a.check_token(token)
        #: whether control needs the token (beyond loopback, or when one was given; never
        #: read-only, where nothing gives control)
        self.token_required = not config.read_only and (
            config.require_token if config.require_token is not None
            else token is not None or not a.is_loopback(config.host))
        if self.token_required and token is None:
            token = a.new_token()
        #: the token that gives control (None where none is needed)
        self.token = token if self.token_required else None
        self._origins = a.handshake_origins(config.allow_origins)
        self._trust_null = a.trusted_null(config.allow_origins)
        self._refused_origins: set[str] = set()
        self.node = Node(context, self.config.node_name)
        self.session_id = str(time.time_ns())
        self._virtual = bool(context.clock.virtual)
        self._closed = False
        self._ids = itertools.count(1)
        self._graph_seen = 0.0  # monotonic time of the last look at the graph
        # State below is the loop's: only code running on the loop touches it.
        self._channels: dict[int, p.Channel] = {}
        self._channel_types: dict[int, str] = {}
        self._channel_ids: dict[tuple[str, str], int] = {}   # kept: an id is reused as is
        self._services: dict[int, p.ServiceChannel] = {}
        self._service_ids: dict[tuple[str, str], int] = {}
        self._offers: dict[str, list[QoSProfile | None]] = {}
        self._parameter_nodes: list[str] = []
        self._unknown_types: set[str] = set()
        self._viewers: set[_Viewer] = set()
        self._feeds: dict[int, _TopicFeed] = {}
        self._clients: dict[tuple[str, str], Client] = {}
        self._parameter_cache: dict[str, Any] = {}
        self._tasks: set[asyncio.Task[None]] = set()
        self._dropped = 0       # written on the loop only; read anywhere (an int is atomic)
        self._history_dropped = 0  # by the subscriptions of feeds that have ended
        self._viewer_count = 0
        self._port = 0
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stop: asyncio.Event | None = None
        self._ready = threading.Event()
        self._connected = threading.Event()  # set once the first viewer has connected
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="servolab-view", daemon=True)
        self._thread.start()
        if not self._ready.wait(self.config.start_timeout) or self._error is not None:
            error = self._error
            self.close()
            raise MiddlewareError(f"view server could not listen on {self.config.host}:"
                                  f"{self.config.port}: {error or 'timed out'}") from error
        for line in self.access:
            _log.info("view: %s", line)

    # -- what a caller may read --------------------------------------------------------------

    @property
    def port(self) -> int:
        """The TCP port it listens on (the one picked when the config said 0)."""
        return self._port

    @property
    def url(self) -> str:
        return f"ws://{self.config.host}:{self._port}"

    @property
    def control_url(self) -> str:
        """The URL to connect to with control: :attr:`url` with the token where one is
        needed (``ws://0.0.0.0:8765/?token=...``), else :attr:`url` itself."""
        return self.url if self.token is None else a.with_token(self.url, self.token)

    @property
    def access(self) -> list[str]:
        """What a client of this server may do, in lines to print at start (no token in
        them)."""
        where = (f"on {self.config.host}, this computer only" if a.is_loopback(self.config.host)
                 else f"on {self.config.host or 'every address'}, beyond this computer (from "
                 "another, connect to this computer's address): anyone who can reach this "
                 "port may watch every topic and parameter")
        pages = ("any web page" if self._origins is None
                 else "pages of Foxglove (app.foxglove.dev), Lichtblick "
                 "(lichtblick-suite.github.io), localhost and the desktop apps"
                 + "".join(f", {o}" for o in self.config.allow_origins)
                 + ", and programs; other web pages are refused")
        if self.config.read_only:
            control = ("read-only (--ws-read-only): clients may watch, not set parameters, "
                       "call services or control playback")
        elif self.token_required:
            control = ("setting parameters, calling services and playback control need the "
                       f"token (?{a.TOKEN_PARAMETER}=... in the URL); without it a client "
                       "may only watch")
        else:
            control = ("every client it lets in may also set parameters, call services and "
                       "control playback: drive the robot")
        return [f"listening {where}", f"it lets in {pages}", control]

    @property
    def dropped(self) -> int:
        """Data frames dropped because a viewer fell behind (all viewers, ever)."""
        return self._dropped

    @property
    def history_dropped(self) -> int:
        """Messages the view's subscriptions dropped to keep their depth (a burst longer than
        the publishers keep, or than ``max_qos_depth``), ever; none while the view keeps up.
        Counted where the transport counts them (in one process, DDS); Zenoh's ring channel
        drops without a count, so over Zenoh this stays 0."""
        dropped = self._history_dropped
        for feed in list(self._feeds.values()):
            subscription = feed.subscription  # once: the loop may end the feed meanwhile
            if subscription is not None:
                dropped += subscription.dropped
        return dropped

    @property
    def viewers(self) -> int:
        """How many clients are connected."""
        return self._viewer_count

    def wait_for_viewer(self, timeout: float | None = None) -> bool:
        """Wait until a viewer has connected (at any time since the server started), in
        short waits so that a stop signal is handled meanwhile; whether one has."""
        end = None if timeout is None else time.monotonic() + timeout
        while not self._connected.wait(0.1):
            if end is not None and time.monotonic() >= end:
                return False
        return True

    @property
    def capabilities(self) -> list[str]:
        caps = [p.PARAMETERS, p.PARAMETERS_SUBSCRIBE, p.SERVICES]
        if self._virtual:
            caps.append(p.TIME)
        if self.playback is not None:
            caps.append(p.PLAYBACK_CONTROL)
        return caps

    # -- life --------------------------------------------------------------------------------

    def _run(self) -> None:
        loop = asyncio.new_event_loop()
        self._loop = loop
        try:
            loop.run_until_complete(self._main())
        except BaseException as exc:  # said by the constructor, or logged
            self._error = exc
            if self._ready.is_set():
                _log.exception("view server stopped")
            self._ready.set()
        finally:
            with contextlib.suppress(Exception):
                loop.run_until_complete(loop.shutdown_default_executor())
            loop.close()

    async def _main(self) -> None:
        self._stop = asyncio.Event()
        async with serve(self._handle, self.config.host, self.config.port,
                         subprotocols=[Subprotocol(s) for s in p.SUBPROTOCOLS],
                         # a page from elsewhere is refused at the handshake, HTTP 403
                         origins=self._origins,
                         process_response=self._said_refusal,
                         # no permessage-deflate: a camera frame compressed per viewer
                         # costs the robot's process more than loopback saves
                         compression=None, max_size=self.config.max_message,
                         close_timeout=self.config.close_timeout) as server:
            self._port = _port_of(server)
            if self._closed:
                return
            self._spawn(self._watch_graph())
            self._spawn(self._watch_parameters())
            if self._virtual:
                self._spawn(self._send_time())
            self._ready.set()
            await self._stop.wait()
            for task in list(self._tasks):
                task.cancel()
            await asyncio.gather(*self._tasks, return_exceptions=True)

    def close(self) -> None:
        """Stop listening, close every connection, destroy the node; a second call does
        nothing."""
        if self._closed:
            return
        self._closed = True
        loop, stop = self._loop, self._stop
        if loop is not None and stop is not None:
            with contextlib.suppress(RuntimeError):  # the loop has already stopped
                loop.call_soon_threadsafe(stop.set)
        self._thread.join(self.config.start_timeout)
        self.node.destroy()

    def __enter__(self) -> ViewServer:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def _spawn(self, work: Any) -> None:
        task: asyncio.Task[None] = asyncio.get_running_loop().create_task(work)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    # -- connections -------------------------------------------------------------------------

    def _said_refusal(self, ws: ServerConnection, request: Request,
                      response: Response) -> None:
        """Log a page refused for its origin, once an origin (the library answers 403)."""
        if response.status_code != 403:
            return
        origin = request.headers.get("Origin", "")
        if origin in self._refused_origins or len(self._refused_origins) >= 64:
            return
        self._refused_origins.add(origin)
        _log.warning("view: refused a connection from a page at %s: not an origin this view "
                     "lets in (--ws-allow-origin ORIGIN lets one in)", p.echo(origin))

    def _rights(self, ws: ServerConnection) -> str:
        """Why the client of ``ws`` may only watch; "" when it may control too."""
        if self.config.read_only:
            return "the view is read-only (--ws-read-only)"
        request = ws.request
        given = a.token_in(request.path) if request is not None else None
        if a.token_matches(given, self.token):
            return ""
        if self.token_required:
            return ("this view listens beyond this computer: control needs its token, "
                    f"given as ?{a.TOKEN_PARAMETER}=... in the URL"
                    + (" (the one given is not it)" if given is not None else ""))
        origin = request.headers.get("Origin") if request is not None else None
        if origin == a.NULL_ORIGIN and not self._trust_null:
            return ("the page has no origin of its own (Origin: null: a local file, or a "
                    "sandboxed frame of any web site); --ws-allow-origin null trusts it")
        return ""

    @staticmethod
    def _address(ws: ServerConnection) -> str:
        try:
            host, port = ws.remote_address[:2]
        except (TypeError, ValueError):
            return "?"
        return f"[{host}]:{port}" if ":" in str(host) else f"{host}:{port}"

    def _overflowed(self, viewer: _Viewer) -> None:
        """The viewer's control queue overflowed: disconnect it, saying why (on the loop)."""
        _log.warning("view: disconnecting client %s: %s", viewer.address, viewer.closing)
        self._spawn(self._disconnect(viewer.ws, CloseCode.POLICY_VIOLATION,
                                     "servolab view: message backlog full (client not "
                                     "reading)"))

    async def _disconnect(self, ws: ServerConnection, code: int, reason: str) -> None:
        """Close with ``code`` and ``reason``; a client that reads nothing cannot hold it up
        beyond ``close_timeout`` (the close frame waits behind what it did not read)."""
        try:
            await asyncio.wait_for(ws.close(code, reason), self.config.close_timeout)
        except (TimeoutError, ConnectionClosed):
            pass
        finally:
            ws.transport.abort()

    async def _handle(self, ws: ServerConnection) -> None:
        viewer = _Viewer(ws, self.config, self._overflowed, address=self._address(ws),
                         watch_only=self._rights(ws))
        self._viewers.add(viewer)
        self._viewer_count = len(self._viewers)
        if self.pacer is not None:
            self.pacer.hold()
        self._connected.set()
        viewer.send(p.server_info(self.config.name, self.capabilities,
                                  metadata={"ROS_DISTRO": "jazzy",
                                            "transport": type(self.context.transport).__name__},
                                  session_id=self.session_id,
                                  data_range_ns=self._data_range()))
        viewer.send(p.advertise(list(self._channels.values())))
        if self._services:
            viewer.send(p.advertise_services(list(self._services.values())))
        if viewer.watch_only:
            viewer.send(p.status(p.WARNING, a.refused_ops(viewer.watch_only),
                                 "servolab.watch_only"))
        writer = asyncio.get_running_loop().create_task(self._write(viewer))
        try:
            async for message in ws:
                self._on_message(viewer, message)
        except ConnectionClosed:
            pass
        finally:
            viewer.closing = viewer.closing or "it left"
            viewer.control.clear()
            viewer.data.clear()
            if viewer.bad_messages > 1 or viewer.failures > 1:
                _log.info("view: client %s sent %d bad message(s) in all%s", viewer.address,
                          viewer.bad_messages, f" and {viewer.failures} the server failed on"
                          if viewer.failures else "")
            self._viewers.discard(viewer)
            self._viewer_count = len(self._viewers)
            if self.pacer is not None:
                self.pacer.release()
            for subscription_id in list(viewer.subscriptions):
                self._unsubscribe(viewer, subscription_id)
            writer.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await writer

    @staticmethod
    async def _write(viewer: _Viewer) -> None:
        """Send what the viewer is owed, control frames first, one at a time (websockets
        waits while the socket's buffer is full: the queue, not the robot, absorbs it)."""
        with contextlib.suppress(ConnectionClosed):
            while not viewer.closing:
                await viewer.wake.wait()
                viewer.wake.clear()
                while (frame := viewer.next_frame()) is not None:
                    await viewer.ws.send(frame)

    def _on_message(self, viewer: _Viewer, message: str | bytes) -> None:
        """Act on one client message; a bad one earns a status error, never a crash. The
        first bad message of a client is logged in one line, the rest counted (said when it
        leaves): a client cannot fill the log."""
        try:
            op = p.parse_text(message) if isinstance(message, str) else p.parse_binary(message)
            self._dispatch(viewer, op)
        except (p.ClientMessageError, RecursionError) as exc:
            text = (str(exc) if isinstance(exc, p.ClientMessageError)
                    else "nested too deeply to read")
            viewer.bad_messages += 1
            if viewer.bad_messages == 1:
                _log.warning("view: client %s sent a message the protocol does not allow "
                             "(%s); more from it are answered, counted, not logged",
                             viewer.address, text)
            viewer.send(p.status(p.ERROR, text))
        except Exception as exc:
            viewer.failures += 1
            if viewer.failures == 1:
                _log.exception("view: a message of client %s failed (more are counted, not "
                               "logged)", viewer.address)
            viewer.send(p.status(p.ERROR, f"{type(exc).__name__}: {exc}"))

    def _dispatch(self, viewer: _Viewer, op: p.ClientOp) -> None:
        if viewer.watch_only and self._refuse_control(viewer, op):
            return
        if isinstance(op, p.ServiceCallRequest | p.PlaybackControlRequest | p.GetParameters
                      | p.SetParameters | p.SubscribeParameterUpdates) \
                and viewer.in_flight >= self.config.in_flight:
            reason = (f"too many requests in flight ({viewer.in_flight}, at most "
                      f"{self.config.in_flight} a client): wait for their answers")
            if isinstance(op, p.ServiceCallRequest):
                viewer.send(p.service_call_failure(op.service_id, op.call_id, reason))
            else:
                viewer.send(p.status(p.ERROR, reason))
            return
        if isinstance(op, p.Subscribe):
            for subscription_id, channel_id in op.subscriptions:
                self._subscribe(viewer, subscription_id, channel_id)
        elif isinstance(op, p.Unsubscribe):
            for subscription_id in op.subscription_ids:
                if subscription_id not in viewer.subscriptions:
                    viewer.send(p.status(p.WARNING, f"unsubscribe: no subscription "
                                                    f"{subscription_id}"))
                else:
                    self._unsubscribe(viewer, subscription_id)
        elif isinstance(op, p.ServiceCallRequest):
            self._serve(viewer, self._call_service(viewer, op))
        elif isinstance(op, p.PlaybackControlRequest):
            self._serve(viewer, self._guarded(viewer, self._playback_control(op)))
        else:
            self._serve(viewer, self._guarded(viewer, self._parameter_op(viewer, op)))

    def _serve(self, viewer: _Viewer, work: Any) -> None:
        """Run a request of the viewer's, counted while in flight."""
        viewer.in_flight += 1
        task: asyncio.Task[None] = asyncio.get_running_loop().create_task(work)
        self._tasks.add(task)

        def done(task: asyncio.Task[None]) -> None:
            self._tasks.discard(task)
            viewer.in_flight -= 1

        task.add_done_callback(done)

    def _refuse_control(self, viewer: _Viewer, op: p.ClientOp) -> bool:
        """Refuse an op that changes the robot or the playback, to a client that may only
        watch (the spec's answer to a call, ``serviceCallFailure``; a ``status`` error to the
        rest); whether it was refused. Subscribing and reading parameters stay open."""
        if isinstance(op, p.ServiceCallRequest):
            viewer.send(p.service_call_failure(op.service_id, op.call_id,
                                               f"callService refused: {viewer.watch_only}"))
        elif isinstance(op, p.SetParameters):
            viewer.send(p.status(p.ERROR, f"setParameters refused: {viewer.watch_only}"))
        elif isinstance(op, p.PlaybackControlRequest):
            viewer.send(p.status(p.ERROR,
                                 f"playbackControlRequest refused: {viewer.watch_only}"))
            if self.playback is not None:  # the app's request gets its answer: as it is
                state = self.playback.state()
                viewer.send(p.playback_state(_STATUS[state.status], state.current_ns,
                                             state.rate if math.isfinite(state.rate)
                                             else MAX_SPEED, False, op.request_id))
        else:
            return False
        return True

    def _data_range(self) -> tuple[int, int] | None:
        if self.playback is None:
            return None
        state = self.playback.state()
        return state.start_ns, state.end_ns

    async def _playback_control(self, op: p.PlaybackControlRequest) -> None:
        """Seek, set the speed, play or pause (in that order, as foxglove-sdk's player does),
        off the loop (a pause waits for the message being played), then tell every viewer
        the state, answering the request."""
        playback = self.playback
        if playback is None:
            raise p.ClientMessageError("playbackControlRequest needs capability "
                                       "'playbackControl', which this server does not offer")

        def control() -> PlaybackState:
            if op.seek_ns is not None:
                playback.seek(op.seek_ns)
                playback.sync()
            playback.set_rate(min(max(op.speed, MIN_SPEED), MAX_SPEED))
            if op.command == p.PLAY:
                playback.resume()
            else:
                playback.pause()
            return playback.state()

        state = await asyncio.get_running_loop().run_in_executor(None, control)
        self._broadcast_state(state, op.seek_ns is not None, op.request_id)

    def _broadcast_state(self, state: PlaybackState, did_seek: bool, request_id: str) -> None:
        self._last_status = state.status
        frame = p.playback_state(_STATUS[state.status], state.current_ns, state.rate
                                 if math.isfinite(state.rate) else MAX_SPEED, did_seek,
                                 request_id)
        for viewer in self._viewers:
            viewer.send(frame)

    async def _guarded(self, viewer: _Viewer, work: Any) -> None:
        try:
            await work
        except p.ClientMessageError as exc:
            viewer.send(p.status(p.ERROR, str(exc)))
        except Exception as exc:
            viewer.send(p.status(p.ERROR, f"{type(exc).__name__}: {exc}"))

    # -- topics ------------------------------------------------------------------------------

    def _subscribe(self, viewer: _Viewer, subscription_id: int, channel_id: int) -> None:
        if subscription_id in viewer.subscriptions:
            viewer.send(p.status(p.ERROR, f"subscribe: subscription id {subscription_id} is "
                                          "already in use"))
            return
        if channel_id not in self._channels:
            viewer.send(p.status(p.WARNING, f"subscribe: channel {channel_id} is not "
                                            "advertised"))
            return
        if channel_id in viewer.subscriptions.values():
            viewer.send(p.status(p.ERROR, f"subscribe: channel {channel_id} is already "
                                          "subscribed"))
            return
        feed = self._feeds.get(channel_id)
        if feed is None:
            feed = _TopicFeed(channel_id)
            channel = self._channels[channel_id]
            qos, wanted = subscription_qos(self._offers.get(channel.topic, []),
                                           min_depth=self.config.min_qos_depth,
                                           max_depth=self.config.max_qos_depth)
            if wanted > qos.depth:  # foxglove_bridge's warning, and what to do about it
                _log.warning("view: reading %s with a history of %d (its publishers keep %d): "
                             "a burst of more is cut to its last %d; raise max_qos_depth "
                             "(servolab view --max-qos-depth)", channel.topic, qos.depth,
                             wanted, qos.depth)
            if qos.transient_local:
                feed.kept = deque(maxlen=max(1, qos.depth))
            feed.subscription = self.node.create_subscription(
                self._channel_types[channel_id], channel.topic, self._forward(feed), qos,
                raw=True)
            self._feeds[channel_id] = feed
        elif feed.kept:  # a latched topic others watch already: what it kept, first
            for stamp, cdr in feed.kept:
                viewer.send_data(p.message_data(subscription_id, stamp, cdr))
        viewer.subscriptions[subscription_id] = channel_id
        feed.receivers[viewer] = subscription_id

    def _unsubscribe(self, viewer: _Viewer, subscription_id: int) -> None:
        channel_id = viewer.subscriptions.pop(subscription_id)
        feed = self._feeds.get(channel_id)
        if feed is None:
            return
        feed.receivers.pop(viewer, None)
        if not feed.receivers:
            self._end_feed(feed)

    def _end_feed(self, feed: _TopicFeed) -> None:
        self._feeds.pop(feed.channel_id, None)
        if feed.subscription is not None:
            self._history_dropped += feed.subscription.dropped
            self.node.destroy_subscription(feed.subscription)
            feed.subscription = None

    def _forward(self, feed: _TopicFeed) -> Callable[[bytes], None]:
        """The subscription's callback, on the executor's thread: stamp, hand over, return."""
        loop = self._loop
        assert loop is not None

        def on_message(cdr: bytes) -> None:
            stamp = self._now_ns()
            with contextlib.suppress(RuntimeError):  # the loop has stopped: nobody listens
                loop.call_soon_threadsafe(self._fan_out, feed, bytes(cdr), stamp)

        return on_message

    def _now_ns(self) -> int:
        """The context's ROS time in ns, exact where the clock keeps whole ns (a bag's
        playback clock: a float of seconds since the epoch is only good to ~240 ns)."""
        exact = getattr(self.context.clock, "ros_time_ns", None)
        return int(exact()) if exact is not None else round(self.context.ros_time() * 1e9)

    def _fan_out(self, feed: _TopicFeed, cdr: bytes, stamp: int) -> None:
        if self._feeds.get(feed.channel_id) is not feed:
            return  # unsubscribed meanwhile
        if feed.kept is not None:
            feed.kept.append((stamp, cdr))
        for viewer, subscription_id in feed.receivers.items():
            self._dropped += viewer.send_data(p.message_data(subscription_id, stamp, cdr))

    def _broadcast(self, frame: str | bytes) -> None:
        for viewer in self._viewers:
            viewer.send(frame)

    # -- the graph ---------------------------------------------------------------------------

    async def _watch_graph(self) -> None:
        while True:
            try:
                await self._look_at_graph()
            except Exception:
                _log.debug("view: looking at the graph failed", exc_info=True)
            await asyncio.sleep(self.config.graph_period)

    async def _look_at_graph(self) -> None:
        self._graph_seen = time.monotonic()
        endpoints = await asyncio.get_running_loop().run_in_executor(
            None, self.context.transport.graph, self.config.graph_timeout)
        self._update_graph(endpoints)

    async def _watch_parameters(self) -> None:
        """Apart from the graph's task: a node slow to answer delays updates, not topics."""
        while True:
            try:
                await self._poll_parameters()
            except Exception:
                _log.debug("view: looking at parameters failed", exc_info=True)
            await asyncio.sleep(self.config.parameter_period)

    def _shown(self, e: Endpoint) -> bool:
        """Every node's topics and services but the view's own, hidden only by their own
        names as ``ros2 topic list`` hides them: a hidden tool node's (``servolab topic pub``,
        ``bag play``) are what the user came to watch."""
        if e.node == self.node.fully_qualified_name:
            return False
        return self.config.include_hidden or not _hidden(e.name)

    def _update_graph(self, endpoints: list[Endpoint]) -> None:
        shown = [e for e in endpoints if self._shown(e)]
        offers: dict[str, list[QoSProfile | None]] = {}
        for e in shown:
            if e.kind == "MP":
                offers.setdefault(e.name, []).append(e.qos)
        self._offers = offers
        self._parameter_nodes = sorted({e.node for e in shown
                                        if e.kind == "SS" and e.name == f"{e.node}/get_parameters"})
        self._update_channels({(e.name, e.type_name) for e in shown if e.kind == "MP"})
        self._update_services({(e.name, e.type_name) for e in shown if e.kind == "SS"})

    def _schema(self, type_name: str) -> str | None:
        try:
            return self.context.types.msgdef(type_name)
        except Exception:
            if type_name not in self._unknown_types:
                self._unknown_types.add(type_name)
                _log.warning("view: type %s is unknown here; its topics are not shown",
                             type_name)
            return None

    def _update_channels(self, topics: set[tuple[str, str]]) -> None:
        current = {(c.topic, self._channel_types[c.id]): c.id for c in self._channels.values()}
        gone = [current[key] for key in sorted(set(current) - topics)]
        new = []
        for topic, type_name in sorted(topics - set(current)):
            schema = self._schema(type_name)
            if schema is None:
                continue
            channel_id = self._channel_ids.setdefault((topic, type_name), next(self._ids))
            channel = p.Channel(channel_id, topic, type_name, schema)
            self._channels[channel_id] = channel
            self._channel_types[channel_id] = type_name
            new.append(channel)
        for channel_id in gone:
            del self._channels[channel_id]
            feed = self._feeds.get(channel_id)
            if feed is not None:
                for viewer, subscription_id in feed.receivers.items():
                    viewer.subscriptions.pop(subscription_id, None)
                self._end_feed(feed)
        if gone:
            self._broadcast(p.unadvertise(gone))
        if new:
            self._broadcast(p.advertise(new))

    def _update_services(self, services: set[tuple[str, str]]) -> None:
        current = {(s.name, s.type): s.id for s in self._services.values()}
        gone = [current[key] for key in sorted(set(current) - services)]
        new = []
        for name, type_name in sorted(services - set(current)):
            try:
                srv = self.context.types.service(type_name)
            except Exception:
                self._schema(type_name)  # says once that it is unknown
                continue
            request, response = self._schema(srv.request), self._schema(srv.response)
            if request is None or response is None:
                continue
            service_id = self._service_ids.setdefault((name, type_name), next(self._ids))
            service = p.ServiceChannel(service_id, name, type_name, srv.request, request,
                                       srv.response, response)
            self._services[service_id] = service
            new.append(service)
        for service_id in gone:
            service = self._services.pop(service_id)
            client = self._clients.pop((service.name, service.type), None)
            if client is not None:  # leave the graph with the server (its calls fail)
                self.node.destroy_client(client)
        if gone:
            self._broadcast(p.unadvertise_services(gone))
        if new:
            self._broadcast(p.advertise_services(new))

    async def _send_time(self) -> None:
        """Time ops while the clock is virtual, so the viewer's clock follows the run."""
        while True:
            now = self._now_ns()
            if self.playback is not None:  # the end reached, say, told unasked
                state = self.playback.state()
                if state.status != self._last_status and self._viewers:
                    self._broadcast_state(state, False, "")
            for viewer in self._viewers:
                if viewer.last_time != now:  # a new viewer gets the time it joined at
                    viewer.last_time = now
                    self._dropped += viewer.send_data(p.time_op(now))
            await asyncio.sleep(self.config.time_period)

    # -- services ----------------------------------------------------------------------------

    def _client(self, name: str, type_name: str) -> Client:
        client = self._clients.get((name, type_name))
        if client is None:
            client = self.node.create_client(type_name, name)
            self._clients[(name, type_name)] = client
        return client

    async def _call(self, client: Client, request: Any) -> Any:
        future: Future[Any] = client.call_async(request, timeout=self.config.call_timeout)
        return await asyncio.wait_for(asyncio.wrap_future(future), self.config.call_timeout + 1)

    async def _call_service(self, viewer: _Viewer, op: p.ServiceCallRequest) -> None:
        service = self._services.get(op.service_id)
        if service is None:
            viewer.send(p.service_call_failure(op.service_id, op.call_id,
                                               f"service {op.service_id} is not advertised"))
            return
        if op.encoding != p.ENCODING:
            viewer.send(p.service_call_failure(op.service_id, op.call_id,
                                               f"encoding {p.echo(op.encoding)} is not supported "
                                               f"(only {p.ENCODING!r})"))
            return
        try:
            client = self._client(service.name, service.type)
            types = self.context.types
            request = types.deserialize(op.payload, client.srv.request)
            response = await self._call(client, request)
            payload = types.serialize(response, client.srv.response)
        except (Exception, asyncio.CancelledError) as exc:  # cancelled: its server left
            reason = str(exc) or type(exc).__name__
            viewer.send(p.service_call_failure(op.service_id, op.call_id, reason))
            return
        viewer.send(p.service_call_response(op.service_id, op.call_id, p.ENCODING, payload))

    # -- parameters --------------------------------------------------------------------------

    async def _has_parameters(self, node: str) -> bool:
        """Whether ``node`` is in the graph with parameter services; a node not seen yet is
        looked for once more (at most ten looks a second)."""
        if node not in self._parameter_nodes and time.monotonic() - self._graph_seen > 0.1:
            await self._look_at_graph()
        return node in self._parameter_nodes

    async def _parameter_call(self, node: str, service: str, **fields: Any) -> Any:
        """Call one of ``node``'s parameter services; only a node the graph has: a client
        naming nodes that do not exist must not make the server a service client for each
        (they would stay, one graph entity each, as long as the server)."""
        if not await self._has_parameters(node):
            raise p.ClientMessageError(f"no node {p.echo(node)} with parameters in the graph")
        srv = "".join(part.capitalize() for part in service.split("_"))
        client = self._client(f"{node}/{service}", f"rcl_interfaces/srv/{srv}")
        return await self._call(client, client.request(**fields))

    async def _node_parameters(self, node: str,
                               names: list[str] | None = None) -> list[p.ParameterValue]:
        """The node's parameters (all when ``names`` is None); an unknown name is left out."""
        if names is None:
            listed = await self._parameter_call(node, "list_parameters")
            names = [str(n) for n in listed.result.names]
        if not names:
            return []
        values = list((await self._parameter_call(node, "get_parameters", names=names)).values)
        if len(values) != len(names):  # one name unknown empties the answer: ask one by one
            found: list[p.ParameterValue] = []
            for name in names if len(names) > 1 else []:
                found += await self._node_parameters(node, [name])
            return found
        return [p.ParameterValue(p.parameter_name(node, n), from_parameter_value(v))
                for n, v in zip(names, values, strict=True)]

    async def _get_parameters(self, full_names: Iterable[str]) -> list[p.ParameterValue]:
        """Values of ``/node.param`` names, or of every node's parameters when none given."""
        wanted: dict[str, list[str]] = {}
        for full in full_names:
            node, name = p.split_parameter_name(full)
            wanted.setdefault(node, []).append(name)
        jobs = ({node: None for node in self._parameter_nodes} if not wanted
                else {node: names for node, names in wanted.items()})
        answers = await asyncio.gather(*(self._node_parameters(node, names)
                                         for node, names in jobs.items()),
                                       return_exceptions=True)
        found: list[p.ParameterValue] = []
        for node, answer in zip(jobs, answers, strict=True):
            if isinstance(answer, BaseException):
                _log.debug("view: parameters of %s: %s", node, answer)
            else:
                found += answer
        return found

    async def _parameter_op(self, viewer: _Viewer, op: p.ClientOp) -> None:
        if isinstance(op, p.GetParameters):
            viewer.send(p.parameter_values(await self._get_parameters(op.names),
                                           op.request_id))
        elif isinstance(op, p.SetParameters):
            await self._set_parameters(viewer, op)
        elif isinstance(op, p.SubscribeParameterUpdates):
            values = await self._get_parameters(op.names)
            for value in values:
                self._parameter_cache[value.name] = value.value
            viewer.parameters.update(v.name for v in values)  # only those that exist
        elif isinstance(op, p.UnsubscribeParameterUpdates):
            if op.names:
                viewer.parameters.difference_update(op.names)
            else:
                viewer.parameters.clear()

    async def _set_parameters(self, viewer: _Viewer, op: p.SetParameters) -> None:
        by_node: dict[str, list[p.ParameterValue]] = {}
        for param in op.parameters:
            node, name = p.split_parameter_name(param.name)
            by_node.setdefault(node, []).append(p.ParameterValue(name, param.value))
        types = self.context.types
        for node, params in by_node.items():
            try:
                answer = await self._parameter_call(node, "set_parameters", parameters=[
                    {"name": q.name, "value": to_parameter_value(types, q.value)}
                    for q in params])
            except Exception as exc:
                viewer.send(p.status(p.ERROR, f"setParameters: {p.cut(node, p.ECHO_LIMIT)}: "
                                              f"{exc or type(exc)}"))
                continue
            for param, result in zip(params, answer.results, strict=False):
                if not result.successful:
                    viewer.send(p.status(p.WARNING, f"setParameters: "
                                         f"{p.parameter_name(node, param.name)}: {result.reason}"))
        if op.request_id is not None:
            names = [q.name for q in op.parameters]
            viewer.send(p.parameter_values(await self._get_parameters(names), op.request_id))
        await self._poll_parameters()

    async def _poll_parameters(self) -> None:
        """Send each parameter-subscribed viewer the values that changed since last seen
        (foxglove_bridge polls too: ROS 2 parameters have no change stream it could use)."""
        watched = set().union(*(v.parameters for v in self._viewers))
        if not watched:
            return
        changed = [value for value in await self._get_parameters(sorted(watched))
                   if self._parameter_cache.get(value.name, _UNSEEN) != value.value]
        for value in changed:
            self._parameter_cache[value.name] = value.value
        for viewer in self._viewers:
            mine = [value for value in changed if value.name in viewer.parameters]
            if mine:
                viewer.send(p.parameter_values(mine))


#: A value no parameter has: the first value seen of a parameter counts as a change.
_UNSEEN = object()


def _port_of(server: Server) -> int:
    for sock in server.sockets:
        port: int = sock.getsockname()[1]
        return port
    raise MiddlewareError("the view server has no socket")
