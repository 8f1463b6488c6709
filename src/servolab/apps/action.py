"""``servolab action``: list a running graph's actions, show who serves and uses one, and send
a goal from the shell, as ``ros2 action list``, ``info`` and ``send_goal`` do.

An action is known by its ``send_goal`` service (``<name>/_action/send_goal``, of type
``<Action>_SendGoal``), whatever transport carries it. ``send_goal`` checks the type and the
YAML values against the goal's fields before it joins the graph, waits up to ``--timeout`` s
for a server, and prints the goal, its id, feedback (``--feedback``), result and final
status in ``ros2 action send_goal``'s words. Ctrl-C while the goal runs cancels it, as ros2's
does, and says whether the server canceled it.

The functions take an open :class:`~servolab.middleware.context.Context` and a ``say``
function, so the CLI stays a parser and the tests capture what is printed.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from servolab.errors import UsageError
from servolab.middleware.errors import MessageError

from .arguments import add_transport, positive_float, transport_options
from .registry import Command
from .topic import DISCOVERY_S

if TYPE_CHECKING:
    from servolab.middleware.context import Context
    from servolab.middleware.messages import MessageTypes

Say = Callable[[str], None]
_SEND_GOAL = "/_action/send_goal"
_SEND_GOAL_TYPE = "_SendGoal"
#: how long Ctrl-C waits for the server to answer the cancel, and then for the goal's end
CANCEL_WAIT_S = 5.0
#: action_msgs/msg/GoalStatus' states used here (servolab.rclpy.action.server has them all;
#: not imported from there, which a command's --help would pay for), and all by number, as
#: ros2action prints them
STATUS_UNKNOWN, STATUS_ACCEPTED, STATUS_EXECUTING, STATUS_SUCCEEDED = 0, 1, 2, 4
STATUS_NAMES = {0: "UNKNOWN", 1: "ACCEPTED", 2: "EXECUTING", 3: "CANCELING", 4: "SUCCEEDED",
                5: "CANCELED", 6: "ABORTED"}


class ActionUse:
    """One action in the graph: its types, and the nodes that serve it and use it."""

    def __init__(self) -> None:
        self.types: set[str] = set()
        self.servers: set[str] = set()
        self.clients: set[str] = set()


def actions(ctx: Context, timeout: float = DISCOVERY_S, *,
            include_hidden: bool = False) -> dict[str, ActionUse]:
    """Action name -> who serves and uses it; tools' hidden nodes left out, and hidden
    action names (a part starting with ``_``) unless ``include_hidden``."""
    from ._graph import hidden, hidden_name

    found: dict[str, ActionUse] = {}
    for e in ctx.transport.graph(timeout):
        if e.kind not in ("SS", "SC") or not e.name.endswith(_SEND_GOAL) \
                or not e.type_name.endswith(_SEND_GOAL_TYPE) or hidden(e.node):
            continue
        name = e.name[:-len(_SEND_GOAL)]
        if hidden_name(name) and not include_hidden:
            continue
        use = found.setdefault(name, ActionUse())
        use.types.add(e.type_name[:-len(_SEND_GOAL_TYPE)])
        (use.servers if e.kind == "SS" else use.clients).add(e.node)
    return found


def action_list(ctx: Context, say: Say, *, show_types: bool = False,
                count_only: bool = False) -> list[str]:
    """Every action, sorted (``-t``: with ``[type]``; ``-c``: only how many)."""
    found = actions(ctx)
    if count_only:
        say(str(len(found)))
    else:
        for name in sorted(found):
            say(name + (f" [{', '.join(sorted(found[name].types))}]" if show_types else ""))
    return sorted(found)


def action_info(ctx: Context, name: str, say: Say, *, show_types: bool = False) -> ActionUse:
    """Who uses and serves the action, as ``ros2 action info`` prints it."""
    from ._graph import topic_name

    name = topic_name(name)
    use = actions(ctx, include_hidden=True).get(name, ActionUse())
    kind = f" [{', '.join(sorted(use.types))}]" if show_types and use.types else ""
    say(f"Action: {name}")
    say(f"Action clients: {len(use.clients)}")
    for node in sorted(use.clients):
        say(f"    {node}{kind}")
    say(f"Action servers: {len(use.servers)}")
    for node in sorted(use.servers):
        say(f"    {node}{kind}")
    return use


def parse_goal(types: MessageTypes, type_name: str, values: str) -> Any:
    """The goal ``values`` (YAML) make for the action ``type_name``, or a one-line error
    naming the type, field or value."""
    if not types.is_action(type_name):
        near = [n for n in types.action_names()
                if n.rsplit("/", 1)[-1] == type_name.rsplit("/", 1)[-1]]
        hint = f" (did you mean {near[0]}?)" if near else ""
        raise MessageError(f"unknown action type {type_name!r}{hint}; 'servolab interface "
                           "list -a' lists them")
    goal = f"{type_name}_Goal"
    try:
        return types.from_yaml(goal, values)
    except MessageError as exc:
        text = str(exc)  # "<pkg/action/X_Goal> <field>: ..." or "values for ... are not YAML"
        if text.startswith(f"{goal} "):
            text = text[len(goal) + 1:]
        raise MessageError(f"goal of {type_name}: {text.replace(goal, 'the goal')}") from None


def _yaml(ctx: Context, msg: Any) -> str:
    import yaml

    return str(yaml.safe_dump(ctx.types.to_value(msg), sort_keys=False, width=10**9)).rstrip()


def send_goal(ctx: Context, name: str, type_name: str, values: str, say: Say, *,
              feedback: bool = False, timeout: float = 30.0) -> int:
    """Send one goal and wait for its end; the final status (a GoalStatus number)."""
    goal = parse_goal(ctx.types, type_name, values)  # refused before the graph is joined
    return send_goal_message(ctx, name, type_name, goal, say, feedback=feedback,
                             timeout=timeout)


def send_goal_message(ctx: Context, name: str, type_name: str, goal: Any, say: Say, *,
                      feedback: bool = False, timeout: float = 30.0,
                      show_goal: bool = True) -> int:
    """Send the goal message ``goal`` and wait for its end, printing as ``ros2 action
    send_goal`` does (the goal itself only with ``show_goal``: a trajectory of hundreds of
    points is not read on a terminal); Ctrl-C cancels it. The final status (a GoalStatus
    number)."""
    from servolab.rclpy.action import ActionClient

    from ._graph import tool_node

    node = tool_node(ctx, "action")
    client = ActionClient(node, type_name, name)
    say("Waiting for an action server to become available...")
    if not client.wait_for_server(timeout_sec=timeout):
        there = sorted(actions(ctx, 0.0))
        listed = f"; the graph has {', '.join(there)}" if there else ""
        raise UsageError(f"no action server for {client.name} within {timeout:g} s "
                         f"(--timeout){listed}")
    if show_goal:
        say(f"Sending goal:\n     {_yaml(ctx, goal)}\n")

    # feedback and the goal's answer come by different ways: feedback that comes first waits
    # until the acceptance is printed, so the output reads in the goal's order
    early: list[Any] | None = []

    def on_feedback(message: Any) -> None:
        if early is not None:
            early.append(message)
        else:
            say(f"Feedback:\n    {_yaml(ctx, message.feedback)}\n")

    sent = client.send_goal_async(goal, feedback_callback=on_feedback if feedback else None)
    # one try from the goal's sending to its result: Ctrl-C at any line printed on the way (a
    # feedback held back and printed after the acceptance, too) cancels an accepted goal
    handle = None
    try:
        handle = client._wait(sent)
        if not handle.accepted:
            say("Goal was rejected.")
            return 0
        say(f"Goal accepted with ID: {bytes(bytearray(handle.goal_id.uuid)).hex()}\n")
        waiting, early = early, None
        for message in waiting or []:
            on_feedback(message)
        response = client._wait(handle.get_result_async())
    except KeyboardInterrupt:
        if handle is None:
            say("Interrupted before the server answered the goal.")
            if not (sent.done() and sent.result().accepted):
                return STATUS_UNKNOWN
            handle = sent.result()
        elif not handle.accepted:
            raise
        return _cancel(client, handle, say)
    say(f"Result:\n    {_yaml(ctx, response.result)}\n")
    status = int(response.status)
    say(f"Goal finished with status: {STATUS_NAMES.get(status, str(status))}")
    return status


def _cancel(client: Any, handle: Any, say: Say) -> int:
    """Ctrl-C while the goal ran: cancel it, as ros2action's send_goal does, only while it is
    accepted or executing (a goal that has just ended keeps its end). The cancel goes out
    before the line is printed, so a second Ctrl-C on the line does not keep it in."""
    if int(handle.status) not in (STATUS_ACCEPTED, STATUS_EXECUTING):
        return int(handle.status)
    canceling = handle.cancel_goal_async()
    say("Canceling goal...")
    executor = client._node.context.executor
    executor.spin_until(canceling.done, CANCEL_WAIT_S)
    if not canceling.done():
        say(f"The server did not answer the cancel within {CANCEL_WAIT_S:g} s")
        return int(handle.status)
    response = canceling.result()
    if not response.goals_canceling:
        say("Failed to cancel goal")
        return int(handle.status)
    say("Goal canceled.")
    result = handle.get_result_async()
    executor.spin_until(result.done, CANCEL_WAIT_S)
    return int(result.result().status) if result.done() else int(handle.status)


def _add_arguments(parser: argparse.ArgumentParser) -> None:
    verbs = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    p = verbs.add_parser("list", help="actions in the graph")
    p.add_argument("-t", "--show-types", action="store_true", help="show each action's type")
    p.add_argument("-c", "--count-actions", action="store_true",
                   help="only how many actions there are")
    add_transport(p)
    p = verbs.add_parser("info", help="who serves and uses an action")
    p.add_argument("action_name", metavar="NAME", help="e.g. /navigate_to_pose")
    p.add_argument("-t", "--show-types", action="store_true", help="show the action's type")
    add_transport(p)
    p = verbs.add_parser("send_goal", help="send a goal and wait for its result "
                         "(Ctrl-C cancels it)")
    p.add_argument("action_name", metavar="NAME", help="e.g. /navigate_to_pose")
    p.add_argument("type_name", metavar="TYPE", help="e.g. nav2_msgs/action/NavigateToPose")
    p.add_argument("values", metavar="VALUES", nargs="?", default="{}",
                   help="the goal in YAML, e.g. \"{order: 5}\" (default: every field at its "
                   "default)")
    p.add_argument("-f", "--feedback", action="store_true", help="print the feedback")
    p.add_argument("--timeout", type=positive_float, default=30.0, metavar="SECONDS",
                   help="wait up to this long for an action server (default 30)")
    add_transport(p)


def _run(args: argparse.Namespace) -> int:
    from servolab.middleware.context import Context
    from servolab.middleware.messages import MessageTypes

    from ._graph import say

    types = MessageTypes()
    if args.action == "send_goal":  # what the user typed is checked before joining the graph
        parse_goal(types, args.type_name, args.values)
    with Context.open(transport_options(args), types=types) as ctx:
        ctx.transport.check_reachable()
        if args.action == "list":
            action_list(ctx, say, show_types=args.show_types, count_only=args.count_actions)
        elif args.action == "info":
            action_info(ctx, args.action_name, say, show_types=args.show_types)
        else:
            send_goal(ctx, args.action_name, args.type_name, args.values, say,
                      feedback=args.feedback, timeout=args.timeout)
    return 0


COMMAND = Command(
    name="action", group="graph", help="list actions, show who uses one, send a goal",
    description="List the actions of a running graph and send goals, as 'ros2 action' does.",
    examples=("servolab action list -t",
              "servolab action info /fibonacci",
              "servolab action send_goal /fibonacci test_msgs/action/Fibonacci "
              "\"{order: 5}\" --feedback"),
    add_arguments=_add_arguments, run=_run)
