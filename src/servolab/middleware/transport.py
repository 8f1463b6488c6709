"""What a node needs of a transport, so that node code never knows which one carries it.

Three transports implement this: :mod:`.local` (one process, messages passed as objects),
:mod:`.zenoh_transport` (processes and machines, CDR bytes over Zenoh in rmw_zenoh's layout)
and :mod:`.dds_transport` (the same bytes over DDS, as ROS 2's DDS middlewares lay them out).
A transport hands messages upward through each subscription's :mod:`.inbox`, filled on the
transport's thread and emptied on the executor's; services and other answers go through
callbacks that may run on any thread, which the :class:`~servolab.middleware.executor.Executor`
moves onto the thread that spins.
"""

from __future__ import annotations

import os
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

from .errors import TransportError
from .qos import QoSProfile

if TYPE_CHECKING:
    from .inbox import Inbox, Wake
    from .messages import MessageTypes, ServiceType


@dataclass(frozen=True)
class MessageInfo:
    """Where a message came from: what ROS 2 calls ``rmw_message_info_t``.

    ``source_timestamp_ns`` is the publisher's wall clock (ns since the UNIX epoch) when it
    published, ``received_timestamp_ns`` the subscriber's when it arrived: their difference is
    the transport latency across processes on one machine.
    """

    source_timestamp_ns: int
    received_timestamp_ns: int
    sequence_number: int = 0
    publisher_gid: bytes = b""


@dataclass(frozen=True, order=True)
class Endpoint:
    """One entity of the graph: a node (``kind`` NN), publisher (MP), subscription (MS),
    service server (SS) or client (SC)."""

    kind: str
    node: str                      # fully qualified node name
    name: str = ""                 # fully qualified topic or service name ("" for a node)
    type_name: str = ""            # pkg/msg/Name or pkg/srv/Name
    #: the QoS a publisher offers or a subscription requests (None where the graph has none)
    qos: QoSProfile | None = field(default=None, compare=False)


#: Node loggers are ``<prefix><fully qualified name>``: ``servolab.node/robot/talker``.
LOGGER_PREFIX = "servolab.node"


@dataclass(frozen=True)
class NodeInfo:
    """The node an entity belongs to, as the transport announces it."""

    name: str
    namespace: str = "/"
    node_id: int = 0

    @property
    def fully_qualified_name(self) -> str:
        return f"{self.namespace.rstrip('/')}/{self.name}"

    @property
    def logger_name(self) -> str:
        """The node's :mod:`logging` logger, where a transport says what concerns one of
        its entities (an incompatible QoS), as rmw's events reach rclpy's node logger."""
        return f"{LOGGER_PREFIX}{self.fully_qualified_name}"


class Closeable(Protocol):
    def close(self) -> None: ...


class Declared:
    """A graph entity's handle whose ``close()`` releases it once, however often called."""

    def __init__(self, close: Callable[[], None]) -> None:
        self._close: Callable[[], None] | None = close

    def close(self) -> None:
        close, self._close = self._close, None
        if close is not None:
            close()


def wait_for(condition: Callable[[], bool], timeout: float, pause: float = 0.005) -> bool:
    """Poll ``condition`` until it holds or ``timeout`` s pass; whether it held (for what a
    middleware tells by a count it keeps, not by a signal: a publisher's matches)."""
    end = time.monotonic() + timeout
    while True:
        if condition():
            return True
        if time.monotonic() >= end:
            return False
        time.sleep(pause)


class TransportPublisher(ABC):
    @abstractmethod
    def publish(self, msg: Any) -> None: ...

    def sender(self) -> Callable[[Any], None]:
        """What :meth:`publish` does, as one function a :class:`.Publisher` keeps: a
        transport may give one with what it needs bound in, no lookups per message."""
        return self.publish

    @abstractmethod
    def publish_serialized(self, cdr: bytes) -> None:
        """Publish a message given as its CDR bytes (bag playback): a transport that carries
        bytes sends them as they are, the in-process one decodes them once."""

    @abstractmethod
    def wait_for_subscription(self, timeout: float) -> bool:
        """Wait up to ``timeout`` s until a subscription exists that what this publisher
        publishes reaches (of its type, in this process or, over Zenoh, routed to by this
        session); whether one does. A message published after True is not lost to start-up."""

    def close(self) -> None:  # noqa: B027 - most publishers hold nothing to release
        pass


#: ``handler(request, reply)``: the transport's request; ``reply(response)`` answers it.
Handler = Callable[[Any, Callable[[Any], None]], None]


#: The ROS domains (``ROS_DOMAIN_ID``): 0..232, as DDS's port mapping allows and ROS 2
#: documents ("The ROS_DOMAIN_ID", docs.ros.org); rmw_zenoh takes the same variable.
DOMAIN_IDS = range(0, 233)


def environment_domain_id() -> int:
    """``$ROS_DOMAIN_ID`` (0 when unset or empty), as every ROS 2 program on the machine
    reads it: the one place servolab does."""
    text = os.environ.get("ROS_DOMAIN_ID", "").strip() or "0"
    if not text.isdigit() or int(text) not in DOMAIN_IDS:
        raise TransportError(f"ROS_DOMAIN_ID={text!r}: a ROS domain is a number 0..232")
    return int(text)




@dataclass
class TransportOptions:
    """How to open a transport: the CLI's ``--transport``, ``--listen``, ``--connect``."""

    kind: str = "local"                       # one of TRANSPORTS
    listen: list[str] = field(default_factory=list)
    connect: list[str] = field(default_factory=list)
    domain_id: int = 0


class Transport(ABC):
    """Carries topics and services between nodes."""

    #: True if subscriptions receive CDR bytes rather than message objects.
    carries_bytes: bool = False

    def __init__(self, types: MessageTypes) -> None:
        self.types = types

    @abstractmethod
    def advertise(self, node: NodeInfo, topic: str, type_name: str,
                  qos: QoSProfile) -> TransportPublisher:
        """A publisher with the profile's history, reliability and durability. Its
        ``publish()`` must not wait on a slow or stopped subscriber unless the QoS is
        RELIABLE + KEEP_ALL (rmw_zenoh's rule): a control loop publishes. With
        TRANSIENT_LOCAL it keeps its last ``depth`` messages for subscriptions made later."""

    @abstractmethod
    def subscribe(self, node: NodeInfo, topic: str, type_name: str, qos: QoSProfile,
                  wake: Wake, *, raw: bool = False) -> Inbox:
        """An inbox that receives the topic's messages (see :mod:`.inbox` for when ``wake``
        is called): message objects, or CDR bytes for ``raw`` subscriptions and always from a
        transport that carries bytes (the subscription deserializes them on the executor's
        thread, not the transport's). With TRANSIENT_LOCAL it first holds what
        TRANSIENT_LOCAL publishers kept, oldest first."""

    @abstractmethod
    def serve(self, node: NodeInfo, name: str, srv: ServiceType, handler: Handler) -> Closeable:
        ...

    @abstractmethod
    def call(self, name: str, srv: ServiceType, request: Any, timeout: float) -> Future[Any]:
        """Send a request; the future holds the response (a message of ``srv``'s response
        type, a class rosbags generates at run time: hence Any), or a :class:`ServiceError`
        when no server answers. The caller waits on it (spinning, if it must run the server)."""

    @abstractmethod
    def announce_node(self, node: NodeInfo) -> Closeable: ...

    @abstractmethod
    def graph(self, timeout: float = 0.5) -> list[Endpoint]:
        """Every entity the transport can see (its own process's and, over Zenoh, others')."""

    def check_reachable(self, timeout: float = 2.0) -> None:  # noqa: B027 - see below
        """Raise :class:`~servolab.middleware.errors.TransportError` (one line) if none of the
        endpoints the user named to connect to answers within ``timeout`` s, so that a graph
        tool says so instead of showing an empty graph. In-process there is nothing to reach."""

    def close(self) -> None:  # noqa: B027 - the local transport holds nothing to release
        pass

    @abstractmethod
    def declare_client(self, node: NodeInfo, name: str, srv: ServiceType) -> Closeable:
        """Show a service client of ``node`` in the graph (kind SC, as rmw_zenoh's clients
        declare their liveliness token when created) until the returned handle is closed."""
