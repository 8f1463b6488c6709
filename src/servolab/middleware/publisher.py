"""A publisher: one topic, one type, one QoS profile (rclpy's ``Publisher``)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .errors import MessageError
from .qos import QoSProfile

if TYPE_CHECKING:
    from .node import Node


class Publisher:
    """Publishes messages of one type on one topic.

    ``publish()`` never waits on a slow or stopped subscriber unless the profile is RELIABLE +
    KEEP_ALL (rmw_zenoh's rule), so a control loop can publish. The message is the publisher's
    again as soon as ``publish()`` returns: it may be changed and published again without
    changing what subscribers already received (rclpy's value semantics).
    """

    def __init__(self, node: Node, type_name: str, topic: str, qos: QoSProfile) -> None:
        self.node = node
        self.type_name = type_name
        self.topic = topic
        self.qos = qos
        self._inner = node.context.transport.advertise(node.info, topic, type_name, qos)
        self._publish = self._inner.sender()  # looked up once: a control loop's every message

    @property
    def topic_name(self) -> str:
        """rclpy's name for :attr:`topic`."""
        return self.topic

    def publish(self, msg: Any) -> None:
        if getattr(msg, "__msgtype__", None) != self.type_name:
            raise MessageError(f"{self.topic} carries {self.type_name}, not "
                               f"{getattr(msg, '__msgtype__', type(msg).__name__)}")
        self._publish(msg)

    def publish_serialized(self, cdr: bytes) -> None:
        """Publish CDR bytes of this publisher's type as they are (bag playback)."""
        self._inner.publish_serialized(cdr)

    def get_subscription_count(self) -> int:
        """Subscriptions matched to this topic and type, in this process and (over Zenoh)
        others, as the graph shows them now: what ``topic pub --wait-matching`` waits on."""
        graph = self.node.context.transport.graph(0.2)
        return sum(1 for e in graph if e.kind == "MS" and e.name == self.topic
                   and e.type_name == self.type_name)

    def wait_for_subscription(self, timeout_sec: float) -> bool:
        """Wait up to ``timeout_sec`` s for a subscription that this publisher's messages
        reach; whether there is one. What a talker does before its first message, so that
        the message is not lost to start-up (``topic pub`` and ``bag play`` wait this way,
        on a condition, not a fixed time)."""
        return self._inner.wait_for_subscription(timeout_sec)

    def destroy(self) -> None:
        self._inner.close()
