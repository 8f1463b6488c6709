"""The context: what the nodes of one process share.

It holds the transport, the message types, the clock, the executor and the parameter values
given before start-up. Nothing of this is global: a test can open two contexts side by side
(two "processes" on one Zenoh network), and closing a context releases all it opened.

The clock is the one source of time for every node of the context: :meth:`Context.ros_time`
(and :meth:`~servolab.middleware.node.Node.stamp`, which every stamp goes through) turns its
readings into ROS time, the epoch's seconds on a wall clock and simulated seconds on a
virtual one (:mod:`servolab.clock`).
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from contextlib import contextmanager
from types import TracebackType
from typing import TYPE_CHECKING, Any

from servolab.clock import Clock, WallClock
from servolab.signals import on_stop_signals

from .errors import TransportError
from .executor import Executor
from .heap import keep_freed_memory
from .local import LocalTransport
from .malformed import MalformedMessages
from .messages import MessageTypes
from .parameters import ParameterOverrides
from .transport import Transport, TransportOptions

if TYPE_CHECKING:
    from .node import Node


def open_transport(options: TransportOptions, types: MessageTypes) -> Transport:
    """The transport the options name: ``local``, ``zenoh``, ``dds`` or ``ros2``."""
    if options.kind == "local":
        if options.listen or options.connect:
            raise TransportError("--listen and --connect need --transport zenoh or dds")
        return LocalTransport(types)
    if options.kind == "zenoh":
        from .zenoh_transport import ZenohTransport  # zenoh loads only when asked for
        return ZenohTransport(types, options)
    if options.kind == "dds":
        from .dds_transport import DdsTransport  # cyclonedds loads only when asked for
        return DdsTransport(types, options)
    if options.kind == "ros2":
        from .ros2_transport import Ros2Transport  # an installed ROS 2's rclpy, when asked for
        return Ros2Transport(types, options)
    raise TransportError(f"unknown transport {options.kind!r} (local, zenoh, dds or ros2)")


class Context:
    """See the module docstring. Use as a context manager, or call :meth:`close`."""

    def __init__(self, transport: Transport, *, clock: Clock | None = None,
                 parameter_overrides: ParameterOverrides | None = None) -> None:
        keep_freed_memory()  # big messages reuse the heap's memory (servolab.middleware.heap)
        self.transport = transport
        self.types = transport.types
        self.clock: Clock = clock or WallClock()
        self.executor = Executor(self.clock)
        self.parameter_overrides = parameter_overrides or ParameterOverrides()
        self.nodes: list[Node] = []
        self._node_ids = itertools.count()
        self._closed = False
        #: the stop signal that shut this context down, if one did (:meth:`stop_on_signals`)
        self.stopped_by: int | None = None
        #: messages and requests from outside that did not deserialize, per publisher
        self.malformed = MalformedMessages()

    @classmethod
    def open(cls, options: TransportOptions | None = None, *, types: MessageTypes | None = None,
             clock: Clock | None = None,
             parameter_overrides: ParameterOverrides | None = None) -> Context:
        keep_freed_memory()  # first: a bad SERVOLAB_KEEP_FREED_MB is said before joining
        types = types or MessageTypes()
        transport = open_transport(options or TransportOptions(), types)
        return cls(transport, clock=clock, parameter_overrides=parameter_overrides)

    def ros_time(self, t: float | None = None) -> float:
        """ROS time in seconds of the clock reading ``t`` (default: now), what a message's
        ``header.stamp`` and a bag's receive times carry: as rclpy's ``ROSClock`` gives it,
        the system time (seconds since the epoch) when the clock is a wall clock
        (``use_sim_time`` false), the simulated time when it is virtual (``use_sim_time``
        true, the time a virtual run publishes on ``/clock``). Durations and timers keep the
        clock's own reading, :meth:`Node.now <servolab.middleware.node.Node.now>`."""
        return self.clock.ros_time(t)

    def next_node_id(self) -> int:
        return next(self._node_ids)

    def add_node(self, node: Node) -> None:
        self.nodes.append(node)

    def remove_node(self, node: Node) -> None:
        if node in self.nodes:
            self.nodes.remove(node)

    # -- running -----------------------------------------------------------------------------

    @property
    def closed(self) -> bool:
        return self._closed

    def ok(self) -> bool:
        return not self._closed and not self.executor.is_shutdown

    def spin(self) -> None:
        """Run callbacks until :meth:`shutdown` or Ctrl-C (which shuts down cleanly)."""
        with self.stop_on_signals():
            self.executor.spin()

    def spin_once(self, timeout: float | None = None) -> bool:
        return self.executor.spin_once(timeout)

    def spin_until(self, done: Any, timeout: float | None = None) -> bool:
        return self.executor.spin_until(done, timeout)

    def spin_for(self, seconds: float) -> None:
        self.executor.spin_for(seconds)

    def shutdown(self) -> None:
        self.executor.shutdown()

    @contextmanager
    def stop_on_signals(self) -> Iterator[None]:
        """Turn SIGINT, SIGTERM and SIGHUP into a clean :meth:`shutdown` while inside (main
        thread only; elsewhere it changes nothing); :attr:`stopped_by` keeps the first
        signal's number, so a command can exit with 128 + it."""
        def stop(signum: int, frame: object) -> None:
            if self.stopped_by is None:
                self.stopped_by = signum
            self.shutdown()

        with on_stop_signals(stop):
            yield

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            for node in list(reversed(self.nodes)):
                node.destroy()
            self.executor.shutdown()  # raises what stopped spin_in_thread, if not yet raised
        finally:
            self.transport.close()

    def __enter__(self) -> Context:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
