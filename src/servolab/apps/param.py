"""``servolab param``: list, get and set the parameters of running nodes, as ``ros2 param``
does.

Every function takes an open :class:`~servolab.middleware.context.Context` and a ``say``
function for its output, so the CLI stays a parser and the tests can capture what is printed.
Values are checked before anything is set. The middleware (and Zenoh) is imported inside the
functions, so that ``servolab --help`` does not load it.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from servolab.middleware.errors import ParameterError

from .arguments import add_transport, transport_options
from .registry import Command
from .topic import DISCOVERY_S

if TYPE_CHECKING:
    from servolab.middleware.context import Context

Say = Callable[[str], None]


def _param_nodes(ctx: Context) -> list[str]:
    from ._graph import hidden

    return sorted({e.node for e in ctx.transport.graph(DISCOVERY_S)
                   if e.kind == "SS" and e.name == f"{e.node}/list_parameters"
                   and not hidden(e.node)})


def _client(ctx: Context, node_name: str, service: str) -> Any:
    from ._graph import tool_node

    node = tool_node(ctx, "param")
    target = node_name if node_name.startswith("/") else f"/{node_name}"
    srv = "".join(p.capitalize() for p in service.split("_"))
    return node.create_client(f"rcl_interfaces/srv/{srv}", f"{target}/{service}")


def param_list(ctx: Context, say: Say, node_name: str | None = None,
               timeout: float = 2.0) -> dict[str, list[str]]:
    """Every node's parameter names (or one node's), as ``ros2 param list`` prints them."""
    nodes = [node_name if node_name.startswith("/") else f"/{node_name}"] if node_name \
        else _param_nodes(ctx)
    listing: dict[str, list[str]] = {}
    for name in nodes:
        names = list(_client(ctx, name, "list_parameters").call(timeout=timeout).result.names)
        listing[name] = names
        say(f"{name}:")
        for param in names:
            say(f"  {param}")
    return listing


def param_get(ctx: Context, node_name: str, name: str, say: Say, timeout: float = 2.0) -> Any:
    from servolab.middleware.parameters import from_parameter_value

    client = _client(ctx, node_name, "get_parameters")
    values = client.call(client.request(names=[name]), timeout=timeout).values
    value = from_parameter_value(values[0]) if values else None
    if value is None:
        raise ParameterError(f"{node_name} has no parameter {name!r}")
    say(f"{name}: {value!r}")
    return value


def param_set(ctx: Context, node_name: str, name: str, text: str, say: Say,
              timeout: float = 2.0) -> None:
    import yaml

    from servolab.middleware.parameters import to_parameter_value

    try:
        value = yaml.safe_load(text)
    except yaml.YAMLError:
        raise ParameterError(f"value {text!r} for {name} is not YAML") from None
    parameter = {"name": name, "value": to_parameter_value(ctx.types, value)}
    client = _client(ctx, node_name, "set_parameters")
    results = client.call(client.request(parameters=[parameter]), timeout=timeout).results
    if not results or not results[0].successful:
        reason = results[0].reason if results else "no answer"
        raise ParameterError(f"setting {name} on {node_name} failed: {reason}")
    say(f"set {name} = {value!r} on {node_name}")


def _add_arguments(parser: argparse.ArgumentParser) -> None:
    actions = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    p = actions.add_parser("list", help="parameters of every node, or of one")
    p.add_argument("node", nargs="?", help="e.g. /robot/talker (default: every node)")
    add_transport(p)
    p = actions.add_parser("get", help="one parameter's value")
    p.add_argument("node", help="e.g. /robot/talker")
    p.add_argument("name")
    add_transport(p)
    p = actions.add_parser("set", help="change a parameter (the value is YAML)")
    p.add_argument("node", help="e.g. /robot/talker")
    p.add_argument("name")
    p.add_argument("value", help="YAML: 0.3, true, [1, 2], ...")
    add_transport(p)


def _run(args: argparse.Namespace) -> int:
    from servolab.middleware.context import Context

    from ._graph import say

    with Context.open(transport_options(args)) as ctx:
        if args.action == "list":
            param_list(ctx, say, args.node)
        elif args.action == "get":
            param_get(ctx, args.node, args.name, say)
        elif args.action == "set":
            param_set(ctx, args.node, args.name, args.value, say)
    return 0


COMMAND = Command(
    name="param", group="graph", help="list, get and set node parameters",
    description="List, get and set the parameters of running nodes, as 'ros2 param' does.",
    examples=("servolab param list",
              "servolab param set /robot/talker speed 0.3 --connect tcp/robot.local:7447"),
    add_arguments=_add_arguments, run=_run)
