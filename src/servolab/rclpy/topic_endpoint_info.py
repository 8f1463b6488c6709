"""``rclpy.topic_endpoint_info``: what ``get_publishers_info_by_topic`` and
``get_subscriptions_info_by_topic`` give (``rclpy/topic_endpoint_info.py``)."""

from __future__ import annotations

from enum import IntEnum
from typing import Any


class TopicEndpointTypeEnum(IntEnum):
    """rmw/types.h's endpoint types."""

    INVALID = 0
    PUBLISHER = 1
    SUBSCRIPTION = 2


class TopicEndpointInfo:
    """One endpoint of a topic: node, type, kind, gid and QoS."""

    def __init__(self, *, node_name: str = "", node_namespace: str = "", topic_type: str = "",
                 endpoint_type: TopicEndpointTypeEnum = TopicEndpointTypeEnum.INVALID,
                 endpoint_gid: list[int] | None = None, qos_profile: Any = None) -> None:
        self.node_name = node_name
        self.node_namespace = node_namespace
        self.topic_type = topic_type
        self.endpoint_type = endpoint_type
        self.endpoint_gid = endpoint_gid or []
        self.qos_profile = qos_profile

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, TopicEndpointInfo):
            return False
        return vars(self) == vars(other)

    __hash__ = None  # type: ignore[assignment]

    def __str__(self) -> str:
        lines = [f"Node name: {self.node_name}", f"Node namespace: {self.node_namespace}",
                 f"Topic type: {self.topic_type}",
                 f"Endpoint type: {self.endpoint_type.name}"]
        return "\n".join(lines)


__all__ = ["TopicEndpointInfo", "TopicEndpointTypeEnum"]
