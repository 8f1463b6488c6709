"""The recorder node: topics in, an MCAP bag out (what ``servolab bag record`` runs, and what
every robot's run folder records through).

It subscribes *raw* (the CDR bytes as they arrived, never decoded and re-encoded) with
unbounded queues, so a burst is recorded whole, not the last ``depth`` messages of it. Topics
that are not in the graph yet are picked up when their first publisher appears, as
``ros2 bag record`` does. The bag is flushed every ``flush_period`` seconds, so a recording cut
off by a kill loses at most that much, and closed completely on Ctrl-C, SIGTERM or an error.
Each message's receive and publish times are on the time base of the run's stamps, as
rosbag2 records them (:meth:`Recorder._writer_for`): simulated time in a simulation, the
epoch's in real time.
"""

from __future__ import annotations

import re
import time
from collections.abc import Mapping
from typing import Any

from servolab.clock import epoch_offset_ns

from .bag import BagWriter, qos_profile
from .context import Context
from .node import Node
from .qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from .subscription import Subscription
from .transport import MessageInfo


class Recorder(Node):
    """Records ``topics`` to the bag directory ``output``.

    ``types`` gives the type of a topic that may not be in the graph when recording starts
    (``{"/cmd_vel": "geometry_msgs/msg/Twist"}``); other topics take the type the graph shows.

    ``all_topics`` also records every topic a publisher appears on while recording, and
    ``regex`` every such topic whose name it matches (``re.search``, as rosbag2's
    ``std::regex_search``), as ``ros2 bag record -a`` and ``-e`` do; ``exclude`` leaves out
    those it matches. Hidden topics (a part of the name starting with ``_``) are left out
    of both, as rosbag2 leaves them out without ``--include-hidden-topics``.
    """

    def __init__(self, context: Context, output: str, topics: list[str], *,
                 types: Mapping[str, str] | None = None, name: str = "_servolab_recorder",
                 namespace: str = "/", flush_period: float = 1.0,
                 discovery_period: float = 0.2, quiet: bool = False,
                 all_topics: bool = False, regex: str | re.Pattern[str] | None = None,
                 exclude: str | re.Pattern[str] | None = None) -> None:
        super().__init__(context, name, namespace)
        #: a robot's run records dozens of topics: ``quiet`` says each at debug level only
        self._say = self.get_logger().debug if quiet else self.get_logger().info
        self.topics = [self.resolve(t) for t in topics]
        given = {self.resolve(t): context.types.check(k) for t, k in (types or {}).items()}
        self._all = all_topics
        self._regex = re.compile(regex) if isinstance(regex, str) else regex
        self._exclude = re.compile(exclude) if isinstance(exclude, str) else exclude
        self.writer = BagWriter(output, context.types)
        self._pending = {t: given.get(t) for t in self.topics}
        self.counts: dict[str, int] = dict.fromkeys(self.topics, 0)
        self._subscriptions: list[Subscription] = []
        self._discover()
        if self._pending or self.discovers:
            self._discovery = self.create_timer(discovery_period, self._discover)
        self.create_timer(flush_period, self.writer.flush)

    @property
    def discovers(self) -> bool:
        """Whether topics are found while recording (``-a`` or ``--regex``)."""
        return self._all or self._regex is not None

    def _wanted(self, topic: str) -> bool:
        """Whether ``-a`` / ``--regex`` asks for a topic a publisher has appeared on."""
        if topic in self.counts or any(p.startswith("_") for p in topic.split("/")):
            return False
        if self._exclude is not None and self._exclude.search(topic):
            return False
        return self._all or (self._regex is not None and bool(self._regex.search(topic)))

    def _discover(self) -> None:
        """Subscribe to every wanted topic whose type is now known (and, with ``-a`` or
        ``--regex``, first add the topics publishers have appeared on)."""
        if not self._pending and not self.discovers:
            return
        graph = self.context.transport.graph(0.2)
        if self.discovers:
            for e in graph:
                if e.kind == "MP" and self._wanted(e.name):
                    self._pending[e.name] = None
                    self.counts[e.name] = 0
        seen: dict[str, set[str]] = {}
        offered: dict[str, list[QoSProfile]] = {}
        for e in graph:
            if e.kind == "MP" and e.name in self._pending:
                seen.setdefault(e.name, set()).add(e.type_name)
                if e.qos is not None:  # one profile per publisher, as rosbag2 records them
                    offered.setdefault(e.name, []).append(e.qos)
        for topic, kind in list(self._pending.items()):
            if kind is None:
                kinds = seen.get(topic, set())
                if len(kinds) != 1:
                    continue  # not there yet (or ambiguous: wait for --type)
                kind = self.context.types.check(kinds.pop())
            offers = offered.get(topic, [])
            self.writer.add_topic(topic, kind, [qos_profile(
                reliable=q.reliable, transient_local=q.transient_local, keep_all=q.keep_all,
                depth=q.depth) for q in offers])
            self._subscriptions.append(self.create_subscription(
                kind, topic, self._writer_for(topic), request_for(offers), raw=True,
                with_info=True))
            del self._pending[topic]
            self._say("recording %s [%s]", topic, kind)

    def _writer_for(self, topic: str) -> Any:
        """The subscription's callback: the message's bytes with its receive and publish times
        in ns, as ``ros2 bag record`` takes them (rosbag2_transport/recorder.cpp,
        ``create_subscription``), on the time base of the run's stamps
        (:meth:`Context.ros_time <.context.Context.ros_time>`), decided per message since a
        simulation may switch between virtual and real time:

        - virtual time (rosbag2 with ``use_sim_time``: ``node->now()``): the simulated time
          when the message is taken, for both (the publisher's wall time says nothing of a
          run that goes at another pace than the wall);
        - real time (rosbag2 without it): the middleware's receive and source timestamps
          (``time.time_ns()`` readings: the system clock, ns since the epoch), carried over to
          ROS time (``time.monotonic_ns()`` + :func:`~servolab.clock.epoch_offset_ns`) by
          the two clocks' difference now: the moments stay the transport's (not when the
          recorder got round to the message) and the time base is the stamps', also when the
          system clock was set during the run."""
        context = self.context
        clock = context.clock

        def write(data: bytes, info: MessageInfo) -> None:
            if clock.virtual:
                stamp = round(context.ros_time() * 1e9)
                self.writer.write(topic, data, stamp, stamp)
            else:
                skew = time.monotonic_ns() + epoch_offset_ns() - time.time_ns()
                received = info.received_timestamp_ns + skew
                sent = info.source_timestamp_ns
                self.writer.write(topic, data, received, sent + skew if sent else received)
            self.counts[topic] += 1
        return write

    @property
    def waiting_for(self) -> list[str]:
        """Topics asked for but not yet subscribed (no publisher seen, type unknown)."""
        return sorted(self._pending)

    def destroy(self) -> None:
        """Stop recording, write what had arrived but was not written yet, and finish the bag
        (summary, index, metadata.yaml)."""
        super().destroy()
        if not hasattr(self, "writer"):
            return  # its BagWriter could not be made: nothing to finish
        try:
            for subscription in self._subscriptions:
                subscription.drain()
        finally:
            self.writer.close()


def request_for(offers: list[QoSProfile]) -> QoSProfile:
    """The subscription that hears every publisher, as rosbag2 adapts it
    (``Rosbag2QoS::adapt_request_to_offers``, rosbag2_storage/qos.cpp): KEEP_ALL, so a burst
    is kept whole; TRANSIENT_LOCAL only if every publisher offers it (then what they kept is
    recorded too); RELIABLE only if every publisher is."""
    return QoSProfile(
        history=HistoryPolicy.KEEP_ALL, depth=0,
        reliability=(ReliabilityPolicy.RELIABLE if all(q.reliable for q in offers)
                     else ReliabilityPolicy.BEST_EFFORT),
        durability=(DurabilityPolicy.TRANSIENT_LOCAL
                    if offers and all(q.transient_local for q in offers)
                    else DurabilityPolicy.VOLATILE))
