"""What the graph commands (``topic``, ``param``, ``bag``, ``launch``) share: printing a line,
and the hidden node a command joins the graph with.

A helper (its name starts with ``_``), so the registry does not import it for
``servolab --help`` and it may import the middleware (and Zenoh) at the top.
"""

from __future__ import annotations

import time

from servolab.middleware.context import Context
from servolab.middleware.node import Node


def say(text: str) -> None:
    """Print one line for the user, flushed at once: the output is often piped or watched
    while the command still runs (``topic echo``, ``bag record``)."""
    print(text, flush=True)


def tool_node(ctx: Context, what: str) -> Node:
    """A hidden node (its name starts with ``_``, as ``ros2`` CLI nodes' do)."""
    return Node(ctx, f"_servolab_{what}_{time.time_ns() % 1_000_000}")


def hidden(node: str) -> bool:
    """Whether a node's name marks it as a tool's, left out of listings."""
    return node.rsplit("/", 1)[-1].startswith("_")
