"""``servolab node``: the nodes of a running graph, as ``ros2 node list`` and ``ros2 node
info`` print them.

The functions take an open :class:`~servolab.middleware.context.Context` and a ``say``
function for their output, so the CLI stays a parser and the tests can capture what is
printed. The middleware (and Zenoh) is imported inside the functions, so that ``servolab
--help`` does not load it.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import TYPE_CHECKING

from servolab.errors import UsageError

from .arguments import add_transport, transport_options
from .registry import Command

if TYPE_CHECKING:
    from servolab.middleware.context import Context
    from servolab.middleware.transport import Endpoint

Say = Callable[[str], None]
#: ros2node's warnings, word for word
DUPLICATES_WARNING = ("WARNING: Be aware that there are nodes in the graph that share an exact "
                      "name, which can have unintended side effects.")
NONUNIQUE_WARNING = ('There are {num_nodes} nodes in the graph with the exact name '
                     '"{node_name}". You are seeing information about only one of them.')
#: rcl_action's names: an action server serves ``<action>/_action/send_goal`` of type
#: ``<pkg>/action/<Name>_SendGoal`` (and a client calls it).
_SEND_GOAL = "/_action/send_goal"
_SEND_GOAL_TYPE = "_SendGoal"


def node_list(ctx: Context, say: Say, *, include_hidden: bool = False,
              count_only: bool = False, warn: Say | None = None) -> list[str]:
    """The fully qualified names of the graph's nodes, sorted, as ``ros2 node list`` prints
    them (``-a`` hidden ones too, ``-c`` only how many); a warning on ``warn`` (stderr) if
    two share a name."""
    from ._graph import graph, node_names
    from ._graph import warn as stderr

    names = node_names(graph(ctx), include_hidden=include_hidden)
    if count_only:
        say(str(len(names)))
    elif names:
        if len(set(names)) < len(names):
            (warn or stderr)(DUPLICATES_WARNING)
        for name in names:
            say(name)
    return names


def _actions(endpoints: list[Endpoint], kind: str, node: str) -> dict[str, list[str]]:
    """Action name -> types, from the send_goal services (``SS`` for servers, ``SC`` for
    clients), as rcl_action's ``get_*_names_and_types_by_node`` finds them."""
    found: dict[str, set[str]] = {}
    for e in endpoints:
        if e.kind == kind and e.node == node and e.name.endswith(_SEND_GOAL) \
                and e.type_name.endswith(_SEND_GOAL_TYPE):
            found.setdefault(e.name[:-len(_SEND_GOAL)], set()).add(
                e.type_name[:-len(_SEND_GOAL_TYPE)])
    return {name: sorted(found[name]) for name in sorted(found)}


def node_info(ctx: Context, name: str, say: Say, *, include_hidden: bool = False,
              warn: Say | None = None) -> dict[str, dict[str, list[str]]]:
    """The node's subscriptions, publishers, service servers and clients, action servers
    and clients, as ``ros2 node info`` prints them (an empty section is an empty line, as
    there); hidden names (a part starting with ``_``) only with ``include_hidden``. Returns
    the sections."""
    from ._graph import graph, hidden_name, listed, names_and_types, node_name, node_names
    from ._graph import warn as stderr

    name = node_name(name)
    endpoints = graph(ctx)
    nodes = node_names(endpoints, include_hidden=True)
    count = nodes.count(name)
    if count == 0:
        shown = node_names(endpoints, include_hidden=include_hidden)
        raise UsageError(f"Unable to find node '{name}'; the graph has "
                         f"{listed(sorted(set(shown)))} ('servolab node list')")
    if count > 1:
        (warn or stderr)(NONUNIQUE_WARNING.format(num_nodes=count, node_name=name))
    sections = {
        "Subscribers": names_and_types(endpoints, ("MS",), node=name),
        "Publishers": names_and_types(endpoints, ("MP",), node=name),
        "Service Servers": names_and_types(endpoints, ("SS",), node=name),
        "Service Clients": names_and_types(endpoints, ("SC",), node=name),
        "Action Servers": _actions(endpoints, "SS", name),
        "Action Clients": _actions(endpoints, "SC", name),
    }
    sections = {title: {n: t for n, t in found.items() if include_hidden or not hidden_name(n)}
                for title, found in sections.items()}
    say(name)
    for title, found in sections.items():
        say(f"  {title}:")
        say("\n".join(f"    {n}: {', '.join(t)}" for n, t in found.items()))
    return sections


def _add_arguments(parser: argparse.ArgumentParser) -> None:
    actions = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    p = actions.add_parser("list", help="nodes in the graph, as ros2 node list")
    p.add_argument("-a", "--all", action="store_true", help="hidden nodes too (names "
                   "starting with _, as servolab's and ros2's tools' are)")
    p.add_argument("-c", "--count-nodes", action="store_true",
                   help="only how many nodes there are")
    add_transport(p)
    p = actions.add_parser(
        "info", help="a node's topics, services and actions, as ros2 node info",
        description="Print what a node subscribes to, publishes, serves and calls, as 'ros2 "
        "node info' does. Where servolab differs: a name without a leading / is taken from / "
        "(ros2 wants it fully qualified), and an unknown node is an error naming the nodes "
        "there are (exit status 2; ros2 exits with 1).")
    p.add_argument("node", help="e.g. /robot/talker")
    p.add_argument("--include-hidden", action="store_true",
                   help="hidden topics, services and actions too")
    add_transport(p)


def _run(args: argparse.Namespace) -> int:
    from servolab.middleware.context import Context

    from ._graph import say

    with Context.open(transport_options(args)) as ctx:
        ctx.transport.check_reachable()  # not an empty graph from an endpoint gone wrong
        if args.action == "list":
            node_list(ctx, say, include_hidden=args.all, count_only=args.count_nodes)
        elif args.action == "info":
            node_info(ctx, args.node, say, include_hidden=args.include_hidden)
    return 0


COMMAND = Command(
    name="node", group="graph", help="list nodes and show what one does",
    description="List the nodes of a running graph and show a node's topics, services and "
    "actions, as 'ros2 node' does.",
    examples=("servolab node list",
              "servolab node info /robot/talker --connect tcp/robot.local:7447"),
    add_arguments=_add_arguments, run=_run)
