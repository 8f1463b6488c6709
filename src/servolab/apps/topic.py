"""``servolab topic``: look at and poke a running graph's topics, as ``ros2 topic`` /
``rostopic`` do.

Every function takes an open :class:`~servolab.middleware.context.Context` and a ``say``
function for its output, so the CLI stays a parser and the tests can capture what is printed.
Values are checked before anything is published. The middleware (and Zenoh) is imported
inside the functions, so that ``servolab --help`` does not load it.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from servolab.errors import UsageError
from servolab.middleware.errors import MessageError

from .arguments import add_transport, transport_options
from .registry import Command

if TYPE_CHECKING:
    from servolab.middleware.context import Context
    from servolab.middleware.qos import QoSProfile
    from servolab.middleware.transport import Endpoint

Say = Callable[[str], None]
#: Seconds to listen for the graph's announcements before answering what is in it.
DISCOVERY_S = 0.5


def topics(ctx: Context, timeout: float = DISCOVERY_S) -> dict[str, set[str]]:
    """Topic name -> the message types its publishers and subscriptions use."""
    found: dict[str, set[str]] = {}
    for e in ctx.transport.graph(timeout):
        if e.kind in ("MP", "MS"):
            found.setdefault(e.name, set()).add(e.type_name)
    return found


def topic_list(ctx: Context, say: Say, *, show_types: bool = False,
               verbose: bool = False, include_hidden: bool = False) -> list[str]:
    """Every topic whatever node publishes or subscribes to it (a ``topic pub`` running
    in a terminal included), hidden names (a part starting with ``_``: an action's
    ``/_action/feedback``) only with ``include_hidden``, as ``ros2 topic list`` lists them."""
    from ._graph import hidden_name

    graph = [e for e in ctx.transport.graph(DISCOVERY_S)
             if e.kind in ("MP", "MS") and (include_hidden or not hidden_name(e.name))]
    names = sorted({e.name for e in graph})
    for name in names:
        kinds = sorted({e.type_name for e in graph if e.name == name and e.kind in ("MP", "MS")})
        line = name + (f" [{', '.join(kinds)}]" if show_types or verbose else "")
        if verbose:
            pubs = sum(1 for e in graph if e.name == name and e.kind == "MP")
            subs = sum(1 for e in graph if e.name == name and e.kind == "MS")
            line += f"  {pubs} publisher(s), {subs} subscription(s)"
        say(line)
    return names


def find_type(ctx: Context, topic: str, given: str | None, wait: float) -> str:
    """The topic's type: the one given (checked), else the one the graph shows."""
    if given:
        return ctx.types.check(given)
    end = time.monotonic() + wait
    while True:
        kinds = topics(ctx).get(topic, set())
        if len(kinds) == 1:
            return ctx.types.check(kinds.pop())
        if len(kinds) > 1:
            raise MessageError(f"{topic} carries several types ({', '.join(sorted(kinds))}); "
                               "name one with --type")
        if time.monotonic() >= end:
            raise MessageError(f"topic {topic} is not in the graph (nobody publishes it yet); "
                               "name its type with --type to wait for it")
        time.sleep(0.1)


def _shorten(value: Any, limit: int) -> Any:
    if isinstance(value, dict):
        return {k: _shorten(v, limit) for k, v in value.items()}
    if isinstance(value, list):
        if len(value) > limit:
            return f"<{len(value)} values>"
        return [_shorten(v, limit) for v in value]
    return value


def echo_qos(offers: list[QoSProfile | None], say: Say | None = None) -> QoSProfile:
    """The subscription ``topic echo`` makes, adapted to the publishers' offers as
    ``ros2 topic echo`` does (ros2topic ``EchoVerb.choose_qos``): RELIABLE if every publisher
    is, else BEST_EFFORT; TRANSIENT_LOCAL if every publisher is (so what a latched topic
    kept is shown), else VOLATILE; each fallback said in ros2's words. servolab keeps every
    message (KEEP_ALL) where ros2 starts from ``sensor_data`` (depth 5), so a burst is
    echoed whole; with no publisher yet it asks RELIABLE, VOLATILE."""
    from servolab.middleware.qos import HistoryPolicy, QoSProfile, adapted_policies

    known = [q for q in offers if q is not None]
    reliable = sum(q.reliable for q in known)
    latched = sum(q.transient_local for q in known)
    if known and 0 < reliable < len(known) and say is not None:
        say("Some, but not all, publishers are offering QoSReliabilityPolicy.RELIABLE. "
            "Falling back to QoSReliabilityPolicy.BEST_EFFORT as it will connect to all "
            "publishers")
    if known and 0 < latched < len(known) and say is not None:
        say("Some, but not all, publishers are offering QoSDurabilityPolicy.TRANSIENT_LOCAL. "
            "Falling back to QoSDurabilityPolicy.VOLATILE as it will connect to all "
            "publishers")
    reliability, durability = adapted_policies(known)
    return QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=0, reliability=reliability,
                      durability=durability)


def topic_echo(ctx: Context, topic: str, say: Say, *, type_name: str | None = None,
               count: int = 0, no_arrays: bool = False, wait: float = 5.0) -> int:
    """Print each message as YAML followed by ``---``, as ``ros2 topic echo`` does; stops
    after ``count`` messages (0: until Ctrl-C). Returns the number printed. The subscription
    takes the publishers' reliability and durability (:func:`echo_qos`), so the last message
    of a latched (TRANSIENT_LOCAL) topic is shown too."""
    import yaml

    from ._graph import tool_node

    node = tool_node(ctx, "echo")
    topic = node.resolve(topic)
    kind = find_type(ctx, topic, type_name, wait)
    offers = [e.qos for e in ctx.transport.graph(0.2 if type_name is None else DISCOVERY_S)
              if e.kind == "MP" and e.name == topic]
    printed = 0

    def show(msg: Any) -> None:
        nonlocal printed
        if count and printed >= count:
            return
        value = ctx.types.to_value(msg)
        say(yaml.safe_dump(_shorten(value, 16) if no_arrays else value, sort_keys=False,
                           default_flow_style=False).rstrip("\n"))
        say("---")
        printed += 1
        if count and printed >= count:
            ctx.shutdown()

    node.create_subscription(kind, topic, show, qos_profile=echo_qos(offers, say))
    ctx.spin()
    return printed


def topic_pub(ctx: Context, topic: str, type_name: str, values: str, say: Say, *,
              rate: float = 1.0, count: int = 0, wait_matching: float = 2.0) -> int:
    """Publish ``values`` (YAML, as ``rostopic pub`` takes them) ``count`` times (0: until
    Ctrl-C) at ``rate`` Hz (0: as fast as possible). Waits up to ``wait_matching`` s for a
    subscription first, so the first messages are not lost. Returns the number published."""
    from ._graph import tool_node

    kind = ctx.types.check(type_name)
    msg = ctx.types.from_yaml(kind, values)  # refused here, before anything is published
    if rate < 0 or count < 0:
        raise MessageError(f"--rate {rate:g} and --count {count} must be >= 0")
    node = tool_node(ctx, "pub")
    topic = node.resolve(topic)
    pub = node.create_publisher(kind, topic, qos_profile=0)
    matched = pub.wait_for_subscription(wait_matching)  # a condition, not a fixed time
    if not matched:
        say(f"no subscription on {topic} after {wait_matching:g} s; publishing anyway "
            "(nobody may receive it)")
    say(f"publishing {kind} on {topic}" + (f" at {rate:g} Hz" if rate else ""))
    sent = 0
    period = 1.0 / rate if rate else 0.0
    next_time = time.monotonic()
    with ctx.stop_on_signals():
        while ctx.ok() and (not count or sent < count):
            pub.publish(msg)
            sent += 1
            if period:
                say(f"publishing #{sent}")
                next_time += period
                ctx.executor.spin_until(lambda: False, max(0.0, next_time - time.monotonic()))
    return sent


def topic_hz(ctx: Context, topic: str, say: Say, *, type_name: str | None = None,
             window: int = 100, wait: float = 5.0, report_every: float = 1.0,
             reports: int = 0) -> list[float]:
    """Print the average rate over the last ``window`` messages every ``report_every`` s, as
    ``ros2 topic hz`` does; returns the rates reported."""
    import statistics

    from ._graph import tool_node

    node = tool_node(ctx, "hz")
    topic = node.resolve(topic)
    kind = find_type(ctx, topic, type_name, wait)
    stamps: deque[float] = deque(maxlen=window + 1)
    rates: list[float] = []
    node.create_subscription(kind, topic, lambda m, info: stamps.append(
        info.received_timestamp_ns / 1e9), qos_profile=0, raw=True, with_info=True)

    last: list[float] = []

    def report() -> None:  # as ros2's print_hz: nothing until a new message came
        if len(stamps) < 2 or (last and last[0] == stamps[-1]):
            return
        last[:] = [stamps[-1]]
        gaps = [b - a for a, b in zip(list(stamps)[:-1], list(stamps)[1:], strict=True)]
        mean = statistics.fmean(gaps)
        rates.append(1.0 / mean)
        say(f"average rate: {1.0 / mean:.3f}\n\tmin: {min(gaps):.3f}s max: {max(gaps):.3f}s "
            f"std dev: {statistics.pstdev(gaps):.5f}s window: {len(gaps)}")
        if reports and len(rates) >= reports:
            ctx.shutdown()

    node.create_timer(report_every, report)
    ctx.spin()
    return rates


def _unknown_topic(topic: str, graph: list[Endpoint]) -> UsageError:
    import difflib

    from ._graph import listed

    names = sorted({e.name for e in graph if e.kind in ("MP", "MS")})
    near = difflib.get_close_matches(topic, names, n=1)
    guess = f" (did you mean {near[0]}?)" if near else ""
    return UsageError(f"Unknown topic '{topic}'{guess}; the graph has {listed(names)} "
                      "('servolab topic list')")


#: rclpy's names of the endpoint kinds (``TopicEndpointTypeEnum``)
_ENDPOINT_TYPE = {"MP": "PUBLISHER", "MS": "SUBSCRIPTION"}


def endpoint_info(ctx: Context, e: Endpoint) -> str:
    """One publisher or subscription as rclpy's ``TopicEndpointInfo.__str__`` prints it (what
    ``ros2 topic info -v`` shows). The history and depth are the endpoint's own, as
    rmw_zenoh reports them (over DDS rclpy says UNKNOWN); deadline, lifespan and liveliness
    are ROS's defaults, the only ones servolab has. servolab's graph carries no GID, so that
    line is empty unless the transport gives one."""
    namespace, _, name = e.node.rpartition("/")
    gid = getattr(e, "gid", b"") or b""
    if e.qos is None:
        reliability = history = durability = "UNKNOWN"
    else:
        reliability, durability = e.qos.reliability.name, e.qos.durability.name
        history = e.qos.history.name if e.qos.keep_all else \
            f"{e.qos.history.name} ({e.qos.depth})"
    try:
        type_hash = ctx.types.rihs01(e.type_name)
    except (KeyError, MessageError):  # a type this process does not know: no hash to show
        type_hash = ""
    return "\n".join([
        f"Node name: {name}",
        f"Node namespace: {namespace or '/'}",
        f"Topic type: {e.type_name}",
        f"Topic type hash: {type_hash}",
        f"Endpoint type: {_ENDPOINT_TYPE[e.kind]}",
        f"GID: {'.'.join(format(b, '02x') for b in gid)}",
        "QoS profile:",
        f"  Reliability: {reliability}",
        f"  History (Depth): {history}",
        f"  Durability: {durability}",
        "  Lifespan: Infinite",
        "  Deadline: Infinite",
        "  Liveliness: AUTOMATIC",
        "  Liveliness lease duration: Infinite",
    ])


def topic_info(ctx: Context, topic: str, say: Say, *, verbose: bool = False) -> tuple[int, int]:
    """The topic's type and how many publishers and subscriptions it has, as ``ros2 topic
    info`` prints them; ``verbose`` adds each endpoint (:func:`endpoint_info`), every line
    followed by an empty one as ros2 prints it. Hidden nodes' endpoints count, as in ros2.
    Returns (publishers, subscriptions)."""
    from ._graph import names_and_types, topic_name

    topic = topic_name(topic)
    graph = ctx.transport.graph(DISCOVERY_S)
    kinds = names_and_types(graph, ("MP", "MS")).get(topic)
    if kinds is None:
        raise _unknown_topic(topic, graph)
    end = "\n" if verbose else ""
    say(f"Type: {kinds[0] if len(kinds) == 1 else kinds}{end}")
    counts = []
    for kind, label in (("MP", "Publisher"), ("MS", "Subscription")):
        found = sorted((e for e in graph if e.kind == kind and e.name == topic),
                       key=lambda e: (e.node, e.type_name))
        counts.append(len(found))
        say(f"{label} count: {len(found)}{end}")
        if verbose:
            for e in found:
                say(endpoint_info(ctx, e) + end)
    return counts[0], counts[1]


def topic_type(ctx: Context, topic: str, say: Say) -> list[str]:
    """The topic's type(s), one a line, as ``ros2 topic type`` prints them."""
    from ._graph import names_and_types, topic_name

    topic = topic_name(topic)
    graph = ctx.transport.graph(DISCOVERY_S)
    kinds = names_and_types(graph, ("MP", "MS")).get(topic)
    if kinds is None:
        raise _unknown_topic(topic, graph)
    for kind in kinds:
        say(kind)
    return kinds


def _bandwidth_unit(bytes_per_s: float) -> Callable[[float], str]:
    if bytes_per_s < 1000:
        return lambda n: f"{n:.0f} B"
    if bytes_per_s < 1_000_000:
        return lambda n: f"{n / 1000:.2f} KB"
    return lambda n: f"{n / 1000 / 1000:.2f} MB"


def format_bw(bytes_per_s: float, sizes: list[int]) -> str:
    """``ros2 topic bw``'s report: the rate and the message sizes, all in the unit the rate
    needs (B, KB = 1000 B, MB), as ros2topic's ``print_bw``."""
    unit = _bandwidth_unit(bytes_per_s)
    mean = sum(sizes) / len(sizes)
    return (f"{unit(bytes_per_s)}/s from {len(sizes)} messages\n\tMessage size mean: "
            f"{unit(mean)} min: {unit(min(sizes))} max: {unit(max(sizes))}")


def topic_bw(ctx: Context, topic: str, say: Say, *, type_name: str | None = None,
             window: int = 100, wait: float = 5.0, report_every: float = 1.0,
             reports: int = 0) -> list[float]:
    """Print the bandwidth the topic uses (its messages' CDR bytes over the last ``window``
    messages, per second of the time since the first of them) every ``report_every`` s, as
    ``ros2 topic bw`` does; returns the rates (B/s) reported."""
    from servolab.middleware.qos import qos_profile_sensor_data

    from ._graph import tool_node

    if window < 1:
        raise UsageError(f"--window {window} must be 1 or more")
    node = tool_node(ctx, "bw")
    topic = node.resolve(topic)
    kind = find_type(ctx, topic, type_name, wait)
    samples: deque[tuple[float, int]] = deque(maxlen=window)
    rates: list[float] = []
    node.create_subscription(kind, topic, lambda data: samples.append(
        (time.monotonic(), len(data))), qos_profile=qos_profile_sensor_data, raw=True)
    say(f"Subscribed to [{topic}]")

    def report() -> None:
        if len(samples) < 2:
            return
        elapsed = time.monotonic() - samples[0][0]
        if elapsed <= 0:
            return
        sizes = [size for _, size in samples]
        rates.append(sum(sizes) / elapsed)
        say(format_bw(rates[-1], sizes))
        if reports and len(rates) >= reports:
            ctx.shutdown()

    node.create_timer(report_every, report)
    ctx.spin()
    return rates


def _add_arguments(parser: argparse.ArgumentParser) -> None:
    actions = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    p = actions.add_parser("list", help="topics in the graph")
    p.add_argument("-t", "--show-types", action="store_true", help="show each topic's type")
    p.add_argument("-v", "--verbose", action="store_true",
                   help="types, and how many publishers and subscriptions")
    p.add_argument("--include-hidden-topics", action="store_true",
                   help="hidden topics too (a part of the name starting with _)")
    add_transport(p)
    p = actions.add_parser(
        "echo", help="print a topic's messages as YAML",
        description="Print a topic's messages as YAML, each followed by '---', as 'ros2 topic "
        "echo' does. Its subscription takes reliability and durability from the publishers, as "
        "ros2's does: a latched (TRANSIENT_LOCAL) topic's last message is shown. Where "
        "servolab differs: it keeps every message (KEEP_ALL) where ros2 keeps 5.")
    p.add_argument("topic")
    p.add_argument("--type", dest="type_name", help="message type (default: from the graph)")
    p.add_argument("--count", type=int, default=0, help="stop after N messages")
    p.add_argument("--no-arr", action="store_true", help="abbreviate long arrays")
    add_transport(p)
    p = actions.add_parser("pub", help="publish YAML values, as rostopic pub")
    p.add_argument("topic")
    p.add_argument("type_name", metavar="TYPE", help="e.g. geometry_msgs/msg/Twist")
    p.add_argument("values", metavar="VALUES", nargs="?", default="",
                   help="YAML, e.g. \"{linear: {x: 0.1}, angular: {z: 0.5}}\"")
    p.add_argument("--rate", type=float, default=1.0, help="Hz; 0: as fast as possible")
    p.add_argument("--count", type=int, default=0, help="publish N times (default: forever)")
    p.add_argument("--once", action="store_const", const=1, dest="count",
                   help="publish once (--count 1)")
    p.add_argument("--wait-matching", type=float, default=2.0, metavar="SECONDS",
                   help="wait up to this long for a subscription before the first message "
                        "(default 2; says so if none came)")
    add_transport(p)
    _add_inspecting(actions)


def _add_inspecting(actions: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """The actions that measure or describe a topic without printing its messages."""
    p = actions.add_parser("hz", help="measure a topic's rate")
    p.add_argument("topic")
    p.add_argument("--type", dest="type_name", help="message type (default: from the graph)")
    p.add_argument("--window", type=int, default=100,
                   help="average over the last N messages (default 100)")
    add_transport(p)
    p = actions.add_parser(
        "bw", help="measure a topic's bandwidth, as ros2 topic bw",
        description="Print every second the bandwidth a topic uses (its messages' serialized "
        "bytes over the last --window messages) and their sizes, as 'ros2 topic bw' does.")
    p.add_argument("topic")
    p.add_argument("--type", dest="type_name", help="message type (default: from the graph)")
    p.add_argument("-w", "--window", type=int, default=100,
                   help="over the last N messages (default 100)")
    add_transport(p)
    p = actions.add_parser(
        "info", help="a topic's type and its publishers and subscriptions, as ros2 topic info",
        description="Print a topic's type and how many publishers and subscriptions it has, as "
        "'ros2 topic info' does; -v shows each one. Where servolab differs: History (Depth) is "
        "the endpoint's own (as over rmw_zenoh; over DDS ros2 says UNKNOWN), and the GID line "
        "is empty (servolab's graph does not carry it).")
    p.add_argument("topic", help="e.g. /cmd_vel (a relative name is taken from /)")
    p.add_argument("-v", "--verbose", action="store_true",
                   help="node name, namespace, type, type hash, GID and QoS of each endpoint")
    add_transport(p)
    p = actions.add_parser(
        "type", help="a topic's type, as ros2 topic type",
        description="Print a topic's type, as 'ros2 topic type' does. Where servolab differs: "
        "a topic not in the graph is an error naming the topics there are (exit status 2; "
        "ros2 prints nothing and exits 1).")
    p.add_argument("topic", help="e.g. /cmd_vel")
    add_transport(p)


def _run(args: argparse.Namespace) -> int:
    from servolab.middleware.context import Context

    from ._graph import say

    with Context.open(transport_options(args)) as ctx:
        if args.action != "pub":
            ctx.transport.check_reachable()  # not an empty graph from an endpoint gone wrong
        if args.action == "list":
            topic_list(ctx, say, show_types=args.show_types, verbose=args.verbose,
                       include_hidden=args.include_hidden_topics)
        elif args.action == "echo":
            topic_echo(ctx, args.topic, say, type_name=args.type_name, count=args.count,
                       no_arrays=args.no_arr)
        elif args.action == "pub":
            sent = topic_pub(ctx, args.topic, args.type_name, args.values, say,
                             rate=args.rate, count=args.count,
                             wait_matching=args.wait_matching)
            print(f"published {sent} message(s)", file=sys.stderr)
        elif args.action == "hz":
            topic_hz(ctx, args.topic, say, type_name=args.type_name, window=args.window)
        elif args.action == "bw":
            topic_bw(ctx, args.topic, say, type_name=args.type_name, window=args.window)
        elif args.action == "info":
            topic_info(ctx, args.topic, say, verbose=args.verbose)
        elif args.action == "type":
            topic_type(ctx, args.topic, say)
    return 0


COMMAND = Command(
    name="topic", group="graph", help="list, echo, publish, time and inspect topics",
    description="Look at and poke the topics of a running graph, as 'ros2 topic' does.",
    examples=("servolab topic list -t",
              "servolab topic echo /cmd_vel --count 5",
              "servolab topic pub /cmd_vel geometry_msgs/msg/Twist "
              "\"{linear: {x: 0.1}}\" --rate 10",
              "servolab topic hz /cmd_vel --connect tcp/robot.local:7447",
              "servolab topic info /cmd_vel -v",
              "servolab topic bw /scan"),
    add_arguments=_add_arguments, run=_run)
