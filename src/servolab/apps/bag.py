"""``servolab bag record | play | info | reindex``: MCAP bags in the rosbag2 layout, as
``ros2 bag``.

Each function takes plain values and a ``say`` function for its output, so tests can call it
and capture what is printed. The middleware (and Zenoh) is imported inside the functions, so
that ``servolab --help`` does not load it.

How ``bag info`` prints a bag (:func:`format_info`, as ``ros2 bag info``) is presentation, so
it is here, not in :mod:`servolab.middleware.bag`, which knows files and timestamps.
"""

from __future__ import annotations

import argparse
import math
import re
import time
from collections.abc import Callable, Mapping
from datetime import datetime
from typing import TYPE_CHECKING

from servolab.errors import UsageError
from servolab.middleware.errors import BagError, MessageError

from .arguments import add_transport, transport_options
from .registry import Command

if TYPE_CHECKING:
    from servolab.middleware.bag import BagCheck, BagDamage, BagInfo
    from servolab.middleware.context import Context
    from servolab.middleware.messages import MessageTypes
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


def compile_regex(option: str, text: str | None) -> re.Pattern[str] | None:
    """``--regex`` / ``--exclude-regex`` compiled, or a one-line error naming it."""
    if text is None:
        return None
    try:
        return re.compile(text)
    except re.error as exc:
        raise UsageError(f"{option} {text!r} is not a regular expression ({exc}); e.g. "
                         "'/robot/.*'") from None


def record(ctx: Context, output: str, topics: list[str], say: Say, *,
           types: dict[str, str] | None = None, all_topics: bool = False,
           regex: str | None = None, exclude: str | None = None) -> dict[str, int]:
    """Record until Ctrl-C or SIGTERM; the bag is complete either way. Returns the counts.
    ``all_topics`` and ``regex`` add the topics publishers appear on while recording (all,
    or those the expression matches), as ``ros2 bag record -a`` and ``-e``."""
    from servolab.middleware.recorder import Recorder

    pattern = compile_regex("--regex", regex)
    excluded = compile_regex("--exclude-regex", exclude)
    if not (topics or all_topics or pattern):
        raise UsageError("nothing to record: name topics, or give -a (all topics) or "
                         "-e REGEX (topics matching it)")
    recorder = Recorder(ctx, output, topics, types=types, all_topics=all_topics,
                        regex=pattern, exclude=excluded)
    say(f"recording to {recorder.writer.path} (Ctrl-C to stop)")
    if all_topics or pattern:
        which = "every topic" if all_topics else f"the topics matching {regex!r}"
        say(f"recording {which} a publisher appears on")
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


def wait_for_subscriptions(publishers: Mapping[str, Publisher], timeout: float) -> list[str]:
    """Wait up to ``timeout`` s in all until every publisher has a subscription that what it
    publishes reaches (:meth:`Publisher.wait_for_subscription`); the topics still without
    one (none: all matched)."""
    end = time.monotonic() + timeout
    return sorted(topic for topic, pub in publishers.items()
                  if not pub.wait_for_subscription(max(0.0, end - time.monotonic())))


def damage_warner(action: str, warn: Say | None = None) -> Callable[[BagDamage], None]:
    """What a command does with each damaged part of a bag it reads: one line on stderr,
    ``servolab bag ACTION: warning: FILE at byte N: ...``, and it goes on."""
    from ._graph import warn as to_stderr

    shown = warn or to_stderr

    def report(damage: BagDamage) -> None:
        shown(f"servolab bag {action}: warning: {damage}")

    return report


def play_bag(ctx: Context, path: str, say: Say, *, rate: float = 1.0,
             topics: list[str] | None = None, wait_matching: float = 2.0,
             warn: Say | None = None, strict: bool = False) -> int:
    """Publish a bag's messages on their topics at the bag's pace times ``rate``. A damaged
    part is said and skipped, the rest played; ``strict`` (the command line's) then ends in
    a one-line :class:`BagError` (exit status 2), so that a script learns of the damage.

    Waits up to ``wait_matching`` s for a subscription on every topic played first (not a
    fixed time), so subscribers started just before lose no message; says so, and plays
    anyway, for topics that have none by then. A damaged chunk is said on stderr (``warn``)
    and skipped; the rest plays."""
    from servolab.middleware.bag import BagReader, play
    from servolab.middleware.node import Node

    reader = BagReader(path, ctx.types, on_damage=damage_warner("play", warn))
    info = reader.info()
    chosen = [t for t in info.topics if topics is None or t.name in topics]
    node = Node(ctx, f"_servolab_player_{time.time_ns() % 1_000_000}")
    try:
        publishers: dict[str, Publisher] = {
            t.name: node.create_publisher(t.type, t.name, qos_profile=0) for t in chosen}
        unmatched = wait_for_subscriptions(publishers, wait_matching)
        if unmatched:
            say(f"no subscription on {', '.join(unmatched)} after {wait_matching:g} s; "
                "playing anyway (nobody may receive those)")
        total = sum(t.count for t in chosen)
        say(f"playing {total} message(s) of {path} at {rate:g}x")
        shown = [time.monotonic()]

        def progress(done: int, total: int) -> None:
            if time.monotonic() - shown[0] >= 1.0 or done == total:
                shown[0] = time.monotonic()
                say(f"  {done}/{total}")

        with ctx.stop_on_signals():
            played = play(reader,
                          lambda topic, kind, data: publishers[topic].publish_serialized(data),
                          rate=math.inf if rate == 0 else rate, clock=ctx.clock, topics=topics,
                          should_stop=lambda: not ctx.ok(), progress=progress)
    finally:
        node.destroy()
    damaged = reader.damage
    skipped = f"; the file has {len(damaged)} damaged part(s), said above" if damaged else ""
    say(f"played {played} message(s){skipped}")
    if damaged and strict:  # what was sound was played; a script must learn it was damaged
        raise BagError(f"{path}: {len(damaged)} damaged part(s) skipped (servolab bag "
                       "reindex keeps what is sound)")
    return played


def _size(n: int) -> str:
    if n < 1024:
        return f"{n} B"
    value, unit = n / 1024, "KiB"
    for bigger in ("MiB", "GiB"):
        if value < 1024:
            break
        value, unit = value / 1024, bigger
    return f"{value:.1f} {unit}"


def _stamp(ns: int) -> str:
    local = datetime.fromtimestamp(ns / 1e9).strftime("%b %d %Y %H:%M:%S")
    return f"{local}.{ns % 1_000_000_000:09d} ({ns // 1_000_000_000}.{ns % 1_000_000_000:09d})"


def format_info(info: BagInfo) -> str:
    """The bag described as ``ros2 bag info`` does."""
    label = 19
    lines = [
        f"{'Files:':<{label}}{info.path}",
        f"{'Bag size:':<{label}}{_size(info.size_bytes)}",
        f"{'Storage id:':<{label}}mcap",
        f"{'Duration:':<{label}}{info.duration_s:.9f}s",
        f"{'Start:':<{label}}{_stamp(info.start_ns)}",
        f"{'End:':<{label}}{_stamp(info.end_ns)}",
        f"{'Messages:':<{label}}{info.message_count}",
    ]
    if info.recovered and not info.damage:
        lines.append(f"{'Recovered:':<{label}}the recording was cut short; "
                     f"{info.message_count} messages read from its complete chunks, "
                     f"last {info.lost_bytes} bytes lost")
    elif info.recovered:
        lost = f", last {info.lost_bytes} bytes lost" if info.lost_bytes else ""
        lines.append(f"{'Recovered:':<{label}}no usable summary; {info.message_count} "
                     f"messages read record by record from its sound chunks{lost}")
    lines.extend(_damage_lines("Damaged:", info.damage, label))
    name_w = max((len(t.name) for t in info.topics), default=0)
    type_w = max((len(t.type) for t in info.topics), default=0)
    rows = [f"Topic: {t.name:<{name_w}} | Type: {t.type:<{type_w}} | Count: {t.count} | "
            f"Serialization Format: cdr" for t in info.topics] or ["(none)"]
    lines.append(f"{'Topic information:':<{label}}{rows[0]}")
    lines.extend(" " * label + row for row in rows[1:])
    return "\n".join(lines)


def _damage_lines(title: str, damage: tuple[BagDamage, ...], label: int) -> list[str]:
    """One line a damaged part (its byte and what it is; the file is named above)."""
    rows = [f"byte {d.offset}: {d.text}" for d in damage]
    if not rows:
        return []
    return [f"{title:<{label}}{rows[0]}", *(" " * label + row for row in rows[1:])]


def format_check(checked: BagCheck, listed: tuple[BagDamage, ...] = ()) -> str:
    """What ``bag info --check`` found, below the bag's description (which lists ``listed``
    already)."""
    label = 19
    head = (f"{'Check:':<{label}}{checked.chunks} sound chunk(s), {checked.messages} "
            "message(s)")
    if checked.sound:
        return (head + "; every chunk's CRC matches, every record is whole, the summary "
                "agrees with them")
    head += f"; {len(checked.problems)} problem(s)"
    more = tuple(d for d in checked.problems if d not in listed)
    return "\n".join([head, *_damage_lines("Also:", more, label)])


def check_bag(path: str, say: Say, types: MessageTypes | None = None) -> None:
    """``bag info --check``: the description, then every damaged part; a damaged bag is a
    one-line error (exit status 2) after the listing."""
    from servolab.middleware.bag import BagReader
    from servolab.middleware.errors import BagError
    from servolab.middleware.messages import MessageTypes

    reader = BagReader(path, types or MessageTypes(),
                       on_damage=lambda damage: None)  # listed below
    checked = reader.check()
    info = reader.info()  # with every damaged part the check found
    say(format_info(info))
    say(format_check(checked, info.damage))
    if not checked.sound:
        raise BagError(f"{checked.path} is damaged: {len(checked.problems)} problem(s), "
                       f"listed above; `servolab bag reindex {path}` keeps what is sound")


def reindex_bag(path: str, say: Say, warn: Say | None = None,
                types: MessageTypes | None = None) -> None:
    """Rewrite a cut-short or damaged bag as a complete one; a sound bag is left alone."""
    from servolab.middleware.bag import reindex
    from servolab.middleware.messages import MessageTypes

    found = reindex(path, types or MessageTypes(), on_damage=damage_warner("reindex", warn))
    if found is None:
        say(f"{path} is complete and sound (every chunk checked); nothing to do")
        return
    lost = f"; the last {found.lost_bytes} byte(s), an unfinished record, were dropped" if (
        found.lost_bytes) else ""
    if found.damage:
        lost += (f"; {len(found.damage)} damaged part(s) found (said above), the damaged "
                 f"file kept as {found.path.name}.damaged")
    say(f"reindexed {found.path}: {found.message_count} message(s) kept{lost}")


def _add_arguments(parser: argparse.ArgumentParser) -> None:
    actions = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    p = actions.add_parser("record", help="record topics to an MCAP bag (rosbag2 layout)")
    p.add_argument("topics", nargs="*", metavar="TOPIC")
    p.add_argument("-a", "--all", "--all-topics", dest="all_topics", action="store_true",
                   help="every topic, also those that appear while recording (hidden ones "
                   "left out; servolab records no services)")
    p.add_argument("-e", "--regex", metavar="REGEX",
                   help="the topics whose name this regular expression matches (searched, "
                   "as rosbag2 does), also those that appear while recording")
    p.add_argument("-x", "--exclude-regex", metavar="REGEX",
                   help="leave out the topics -a or -e found whose name this matches")
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
    p.add_argument("--wait-matching", type=float, default=2.0, metavar="SECONDS",
                   help="wait up to this long for a subscription on every topic before the "
                        "first message (default 2; says so for topics that have none)")
    add_transport(p)
    p = actions.add_parser("info", help="topics, types, counts and duration of a bag")
    p.add_argument("path")
    p.add_argument("--check", action="store_true",
                   help="also read the whole file: every chunk's CRC, every record, the "
                   "summary against them; say what is damaged (exit status 2 if anything is)")
    p = actions.add_parser("reindex", help="make a bag whose recording was killed, or whose "
                           "file is damaged, a complete file (summary, index, metadata.yaml) of "
                           "what is sound, that every MCAP reader opens")
    p.add_argument("path", help="bag folder or .mcap file")


def _run(args: argparse.Namespace) -> int:
    from servolab.middleware.bag import BagReader
    from servolab.middleware.context import Context
    from servolab.middleware.messages import MessageTypes

    from ._graph import say

    if args.action == "info":
        if args.check:
            check_bag(args.path, say)
            return 0
        reader = BagReader(args.path, MessageTypes(), on_damage=lambda damage: None)
        say(format_info(reader.info()))  # with what opening found damaged
        return 0
    if args.action == "reindex":
        reindex_bag(args.path, say)
        return 0
    types = parse_topic_types(args.types) if args.action == "record" else None
    if args.action == "record":  # what the user typed is checked before joining the graph
        compile_regex("--regex", args.regex)
        compile_regex("--exclude-regex", args.exclude_regex)
        if not (args.topics or args.all_topics or args.regex):
            raise UsageError("nothing to record: name topics, or give -a (all topics) or "
                             "-e REGEX (topics matching it)")
    with Context.open(transport_options(args)) as ctx:
        if args.action == "record":
            record(ctx, args.output, args.topics, say, types=types, all_topics=args.all_topics,
                   regex=args.regex, exclude=args.exclude_regex)
        elif args.action == "play":
            play_bag(ctx, args.path, say, rate=args.rate, topics=args.topics,
                     wait_matching=args.wait_matching, strict=True)
    return 0


COMMAND = Command(
    name="bag", group="graph", help="record, play and inspect MCAP bags",
    description="Record topics to an MCAP bag in the rosbag2 layout (Foxglove and ros2 bag "
    "open it), play one back, show what is in one (--check: and whether it is damaged), or "
    "make a killed recording or a damaged file a complete one again.",
    examples=("servolab bag record /cmd_vel /odom -o runs/drive1",
              "servolab bag record -a -o runs/everything",
              "servolab bag record -e '/robot/.*' -o runs/robot",
              "servolab bag info runs/drive1",
              "servolab bag info --check runs/drive1",
              "servolab bag play runs/drive1 --rate 2",
              "servolab bag reindex runs/drive1"),
    add_arguments=_add_arguments, run=_run)
