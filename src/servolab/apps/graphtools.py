"""What ``servolab topic`` and ``servolab param`` do: look at and poke a running graph, as
``ros2 topic`` / ``rostopic`` and ``ros2 param`` do.

Every function takes an open :class:`~servolab.middleware.context.Context` and a ``say``
function for its output, so the CLI stays a parser and the tests can capture what is printed.
Values are checked before anything is published or set.
"""

from __future__ import annotations

import statistics
import time
from collections import deque
from collections.abc import Callable
from typing import Any

import yaml

from servolab.middleware.context import Context
from servolab.middleware.errors import MessageError, ParameterError, ServiceError
from servolab.middleware.node import Node
from servolab.middleware.parameters import from_parameter_value, to_parameter_value

Say = Callable[[str], None]
DISCOVERY_S = 0.5


def _tool_node(ctx: Context, what: str) -> Node:
    """A hidden node (its name starts with ``_``, as ``ros2`` CLI nodes' do)."""
    return Node(ctx, f"_servolab_{what}_{time.time_ns() % 1_000_000}")


def _hidden(node: str) -> bool:
    return node.rsplit("/", 1)[-1].startswith("_")


def topics(ctx: Context, timeout: float = DISCOVERY_S) -> dict[str, set[str]]:
    """Topic name -> the message types its publishers and subscriptions use."""
    found: dict[str, set[str]] = {}
    for e in ctx.transport.graph(timeout):
        if e.kind in ("MP", "MS"):
            found.setdefault(e.name, set()).add(e.type_name)
    return found


def topic_list(ctx: Context, say: Say, *, show_types: bool = False,
               verbose: bool = False) -> list[str]:
    graph = [e for e in ctx.transport.graph(DISCOVERY_S) if not _hidden(e.node)]
    names = sorted({e.name for e in graph if e.kind in ("MP", "MS")})
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


def topic_echo(ctx: Context, topic: str, say: Say, *, type_name: str | None = None,
               count: int = 0, no_arrays: bool = False, wait: float = 5.0) -> int:
    """Print each message as YAML followed by ``---``, as ``ros2 topic echo`` does; stops
    after ``count`` messages (0: until Ctrl-C). Returns the number printed."""
    node = _tool_node(ctx, "echo")
    topic = node.resolve(topic)
    kind = find_type(ctx, topic, type_name, wait)
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

    node.create_subscription(kind, topic, show, depth=0)
    ctx.spin()
    return printed


def topic_pub(ctx: Context, topic: str, type_name: str, values: str, say: Say, *,
              rate: float = 1.0, count: int = 0, wait_matching: float = 2.0) -> int:
    """Publish ``values`` (YAML, as ``rostopic pub`` takes them) ``count`` times (0: until
    Ctrl-C) at ``rate`` Hz (0: as fast as possible). Waits up to ``wait_matching`` s for a
    subscription first, so the first messages are not lost. Returns the number published."""
    kind = ctx.types.check(type_name)
    msg = ctx.types.from_yaml(kind, values)  # refused here, before anything is published
    if rate < 0 or count < 0:
        raise MessageError(f"--rate {rate:g} and --count {count} must be >= 0")
    node = _tool_node(ctx, "pub")
    topic = node.resolve(topic)
    pub = node.create_publisher(kind, topic, depth=0)
    end = time.monotonic() + wait_matching
    while time.monotonic() < end and not any(
            e.kind == "MS" and e.name == topic for e in ctx.transport.graph(0.2)):
        time.sleep(0.05)
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
    time.sleep(0.2 if ctx.transport.carries_bytes else 0.0)  # let the last puts leave
    return sent


def topic_hz(ctx: Context, topic: str, say: Say, *, type_name: str | None = None,
             window: int = 100, wait: float = 5.0, report_every: float = 1.0,
             reports: int = 0) -> list[float]:
    """Print the average rate over the last ``window`` messages every ``report_every`` s, as
    ``ros2 topic hz`` does; returns the rates reported."""
    node = _tool_node(ctx, "hz")
    topic = node.resolve(topic)
    kind = find_type(ctx, topic, type_name, wait)
    stamps: deque[float] = deque(maxlen=window + 1)
    rates: list[float] = []
    node.create_subscription(kind, topic, lambda m, info: stamps.append(
        info.received_timestamp_ns / 1e9), depth=0, raw=True)

    def report() -> None:
        if len(stamps) < 2:
            say(f"no new messages on {topic}")
            return
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


# -- parameters -------------------------------------------------------------------------------

def _param_nodes(ctx: Context) -> list[str]:
    return sorted({e.node for e in ctx.transport.graph(DISCOVERY_S)
                   if e.kind == "SS" and e.name == f"{e.node}/list_parameters"
                   and not _hidden(e.node)})


def _client(ctx: Context, node_name: str, service: str) -> Any:
    node = _tool_node(ctx, "param")
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
    client = _client(ctx, node_name, "get_parameters")
    values = client.call(client.request(names=[name]), timeout=timeout).values
    value = from_parameter_value(values[0]) if values else None
    if value is None:
        raise ParameterError(f"{node_name} has no parameter {name!r}")
    say(f"{name}: {value!r}")
    return value


def param_set(ctx: Context, node_name: str, name: str, text: str, say: Say,
              timeout: float = 2.0) -> None:
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


__all__ = ["ServiceError", "param_get", "param_list", "param_set", "topic_echo", "topic_hz",
           "topic_list", "topic_pub", "topics"]
