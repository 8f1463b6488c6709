"""What servolab's DDS transport costs over the DDS under it: a ``geometry_msgs/msg/Twist``
between two processes, through servolab (``--transport dds``) and through bare Cyclone DDS
(the same ``cyclonedds`` binding, the same topic type and the same CDR bytes, written and taken
raw on a wait set, as servolab's transport does), in the same run.

**Latency** is half the round trip of one message echoed back by the other process (one in
flight), median and 99th percentile. **Throughput** is one way: N messages back to back,
reliable and KEEP_ALL, until the echo side, which counts them, answers once it has all N.
The ratios servolab/bare are what carry over to other machines.

The real rclpy (Fast DDS) is not measured here: its messages would cross vendors, so its
figures would not isolate servolab's cost (``tests/middleware/test_dds_rclpy.py`` shows that
it interoperates).

Run: ``.venv/bin/python benchmarks/dds.py [--quick]``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

TWIST = "geometry_msgs/msg/Twist"
COUNT = "std_msgs/msg/UInt64"


class Bare:
    """Bare Cyclone DDS: a participant, the ``ping`` writer or reader and the ``pong`` one."""

    def __init__(self, domain: int, send: str, receive: str) -> None:
        from cyclonedds.core import (
            GuardCondition,
            InstanceState,
            Policy,
            Qos,
            ReadCondition,
            SampleState,
            ViewState,
            WaitSet,
        )
        from cyclonedds.domain import DomainParticipant
        from cyclonedds.pub import DataWriter
        from cyclonedds.sub import DataReader
        from cyclonedds.topic import Topic

        from servolab.middleware.dds_types import DdsTypes
        from servolab.middleware.messages import MessageTypes

        self.types = MessageTypes()
        dds_types = DdsTypes(self.types)
        self.participant = DomainParticipant(domain)
        qos = Qos(Policy.Reliability.Reliable(100_000_000), Policy.History.KeepAll,
                  Policy.DataRepresentation(use_cdrv0_representation=True))
        self.writer = DataWriter(self.participant, Topic(
            self.participant, f"rt/{send}", dds_types.get(TWIST)), qos)
        self.reader = DataReader(self.participant, Topic(
            self.participant, f"rt/{receive}", dds_types.get(TWIST)), qos)
        self._mask = SampleState.Any | ViewState.Any | InstanceState.Any
        self.waitset = WaitSet(self.participant)
        self.guard = GuardCondition(self.participant)
        self.waitset.attach(ReadCondition(self.reader, self._mask))
        self.waitset.attach(self.guard)
        self.stopped = False

    def write(self, data: bytes) -> None:
        from cyclonedds import _clayer
        _clayer.ddspy_write(self.writer._ref, data)

    def matched(self) -> bool:
        return (self.writer.get_publication_matched_status().current_count > 0
                and self.reader.get_subscription_matched_status().current_count > 0)

    def loop(self, on_data: Callable[[bytes], None]) -> None:
        from cyclonedds import _clayer
        from cyclonedds.util import duration
        while not self.stopped:
            self.waitset.wait(duration(seconds=0.2))
            taken = _clayer.ddspy_take(self.reader._ref, self._mask, 256)
            if isinstance(taken, int):
                return
            for data, info in taken:
                if info.valid_data:
                    on_data(data)


def echo(engine: str, domain: int) -> None:
    """The other process: send every ping back; after a flood of N, say N."""
    if engine == "bare":
        bare = Bare(domain, "pong", "ping")
        bare.loop(bare.write)
        return
    from servolab.middleware.context import Context
    from servolab.middleware.node import Node
    from servolab.middleware.transport import TransportOptions
    with Context.open(TransportOptions("dds", domain_id=domain)) as ctx:
        node = Node(ctx, "echo")
        pong = node.create_publisher(TWIST, "/pong", 0)
        node.create_subscription(TWIST, "/ping", pong.publish, 0)
        ctx.spin()


def measure(engine: str, domain: int, rounds: int, flood: int) -> dict[str, float]:
    env = {**os.environ, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    child = subprocess.Popen([sys.executable, __file__, "--echo", engine, "--domain",
                              str(domain)], env=env, stdin=subprocess.DEVNULL)
    try:
        return _measure(engine, domain, rounds, flood)
    finally:
        child.terminate()
        try:
            child.wait(5)
        except subprocess.TimeoutExpired:
            child.kill()
            child.wait()


def _measure(engine: str, domain: int, rounds: int, flood: int) -> dict[str, float]:
    got = threading.Semaphore(0)
    count = [0]

    def on_pong(_data: Any) -> None:
        count[0] += 1
        got.release()

    if engine == "bare":
        bare = Bare(domain, "ping", "pong")
        payload = bare.types.serialize(bare.types.default(TWIST), TWIST)
        send: Callable[[], None] = lambda: bare.write(payload)  # noqa: E731
        ready = bare.matched
        thread = threading.Thread(target=bare.loop, args=(on_pong,), daemon=True)
        thread.start()
        close = lambda: setattr(bare, "stopped", True)  # noqa: E731
    else:
        from servolab.middleware.context import Context
        from servolab.middleware.node import Node
        from servolab.middleware.transport import TransportOptions
        ctx = Context.open(TransportOptions("dds", domain_id=domain))
        node = Node(ctx, "main")
        ping = node.create_publisher(TWIST, "/ping", 0)
        node.create_subscription(TWIST, "/pong", on_pong, 0)
        msg = node.message(TWIST)
        send = lambda: ping.publish(msg)  # noqa: E731
        ready = lambda: ping.get_subscription_count() > 0  # noqa: E731
        spinner = ctx.executor.spin_in_thread()

        def close() -> None:
            ctx.shutdown()
            spinner.join(2.0)
            ctx.close()
    try:
        deadline = time.monotonic() + 30
        while not ready():
            if time.monotonic() > deadline:
                raise SystemExit(f"{engine}: the echo process never matched")
            time.sleep(0.01)
        # the echo's own reader and writer match a moment after ours: ping until it answers
        while not got.acquire(timeout=0.05):
            send()
        while got.acquire(timeout=0.3):
            pass
        halves = []
        for _ in range(rounds):
            start = time.perf_counter()
            send()
            if not got.acquire(timeout=5):
                raise SystemExit(f"{engine}: an echo was lost")
            halves.append((time.perf_counter() - start) / 2)
        start = time.perf_counter()
        for _ in range(flood):
            send()
        for _ in range(flood):
            if not got.acquire(timeout=10):
                raise SystemExit(f"{engine}: the flood's echoes stopped at {count[0]}")
        elapsed = time.perf_counter() - start
    finally:
        close()
    halves.sort()
    return {"p50_us": statistics.median(halves) * 1e6,
            "p99_us": halves[int(0.99 * (len(halves) - 1))] * 1e6,
            "msg_per_s": flood / elapsed}


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="a short run, to check it works")
    parser.add_argument("--echo", choices=("bare", "servolab"), help=argparse.SUPPRESS)
    parser.add_argument("--domain", type=int, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.echo:
        echo(args.echo, args.domain)
        return 0
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    from tests.rosoracle import free_domain_id

    rounds, flood = (50, 200) if args.quick else (1000, 5000)
    figures = {engine: measure(engine, free_domain_id(), rounds, flood)
               for engine in ("bare", "servolab")}
    print(f"Twist between two processes over Cyclone DDS on loopback, {rounds} pings, "
          f"a flood of {flood} (reliable, KEEP_ALL)")
    for engine, f in figures.items():
        print(f"  {engine:9} p50 {f['p50_us']:7.0f} us  p99 {f['p99_us']:7.0f} us  "
              f"{f['msg_per_s']:9.0f} msg/s")
    s, b = figures["servolab"], figures["bare"]
    print(f"ratio servolab/bare: latency p50 x{s['p50_us'] / b['p50_us']:.2f}, "
          f"messages per second x{s['msg_per_s'] / b['msg_per_s']:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
