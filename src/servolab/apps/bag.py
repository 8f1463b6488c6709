"""``servolab bag record | play | info | reindex``: MCAP bags in the rosbag2 layout, as
``ros2 bag``.

Each function takes plain values and a ``say`` function for its output, so tests can call it
and capture what is printed. The middleware (and Zenoh) is imported inside the functions, so
that ``servolab --help`` does not load it.
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

from servolab.middleware.errors import MessageError

from .arguments import add_transport, transport_options
from .registry import Command

if TYPE_CHECKING:
    from servolab.middleware.context import Context
    from servolab.middleware.publisher import Publisher

Say = Callable[[str], None]


def parse_topic_types(pairs: list[str]) -> dict[str, str]:
    """``/cmd_vel:geometry_msgs/msg/Twist`` pairs of ``--type``."""
    types = {}
    for pair in pairs:
        topic, sep, kind = pair.partition(":")
        if not sep or not topic or not kind:
            raise MessageError(f"--type {pair!r} is not TOPIC:TYPE, e.g. "
                               "/cmd_vel:geometry_msgs/msg/Twist")
        types[topic] = kind
    return types


def record(ctx: Context, output: str, topics: list[str], say: Say, *,
           types: dict[str, str] | None = None) -> dict[str, int]:
    """Record until Ctrl-C or SIGTERM; the bag is complete either way. Returns the counts."""
    from servolab.middleware.recorder import Recorder

    recorder = Recorder(ctx, output, topics, types=types)
    say(f"recording to {recorder.writer.path} (Ctrl-C to stop)")
    if recorder.waiting_for:
        say(f"waiting for publishers of {', '.join(recorder.waiting_for)}")
    try:
        ctx.spin()
    finally:
        recorder.destroy()
    total = sum(recorder.counts.values())
    say(f"recorded {total} message(s) to {recorder.writer.path}: " + ", ".join(
        f"{t} {n}" for t, n in recorder.counts.items()))
    return recorder.counts


def play_bag(ctx: Context, path: str, say: Say, *, rate: float = 1.0,
             topics: list[str] | None = None, wait_matching: float = 1.0) -> int:
    """Publish a bag's messages on their topics at the bag's pace times ``rate``."""
    from servolab.middleware.bag import BagReader, play
    from servolab.middleware.node import Node

    reader = BagReader(path, ctx.types)
    info = reader.info()
    chosen = [t for t in info.topics if topics is None or t.name in topics]
    node = Node(ctx, f"_servolab_player_{time.time_ns() % 1_000_000}")
    publishers: dict[str, Publisher] = {
        t.name: node.create_publisher(t.type, t.name, qos_profile=0) for t in chosen}
    end = time.monotonic() + wait_matching
    while time.monotonic() < end and not any(
            e.kind == "MS" and e.name in publishers for e in ctx.transport.graph(0.2)):
        time.sleep(0.05)
    total = sum(t.count for t in chosen)
    say(f"playing {total} message(s) of {path} at {rate:g}x")
    shown = [time.monotonic()]

    def progress(done: int, total: int) -> None:
        if time.monotonic() - shown[0] >= 1.0 or done == total:
            shown[0] = time.monotonic()
            say(f"  {done}/{total}")

    with ctx.stop_on_signals():
        played = play(reader, lambda topic, kind, data: publishers[topic].publish_serialized(data),
                      rate=math.inf if rate == 0 else rate, clock=ctx.clock, topics=topics,
                      should_stop=lambda: not ctx.ok(), progress=progress)
    time.sleep(0.2 if ctx.transport.carries_bytes else 0.0)  # let the last puts leave
    say(f"played {played} message(s)")
    return played


def reindex_bag(path: str, say: Say) -> None:
    """Rewrite a cut-short bag as a complete one; a complete bag is left alone."""
    from servolab.middleware.bag import reindex
    from servolab.middleware.messages import MessageTypes

    found = reindex(path, MessageTypes())
    if found is None:
        say(f"{path} is complete (it has its summary and index); nothing to do")
        return
    lost = f"; the last {found.lost_bytes} byte(s), an unfinished chunk, were dropped" if (
        found.lost_bytes) else ""
    say(f"reindexed {found.path}: {found.message_count} message(s) kept{lost}")


def _add_arguments(parser: argparse.ArgumentParser) -> None:
    actions = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    p = actions.add_parser("record", help="record topics to an MCAP bag (rosbag2 layout)")
    p.add_argument("topics", nargs="+", metavar="TOPIC")
    p.add_argument("-o", "--output", required=True, metavar="PATH", help="bag folder to create")
    p.add_argument("--type", dest="types", action="append", default=[], metavar="TOPIC:TYPE",
                   help="type of a topic not yet in the graph, e.g. /cmd_vel:geometry_msgs/"
                   "msg/Twist")
    add_transport(p)
    p = actions.add_parser("play", help="publish a bag's messages at its own (or a scaled) rate")
    p.add_argument("path")
    p.add_argument("--rate", type=float, default=1.0, help="speed factor; 0: as fast as "
                   "possible")
    p.add_argument("--topics", nargs="+", metavar="TOPIC", help="play only these topics")
    add_transport(p)
    p = actions.add_parser("info", help="topics, types, counts and duration of a bag")
    p.add_argument("path")
    p = actions.add_parser("reindex", help="make a bag whose recording was killed a complete "
                           "file (summary, index, metadata.yaml) that every MCAP reader opens")
    p.add_argument("path", help="bag folder or .mcap file")


def _run(args: argparse.Namespace) -> int:
    from servolab.middleware.bag import BagReader, format_info
    from servolab.middleware.context import Context
    from servolab.middleware.messages import MessageTypes

    from ._graph import say

    if args.action == "info":
        say(format_info(BagReader(args.path, MessageTypes()).info()))
        return 0
    if args.action == "reindex":
        reindex_bag(args.path, say)
        return 0
    types = parse_topic_types(args.types) if args.action == "record" else None
    with Context.open(transport_options(args)) as ctx:
        if args.action == "record":
            record(ctx, args.output, args.topics, say, types=types)
        elif args.action == "play":
            play_bag(ctx, args.path, say, rate=args.rate, topics=args.topics)
    return 0


COMMAND = Command(
    name="bag", group="graph", help="record, play and inspect MCAP bags",
    description="Record topics to an MCAP bag in the rosbag2 layout (Foxglove and ros2 bag "
    "open it), play one back, show what is in one, or make a killed recording a complete "
    "file again.",
    examples=("servolab bag record /cmd_vel /odom -o runs/drive1",
              "servolab bag info runs/drive1",
              "servolab bag play runs/drive1 --rate 2",
              "servolab bag reindex runs/drive1"),
    add_arguments=_add_arguments, run=_run)
