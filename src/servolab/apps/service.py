"""``servolab service``: list a running graph's services and call them from the shell, as
``ros2 service list`` and ``ros2 service call`` do.

``call`` checks everything the user typed before it joins the graph: the service type
(with a guess when it is misspelt), and the YAML values against the request's fields. Then it
waits up to ``--timeout`` s for a node to serve the name (a name nobody serves is refused,
listing the services there are; one served with another type is refused naming it) and up
to ``--timeout`` s more for the answer, and prints request and response as ``ros2 service
call`` does. Exit statuses are the CLI's: 2 for what the user typed, 1 for a service that
did not answer in time or whose handler failed.

The functions take an open :class:`~servolab.middleware.context.Context` and a ``say``
function for their output, so the CLI stays a parser and the tests can capture what is
printed. The middleware (and Zenoh) is imported inside the functions, so that ``servolab
--help`` does not load it.
"""

from __future__ import annotations

import argparse
import difflib
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from servolab.errors import UsageError
from servolab.middleware.errors import MessageError

from .arguments import add_transport, positive_float, transport_options
from .registry import Command
from .topic import DISCOVERY_S

if TYPE_CHECKING:
    from servolab.middleware.context import Context
    from servolab.middleware.messages import MessageTypes, ServiceType

Say = Callable[[str], None]
#: How many service names an error lists before it says how many more there are.
_LISTED = 12
#: How much longer than ``--timeout`` the transport waits for an answer (see :func:`_answer`).
_TRANSPORT_GRACE_S = 1.0


def services(ctx: Context, timeout: float = DISCOVERY_S, *, servers_only: bool = False,
             include_hidden: bool = False) -> dict[str, set[str]]:
    """Service name -> the types its servers (and, unless ``servers_only``, clients) use,
    tools' hidden nodes and hidden names (a part starting with ``_``, as ros2cli hides them)
    left out unless ``include_hidden``. ``ros2 service list`` counts a name a client uses
    as a service too (rmw_zenoh's graph cache files servers and clients under one map,
    ``graph_cache.cpp``, ``update_topic_maps_for_put``), so the listing does."""
    from ._graph import hidden, hidden_name

    kinds = ("SS",) if servers_only else ("SS", "SC")
    found: dict[str, set[str]] = {}
    for e in ctx.transport.graph(timeout):
        if e.kind in kinds and (include_hidden or not (hidden(e.node) or hidden_name(e.name))):
            found.setdefault(e.name, set()).add(e.type_name)
    return found


def service_list(ctx: Context, say: Say, *, show_types: bool = False,
                 count_only: bool = False, include_hidden: bool = False) -> list[str]:
    """Every service in the graph, sorted; ``show_types`` adds ``[type]`` as ``ros2 service
    list -t`` does, ``count_only`` prints only how many (``-c``)."""
    found = services(ctx, include_hidden=include_hidden)
    if count_only:
        say(str(len(found)))
        return sorted(found)
    for name in sorted(found):
        say(name + (f" [{', '.join(sorted(found[name]))}]" if show_types else ""))
    return sorted(found)


def service_type(ctx: Context, name: str, say: Say) -> list[str]:
    """The service's type(s), one a line, as ``ros2 service type`` prints them; a name not in
    the graph is a one-line error listing those that are (ros2 exits 1 silently)."""
    from ._graph import topic_name

    name = topic_name(name, is_service=True)
    found = services(ctx, include_hidden=True)
    if name not in found:
        raise _unknown_service(name, services(ctx, 0.0))
    kinds = sorted(found[name])
    for kind in kinds:
        say(kind)
    return kinds


def parse_request(types: MessageTypes, type_name: str, values: str) -> tuple[ServiceType, Any]:
    """The service type and the request ``values`` (YAML, as ``ros2 service call`` takes
    them) make, or a one-line :class:`MessageError` naming the bad type, field or value."""
    srv = types.service(type_name)
    try:
        return srv, types.from_yaml(srv.request, values)
    except MessageError as exc:
        text = str(exc)  # "<pkg/srv/X_Request> <field>: ..." or "values for ... are not YAML"
        if text.startswith(f"{srv.request} "):
            text = text[len(srv.request) + 1:]
        text = text.replace(srv.request, "the request")
        raise MessageError(f"request of {srv.name}: {text}") from None


def _unknown_service(name: str, there: dict[str, set[str]]) -> UsageError:
    names = sorted(there)
    if not names:
        return UsageError(f"no service {name} in the graph, which has no services (is the "
                          "node running, and are the Zenoh endpoints right?)")
    near = difflib.get_close_matches(name, names, n=1)
    guess = f" (did you mean {near[0]}?)" if near else ""
    shown = ", ".join(names[:_LISTED])
    more = f" and {len(names) - _LISTED} more ('servolab service list')" \
        if len(names) > _LISTED else ""
    return UsageError(f"no service {name} in the graph{guess}; it has {shown}{more}")


def find_server(ctx: Context, name: str, srv: ServiceType, wait: float,
                say: Say | None = None) -> None:
    """Return once a node serves ``name`` with type ``srv``, waiting up to ``wait`` s (and
    saying so once, as ``ros2 service call`` does); else a :class:`UsageError` listing the
    services there are, or naming the type the name is served with."""
    end = time.monotonic() + wait
    told = False
    while True:
        served = services(ctx, servers_only=True)
        kinds = served.get(name, set())
        if srv.name in kinds:
            return
        if kinds:
            raise UsageError(f"service {name} is a {', '.join(sorted(kinds))}, not a "
                             f"{srv.name}")
        if time.monotonic() >= end:
            if name in services(ctx, 0.2):
                raise UsageError(f"no node serves {name} (only clients use it); "
                                 f"waited {wait:g} s")
            raise _unknown_service(name, services(ctx, 0.2, servers_only=True))
        if not told and say is not None:
            say("waiting for service to become available...")
            told = True
        time.sleep(0.1)


def service_call(ctx: Context, name: str, type_name: str, values: str, say: Say, *,
                 timeout: float = 5.0) -> Any:
    """Call ``name`` once with the request ``values`` make and return the response,
    printing both as ``ros2 service call`` does (``requester: making request: ...``, then
    ``response:`` and the response, each followed by an empty line)."""
    from ._graph import tool_node

    srv, request = parse_request(ctx.types, type_name, values)  # refused before the graph
    if timeout <= 0:
        raise UsageError(f"--timeout {timeout:g} must be > 0")
    node = tool_node(ctx, "service")
    name = node.resolve(name)
    find_server(ctx, name, srv, timeout, say)
    client = node.create_client(srv.name, name)
    say(f"requester: making request: {ctx.types.repr_of(request)}\n")
    response = _answer(ctx, client, request, timeout)
    say(f"response:\n{ctx.types.repr_of(response)}\n")
    return response


def _answer(ctx: Context, client: Any, request: Any, timeout: float) -> Any:
    """The response within ``timeout`` s, or a :class:`ServiceError` saying that none came
    (or the server's reason, when its handler failed). The transport is given a little longer
    than the caller waits, so that a late answer is told as "did not answer within", never as
    the transport's own time-out reply."""
    import concurrent.futures

    from servolab.middleware.errors import ServiceError

    future = client.call_async(request, timeout + _TRANSPORT_GRACE_S)
    if ctx.executor.spinning_elsewhere:
        concurrent.futures.wait([future], timeout)
    else:  # spin, so that a server in this process (--transport local) can answer
        ctx.executor.spin_until(future.done, timeout)
    if not future.done():
        raise ServiceError(f"service {client.name} did not answer within {timeout:g} s "
                           "(--timeout)")
    return future.result()


def _add_arguments(parser: argparse.ArgumentParser) -> None:
    actions = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    p = actions.add_parser("list", help="services in the graph")
    p.add_argument("-t", "--show-types", action="store_true", help="show each service's type")
    p.add_argument("-c", "--count-services", action="store_true",
                   help="only how many services there are")
    p.add_argument("--include-hidden-services", action="store_true",
                   help="hidden services too (a part of the name starting with _)")
    add_transport(p)
    p = actions.add_parser(
        "type", help="a service's type, as ros2 service type",
        description="Print a service's type, as 'ros2 service type' does. Where servolab "
        "differs: a name not in the graph is an error naming the services there are (exit "
        "status 2; ros2 prints nothing and exits 1).")
    p.add_argument("service_name", metavar="NAME", help="e.g. /controller_m14/set_speed")
    add_transport(p)
    p = actions.add_parser("call", help="call a service with YAML values, as ros2 service call")
    p.add_argument("service_name", metavar="NAME", help="e.g. /controller_m14/set_speed")
    p.add_argument("type_name", metavar="TYPE", help="e.g. dynamixel_controllers/srv/SetSpeed")
    p.add_argument("values", metavar="VALUES", nargs="?", default="{}",
                   help="YAML, e.g. \"{speed: 0.5}\" (default: every field at its default)")
    p.add_argument("--timeout", type=positive_float, default=5.0, metavar="SECONDS",
                   help="wait up to this long for the service to appear, and as long again "
                        "for its answer (default 5)")
    add_transport(p)


def _run(args: argparse.Namespace) -> int:
    from servolab.middleware.context import Context
    from servolab.middleware.messages import MessageTypes

    from ._graph import say

    types = MessageTypes()
    if args.action == "call":  # what the user typed is checked before joining the graph
        parse_request(types, args.type_name, args.values)
    with Context.open(transport_options(args), types=types) as ctx:
        ctx.transport.check_reachable()  # not an empty graph from an endpoint gone wrong
        if args.action == "list":
            service_list(ctx, say, show_types=args.show_types, count_only=args.count_services,
                         include_hidden=args.include_hidden_services)
        elif args.action == "type":
            service_type(ctx, args.service_name, say)
        elif args.action == "call":
            service_call(ctx, args.service_name, args.type_name, args.values, say,
                         timeout=args.timeout)
    return 0


COMMAND = Command(
    name="service", group="graph", help="list, type and call services",
    description="List the services of a running graph and call them, as 'ros2 service' does.",
    examples=("servolab service list -t",
              "servolab service type /controller_m14/set_speed",
              "servolab service call /controller_m14/set_speed "
              "dynamixel_controllers/srv/SetSpeed \"{speed: 0.5}\"",
              "servolab service call /controller_m14/torque_enable "
              "dynamixel_controllers/srv/TorqueEnable \"{torque_enable: false}\" "
              "--connect tcp/robot.local:7447"),
    add_arguments=_add_arguments, run=_run)
