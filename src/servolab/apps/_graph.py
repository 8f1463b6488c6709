"""What the graph commands (``topic``, ``node``, ``service``, ``param``, ``bag``, ``launch``)
share: printing a line, the hidden node a command joins the graph with, and the graph's
contents grouped as rclpy's graph API gives them (``get_node_names_and_namespaces``,
``get_publisher_names_and_types_by_node``, ...), so that every command reads one view.

A helper (its name starts with ``_``), so the registry does not import it for
``servolab --help`` and it may import the middleware (and Zenoh) at the top.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Iterable

from servolab.errors import UsageError
from servolab.middleware.context import Context
from servolab.middleware.errors import NameValidationError
from servolab.middleware.names import fully_qualified_name, validate_node_name
from servolab.middleware.node import Node
from servolab.middleware.transport import Endpoint

#: Seconds to listen for the graph's announcements before answering what is in it.
DISCOVERY_S = 0.5
#: rclpy's ``HIDDEN_NODE_PREFIX``: a node, topic or service whose name (any part of it, for
#: topics and services, as ros2cli's ``_is_hidden_name``) starts with it is hidden.
HIDDEN_PREFIX = "_"
#: How many names an error lists before it says how many more there are.
LISTED = 12


def say(text: str) -> None:
    """Print one line for the user, flushed at once: the output is often piped or watched
    while the command still runs (``topic echo``, ``bag record``)."""
    print(text, flush=True)


def warn(text: str) -> None:
    """A warning on stderr, as ros2cli prints its warnings, so stdout stays the listing."""
    print(text, file=sys.stderr, flush=True)


def tool_node(ctx: Context, what: str) -> Node:
    """A hidden node (its name starts with ``_``, as ``ros2`` CLI nodes' do)."""
    return Node(ctx, f"_servolab_{what}_{time.time_ns() % 1_000_000}")


def hidden(node: str) -> bool:
    """Whether a node's name marks it as a tool's, left out of listings."""
    return node.rsplit("/", 1)[-1].startswith(HIDDEN_PREFIX)


def hidden_name(name: str) -> bool:
    """Whether a topic or service name is hidden: any part of it starts with ``_``
    (ros2cli's ``_is_hidden_name``), as ``/robot/_action/feedback`` does."""
    return any(part.startswith(HIDDEN_PREFIX) for part in name.split("/"))


def graph(ctx: Context, timeout: float = DISCOVERY_S) -> list[Endpoint]:
    """Everything the transport sees after ``timeout`` s of listening."""
    return ctx.transport.graph(timeout)


def node_names(endpoints: Iterable[Endpoint], *, include_hidden: bool = False) -> list[str]:
    """Fully qualified names of the nodes, sorted, a name twice if two nodes share it (as
    ``get_node_names_and_namespaces`` lists them)."""
    return sorted(e.node for e in endpoints
                  if e.kind == "NN" and (include_hidden or not hidden(e.node)))


def names_and_types(endpoints: Iterable[Endpoint], kinds: Iterable[str], *,
                    node: str | None = None) -> dict[str, list[str]]:
    """Name -> sorted types of the entities of ``kinds`` (``MP``, ``MS``, ``SS``, ``SC``), of
    one node if ``node`` is given; sorted by name, as rcl returns them."""
    wanted = set(kinds)
    found: dict[str, set[str]] = {}
    for e in endpoints:
        if e.kind in wanted and (node is None or e.node == node):
            found.setdefault(e.name, set()).add(e.type_name)
    return {name: sorted(found[name]) for name in sorted(found)}


def topic_name(text: str, *, is_service: bool = False) -> str:
    """A topic or service name as the user typed it, made absolute (``chatter`` is
    ``/chatter``), or the name's error showing where it breaks the rules."""
    return fully_qualified_name(text, "/", is_service=is_service)


def node_name(text: str) -> str:
    """A fully qualified node name from what the user typed (``talker`` is ``/talker``), or a
    one-line :class:`UsageError` naming it."""
    name = text if text.startswith("/") else f"/{text}"
    namespace, _, base = name.rpartition("/")
    try:
        validate_node_name(base)
        if namespace:
            fully_qualified_name(namespace)
    except NameValidationError as exc:
        raise UsageError(f"{text!r} is not a node name ({exc.summary}); "
                         "'servolab node list' shows the nodes there are") from None
    return name


def listed(names: list[str]) -> str:
    """``a, b, c`` for an error, the first :data:`LISTED` names and how many more."""
    more = f" and {len(names) - LISTED} more" if len(names) > LISTED else ""
    return ", ".join(names[:LISTED]) + more if names else "none"
