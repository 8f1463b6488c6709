"""Where servolab's latency between two processes goes: one ``geometry_msgs/msg/Twist``
every 2 ms from a servolab publisher in a child process, received here over Zenoh.

Each message carries rmw_zenoh's attachment, whose source timestamp (``time.time_ns()`` on
the same machine) is when it was published. The receiver records, per message:

- ``servolab``: when the subscription's inbox *watcher* thread had the sample (Zenoh's
  thread woke it from the channel's ``recv()``), and when the executor's thread ran the
  callback. The difference is the one hop bare Zenoh does not have: the watcher waking the
  thread where servolab's callbacks run (``src/servolab/middleware/zenoh_inbox.py``);
- ``zenoh``: when a bare Zenoh subscriber's callback ran (on Zenoh's own thread).

The anchor, measured in the same run, is a bare ``threading.Condition`` wake-up between two
threads of this process (one notifies, one waits): what a thread wake-up costs on this machine,
nothing of Zenoh's or servolab's in it. The hop is printed as a ratio to it. The same is then
measured with the subscription's ``run_on_arrival`` (a message that finds the executor idle
runs on the watcher: no thread woken between the watcher and the callback). The watcher's
moment is taken by wrapping the inbox's private wake function: this file measures servolab's
internals and says so.

Run: ``.venv/bin/python benchmarks/wakeups.py [--quick] [--json PATH]``.
"""

from __future__ import annotations

import argparse
import json
import os
import select
import socket
import statistics
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import zenoh

from servolab.middleware.context import Context
from servolab.middleware.messages import MessageTypes
from servolab.middleware.node import Node
from servolab.middleware.rmw_zenoh import ATTACHMENT, topic_keyexpr
from servolab.middleware.transport import MessageInfo, TransportOptions
from servolab.middleware.zenoh_transport import open_session

TWIST = "geometry_msgs/msg/Twist"
TOPIC = "/bench/wakeups"
PERIOD = 0.002  # s between messages: each arrives at an idle receiver
CONNECT_TIMEOUT = 20.0


def percentile(values: Sequence[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(len(ordered) * q))]


def condition_wakeup_us(count: int) -> list[float]:
    """Microseconds from ``notify()`` to the waiting thread running again, ``count`` times."""
    cond = threading.Condition()
    stamps: list[int] = []
    waiting = threading.Event()
    delays: list[float] = []

    def waiter() -> None:
        for _ in range(count):
            with cond:
                waiting.set()
                while not stamps:
                    cond.wait(1.0)
                sent = stamps.pop()
            delays.append((time.perf_counter_ns() - sent) / 1e3)

    thread = threading.Thread(target=waiter, daemon=True)
    thread.start()
    for _ in range(count):
        waiting.wait(5.0)
        waiting.clear()
        time.sleep(PERIOD / 2)  # the waiter is asleep by now, as an idle executor is
        with cond:
            stamps.append(time.perf_counter_ns())
            cond.notify()
    thread.join(5.0)
    return delays


def run_child(endpoint: str, count: int) -> int:
    """Publish ``count`` Twists, one every :data:`PERIOD`, once the receiver is there."""
    with Context.open(TransportOptions("zenoh", connect=[endpoint])) as context:
        node = Node(context, "wakeups_talker")
        pub = node.create_publisher(TWIST, TOPIC, 10)
        msg = node.message(TWIST, linear={"x": 0.1}, angular={"z": 0.5})
        if not pub.wait_for_subscription(CONNECT_TIMEOUT):
            print("no subscriber", flush=True)
            return 1
        print("ready", flush=True)
        time.sleep(0.3)  # the receiver's side of discovery settles
        next_t = time.monotonic()
        for _ in range(count):
            pub.publish(msg)
            next_t += PERIOD
            time.sleep(max(0.0, next_t - time.monotonic()))
    return 0


def talker(endpoint: str, count: int) -> subprocess.Popen[str]:
    proc = subprocess.Popen([sys.executable, str(Path(__file__).resolve()), "--child",
                             "--connect", endpoint, "--count", str(count)],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    assert proc.stdout is not None
    ready, _, _ = select.select([proc.stdout], [], [], CONNECT_TIMEOUT)
    line = proc.stdout.readline().strip() if ready else ""
    if line != "ready":
        proc.kill()
        proc.wait()
        raise RuntimeError(f"the talker did not start ({line or 'no output'})")
    return proc


def stop(proc: subprocess.Popen[str]) -> None:
    try:
        proc.wait(timeout=CONNECT_TIMEOUT)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


def measure_servolab(count: int, on_arrival: bool = False) -> dict[str, list[float]]:
    """Per message: the watcher's and the callback's delay after publishing (us), and the
    hop between them; with ``on_arrival``, the subscription's ``run_on_arrival``."""
    endpoint = f"tcp/127.0.0.1:{_free_port()}"
    watcher: dict[int, int] = {}
    callback: dict[int, int] = {}
    sent: dict[int, int] = {}
    with Context.open(TransportOptions("zenoh", listen=[endpoint])) as context:
        node = Node(context, "wakeups_listener")

        def on_twist(msg: Any, info: MessageInfo) -> None:
            callback[info.sequence_number] = time.time_ns()
            sent[info.sequence_number] = info.source_timestamp_ns

        sub = node.create_subscription(TWIST, TOPIC, on_twist, 10, with_info=True,
                                       run_on_arrival=on_arrival)
        inbox = sub._inbox  # the watcher hands its sample over through the inbox's wake
        wake: Callable[[], None] = inbox._wake  # type: ignore[attr-defined]

        def stamped_wake() -> None:
            now = time.time_ns()  # first: the decoding below is not the hop's
            held = inbox._held  # type: ignore[attr-defined]
            if held is not None and held.attachment is not None:
                sequence, _, _, _ = ATTACHMENT.unpack(held.attachment.to_bytes())
                watcher[sequence] = now
            wake()

        inbox._wake = stamped_wake  # type: ignore[attr-defined]
        proc = talker(endpoint, count)
        try:
            context.spin_until(lambda: len(callback) >= count or proc.poll() is not None,
                               timeout=count * PERIOD * 5 + CONNECT_TIMEOUT)
            context.spin_for(0.05)
        finally:
            stop(proc)
    # a message that came while the executor was still busy with the one before waited in
    # the channel, not in the watcher's recv(): it has no watcher moment and is left out
    both = sorted(set(watcher) & set(callback))
    return {"received": [float(len(callback))],
            "watcher_us": [(watcher[k] - sent[k]) / 1e3 for k in both],
            "callback_us": [(callback[k] - sent[k]) / 1e3 for k in both],
            "hop_us": [(callback[k] - watcher[k]) / 1e3 for k in both]}


def measure_zenoh(count: int, types: MessageTypes) -> dict[str, list[float]]:
    """Per message: bare Zenoh's callback delay after publishing (us)."""
    endpoint = f"tcp/127.0.0.1:{_free_port()}"
    options = TransportOptions("zenoh", listen=[endpoint])
    session = open_session(options)
    delays: list[float] = []
    done = threading.Event()

    def on_sample(sample: zenoh.Sample) -> None:
        now = time.time_ns()
        if sample.attachment is not None:
            _, source_ns, _, _ = ATTACHMENT.unpack(sample.attachment.to_bytes())
            delays.append((now - source_ns) / 1e3)
            if len(delays) >= count:
                done.set()

    key = topic_keyexpr(options.domain_id, TOPIC, TWIST, types.rihs01(TWIST))
    subscriber = session.declare_subscriber(key, on_sample)  # what the talker waits to match
    try:
        proc = talker(endpoint, count)
        try:
            done.wait(count * PERIOD * 5 + CONNECT_TIMEOUT)
        finally:
            stop(proc)
    finally:
        subscriber.undeclare()
        session.close()
    return {"callback_us": delays}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="a few messages: that it runs")
    parser.add_argument("--json", type=Path, help="also write the figures to this file")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--connect", help=argparse.SUPPRESS)
    parser.add_argument("--count", type=int, default=0, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        return run_child(args.connect, args.count)
    count = 50 if args.quick else 1500
    types = MessageTypes()
    anchor = condition_wakeup_us(count)
    ours = measure_servolab(count)
    arrival = measure_servolab(count, on_arrival=True)
    bare = measure_zenoh(count, types)
    print(f"one Twist every {PERIOD * 1e3:g} ms between two processes, {count} messages "
          f"({len(ours['hop_us'])} of them found servolab's executor idle); delays after "
          "publish (p50 / p90, us):")
    rows = [("bare zenoh: callback (Zenoh's thread)", bare["callback_us"]),
            ("servolab: watcher has the sample", ours["watcher_us"]),
            ("servolab: callback (executor's thread)", ours["callback_us"]),
            ("servolab: watcher -> callback (the hop)", ours["hop_us"]),
            ("run_on_arrival: callback (watcher's thread)", arrival["callback_us"]),
            ("run_on_arrival: watcher -> callback", arrival["hop_us"]),
            ("anchor: threading.Condition wake-up", anchor)]
    for label, values in rows:
        print(f"  {label:42} {percentile(values, 0.5):8.1f} {percentile(values, 0.9):8.1f}")
    hop, wake = statistics.median(ours["hop_us"]), statistics.median(anchor)
    print(f"the hop is x{hop / wake:.2f} of a bare thread wake-up; servolab's callback comes "
          f"x{statistics.median(ours['callback_us']) / statistics.median(bare['callback_us']):.2f}"
          " as late as bare zenoh's")
    late = statistics.median(arrival["callback_us"]) / statistics.median(bare["callback_us"])
    print(f"with run_on_arrival the callback comes x{late:.2f} as late as bare zenoh's (no "
          "thread woken: it runs on the watcher)")
    if args.json:
        args.json.write_text(json.dumps({"count": count, "anchor_us": anchor, **ours,
                                         "run_on_arrival": arrival,
                                         "zenoh_callback_us": bare["callback_us"]}))
    return 0


if __name__ == "__main__":
    os.environ.setdefault("PYTHONUNBUFFERED", "1")
    sys.exit(main())
