"""What ``servolab bag record | play | info`` do."""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable

from servolab.middleware.bag import BagReader, format_info, play
from servolab.middleware.context import Context
from servolab.middleware.errors import MessageError
from servolab.middleware.messages import MessageTypes
from servolab.middleware.node import Node, Publisher
from servolab.middleware.recorder import Recorder
from servolab.middleware.transport import TransportOptions

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
    reader = BagReader(path, ctx.types)
    info = reader.info()
    chosen = [t for t in info.topics if topics is None or t.name in topics]
    node = Node(ctx, f"_servolab_player_{time.time_ns() % 1_000_000}")
    publishers: dict[str, Publisher] = {
        t.name: node.create_publisher(t.type, t.name, depth=0) for t in chosen}
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


def dispatch(args: argparse.Namespace,
             options: Callable[[argparse.Namespace], TransportOptions], say: Say) -> int:
    if args.action == "info":
        say(format_info(BagReader(args.path, MessageTypes()).info()))
        return 0
    types = parse_topic_types(args.types) if args.action == "record" else None
    with Context.open(options(args)) as ctx:
        if args.action == "record":
            record(ctx, args.output, args.topics, say, types=types)
        elif args.action == "play":
            play_bag(ctx, args.path, say, rate=args.rate, topics=args.topics)
    return 0
