"""Shared fixtures: free loopback ports and Zenoh contexts that are always closed (the
message types and the in-process ``ctx`` are tests/conftest.py's)."""

from __future__ import annotations

import socket
from collections.abc import Iterator
from typing import Any

import pytest

from servolab.middleware.context import Context
from servolab.middleware.messages import MessageTypes
from servolab.middleware.transport import TransportOptions


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def zenoh_pair(types: MessageTypes) -> Iterator[tuple[Context, Context, int]]:
    """Two contexts, as two processes would have them: one listens, one connects."""
    port = free_port()
    a = Context.open(TransportOptions("zenoh", listen=[f"tcp/127.0.0.1:{port}"]), types=types)
    try:
        b = Context.open(TransportOptions("zenoh", connect=[f"tcp/127.0.0.1:{port}"]),
                         types=types)
    except BaseException:
        a.close()
        raise
    try:
        yield a, b, port
    finally:
        b.close()
        a.close()


def foreign_zenoh_peer(endpoint: str) -> Any:
    """A plain Zenoh session connected to ``endpoint``: a peer that is no ROS node and no
    servolab (issue 45's attacker), which the caller closes."""
    import zenoh

    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("connect/endpoints", f'["{endpoint}"]')
    config.insert_json5("scouting/multicast/enabled", "false")
    return zenoh.open(config)
