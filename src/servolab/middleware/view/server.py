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
from websockets.typing import Subprotocol

from ..errors import MiddlewareError
from ..node import Node
from ..parameters import from_parameter_value, to_parameter_value
from ..qos import DurabilityPolicy, QoSProfile, adapted_policies
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
    call_timeout: float = 5.0         # s a service or parameter call may take
    include_hidden: bool = False      # also show nodes, topics, services named _...
    start_timeout: float = 10.0       # s to wait for the socket to listen
    close_timeout: float = 1.0        # s a viewer that reads nothing may hold up close()


@dataclass(eq=False)
class _Viewer:
    """One connected client: its queues, its subscriptions, its parameter subscriptions."""

    ws: ServerConnection
    send_queue: int
    control: deque[str | bytes] = field(default_factory=deque)
    data: deque[bytes] = field(default_factory=deque)
    wake: asyncio.Event = field(default_factory=asyncio.Event)
    subscriptions: dict[int, int] = field(default_factory=dict)  # subscription id -> channel
    parameters: set[str] = field(default_factory=set)
    dropped: int = 0
    last_time: int = -1               # the last time op's value it was sent

    def send(self, frame: str | bytes) -> None:
        """A frame that must arrive (advertisements, answers): never dropped."""
        self.control.append(frame)
        self.wake.set()

    def send_data(self, frame: bytes) -> bool:
        """A data frame; False if the queue was full and the oldest one was dropped."""
        dropped = len(self.data) >= self.send_queue
        if dropped:
            self.data.popleft()
            self.dropped += 1
        self.data.append(frame)
        self.wake.set()
        return not dropped


@dataclass(eq=False)
class _TopicFeed:
    """The one servolab subscription behind a channel, shared by every viewer of it."""

    channel_id: int
    subscription: Subscription | None = None
    receivers: dict[_Viewer, int] = field(default_factory=dict)  # viewer -> subscription id
    #: a latched topic's last messages (stamp, CDR), up to its depth: the subscription's
    #: TRANSIENT_LOCAL replay reaches the first viewer only, a later one gets them from here
    kept: deque[tuple[int, bytes]] | None = None


def subscription_qos(offers: Iterable[QoSProfile | None]) -> QoSProfile:
    """The QoS to subscribe with, adapted to the publishers as ``ros2 topic echo`` adapts it:
    RELIABLE if every publisher is, else BEST_EFFORT; TRANSIENT_LOCAL if every publisher is, so
    a latched ``/robot_description`` or map reaches a viewer that connects late."""
    offers = list(offers)
    reliability, durability = adapted_policies(offers)
    latched = durability == DurabilityPolicy.TRANSIENT_LOCAL
    depth = max([10, *(q.depth for q in offers if q is not None and latched)])
    return QoSProfile(depth=depth, reliability=reliability, durability=durability)


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
        self.node = Node(context, self.config.node_name)
        self.session_id = str(time.time_ns())
        self._virtual = bool(context.clock.virtual)
        self._closed = False
        self._ids = itertools.count(1)
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

    # -- what a caller may read --------------------------------------------------------------

    @property
    def port(self) -> int:
        """The TCP port it listens on (the one picked when the config said 0)."""
        return self._port

    @property
    def url(self) -> str:
        return f"ws://{self.config.host}:{self._port}"

    @property
    def dropped(self) -> int:
        """Data frames dropped because a viewer fell behind (all viewers, ever)."""
        return self._dropped

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
                         # no permessage-deflate: a camera frame compressed per viewer
                         # costs the robot's process more than loopback saves
                         compression=None, max_size=64 * 2**20,
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

    async def _handle(self, ws: ServerConnection) -> None:
        viewer = _Viewer(ws, self.config.send_queue)
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
        writer = asyncio.get_running_loop().create_task(self._write(viewer))
        try:
            async for message in ws:
                self._on_message(viewer, message)
        except ConnectionClosed:
            pass
        finally:
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
            while True:
                await viewer.wake.wait()
                viewer.wake.clear()
                while viewer.control or viewer.data:
                    frame = viewer.control.popleft() if viewer.control else viewer.data.popleft()
                    await viewer.ws.send(frame)

    def _on_message(self, viewer: _Viewer, message: str | bytes) -> None:
        """Act on one client message; a bad one earns a status error, never a crash."""
        try:
            op = p.parse_text(message) if isinstance(message, str) else p.parse_binary(message)
            self._dispatch(viewer, op)
        except p.ClientMessageError as exc:
            viewer.send(p.status(p.ERROR, str(exc)))
        except Exception as exc:
            _log.exception("view: a client message failed")
            viewer.send(p.status(p.ERROR, f"{type(exc).__name__}: {exc}"))

    def _dispatch(self, viewer: _Viewer, op: p.ClientOp) -> None:
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
            self._spawn(self._call_service(viewer, op))
        elif isinstance(op, p.PlaybackControlRequest):
            self._spawn(self._guarded(viewer, self._playback_control(op)))
        else:
            self._spawn(self._guarded(viewer, self._parameter_op(viewer, op)))

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
            qos = subscription_qos(self._offers.get(channel.topic, []))
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
            if not viewer.send_data(p.message_data(subscription_id, stamp, cdr)):
                self._dropped += 1

    def _broadcast(self, frame: str | bytes) -> None:
        for viewer in self._viewers:
            viewer.send(frame)

    # -- the graph ---------------------------------------------------------------------------

    async def _watch_graph(self) -> None:
        loop = asyncio.get_running_loop()
        while True:
            try:
                endpoints = await loop.run_in_executor(None, self.context.transport.graph,
                                                       self.config.graph_timeout)
                self._update_graph(endpoints)
            except Exception:
                _log.debug("view: looking at the graph failed", exc_info=True)
            await asyncio.sleep(self.config.graph_period)

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
                    if not viewer.send_data(p.time_op(now)):
                        self._dropped += 1
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
                                               f"encoding {op.encoding!r} is not supported "
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

    async def _parameter_call(self, node: str, service: str, **fields: Any) -> Any:
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
            viewer.parameters.update(op.names or [v.name for v in values])
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
                viewer.send(p.status(p.ERROR, f"setParameters: {node}: {exc or type(exc)}"))
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
