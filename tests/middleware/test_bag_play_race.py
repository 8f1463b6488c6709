"""No start-up race in ``servolab bag play``: a bag played into subscriptions made just before
loses none of its messages, the first ones included.

``bag play`` makes its publishers and then waits (boundedly) until every topic it plays has a
subscription it can reach, as ``topic pub --wait-matching`` does; over Zenoh a subscription in
another session or process is known by its liveliness token and by the session's routes. Each
test repeats the race many times, each time with fresh subscriptions on fresh topics.
"""

from __future__ import annotations

import sys
import threading
from pathlib import Path

import pytest

from servolab.middleware.bag import BagWriter
from servolab.middleware.context import Context
from servolab.middleware.messages import MessageTypes
from servolab.middleware.transport import MessageInfo, NodeInfo
from tests.clirun import servolab
from tests.middleware.conftest import free_port
from tests.middleware.inboxes import subscribe_with
from tests.processes import started
from tests.waiting import wait_for, wait_for_line

STRING = "std_msgs/msg/String"
REPETITIONS = 200
#: Messages a topic holds in each bag: fewer than a subscription's default depth (10), so
#: nothing may be dropped by the queue itself however fast the bag is played.
PER_TOPIC = 4


def write_bag(path: Path, types: MessageTypes, topics: list[str]) -> list[tuple[str, str]]:
    """A small bag on ``topics``, their messages interleaved 1 ms apart; returns the
    (topic, text) of each message in order."""
    order = [(topic, f"{topic} #{i}") for i in range(PER_TOPIC) for topic in topics]
    with BagWriter(path, types) as writer:
        for topic in topics:
            writer.add_topic(topic, STRING)
        for k, (topic, text) in enumerate(order):
            writer.write(topic, types.serialize(types.from_value(STRING, {"data": text})),
                         1_700_000_000_000_000_000 + k * 1_000_000)
    return order


def play_once(player: Context, listener: Context, bag: Path, topics: list[str]) -> str | None:
    """Subscriptions on ``topics`` appear in ``listener``, and at once ``player`` plays a new
    bag on them as fast as it can (``bag play --rate 0``); what was lost, if anything."""
    from servolab.apps.bag import play_bag

    order = write_bag(bag, player.types, topics)
    wanted = {t: [text for topic, text in order if topic == t] for t in topics}
    got: dict[str, list[str]] = {t: [] for t in topics}
    lock = threading.Lock()

    def deliver(data: bytes, info: MessageInfo, topic: str) -> None:
        text = listener.types.deserialize(data, STRING).data
        with lock:
            got[topic].append(text)

    def complete() -> bool:
        with lock:
            return all(len(got[t]) >= len(wanted[t]) for t in topics)

    node = NodeInfo("listener", node_id=7)
    subscriptions = [subscribe_with(
        listener.transport, node, t, STRING, lambda data, info, t=t: deliver(data, info, t),
        raw=True) for t in topics]
    try:
        said: list[str] = []
        played = play_bag(player, str(bag), said.append, rate=0, wait_matching=20.0)
        assert played == len(order), said
        assert not any("no subscription" in s for s in said), said
        try:
            # Generous: a loaded 2-core machine is slow; a lost message never comes.
            wait_for(complete, f"the messages of {bag}", timeout=10.0)
        except AssertionError:
            return f"{bag.name}: {({t: len(v) for t, v in got.items()})}"
        assert got == wanted, f"{bag.name}: out of order or repeated"
        return None
    finally:
        for s in subscriptions:
            s.close()


def play_race(player: Context, listener: Context, tmp_path: Path, repetitions: int,
              prefix: str = "/race") -> None:
    """``repetitions`` times :func:`play_once`, on fresh topics: every message arrives, in
    each topic's order."""
    lost = [loss for k in range(repetitions)
            if (loss := play_once(player, listener, tmp_path / f"bag_{k}",
                                  [f"{prefix}_{k}/a", f"{prefix}_{k}/b"]))]
    assert not lost, f"{len(lost)} of {repetitions} plays lost messages: {lost[:5]}"


@pytest.mark.slow
def test_play_into_local_subscriptions_made_just_before(tmp_path: Path,
                                                        types: MessageTypes) -> None:
    """In one process on the in-process transport, 200 times."""
    ctx = Context.open(types=types)
    try:
        play_race(ctx, ctx, tmp_path, REPETITIONS)
    finally:
        ctx.close()


@pytest.mark.slow
def test_play_into_zenoh_subscriptions_made_just_before(tmp_path: Path, zenoh_pair) -> None:
    """Two Zenoh sessions in this process (as two processes would have them), 200 times:
    the player's session must see the listener's subscriptions, and route to them, before its
    first message."""
    a, b, _ = zenoh_pair
    play_race(a, b, tmp_path, REPETITIONS)
    play_race(b, a, tmp_path / "reverse", 20, "/back")  # the connecting session playing as well


LISTENER = """
import sys
from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.middleware.transport import TransportOptions
ctx = Context.open(TransportOptions("zenoh", listen=[sys.argv[1]]))
node = Node(ctx, "listener")
for topic in sys.argv[2:]:
    node.create_subscription("std_msgs/msg/String", topic,
                             lambda msg, topic=topic: print("got", msg.data, flush=True))
print("ready", flush=True)
with ctx.stop_on_signals():
    ctx.spin()
ctx.close()
"""


@pytest.mark.slow
def test_bag_play_reaches_a_subscriber_process_started_just_before(
        tmp_path: Path, types: MessageTypes) -> None:
    """``servolab bag play --rate 0`` run the moment a fresh subscriber process says it has
    subscribed: every message arrives, in order, a few times over."""
    for k in range(5):
        topics = [f"/race_{k}/a", f"/race_{k}/b"]
        order = write_bag(tmp_path / f"bag_{k}", types, topics)
        endpoint = f"tcp/127.0.0.1:{free_port()}"
        with started([sys.executable, "-c", LISTENER, endpoint, *topics]) as listener:
            wait_for_line(listener, "ready", timeout=30.0)
            played = servolab("bag", "play", str(tmp_path / f"bag_{k}"), "--rate", "0",
                              "--wait-matching", "20", "--connect", endpoint, timeout=60)
            assert played.returncode == 0, played.stderr
            assert f"played {len(order)} message(s)" in played.stdout, played.stdout
            assert "no subscription" not in played.stdout, played.stdout
            received: list[str] = []
            while len(received) < len(order):  # a lost message never comes: the wait fails
                line = wait_for_line(listener, "got ", timeout=10.0)[-1]
                received.append(line.removeprefix("got "))
        for topic in topics:
            assert [t for t in received if t.startswith(topic + " ")] == [
                text for name, text in order if name == topic], (k, received)
