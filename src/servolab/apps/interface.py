"""``servolab interface``: the message and service types servolab knows, as ``ros2
interface list`` and ``ros2 interface show`` print them.

servolab's types come from ``rosbags``' store of ROS 2 Jazzy's definitions plus its own
(:mod:`servolab.middleware.messages`), which keep each field's type and name but not the
``.msg`` file's comments, blank lines and spacing: ``show`` prints the definition as
``ros2 interface show --no-comments`` would, one space between type and name.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from .registry import Command

if TYPE_CHECKING:
    from servolab.middleware.messages import MessageTypes

Say = Callable[[str], None]
#: rosidl's separator of a service's request and response
SERVICE_SEPARATOR = "---"


def interface_list(types: MessageTypes, say: Say, *, messages: bool = True,
                   services: bool = True, actions: bool = True) -> None:
    """``Messages:``, ``Services:`` and ``Actions:``, each type indented by four spaces,
    sorted, as ``ros2 interface list`` prints them."""
    if messages:
        say("Messages:")
        for name in types.names():
            say(f"    {name}")
    if services:
        say("Services:")
        for name in types.service_names():
            say(f"    {name}")
    if actions:
        say("Actions:")
        for name in types.action_names():
            say(f"    {name}")


def interface_package(types: MessageTypes, package: str, say: Say) -> list[str]:
    """Every interface of one package, sorted, as ``ros2 interface package`` prints them; an
    unknown package is a one-line error naming the nearest."""
    import difflib

    from servolab.errors import UsageError

    found = [n for n in (*types.names(), *types.service_names(), *types.action_names())
             if n.split("/")[0] == package]
    if not found:
        packages = sorted({n.split("/")[0] for n in types.store.fielddefs})
        near = difflib.get_close_matches(package, packages, n=1)
        raise UsageError(f"unknown package {package!r}"
                         + (f" (did you mean {near[0]}?)" if near else "")
                         + "; 'servolab interface list' lists every type")
    for name in sorted(found):
        say(name)
    return sorted(found)


def _type_text(node: tuple[Any, Any], package: str) -> str:
    """A field's type as a ``.msg`` file writes it: ``float64``, ``string<=10``, ``Vector3``
    (same package), ``std_msgs/Header``, with ``[]``, ``[N]`` or ``[<=N]`` for arrays."""
    from rosbags.interfaces import Nodetype

    kind, detail = node
    if kind == Nodetype.BASE:
        name, bound = detail
        return f"{name}<={bound}" if bound else str(name)
    if kind == Nodetype.NAME:
        pkg, _, short = str(detail).split("/")
        return short if pkg == package else f"{pkg}/{short}"
    element, count = detail
    inner = _type_text(element, package)
    if kind == Nodetype.ARRAY:
        return f"{inner}[{count}]"
    return f"{inner}[<={count}]" if count else f"{inner}[]"


def _nested(node: tuple[Any, Any]) -> str | None:
    from rosbags.interfaces import Nodetype

    kind, detail = node
    if kind == Nodetype.NAME:
        return str(detail)
    if kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
        return _nested(detail[0])
    return None


def _constant(kind: str, value: Any) -> str:
    if kind == "bool":
        return "true" if value else "false"
    if kind == "string":
        return repr(value) if any(c in str(value) for c in " #'\"") else str(value)
    return str(value)


def definition_lines(types: MessageTypes, name: str, indent: int = 0) -> list[str]:
    """The lines ``ros2 interface show`` prints for message type ``name``: its constants and
    fields, each field of a message type followed by that type's lines one tab further in."""
    constants, fields = types.store.fielddefs[name]
    package = name.split("/")[0]
    tab = "\t" * indent
    lines = [f"{tab}{kind} {const}={_constant(kind, value)}" for const, kind, value in constants]
    for field, node in fields:
        lines.append(f"{tab}{_type_text(node, package)} {field}")
        nested = _nested(node)
        if nested is not None:
            lines.extend(definition_lines(types, nested, indent + 1))
    return lines


def interface_show(types: MessageTypes, name: str, say: Say) -> list[str]:
    """Print a message or service type's definition as ``ros2 interface show`` does: nested
    types expanded and indented by tabs, a service's request and response around ``---``.
    An unknown name is a one-line error with a guess."""
    from servolab.middleware.errors import MessageError

    parts = name.strip().split("/")
    if len(parts) == 3 and parts[1] == "srv":
        srv = types.service(name)
        lines = [*definition_lines(types, srv.request), SERVICE_SEPARATOR,
                 *definition_lines(types, srv.response)]
    elif len(parts) == 3 and parts[1] == "action":
        if not types.is_action(name.strip()):
            raise MessageError(f"unknown action type {name!r} ('servolab interface list -a')")
        action = name.strip()
        lines = [*definition_lines(types, f"{action}_Goal"), SERVICE_SEPARATOR,
                 *definition_lines(types, f"{action}_Result"), SERVICE_SEPARATOR,
                 *definition_lines(types, f"{action}_Feedback")]
    elif (len(parts) == 3 and parts[1] == "msg") or len(parts) == 2:
        lines = definition_lines(types, types.check(name))
    else:
        raise MessageError(f"Invalid name {name!r}: expected three parts separated by '/', "
                           "e.g. std_msgs/msg/String, std_srvs/srv/Trigger or "
                           "test_msgs/action/Fibonacci "
                           "('servolab interface list')")
    for line in lines:
        say(line)
    return lines


def _add_arguments(parser: argparse.ArgumentParser) -> None:
    actions = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    p = actions.add_parser("list", help="every message and service type, as ros2 interface "
                           "list")
    p.add_argument("-m", "--only-msgs", action="store_true", help="only the message types")
    p.add_argument("-s", "--only-srvs", action="store_true", help="only the service types")
    p.add_argument("-a", "--only-actions", action="store_true",
                   help="only the action types")
    p = actions.add_parser("package", help="every interface of one package, as ros2 "
                           "interface package")
    p.add_argument("package", help="e.g. nav2_msgs")
    p = actions.add_parser(
        "show", help="a type's definition, nested types expanded, as ros2 interface show",
        description="Print a message, service or action type's definition as 'ros2 interface "
        "show' does: nested types expanded, one tab deeper each, and '---' between a service's "
        "request and response (an action's goal, result and feedback). Where servolab "
        "differs: the definitions come without the .msg files' comments and blank lines (as "
        "'ros2 interface show --no-comments') and with one space between type and name; "
        "fields' default values are not shown.")
    p.add_argument("type", help="e.g. geometry_msgs/msg/Twist, std_srvs/srv/SetBool, "
                   "nav2_msgs/action/NavigateToPose")


def _run(args: argparse.Namespace) -> int:
    from servolab.middleware.messages import MessageTypes

    from ._graph import say

    types = MessageTypes()
    if args.action == "list":
        only = args.only_msgs or args.only_srvs or args.only_actions
        interface_list(types, say, messages=not only or args.only_msgs,
                       services=not only or args.only_srvs,
                       actions=not only or args.only_actions)
    elif args.action == "show":
        interface_show(types, args.type, say)
    elif args.action == "package":
        interface_package(types, args.package, say)
    return 0


COMMAND = Command(
    name="interface", group="graph", help="list message, service and action types; show one",
    description="List the message, service and action types servolab knows (rosbags' ROS 2 "
    "Jazzy set, the packages servolab ships, and those SERVOLAB_INTERFACE_PATH names) and "
    "show a type's definition, as 'ros2 interface' does.",
    examples=("servolab interface list",
              "servolab interface show geometry_msgs/msg/TwistStamped",
              "servolab interface show dynamixel_controllers/srv/SetSpeed"),
    add_arguments=_add_arguments, run=_run)
