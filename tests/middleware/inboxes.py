"""Subscribing straight to a transport, without a node or an executor: each message is
handed to ``deliver(data, info)`` on the transport's thread as soon as it arrives (the
start-up race tests, which watch the transport alone)."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

from servolab.middleware.inbox import Inbox
from servolab.middleware.qos import QoSProfile
from servolab.middleware.transport import MessageInfo, NodeInfo, Transport


def subscribe_with(transport: Transport, node: NodeInfo, topic: str, type_name: str,
                   deliver: Callable[[Any, MessageInfo], None], *,
                   qos: QoSProfile | None = None, raw: bool = False) -> Inbox:
    """Subscribe; on every wake-up take all that waits, in order, under one lock."""
    box: list[Inbox] = []
    lock = threading.Lock()

    def wake() -> None:
        with lock:
            while box and (taken := box[0].take()) is not None:
                deliver(*taken)

    box.append(transport.subscribe(node, topic, type_name, qos or QoSProfile(), wake,
                                   raw=raw))
    wake()  # what came before box was filled
    return box[0]
