"""``servolab view BAG``: a recorded run played to Foxglove or Lichtblick as the live run was
shown.

:class:`BagPlayer` opens an in-process :class:`~servolab.middleware.context.Context` of its
own on a :class:`PlaybackClock` (a :class:`~servolab.clock.VirtualClock` that may also jump
back) started at the bag's first log time, with one publisher per recorded topic, of the
recorded type and with the QoS its publishers offered (:func:`playback_qos`: a latched
``/robot_description``, ``/map`` or ``/tf_static`` stays latched, so a viewer that subscribes
later still gets it). It plays the messages in log-time order, and moves the clock to each
message's log time before publishing it: a :class:`~.server.ViewServer` on the player's context
then stamps every message with its recorded time and its time ops follow the recording, as
they followed the live run.

The player is its context's clock owner *and* its executor's only spinner. After each
message it runs the callbacks the message caused (a viewer's subscription, a test's) before
time moves on, so a callback reads the message's own log time from the context's clock.
Between messages it keeps running the callbacks other threads bring (a viewer subscribing, a
parameter request). Nobody else may spin the context: an executor spun with a timeout on a
virtual clock moves the clock itself (:mod:`servolab.middleware.executor`), which would run
the recording ahead of its messages. For the same reason, nodes added to the context should
have no timers.

Pacing is to the wall clock: the wall time between two messages is their recorded gap divided
by the rate. The wait is on a condition with a timeout, so :meth:`BagPlayer.pause`,
:meth:`~BagPlayer.seek`, :meth:`~BagPlayer.set_rate` and :meth:`~BagPlayer.stop` interrupt it
at once; each is thread-safe, for the view server's thread to call (Foxglove's playback
controls). Their meaning follows the Foxglove SDK's player (``ws-playback-control-mcap``):
``resume`` at the end does nothing, a seek from the end leaves the player paused there.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import threading
import time
from collections import deque
from collections.abc import Callable, Generator, Mapping, Sequence
from dataclasses import dataclass
from types import TracebackType
from typing import Any, NamedTuple

from servolab.clock import VirtualClock

from ..bag import BagInfo, BagMessage, BagReader
from ..bag.reader import _offered_qos
from ..context import Context
from ..errors import BagError, MiddlewareError
from ..messages import MessageTypes
from ..node import Node
from ..publisher import Publisher
from ..qos import (
    KEEP_ALL_HISTORY,
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
)
from ..transport import TransportOptions
from .defaults import DEFAULT_HOST, DEFAULT_PORT
from .pacing import MAX_LAG

_log = logging.getLogger("servolab.view.player")

PLAYING, PAUSED, ENDED = "playing", "paused", "ended"

#: s between two looks at callbacks other threads bring while the player waits (and at
#: whether its context was shut down): the latency of a viewer's subscription while paused.
POLL_PERIOD = 0.01
#: Topics latched by convention, taken as latched when the bag recorded no QoS for them (a
#: topic named with ``--type`` before its publisher appeared): (depth kept for late viewers).
LATCHED_BY_NAME: Mapping[str, int] = {"/robot_description": 1, "/map": 1, "/tf_static": 100}
#: The player's node, named as rosbag2's player names its own (not hidden, as it plays for all).
NODE_NAME = "servolab_player"


class PlayerState(NamedTuple):
    """What :meth:`BagPlayer.state` says: ``status`` is ``"playing"``, ``"paused"`` or
    ``"ended"``; times are ROS time in ns (the recording's log times)."""

    status: str
    current_ns: int
    start_ns: int
    end_ns: int
    rate: float


class PlaybackClock(VirtualClock):
    """A :class:`~servolab.clock.VirtualClock` that its owner may also move back
    (:meth:`jump_to`: a seek, a loop), and that knows its time in whole nanoseconds
    (:meth:`ros_time_ns`), as a bag does: a float of seconds since the epoch is only good to
    a quarter of a microsecond."""

    def __init__(self, start_ns: int) -> None:
        super().__init__(start_ns / 1e9)
        self._ns = int(start_ns)

    def ros_time_ns(self) -> int:
        """The exact log time the clock was last moved to (ns), while nothing else moved it."""
        return self._ns if self._ns / 1e9 == self.now() else round(self.now() * 1e9)

    def advance_to_ns(self, t_ns: int) -> None:
        """Move forward to ``t_ns`` (no-op if it is not ahead), keeping the exact ns."""
        if t_ns > self._ns:
            self._ns = int(t_ns)
        self.advance_to(t_ns / 1e9)

    def jump_to(self, t_ns: int) -> None:
        """Move to ``t_ns``, also back in time; callbacks of :meth:`call_every` start their
        periods again from there."""
        t = t_ns / 1e9
        self._ns = int(t_ns)
        if t >= self.now():
            self.advance_to(t)
            return
        self._t = t
        ticks = self._ticks
        with ticks._lock:
            for tick in ticks._ticks:
                tick.start = t
                tick.due = t + tick.period * (1 - 1e-9)
            ticks.next_due = min((tick.due for tick in ticks._ticks), default=math.inf)


# -- QoS as recorded -------------------------------------------------------------------------


#: rmw's numbers for the policies, as version-8 metadata writes them (1 and 2 only: the rest
#: are system_default, unknown or best_available, which leave servolab's default).
_POLICY_NUMBERS = {
    "history": {1: "keep_last", 2: "keep_all"},
    "reliability": {1: "reliable", 2: "best_effort"},
    "durability": {1: "transient_local", 2: "volatile"},
}


def _policy(profile: Mapping[str, Any], key: str) -> str:
    value = profile.get(key)
    if isinstance(value, int) and not isinstance(value, bool):
        return _POLICY_NUMBERS[key].get(value, "")
    return value.lower() if isinstance(value, str) else ""


def profile_of(recorded: Mapping[str, Any]) -> QoSProfile:
    """One offered profile as rosbag2 writes it (version 9: policies by name; version 8's
    numbers are read too) as a :class:`~.qos.QoSProfile`; what servolab does not honour is
    left out, and
    ``system_default`` or an unknown policy is servolab's default."""
    keep_all = _policy(recorded, "history") == "keep_all"
    depth = recorded.get("depth")
    depth = depth if isinstance(depth, int) and not isinstance(depth, bool) and depth > 0 else 10
    return QoSProfile(
        history=HistoryPolicy.KEEP_ALL if keep_all else HistoryPolicy.KEEP_LAST,
        depth=0 if keep_all else depth,
        reliability=(ReliabilityPolicy.BEST_EFFORT
                     if _policy(recorded, "reliability") == "best_effort"
                     else ReliabilityPolicy.RELIABLE),
        durability=(DurabilityPolicy.TRANSIENT_LOCAL
                    if _policy(recorded, "durability") == "transient_local"
                    else DurabilityPolicy.VOLATILE))


def playback_qos(topic: str, offered: Sequence[Mapping[str, Any]]) -> QoSProfile:
    """The profile to play a topic with, from the profiles its publishers offered when it was
    recorded (one per publisher), as ``ros2 bag play`` offers them again:

    - TRANSIENT_LOCAL if every publisher offered it, keeping as many messages as they kept
      together (three static transform broadcasters of depth 1 each: the last three
      ``/tf_static`` messages), so a viewer that subscribes later gets what a late
      subscriber of the live run got;
    - RELIABLE if every publisher was, else BEST_EFFORT;
    - no recorded profile: RELIABLE, VOLATILE, except for the topics latched by convention
      (:data:`LATCHED_BY_NAME`)."""
    profiles = [profile_of(p) for p in offered]
    if not profiles:
        kept = LATCHED_BY_NAME.get(topic)
        if kept is None:
            return QoSProfile()
        return QoSProfile(depth=kept, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    reliable = all(p.reliable for p in profiles)
    latched = all(p.transient_local for p in profiles)
    if latched:
        depth = min(KEEP_ALL_HISTORY, sum(p.history_depth for p in profiles))
    else:
        depth = max(p.depth if not p.keep_all else 10 for p in profiles)
    return QoSProfile(depth=depth,
                      reliability=(ReliabilityPolicy.RELIABLE if reliable
                                   else ReliabilityPolicy.BEST_EFFORT),
                      durability=(DurabilityPolicy.TRANSIENT_LOCAL if latched
                                  else DurabilityPolicy.VOLATILE))


def recorded_offers(reader: BagReader) -> dict[str, list[dict[str, Any]]]:
    """Each topic's offered QoS profiles as the bag recorded them (channel metadata
    ``offered_qos_profiles``, version 8's numbers read as version 9's names)."""
    # BagReader has no public accessor for a channel's metadata yet: read its index.
    offers: dict[str, list[dict[str, Any]]] = {}
    for channel in reader._index.channels.values():
        offers.setdefault(channel.topic, []).extend(_offered_qos(channel))
    return offers


# -- the player ------------------------------------------------------------------------------


@dataclass
class _Topic:
    """One recorded (topic, type): its publisher and the QoS it plays with."""

    name: str
    type: str
    qos: QoSProfile
    publisher: Publisher


class BagPlayer:
    """Plays the bag at ``path`` into a context of its own (:attr:`context`); see the module
    docstring. Playing from construction, or paused at the start with ``paused=True`` (add
    subscribers or a view server first, then :meth:`resume`). :meth:`close` (or leaving a
    ``with`` block) stops it and closes the context.

    ``rate`` is recorded seconds per wall second (0 or infinity: as fast as possible);
    ``loop`` starts again at the beginning at the end, for ever. A bag that cannot be read
    raises :class:`~servolab.middleware.errors.BagError` naming it."""

    def __init__(self, path: str | os.PathLike[str], *, rate: float = 1.0, loop: bool = False,
                 paused: bool = False, types: MessageTypes | None = None,
                 node_name: str = NODE_NAME, poll_period: float = POLL_PERIOD,
                 wall: Callable[[], float] = time.monotonic) -> None:
        self.path = os.fspath(path)
        self._check_rate(rate)
        self.reader = BagReader(path, types or MessageTypes())
        self.info: BagInfo = self.reader.info()
        if self.info.message_count == 0:
            raise BagError(f"bag {self.path} holds no messages: nothing to play")
        self.start_ns, self.end_ns = self.info.start_ns, self.info.end_ns
        self.clock = PlaybackClock(self.start_ns)
        self.context = Context.open(TransportOptions("local"), types=self.reader.types,
                                    clock=self.clock)
        self._poll = poll_period
        self._wall = wall
        self._cond = threading.Condition(threading.RLock())
        # State below is shared: read and written under _cond.
        self._status = PAUSED if paused else PLAYING
        self._rate = float(rate)
        self._loop = bool(loop)
        self._current_ns = self.start_ns
        self._seek_to: int | None = None
        self._anchor: tuple[int, float] | None = None   # (log time ns, wall s) of pacing
        self._stopping = False
        self._publishing = False
        self._finished = False
        self._turns = 0
        #: messages played (republished latched messages not counted)
        self.played = 0
        #: times playback started again at the beginning (``loop``)
        self.loops = 0
        #: topics left out, with why (a type this process cannot publish)
        self.skipped: dict[str, str] = {}
        #: what stopped the player thread, if it failed
        self.error: BaseException | None = None
        try:
            self.node = Node(self.context, node_name)
            offers = recorded_offers(self.reader)
            self._topics: dict[tuple[str, str], _Topic] = {}
            for topic in self.info.topics:
                qos = playback_qos(topic.name, offers.get(topic.name, []))
                try:
                    publisher = self.node.create_publisher(topic.type, topic.name, qos)
                except MiddlewareError as exc:
                    self.skipped[topic.name] = str(exc)
                    continue
                self._topics[(topic.name, topic.type)] = _Topic(topic.name, topic.type, qos,
                                                                publisher)
        except BaseException:
            self.context.close()
            raise
        self._thread = threading.Thread(target=self._run, name="servolab-bag-player",
                                        daemon=True)
        self._thread.start()

    # -- what a caller may read --------------------------------------------------------------

    @property
    def publishers(self) -> dict[str, Publisher]:
        """The publisher of each topic played (by topic name)."""
        return {t.name: t.publisher for t in self._topics.values()}

    @property
    def latched_topics(self) -> list[str]:
        """Topics played TRANSIENT_LOCAL, whose last messages reach late subscribers."""
        return sorted({t.name for t in self._topics.values() if t.qos.transient_local})

    @property
    def loop(self) -> bool:
        return self._loop

    @loop.setter
    def loop(self, value: bool) -> None:
        with self._cond:
            self._loop = bool(value)
            self._cond.notify_all()

    def state(self) -> PlayerState:
        """(status, current time ns, start ns, end ns, rate), read at once."""
        with self._cond:
            return PlayerState(self._status, self._current_ns, self.start_ns, self.end_ns,
                               self._rate)

    @property
    def finished(self) -> bool:
        """Whether the player thread has stopped (:meth:`stop`, or its context shut down)."""
        return self._finished

    # -- controls (any thread) ---------------------------------------------------------------

    def pause(self) -> None:
        """Stop playing where it is. Once this returns no message is played until
        :meth:`resume` (a message being played when it was called has been played, with the
        callbacks it caused). At the end it does nothing."""
        with self._cond:
            if self._status == PLAYING:
                self._status = PAUSED
                self._anchor = None
                self._cond.notify_all()
            if threading.current_thread() is not self._thread:  # a callback: it is done then
                self._cond.wait_for(lambda: not self._publishing)

    def resume(self) -> None:
        """Play on from where it was paused (or seeked to); at the end it does nothing (seek
        first)."""
        with self._cond:
            if self._status == PAUSED:
                self._status = PLAYING
                self._anchor = None
                self._cond.notify_all()

    def seek(self, t_ns: int) -> None:
        """Jump to ``t_ns`` (ns of ROS time, clamped to the bag's range): the next message
        played is the first at or after it, the clock is moved there (also back), and each
        latched topic's last messages before it are published again, so a 3D panel shows the
        state at ``t_ns``. Playing or paused stays as it was; at the end, paused. Done on the
        player's thread: :meth:`sync` waits for it."""
        t_ns = max(self.start_ns, min(self.end_ns, int(t_ns)))
        with self._cond:
            self._seek_to = t_ns
            self._current_ns = t_ns
            self._anchor = None
            if self._status == ENDED and not self._finished:
                self._status = PAUSED
            self._cond.notify_all()

    def set_rate(self, rate: float) -> None:
        """Recorded seconds per wall second from now on (0 or infinity: as fast as possible)."""
        self._check_rate(rate)
        with self._cond:
            self._rate = float(rate)
            self._anchor = None
            self._cond.notify_all()

    def stop(self) -> None:
        """Stop playing for good (the state says ``ended``) and wait for the player's thread;
        a second call does nothing."""
        with self._cond:
            self._stopping = True
            self._cond.notify_all()
        if threading.current_thread() is not self._thread:
            self._thread.join()

    def close(self) -> None:
        """:meth:`stop`, then close the context (close a view server on it first)."""
        self.stop()
        self.context.close()

    def __enter__(self) -> BagPlayer:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    # -- waiting (any thread) ----------------------------------------------------------------

    def wait(self, timeout: float | None = None) -> bool:
        """Wait up to ``timeout`` s (None: for ever) until the end is reached (or the player
        stopped); whether it was."""
        with self._cond:
            return self._cond.wait_for(lambda: self._status == ENDED or self._finished, timeout)

    def sync(self, timeout: float = 10.0) -> bool:
        """Wait until the player's thread has gone round its loop after this call (a seek
        asked for before it is then done, a pause taken notice of); whether it did in
        ``timeout`` s. From the player's own thread (a callback) it returns False at once."""
        if threading.current_thread() is self._thread:
            return False
        with self._cond:
            target = self._turns + 2
            return self._cond.wait_for(lambda: self._turns >= target or self._finished,
                                       timeout) and not self._finished

    # -- the player's thread -----------------------------------------------------------------

    @staticmethod
    def _check_rate(rate: float) -> None:
        if not isinstance(rate, int | float) or isinstance(rate, bool) or math.isnan(rate) \
                or rate < 0:
            raise BagError(f"playback rate must be zero (as fast as possible), positive or "
                           f"infinite, not {rate!r}")

    def _run(self) -> None:
        try:
            with self.context.executor.spinning():
                self._play()
        except BaseException as exc:
            self.error = exc
            _log.exception("bag player stopped")
        finally:
            with self._cond:
                self._finished = True
                self._status = ENDED
                self._cond.notify_all()

    def _go_on(self) -> bool:
        """Whether to keep playing (under _cond): not stopped, the context not shut down."""
        return not self._stopping and self.context.ok()

    def _turn(self) -> None:
        """One more time round (under _cond), for :meth:`sync`."""
        self._turns += 1
        self._cond.notify_all()

    def _drain(self) -> None:
        """Run the callbacks waiting in the context's executor (never moves the clock:
        ``spin_once(0)`` only runs what is ready or due)."""
        spin_once = self.context.executor.spin_once
        for _ in range(100_000):
            if not spin_once(0):
                return

    def _rest(self, timeout: float | None = None) -> None:
        """Wait up to ``timeout`` s (default: one poll period), or until a control wakes it
        (under _cond), then run the callbacks other threads brought meanwhile."""
        self._cond.wait(self._poll if timeout is None else timeout)
        self._turn()
        self._cond.release()
        try:
            self._drain()
        finally:
            self._cond.acquire()

    def _play(self) -> None:
        messages = self.reader.messages()
        try:
            pending = next(messages, None)
            with self._cond:
                while self._go_on():
                    seek = self._seek_to
                    if seek is not None:
                        self._seek_to = None
                        self._cond.release()
                        try:
                            messages.close()
                            messages, pending = self._from(seek)
                        finally:
                            self._cond.acquire()
                        if self._seek_to is None:  # no newer seek came meanwhile
                            self._current_ns = seek
                        continue
                    self._turn()  # after a seek: sync() returns once it is done
                    if self._status != PLAYING:
                        self._rest()
                        continue
                    if pending is None:
                        if self._loop:
                            self.loops += 1
                            self._seek_to = self._current_ns = self.start_ns
                            self._anchor = None
                            continue
                        self._status = ENDED
                        self._current_ns = self.end_ns
                        self._cond.notify_all()
                        continue
                    delay = self._delay(pending.log_time_ns)
                    if delay > 0:
                        self._rest(min(delay, self._poll))
                        continue
                    # Played outside _cond (controls are never held up by a message), but
                    # flagged: pause() returns only once the message and its callbacks are done.
                    self._publishing = True
                    self._cond.release()
                    try:
                        self._publish(pending)
                    finally:
                        self._cond.acquire()
                        self._publishing = False
                        self._cond.notify_all()
                    self.played += 1
                    if self._seek_to is None:  # a seek made while it played has moved on
                        self._current_ns = pending.log_time_ns
                    pending = next(messages, None)
        finally:
            messages.close()

    def _delay(self, t_ns: int) -> float:
        """Wall seconds until the message at ``t_ns`` is due (under _cond, playing): its
        recorded gap from the pacing anchor over the rate; 0 or less: now. Meanwhile the
        clock follows the wall (times the rate), short of the message's time, so a viewer's
        time moves between sparse messages as it did in the run."""
        rate = self._rate
        if rate == 0 or math.isinf(rate):
            return 0.0
        now = self._wall()
        if self._anchor is None:
            self._anchor = (self._current_ns, now)
        origin_ns, origin_wall = self._anchor
        left = origin_wall + (t_ns - origin_ns) / 1e9 / rate - now
        if left < -MAX_LAG:  # fell behind: go on from here rather than burst to catch up
            self._anchor = (t_ns, now)
        elif left > 0:  # time passes between messages too, as it did in the run
            paced_ns = origin_ns + round((now - origin_wall) * rate * 1e9)
            if self._current_ns < paced_ns < t_ns:
                self.clock.advance_to_ns(paced_ns)
                self._current_ns = paced_ns
        return left

    def _publish(self, message: BagMessage) -> None:
        """Move the clock to the message's log time, publish it, run what it caused."""
        topic = self._topics.get((message.topic, message.type))
        if topic is None:
            return  # a topic skipped at start
        self.clock.advance_to_ns(message.log_time_ns)
        topic.publisher.publish_serialized(message.data)
        self._drain()

    def _from(self, t_ns: int) -> tuple[Generator[BagMessage, None, None], BagMessage | None]:
        """Seek (on the player's thread, not under _cond): the latched topics' last messages
        before ``t_ns`` published again by fresh publishers (whose history then holds only
        those), the clock moved there, and the messages from ``t_ns`` on."""
        latched = [t for t in self._topics.values() if t.qos.transient_local]
        history: dict[tuple[str, str], deque[BagMessage]] = {
            (t.name, t.type): deque(maxlen=t.qos.history_depth) for t in latched}
        if latched:
            with contextlib.closing(self.reader.messages({t.name for t in latched})) as found:
                for message in found:
                    if message.log_time_ns >= t_ns:
                        break
                    kept = history.get((message.topic, message.type))
                    if kept is not None:
                        kept.append(message)
        for topic in latched:  # a fresh history: what was played after t_ns is forgotten
            self.node.destroy_publisher(topic.publisher)
            topic.publisher = self.node.create_publisher(topic.type, topic.name, topic.qos)
        self.clock.jump_to(t_ns)
        republished = sorted((m for kept in history.values() for m in kept),
                             key=lambda m: m.log_time_ns)
        for message in republished:
            self._topics[(message.topic, message.type)].publisher.publish_serialized(
                message.data)
        self._drain()
        messages = self.reader.messages()
        pending = next(messages, None)
        while pending is not None and pending.log_time_ns < t_ns:
            pending = next(messages, None)
        return messages, pending


# -- servolab view BAG -----------------------------------------------------------------------

#: s to wait, once a viewer is connected, for it to subscribe to a topic before playing.
SUBSCRIBE_WAIT = 2.0


def _wait(done: Callable[[], bool], ok: Callable[[], bool], timeout: float | None = None,
          step: float = 0.05) -> bool:
    """Wait (in short steps, so a stop signal is handled) until ``done()`` or not ``ok()``."""
    deadline = None if timeout is None else time.monotonic() + timeout
    pause = threading.Event()
    while not done() and ok():
        if deadline is not None and time.monotonic() >= deadline:
            break
        pause.wait(step)
    return done()


def serve_bag(path: str, *, host: str = DEFAULT_HOST, port: int = DEFAULT_PORT, rate: float = 1.0,
              loop: bool = False, say: Callable[[str], None] = print,
              wait_for_viewer: bool = True, types: MessageTypes | None = None,
              keep_serving: bool = False, allow_origins: tuple[str, ...] = (),
              read_only: bool = False, token: str | None = None) -> int:
    """Serve the bag at ``path`` to Foxglove or Lichtblick on ``ws://host:port`` as its run was
    shown live: wait for the first viewer (and up to :data:`SUBSCRIBE_WAIT` s for it to
    subscribe), play at ``rate`` to the end (for ever with ``loop``) or until SIGINT or
    SIGTERM; returns the messages played. ``allow_origins``, ``read_only`` and ``token``:
    who may connect and control, as :class:`.server.ViewConfig` has them. A bag that cannot be
    read raises
    :class:`~servolab.middleware.errors.BagError` naming it, before anything listens."""
    from .server import ViewConfig, ViewServer

    with BagPlayer(path, rate=rate, loop=loop, paused=True, types=types) as player:
        ctx = player.context
        for topic, reason in sorted(player.skipped.items()):
            say(f"not playing {topic}: {reason}")
        config = ViewConfig(host=host, port=port, allow_origins=allow_origins,
                            read_only=read_only, token=token)
        with ViewServer(ctx, config, playback=player) as view, ctx.stop_on_signals():
            info = player.info
            say(f"serving {path} ({info.message_count} message(s), {info.duration_s:.1f} s) "
                f"on {view.control_url}: open it in Foxglove or Lichtblick (Open connection > "
                "Foxglove WebSocket); Ctrl-C stops")
            for line in view.access:
                say(f"  {line}")
            if wait_for_viewer:
                say("waiting for a viewer")
                _wait(lambda: view.viewers > 0, ctx.ok)
                publishers = list(player.publishers.values())
                _wait(lambda: any(p.wait_for_subscription(0) for p in publishers), ctx.ok,
                      SUBSCRIBE_WAIT)
            if ctx.ok():
                speed = "as fast as possible" if rate == 0 or math.isinf(rate) else \
                    f"at {rate:g}x"
                say(f"playing {speed}" + (", looping (Ctrl-C stops)" if loop else ""))
                player.resume()
                _wait(lambda: player.wait(0), lambda: ctx.ok() and not player.finished)
            if keep_serving and ctx.ok():  # the app may still seek back and play again
                say("at the end: the app's playback controls seek and play again; Ctrl-C "
                    "stops")
                _wait(lambda: False, ctx.ok)
            player.stop()
        if player.error is not None:
            raise player.error
        played = player.played
    say(f"played {played} message(s)")
    return played

