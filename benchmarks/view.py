"""What ``servolab view`` costs over the Foxglove SDK's own server (issue 33): latency from
publish to client receipt, and one-way throughput, of Armstrong's ``/joint_states`` (a
``sensor_msgs/msg/JointState`` of its 21 joints: names, positions, velocities) and of one
640x376 mono8 ``sensor_msgs/msg/Image`` (a frame of the fly treadmill's camera), through
servolab view and through foxglove-sdk alone carrying the same CDR bytes, in the same run.

Two setups per message, one process, everything on loopback:

- ``servolab``: an in-process :class:`~servolab.middleware.context.Context` spun on a thread,
  a node publishing the message (``publisher.publish(msg)``: servolab serializes it to CDR for
  the server's raw subscription), and a :class:`~servolab.middleware.view.ViewServer` on a free
  port;
- ``sdk``: ``foxglove.start_server`` (its own ``foxglove.Context``) on a free port and a
  ``Channel`` with the same ``ros2msg`` schema, ``channel.log(cdr)`` of the bytes servolab
  writes for the same message (already serialized: the SDK is handed bytes).

The client is the same for both: a ``websockets`` asyncio client on its own thread and event
loop, subprotocol ``foxglove.sdk.v1``, no ``permessage-deflate`` offered (the SDK's server
does not compress, so the two carry the same bytes), subscribed to the one channel. Each
message carries a sequence number in ``header.stamp.nanosec``; the client reads back that field
alone from the CDR of each Message Data frame and notes ``time.perf_counter_ns()`` the moment
the frame is received.

**Latency** is client receipt minus the moment before ``publish`` (servolab) or ``log`` (sdk),
one message in flight (the next one goes once the last has arrived), median and 99th
percentile. **Throughput** is one way: N messages back to back, until the client has the last
of them; messages (and CDR megabytes) per second delivered, the median of a few rounds, and how
many of the N arrived. Both sides get the same room for a burst: the SDK's per-client backlog
is 1024 frames, and servolab's publisher keeps 1024 (KEEP_LAST) with the view's
``max_qos_depth`` and ``send_bytes`` raised to match (the view reads a topic with its
publishers' depth, as foxglove_bridge does); either may drop the oldest when the client
falls behind; a drop is counted, not hidden.

The ratios servolab/sdk (latency over latency; the SDK's rate over servolab's, i.e. time per
message) are measured in the same run, so they carry over to other machines better than the
absolute figures. servolab's figures include its CDR serialization in ``publish`` (printed
alone at the end); the SDK's do not.

Both run with the C heap servolab gives its processes (:mod:`servolab.middleware.heap`), set
before either is measured: they share the process, so the heap is the same for both.

Servers listen on free ports (port 0) and are stopped at the end of their setup.

Run: ``.venv/bin/python benchmarks/view.py [--quick] [--json PATH]``.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import gc
import json
import math
import platform
import statistics
import struct
import sys
import threading
import time
import timeit
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from importlib import metadata
from pathlib import Path
from typing import Any, Protocol

import foxglove
import numpy as np
from websockets.asyncio.client import ClientConnection, connect
from websockets.typing import Subprotocol

from servolab.middleware.context import Context
from servolab.middleware.heap import keep_freed_memory
from servolab.middleware.messages import MessageTypes
from servolab.middleware.node import Node
from servolab.middleware.view import ViewConfig, ViewServer

JOINT_STATE = "sensor_msgs/msg/JointState"
IMAGE = "sensor_msgs/msg/Image"
IMAGE_WIDTH, IMAGE_HEIGHT = 640, 376
TOPICS = {JOINT_STATE: "/joint_states", IMAGE: "/camera/image_raw"}
SHORT_NAMES = {JOINT_STATE: "JointState", IMAGE: "Image"}
SUBPROTOCOL = "foxglove.sdk.v1"
SETUPS = ("servolab", "sdk")

#: where the sequence number sits in the CDR of both messages: after the 4-byte encapsulation
#: header, ``header.stamp.sec`` (int32) then ``header.stamp.nanosec`` (uint32)
SEQ_OFFSET = 8
MESSAGE_DATA = 0x01
DATA_HEADER = 13  # opcode u8, subscription id u32, log time u64

CONNECT_TIMEOUT = 20.0  # s for the channel to be advertised and a first message to arrive
ANSWER_TIMEOUT = 10.0   # s for one message once connected


@dataclass(frozen=True)
class Sizes:
    """How much to measure for one message type."""

    pings: int
    warmup: int
    flood: int
    rounds: int


FULL = {JOINT_STATE: Sizes(pings=5000, warmup=500, flood=1000, rounds=5),
        IMAGE: Sizes(pings=1000, warmup=100, flood=200, rounds=5)}
QUICK = {JOINT_STATE: Sizes(pings=40, warmup=5, flood=50, rounds=1),
         IMAGE: Sizes(pings=15, warmup=3, flood=10, rounds=1)}


def armstrong_joints() -> list[str]:
    """Armstrong's 21 movable joints, in its description's order (its ``/joint_states``)."""
    from servolab.robots.armstrong.description import describe
    return [j.name for j in describe().joints if j.kind != "fixed"]


def sample_message(types: MessageTypes, type_name: str) -> Any:
    """What both setups send: Armstrong's joint state, or one camera frame of noise."""
    if type_name == JOINT_STATE:
        names = armstrong_joints()
        rng = np.random.default_rng(0)
        return types.from_value(JOINT_STATE, {
            "header": {"stamp": {"sec": 1_700_000_000}, "frame_id": ""}, "name": names,
            "position": rng.uniform(-1.5, 1.5, len(names)).tolist(),
            "velocity": rng.uniform(-3.0, 3.0, len(names)).tolist()})
    rng = np.random.default_rng(0)
    msg = types.from_value(IMAGE, {
        "header": {"stamp": {"sec": 1_700_000_000}, "frame_id": "camera"},
        "height": IMAGE_HEIGHT, "width": IMAGE_WIDTH, "encoding": "mono8", "step": IMAGE_WIDTH})
    msg.data = rng.integers(0, 256, IMAGE_WIDTH * IMAGE_HEIGHT, dtype=np.uint8)
    return msg


def with_seq(cdr: bytes, seq: int) -> bytes:
    """The CDR ``cdr`` with ``header.stamp.nanosec`` set to ``seq``."""
    out = bytearray(cdr)
    struct.pack_into("<I", out, SEQ_OFFSET, seq)
    return bytes(out)


# -- the client ------------------------------------------------------------------------------


class ViewClient:
    """A Foxglove WebSocket client on its own thread and asyncio loop: subscribes to ``topic``
    once it is advertised, and notes when each message (by sequence number) is received."""

    def __init__(self, url: str, topic: str) -> None:
        self.topic = topic
        self.arrivals: dict[int, int] = {}   # seq -> perf_counter_ns at receipt
        self.received = 0
        self.want = -1                       # the seq whose receipt sets ``arrived``
        self.arrived = threading.Event()
        self.subscribed = threading.Event()
        self.last_frame = b""
        self._ws: ClientConnection | None = None
        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._loop.run_forever, name="view-bench-client",
                                        daemon=True)
        self._thread.start()
        self._task: Future[None] = asyncio.run_coroutine_threadsafe(self._run(url), self._loop)

    async def _run(self, url: str) -> None:
        async with connect(url, subprotocols=[Subprotocol(SUBPROTOCOL)], compression=None,
                           max_size=None, open_timeout=CONNECT_TIMEOUT) as ws:
            self._ws = ws
            async for frame in ws:
                now = time.perf_counter_ns()
                if isinstance(frame, bytes):
                    if frame[0] == MESSAGE_DATA:
                        (seq,) = struct.unpack_from("<I", frame, DATA_HEADER + SEQ_OFFSET)
                        self.arrivals[seq] = now
                        self.received += 1
                        self.last_frame = frame
                        if seq == self.want:
                            self.arrived.set()
                    continue
                op = json.loads(frame)
                if op.get("op") == "advertise" and not self.subscribed.is_set():
                    for channel in op["channels"]:
                        if channel["topic"] == self.topic:
                            await ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                                {"id": 1, "channelId": channel["id"]}]}))
                            self.subscribed.set()

    def expect(self, seq: int) -> None:
        """Before sending ``seq``: :meth:`wait` then waits for it."""
        self.arrived.clear()
        self.want = seq

    def wait(self, timeout: float) -> bool:
        if self.arrived.wait(timeout):
            return True
        if self._task.done():
            self._task.result()  # the connection ended: say why
            raise RuntimeError("the client's connection closed")
        return False

    def wait_subscribed(self, timeout: float) -> None:
        deadline = time.monotonic() + timeout
        while not self.subscribed.wait(0.05):
            if self._task.done():
                self._task.result()
                raise RuntimeError("the client's connection closed before subscribing")
            if time.monotonic() > deadline:
                raise RuntimeError(f"{self.topic} was not advertised within {timeout:g} s")

    def close(self) -> None:
        ws = self._ws
        if ws is not None and not self._task.done():
            asyncio.run_coroutine_threadsafe(ws.close(), self._loop).result(ANSWER_TIMEOUT)
        with contextlib.suppress(Exception):  # closed either way; wait() said what went wrong
            self._task.result(ANSWER_TIMEOUT)
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(ANSWER_TIMEOUT)
        self._loop.close()


# -- the two sending sides -------------------------------------------------------------------


#: the room for a burst on each side: foxglove-sdk's per-client backlog (its
#: ``message_backlog_size`` default), and servolab's publisher depth and max_qos_depth
BURST_DEPTH = 1024
#: and the bytes a viewer may owe, which the SDK does not bound (the view's default, 32 MB,
#: holds 139 of the 240 kB images)
BURST_BYTES = BURST_DEPTH * 2**18


class Sender(Protocol):
    url: str

    def prepare(self, seq: int) -> Any: ...
    def send(self, item: Any) -> None: ...
    def flood(self, first: int, n: int) -> Callable[[], None]: ...
    def expected(self, seq: int) -> bytes: ...


class ServolabSender:
    """A node publishing the message object; the view server on the same context."""

    def __init__(self, context: Context, view: ViewServer, type_name: str, msg: Any) -> None:
        self.node = Node(context, "bench_talker")
        self.publisher = self.node.create_publisher(type_name, TOPICS[type_name], BURST_DEPTH)
        self.msg, self.type_name, self.types = msg, type_name, context.types
        self.view = view
        self.url = view.url

    def prepare(self, seq: int) -> Any:
        self.msg.header.stamp.nanosec = seq  # publish copies: the next change is safe
        return self.msg

    def send(self, item: Any) -> None:
        self.publisher.publish(item)

    def flood(self, first: int, n: int) -> Callable[[], None]:
        msg, publish = self.msg, self.publisher.publish

        def go() -> None:
            for seq in range(first, first + n):
                msg.header.stamp.nanosec = seq
                publish(msg)
        return go

    def expected(self, seq: int) -> bytes:
        self.msg.header.stamp.nanosec = seq
        return self.types.serialize(self.msg, self.type_name)


class SdkSender:
    """A foxglove-sdk channel logging the CDR bytes (the sequence number patched in)."""

    def __init__(self, server: Any, channel: foxglove.Channel, cdr: bytes) -> None:
        self.channel, self.cdr = channel, cdr
        self.url = f"ws://127.0.0.1:{server.port}"

    def prepare(self, seq: int) -> Any:
        return with_seq(self.cdr, seq)

    def send(self, item: Any) -> None:
        self.channel.log(item)

    def flood(self, first: int, n: int) -> Callable[[], None]:
        items = [with_seq(self.cdr, seq) for seq in range(first, first + n)]
        log = self.channel.log

        def go() -> None:
            for item in items:
                log(item)
        return go

    def expected(self, seq: int) -> bytes:
        return with_seq(self.cdr, seq)


@contextmanager
def servolab_sender(types: MessageTypes, type_name: str, msg: Any) -> Iterator[Sender]:
    context = Context.open(types=types)
    thread = context.executor.spin_in_thread()
    view: ViewServer | None = None
    try:
        view = ViewServer(context, ViewConfig(host="127.0.0.1", port=0, graph_period=0.05,
                                              max_qos_depth=BURST_DEPTH,
                                              send_bytes=BURST_BYTES))
        yield ServolabSender(context, view, type_name, msg)
    finally:
        if view is not None:
            view.close()
        context.shutdown()
        thread.join()
        context.close()


@contextmanager
def sdk_sender(types: MessageTypes, type_name: str, cdr: bytes) -> Iterator[Sender]:
    fox_context = foxglove.Context()
    server = foxglove.start_server(name="view-bench", host="127.0.0.1", port=0,
                                   context=fox_context, supported_encodings=["cdr"])
    try:
        schema = foxglove.Schema(name=type_name, encoding="ros2msg",
                                 data=types.msgdef(type_name).encode())
        channel = foxglove.Channel(TOPICS[type_name], schema=schema, message_encoding="cdr",
                                   context=fox_context)
        try:
            yield SdkSender(server, channel, cdr)
        finally:
            channel.close()
    finally:
        server.stop()


# -- measuring -------------------------------------------------------------------------------


@dataclass
class Figures:
    message: str
    setup: str           # servolab | sdk
    cdr_bytes: int
    latency_p50_us: float
    latency_p99_us: float
    throughput_msg_s: float
    throughput_mb_s: float
    flood: int           # messages sent back to back per round
    delivered: int       # the fewest of them the client got in a round
    server_dropped: int  # of those lost, dropped by the view server's per-viewer queue


class Measure:
    """One setup's run: connect, warm up, time the pings, then the floods."""

    def __init__(self, sender: Sender, client: ViewClient, label: str) -> None:
        self.sender, self.client, self.label = sender, client, label
        self.seq = 0

    def ping(self, timeout: float) -> int | None:
        """Send the next message and wait for it; its latency in ns (None: not in time)."""
        self.seq += 1
        item = self.sender.prepare(self.seq)
        self.client.expect(self.seq)
        start = time.perf_counter_ns()
        self.sender.send(item)
        if not self.client.wait(timeout):
            return None
        return self.client.arrivals[self.seq] - start

    def connect(self) -> None:
        """Subscribe, then send until one arrives (the subscription takes a moment)."""
        self.client.wait_subscribed(CONNECT_TIMEOUT)
        deadline = time.monotonic() + CONNECT_TIMEOUT
        while time.monotonic() < deadline:
            if self.ping(0.2) is not None:
                return
        raise RuntimeError(f"{self.label}: nothing arrived within {CONNECT_TIMEOUT:.0f} s")

    def check_last(self) -> None:
        frame = self.client.last_frame
        (seq,) = struct.unpack_from("<I", frame, DATA_HEADER + SEQ_OFFSET)
        if frame[DATA_HEADER:] != self.sender.expected(seq):
            raise RuntimeError(f"{self.label}: the client got other bytes than were sent")

    def run(self, sizes: Sizes) -> tuple[list[int], list[float], int]:
        """Latencies (ns) of the pings; messages per second of each flood round; the fewest
        delivered in a round."""
        self.connect()
        for _ in range(sizes.warmup):
            if self.ping(ANSWER_TIMEOUT) is None:
                raise RuntimeError(f"{self.label}: a warm-up message did not arrive")
        latencies: list[int] = []
        rates: list[float] = []
        delivered = sizes.flood
        gc.collect()
        gc.disable()
        try:
            for _ in range(sizes.pings):
                latency = self.ping(ANSWER_TIMEOUT)
                if latency is None:
                    raise RuntimeError(f"{self.label}: message {self.seq} did not arrive "
                                       f"within {ANSWER_TIMEOUT:g} s")
                latencies.append(latency)
            self.check_last()
            for _ in range(sizes.rounds):
                first = self.seq + 1
                send_all = self.sender.flood(first, sizes.flood)
                self.seq += sizes.flood
                self.client.expect(self.seq)
                before = self.client.received
                start = time.perf_counter_ns()
                send_all()
                if not self.client.wait(ANSWER_TIMEOUT + sizes.flood * 0.01):
                    raise RuntimeError(f"{self.label}: the last of {sizes.flood} messages sent "
                                       "back to back did not arrive")
                elapsed = (self.client.arrivals[self.seq] - start) / 1e9
                got = min(self.client.received - before,
                          sum(1 for s in range(first, self.seq + 1) if s in self.client.arrivals))
                delivered = min(delivered, got)
                rates.append(got / elapsed)
                gc.collect()
            self.check_last()
        finally:
            gc.enable()
        return latencies, rates, delivered


def percentile(values: Sequence[float], q: float) -> float:
    return float(np.percentile(np.asarray(values), q))


def run_setup(setup: str, type_name: str, sizes: Sizes, types: MessageTypes) -> Figures:
    msg = sample_message(types, type_name)
    cdr = types.serialize(msg, type_name)
    label = f"{SHORT_NAMES[type_name]}, {setup}"
    opened = (servolab_sender(types, type_name, msg) if setup == "servolab"
              else sdk_sender(types, type_name, cdr))
    with opened as sender:
        client = ViewClient(sender.url, TOPICS[type_name])
        try:
            latencies, rates, delivered = Measure(sender, client, label).run(sizes)
        finally:
            client.close()
        server_dropped = sender.view.dropped if isinstance(sender, ServolabSender) else 0
    rate = statistics.median(rates)
    return Figures(message=SHORT_NAMES[type_name], setup=setup, cdr_bytes=len(cdr),
                   latency_p50_us=percentile(latencies, 50) / 1e3,
                   latency_p99_us=percentile(latencies, 99) / 1e3,
                   throughput_msg_s=rate, throughput_mb_s=rate * len(cdr) / 1e6,
                   flood=sizes.flood, delivered=delivered, server_dropped=server_dropped)


# -- report ----------------------------------------------------------------------------------


def ratios(rows: list[Figures]) -> list[dict[str, Any]]:
    """servolab over sdk for each message: > 1 means servolab view costs more."""
    out = []
    for message in dict.fromkeys(r.message for r in rows):
        ours = next(r for r in rows if (r.message, r.setup) == (message, "servolab"))
        sdk = next(r for r in rows if (r.message, r.setup) == (message, "sdk"))
        out.append({"message": message,
                    "latency_p50": ours.latency_p50_us / sdk.latency_p50_us,
                    "latency_p99": ours.latency_p99_us / sdk.latency_p99_us,
                    "time_per_message": sdk.throughput_msg_s / ours.throughput_msg_s,
                    "rate": ours.throughput_msg_s / sdk.throughput_msg_s})
    return out


def serialize_us(types: MessageTypes, type_name: str) -> float:
    """Microseconds of the CDR serialization each servolab publish makes here, timed alone."""
    msg = sample_message(types, type_name)
    number = 2000 if type_name == JOINT_STATE else 200
    return min(timeit.repeat(lambda: types.serialize(msg, type_name), number=number,
                             repeat=5)) / number * 1e6


def _version(dist: str) -> str:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "?"


def main(argv: Sequence[str] | None = None,
         progress: Callable[[str], None] = lambda s: print(s, file=sys.stderr, flush=True)
         ) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true",
                        help="a few messages per setup: checks that it runs, not how fast")
    parser.add_argument("--json", type=Path, help="also write the figures to this file")
    args = parser.parse_args(argv)

    keep_freed_memory()  # before either setup: the heap is the process's (the docstring)
    sizes = QUICK if args.quick else FULL
    types = MessageTypes()
    print(f"servolab view benchmark: Python {platform.python_version()}, foxglove-sdk "
          f"{_version('foxglove-sdk')}, websockets {_version('websockets')}, "
          f"{platform.machine()}{' (quick)' if args.quick else ''}")
    rows: list[Figures] = []
    for type_name in (JOINT_STATE, IMAGE):
        for setup in SETUPS:
            progress(f"  measuring {SHORT_NAMES[type_name]}: {setup}...")
            rows.append(run_setup(setup, type_name, sizes[type_name], types))

    print()
    print("latency = publish (servolab) or log (sdk) to client receipt, one in flight; "
          "throughput = one way, N back to back")
    print(f"{'message':10} {'setup':9} {'bytes':>7} {'p50 us':>9} {'p99 us':>9} "
          f"{'msg/s':>9} {'MB/s':>8} {'delivered':>11}")
    for r in rows:
        print(f"{r.message:10} {r.setup:9} {r.cdr_bytes:7d} {r.latency_p50_us:9.1f} "
              f"{r.latency_p99_us:9.1f} {r.throughput_msg_s:9.0f} {r.throughput_mb_s:8.1f} "
              f"{f'{r.delivered}/{r.flood}':>11}")
    for r in rows:
        if r.delivered < r.flood:
            lost = r.flood - r.delivered
            why = (f"{r.server_dropped} by the server's per-viewer queue, the rest by the "
                   f"subscription's history of {BURST_DEPTH}" if r.setup == "servolab"
                   else "by the SDK's per-client backlog")
            print(f"  dropped, {r.message} {r.setup}: {lost} of {r.flood} sent back to back "
                  f"({why}); msg/s counts those delivered")
    print()
    print("servolab view / foxglove-sdk (> 1: servolab costs more):")
    found = ratios(rows)
    for q in found:
        print(f"ratio {q['message']}: latency p50 x{q['latency_p50']:.2f}, "
              f"p99 x{q['latency_p99']:.2f}, messages per second x{q['rate']:.2f} "
              f"(time per message x{q['time_per_message']:.2f})")
    costs = {SHORT_NAMES[t]: serialize_us(types, t) for t in (JOINT_STATE, IMAGE)}
    print("servolab's CDR serialization per publish, timed alone (in its figures above, not in "
          "the sdk's): " + ", ".join(f"{m} {us:.1f} us" for m, us in costs.items()))
    if args.json:
        args.json.write_text(json.dumps({
            "quick": args.quick, "rows": [asdict(r) for r in rows], "ratios": found,
            "serialize_us": costs,
            "sizes": {SHORT_NAMES[k]: asdict(v) for k, v in sizes.items()}}, indent=2))
    figures = [v for r in rows for v in (r.latency_p50_us, r.latency_p99_us,
                                         r.throughput_msg_s)]
    figures += [v for q in found for k, v in q.items() if k != "message"]
    return 0 if all(math.isfinite(v) and v > 0 for v in figures) else 1


if __name__ == "__main__":
    sys.exit(main())
