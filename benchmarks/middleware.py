"""What servolab's middleware costs over the engine under it: latency and throughput of a
``geometry_msgs/msg/Twist`` and of a 640x376 mono8 ``sensor_msgs/msg/Image`` (one frame of the
fly treadmill's camera), through servolab and through bare ``zenoh`` carrying the same bytes.

Four setups, each with the same two roles, a *main* side that measures and an *echo* side:

- ``servolab, one process``: two nodes in one context on the in-process transport (the
  default), the echo node's callback republishing what it hears;
- ``zenoh, one process``: one Zenoh session whose subscriber callback ``put``s the sample's
  payload back (Zenoh's own local delivery);
- ``servolab, two processes``: the main node here, the echo node in a child OS process, on the
  Zenoh transport over loopback TCP;
- ``zenoh, two processes``: the same with bare Zenoh sessions, opened with servolab's own
  session configuration (peer mode, no scouting, ``CongestionControl.BLOCK``) so that the
  only difference is servolab: CDR serialization (servolab's generated codec,
  ``servolab.middleware.fast_cdr``), rmw_zenoh's key expressions and attachment, the
  subscription queue and the executor.

Every process of every setup runs with the C heap servolab gives its own processes
(:mod:`servolab.middleware.heap`: freed memory kept, not faulted in again), the bare ones too:
a Zenoh ``put`` copies a frame into a new buffer, and with glibc's defaults bare Zenoh's
one-process Image rate is about an eighth of what it is with that heap, which would measure
the heap rather than servolab.

**Latency** is half the round trip of one message echoed back (ping-pong, one message in
flight), from before ``publish`` to the moment the main side's callback has the answer, given
as the median and 99th percentile. **Throughput** is one way: the main side publishes N
messages back to back and the echo side, which counts them, answers with a small
``std_msgs/msg/UInt64`` (eight bytes on bare Zenoh) once it has all N; the figure is N over
the time to that answer, in messages and CDR megabytes per second, the median of a few rounds.

The ratios servolab/zenoh (latency over latency, and time per message over time per message
for throughput) are measured in the same run, so they carry over to other machines better
than the absolute figures. In one process servolab does not use Zenoh at all; that ratio
says how the default transport compares with the cheapest thing Zenoh can do.

The end of the report gives, for a Twist between two processes, issue 15's two targets (p50
latency at most x1.5 of bare Zenoh's, messages per second at least x0.5) as met or NOT met,
then the Python work per message timed alone (CDR serialization, deserialization, and the
copy each in-process publish makes for value semantics, with its share of the one-process
figures), with the generated CDR codec beside rosbags' (the oracle it replaced, issue 32) timed
in the same run as a ratio, and, when the rate target is not met, what remains and why.

Child processes listen on nothing and connect to the main side's free loopback port; each is
stopped when its setup ends (its stdin closes; it is killed if it does not leave).

A Twist's publish over Zenoh is also timed alone, in one session: a bare ``put``, a ``put``
with rmw_zenoh's attachment, and servolab's whole ``publish``. ``--runs N`` measures every
setup N times and ends with the spread of the ratios over the runs and in how many runs each
target was met: single runs on a shared machine move by tens of per cent.

Run: ``.venv/bin/python benchmarks/middleware.py [--quick] [--runs N] [--json PATH]``.
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import platform
import select
import socket
import statistics
import struct
import subprocess
import sys
import threading
import time
import timeit
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from importlib import metadata
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import zenoh

from servolab.middleware.context import Context
from servolab.middleware.heap import keep_freed_memory
from servolab.middleware.messages import MessageTypes, copy_message
from servolab.middleware.node import Node
from servolab.middleware.transport import TransportOptions
from servolab.middleware.zenoh_transport import open_session

TWIST = "geometry_msgs/msg/Twist"
IMAGE = "sensor_msgs/msg/Image"
COUNT = "std_msgs/msg/UInt64"
IMAGE_WIDTH, IMAGE_HEIGHT = 640, 376

# Topics of the servolab side and keys of the bare Zenoh side.
PING, PONG, FLOOD, FLOOD_ACK = "/bench/ping", "/bench/pong", "/bench/flood", "/bench/flood_ack"
KEYS = {name: "servolab_bench" + name for name in (PING, PONG, FLOOD, FLOOD_ACK)}

CONNECT_TIMEOUT = 20.0  # s for a child to start and the first echo to come back
ANSWER_TIMEOUT = 10.0   # s for one answer once connected
BLOCK = zenoh.CongestionControl.BLOCK


@dataclass(frozen=True)
class Sizes:
    """How much to measure for one message type."""

    pings: int
    warmup: int
    flood: int
    rounds: int
    #: s to wait once the echo first answers, for answers to earlier pings (not timed)
    settle: float = 0.3
    #: calls per timing of the Python work alone (python_costs, publish_costs), and repeats
    number: int = 2000
    repeat: int = 5


FULL = {TWIST: Sizes(pings=5000, warmup=500, flood=20000, rounds=5),
        IMAGE: Sizes(pings=1000, warmup=100, flood=1000, rounds=5, number=200)}
# --quick checks that every setup runs and what the report says, not how fast: a few messages,
# a short settle (the warm-up pings take any late answer), the Python work timed briefly
QUICK = {TWIST: Sizes(pings=60, warmup=10, flood=100, rounds=1, settle=0.05, number=200,
                      repeat=2),
         IMAGE: Sizes(pings=15, warmup=3, flood=10, rounds=1, settle=0.05, number=20,
                      repeat=2)}
SHORT_NAMES = {TWIST: "Twist", IMAGE: "Image"}


def sample_message(types: MessageTypes, type_name: str) -> Any:
    """The message every setup sends: a turning ``cmd_vel``, or one camera frame of noise."""
    if type_name == TWIST:
        return types.from_value(TWIST, {"linear": {"x": 0.1}, "angular": {"z": 0.5}})
    rng = np.random.default_rng(0)
    msg = types.from_value(IMAGE, {
        "header": {"frame_id": "camera"}, "height": IMAGE_HEIGHT, "width": IMAGE_WIDTH,
        "encoding": "mono8", "step": IMAGE_WIDTH})
    msg.data = rng.integers(0, 256, IMAGE_WIDTH * IMAGE_HEIGHT, dtype=np.uint8)
    return msg


def same_message(a: Any, b: Any) -> bool:
    """Field-by-field equality of two messages (arrays compared by value)."""
    if type(a) is not type(b):
        return False
    if not hasattr(a, "__dataclass_fields__"):
        return bool(np.array_equal(a, b)) if isinstance(a, np.ndarray) else a == b
    return all(same_message(getattr(a, f), getattr(b, f)) for f in a.__dataclass_fields__)


def python_costs(types: MessageTypes, type_name: str, sizes: Sizes) -> dict[str, float]:
    """Microseconds per message of the Python work servolab adds, each timed alone: CDR
    serialization (every publish over Zenoh), deserialization (every message received over
    Zenoh, from a memoryview as the transport hands it over) and the copy each in-process
    publish makes for value semantics (``messages.copy_message``); and, for comparison, the
    same CDR work through rosbags' ``Typestore`` (what servolab used before its generated
    codec, and still the oracle it is tested against)."""
    msg = sample_message(types, type_name)
    cdr = memoryview(types.serialize(msg, type_name))
    number = sizes.number
    store = types.store
    work = {"serialize_us": lambda: types.serialize(msg, type_name),
            "deserialize_us": lambda: types.deserialize(cdr, type_name),
            "copy_us": lambda: copy_message(msg),
            "rosbags_serialize_us": lambda: bytes(store.serialize_cdr(msg, type_name)),
            "rosbags_deserialize_us": lambda: store.deserialize_cdr(cdr, type_name)}
    return {name: min(timeit.repeat(f, number=number, repeat=sizes.repeat)) / number * 1e6
            for name, f in work.items()}


def publish_costs(types: MessageTypes, quick: bool = False) -> dict[str, float]:
    """Microseconds per publish of a Twist over Zenoh, each timed alone in one session with
    a subscriber of its own (so that Zenoh routes every put): a bare ``put`` of the CDR
    bytes, the same with rmw_zenoh's 33-byte attachment (what every ROS 2 peer expects), and
    servolab's whole ``Publisher.publish`` (serializing, packing the attachment, the put)."""
    options = TransportOptions("zenoh", listen=[_loopback()])
    number, repeat, costs = (500, 2, {}) if quick else (5000, 5, {})
    with Context.open(options, types=types) as context:
        node = Node(context, "bench_publish_costs")
        pub = node.create_publisher(TWIST, PING, 0)
        msg = sample_message(types, TWIST)
        payload = types.serialize(msg, TWIST)
        attachment = bytes(33)
        session = context.transport.session  # type: ignore[attr-defined]
        key = KEYS[PING]
        sink = session.declare_subscriber(key, zenoh.handlers.FifoChannel(2 * number))
        own = session.declare_subscriber(pub._inner._key,  # type: ignore[attr-defined]
                                         zenoh.handlers.FifoChannel(2 * number))
        bare = session.declare_publisher(key, congestion_control=BLOCK)
        work = {"put_us": lambda: bare.put(payload),
                "put_attachment_us": lambda: bare.put(payload, attachment=attachment),
                "publish_us": lambda: pub.publish(msg)}
        try:
            for name, f in work.items():
                best = math.inf
                for _ in range(repeat):
                    best = min(best, timeit.timeit(f, number=number) / number * 1e6)
                    for channel in (sink.handler, own.handler):
                        while channel.try_recv() is not None:
                            pass
                costs[name] = best
        finally:
            entities: list[Any] = [bare, sink, own]
            for entity in entities:
                entity.undeclare()
    return costs


# -- the echo side ---------------------------------------------------------------------------


class ServolabEcho(Node):
    """Republishes every ping as a pong; counts the flood and answers each ``flood`` of it."""

    def __init__(self, context: Context, type_name: str, flood: int,
                 on_arrival: bool = False) -> None:
        super().__init__(context, "bench_echo")
        self.flood, self.counted = flood, 0
        self.pong = self.create_publisher(type_name, PONG, 0)
        self.ack = self.create_publisher(COUNT, FLOOD_ACK, 0)
        self.create_subscription(type_name, PING, self.pong.publish, 0,
                                 run_on_arrival=on_arrival)
        self.create_subscription(type_name, FLOOD, self._on_flood, 0,
                                 run_on_arrival=on_arrival)

    def _on_flood(self, msg: Any) -> None:
        self.counted += 1
        if self.counted % self.flood == 0:
            self.ack.publish(self.message(COUNT, data=self.counted))


class ZenohEcho:
    """The same as :class:`ServolabEcho` with bare Zenoh: payloads go back untouched."""

    def __init__(self, session: zenoh.Session, flood: int) -> None:
        self.flood, self.counted = flood, 0
        self.pong = session.declare_publisher(KEYS[PONG], congestion_control=BLOCK)
        self.ack = session.declare_publisher(KEYS[FLOOD_ACK], congestion_control=BLOCK)
        self.subscribers = [
            session.declare_subscriber(KEYS[PING], lambda s: self.pong.put(s.payload)),
            session.declare_subscriber(KEYS[FLOOD], self._on_flood)]

    def _on_flood(self, sample: zenoh.Sample) -> None:
        self.counted += 1
        if self.counted % self.flood == 0:
            self.ack.put(struct.pack("<Q", self.counted))

    def close(self) -> None:
        for entity in (*self.subscribers, self.pong, self.ack):
            entity.undeclare()


# -- the main side ---------------------------------------------------------------------------


class MainSide(Protocol):
    def send_ping(self) -> None: ...
    def wait_pong(self, timeout: float) -> bool: ...
    def last_pong_matches(self) -> bool: ...
    def flood(self, n: int, timeout: float) -> int: ...
    def settle(self, seconds: float) -> None: ...


class ServolabMain(Node):
    """Publishes pings and floods, hears pongs and acks, all through one executor."""

    def __init__(self, context: Context, type_name: str, msg: Any,
                 on_arrival: bool = False) -> None:
        super().__init__(context, "bench_main")
        self.msg = msg
        self.pongs, self.acked, self.last_pong = 0, 0, None
        self.ping = self.create_publisher(type_name, PING, 0)
        self.flood_pub = self.create_publisher(type_name, FLOOD, 0)
        self.create_subscription(type_name, PONG, self._on_pong, 0, run_on_arrival=on_arrival)
        self.create_subscription(COUNT, FLOOD_ACK, self._on_ack, 0, run_on_arrival=on_arrival)

    def _on_pong(self, msg: Any) -> None:
        self.pongs += 1
        self.last_pong = msg

    def _on_ack(self, msg: Any) -> None:
        self.acked = msg.data

    def send_ping(self) -> None:
        self._before = self.pongs
        self.ping.publish(self.msg)

    def wait_pong(self, timeout: float) -> bool:
        return self.context.spin_until(lambda: self.pongs > self._before, timeout)

    def last_pong_matches(self) -> bool:
        return same_message(self.last_pong, self.msg)

    def flood(self, n: int, timeout: float) -> int:
        target = self.acked + n
        for _ in range(n):
            self.flood_pub.publish(self.msg)
        self.context.spin_until(lambda: self.acked >= target, timeout)
        return self.acked - (target - n)

    def settle(self, seconds: float) -> None:
        self.context.spin_for(seconds)


class ZenohMain:
    """Bare Zenoh: ``put`` the CDR bytes, wait on an event set by the subscriber callback."""

    def __init__(self, session: zenoh.Session, payload: bytes) -> None:
        self.payload = payload
        self.last_pong: bytes | None = None
        self.acked = 0
        self._pong = threading.Event()
        self._ack = threading.Condition()
        self.ping = session.declare_publisher(KEYS[PING], congestion_control=BLOCK)
        self.flood_pub = session.declare_publisher(KEYS[FLOOD], congestion_control=BLOCK)
        self.subscribers = [session.declare_subscriber(KEYS[PONG], self._on_pong),
                            session.declare_subscriber(KEYS[FLOOD_ACK], self._on_ack)]

    def _on_pong(self, sample: zenoh.Sample) -> None:
        self.last_pong = sample.payload.to_bytes()
        self._pong.set()

    def _on_ack(self, sample: zenoh.Sample) -> None:
        with self._ack:
            (self.acked,) = struct.unpack("<Q", sample.payload.to_bytes())
            self._ack.notify_all()

    def send_ping(self) -> None:
        self._pong.clear()
        self.ping.put(self.payload)

    def wait_pong(self, timeout: float) -> bool:
        return self._pong.wait(timeout)

    def last_pong_matches(self) -> bool:
        return self.last_pong == self.payload

    def flood(self, n: int, timeout: float) -> int:
        target = self.acked + n
        for _ in range(n):
            self.flood_pub.put(self.payload)
        with self._ack:
            self._ack.wait_for(lambda: self.acked >= target, timeout)
        return self.acked - (target - n)

    def settle(self, seconds: float) -> None:
        time.sleep(seconds)
        self._pong.clear()

    def close(self) -> None:
        for entity in (*self.subscribers, self.ping, self.flood_pub):
            entity.undeclare()


# -- measuring -------------------------------------------------------------------------------


@dataclass
class Figures:
    message: str
    setup: str
    engine: str          # servolab | zenoh
    processes: int
    cdr_bytes: int
    latency_p50_us: float
    latency_p99_us: float
    throughput_msg_s: float
    throughput_mb_s: float


def connect(main: MainSide, label: str, settle: float) -> None:
    """Ping until the echo answers (a child needs time to start and to find us)."""
    deadline = time.monotonic() + CONNECT_TIMEOUT
    while time.monotonic() < deadline:
        main.send_ping()
        if main.wait_pong(0.2):
            main.settle(settle)  # let answers to earlier pings arrive before timing starts
            if not main.last_pong_matches():
                raise RuntimeError(f"{label}: the echo came back different from what was sent")
            return
    raise RuntimeError(f"{label}: no echo within {CONNECT_TIMEOUT:.0f} s")


def measure(main: MainSide, label: str, sizes: Sizes) -> tuple[list[float], list[float]]:
    """Half round trips (s) of ``sizes.pings`` pings, and the floods' messages per second."""
    connect(main, label, sizes.settle)
    for _ in range(sizes.warmup):
        main.send_ping()
        if not main.wait_pong(ANSWER_TIMEOUT):
            raise RuntimeError(f"{label}: a warm-up ping got no answer")
    half_trips: list[float] = []
    rates: list[float] = []
    gc.collect()
    gc.disable()
    try:
        for _ in range(sizes.pings):
            start = time.perf_counter()
            main.send_ping()
            if not main.wait_pong(ANSWER_TIMEOUT):
                raise RuntimeError(f"{label}: a ping got no answer within {ANSWER_TIMEOUT} s")
            half_trips.append((time.perf_counter() - start) / 2)
        if not main.last_pong_matches():
            raise RuntimeError(f"{label}: the last echo differs from what was sent")
        for _ in range(sizes.rounds):
            start = time.perf_counter()
            arrived = main.flood(sizes.flood, ANSWER_TIMEOUT + sizes.flood * 0.01)
            elapsed = time.perf_counter() - start
            if arrived != sizes.flood:
                raise RuntimeError(f"{label}: {arrived} of {sizes.flood} flood messages arrived")
            rates.append(sizes.flood / elapsed)
            gc.collect()
    finally:
        gc.enable()
    return half_trips, rates


def percentile(values: Sequence[float], q: float) -> float:
    return float(np.percentile(np.asarray(values), q))


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextmanager
def child(engine: str, type_name: str, flood: int, endpoint: str,
          on_arrival: bool = False) -> Iterator[None]:
    """The echo side in its own OS process; stopped (stdin closed, then killed) on exit."""
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", engine,
           "--type", type_name, "--flood", str(flood), "--connect", endpoint,
           *(["--run-on-arrival"] if on_arrival else [])]
    proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        ready, _, _ = select.select([proc.stdout], [], [], CONNECT_TIMEOUT)
        line = proc.stdout.readline().strip() if ready else ""  # type: ignore[union-attr]
        if line != "ready":
            proc.kill()
            err = proc.stderr.read().strip().splitlines()  # type: ignore[union-attr]
            raise RuntimeError(f"echo process ({engine}) did not start: "
                               f"{err[-1] if err else 'no output'}")
        yield
    finally:
        try:
            proc.stdin.close()  # type: ignore[union-attr]
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def run_setup(engine: str, processes: int, type_name: str, sizes: Sizes,
              types: MessageTypes, on_arrival: bool = False) -> Figures:
    msg = sample_message(types, type_name)
    payload = types.serialize(msg, type_name)
    label = f"{SHORT_NAMES[type_name]}, {engine}, {processes} process(es)"
    if processes == 1 and engine == "servolab":
        with Context.open(types=types) as context:
            ServolabEcho(context, type_name, sizes.flood)
            half_trips, rates = measure(ServolabMain(context, type_name, msg), label, sizes)
    elif processes == 1:
        session = open_session(TransportOptions("zenoh", listen=[_loopback()]))
        try:
            echo = ZenohEcho(session, sizes.flood)
            main = ZenohMain(session, payload)
            try:
                half_trips, rates = measure(main, label, sizes)
            finally:
                main.close()
                echo.close()
        finally:
            session.close()
    else:
        endpoint = _loopback()
        options = TransportOptions("zenoh", listen=[endpoint])
        if engine == "servolab":
            with Context.open(options, types=types) as context:
                main_node = ServolabMain(context, type_name, msg, on_arrival)
                with child(engine, type_name, sizes.flood, endpoint, on_arrival):
                    half_trips, rates = measure(main_node, label, sizes)
        else:
            session = open_session(options)
            try:
                main = ZenohMain(session, payload)
                try:
                    with child(engine, type_name, sizes.flood, endpoint):
                        half_trips, rates = measure(main, label, sizes)
                finally:
                    main.close()
            finally:
                session.close()
    rate = statistics.median(rates)
    return Figures(
        message=SHORT_NAMES[type_name],
        setup=f"{engine}, {'one process' if processes == 1 else 'two processes'}",
        engine=engine, processes=processes, cdr_bytes=len(payload),
        latency_p50_us=percentile(half_trips, 50) * 1e6,
        latency_p99_us=percentile(half_trips, 99) * 1e6,
        throughput_msg_s=rate, throughput_mb_s=rate * len(payload) / 1e6)


def _loopback() -> str:
    return f"tcp/127.0.0.1:{free_port()}"


# -- the child process -----------------------------------------------------------------------


def run_child(engine: str, type_name: str, flood: int, endpoint: str,
              on_arrival: bool = False) -> int:
    """Echo until stdin closes (the parent is done, or gone)."""
    keep_freed_memory()  # the same heap for either engine (the module docstring)
    options = TransportOptions("zenoh", connect=[endpoint])

    def wait_for_parent() -> None:
        sys.stdin.read()

    if engine == "servolab":
        with Context.open(options) as context:
            ServolabEcho(context, type_name, flood, on_arrival)

            def stop_when_parent_is_done() -> None:
                wait_for_parent()
                context.shutdown()
            threading.Thread(target=stop_when_parent_is_done, daemon=True).start()
            print("ready", flush=True)
            context.executor.spin()
        return 0
    session = open_session(options)
    try:
        echo = ZenohEcho(session, flood)
        print("ready", flush=True)
        wait_for_parent()
        echo.close()
    finally:
        session.close()
    return 0


# -- report ----------------------------------------------------------------------------------


SETUPS = (("servolab", 1), ("zenoh", 1), ("servolab", 2), ("zenoh", 2))


def ratios(rows: list[Figures]) -> list[dict[str, Any]]:
    """servolab over zenoh for each message and process count: > 1 means servolab costs more."""
    out = []
    for message in dict.fromkeys(r.message for r in rows):
        for processes in (1, 2):
            ours = next(r for r in rows if (r.message, r.engine, r.processes)
                        == (message, "servolab", processes))
            bare = next(r for r in rows if (r.message, r.engine, r.processes)
                        == (message, "zenoh", processes))
            out.append({"message": message, "processes": processes,
                        "latency_p50": ours.latency_p50_us / bare.latency_p50_us,
                        "latency_p99": ours.latency_p99_us / bare.latency_p99_us,
                        "time_per_message": bare.throughput_msg_s / ours.throughput_msg_s,
                        "rate": ours.throughput_msg_s / bare.throughput_msg_s})
    return out


def ratio(costs: dict[str, float], work: str) -> float:
    """The generated codec's time over rosbags' for ``serialize`` or ``deserialize``
    (< 1: the codec is faster)."""
    return costs[f"{work}_us"] / costs[f"rosbags_{work}_us"]


def _version(dist: str) -> str:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "?"


def main(argv: Sequence[str] | None = None,
         progress: Callable[[str], None] = lambda s: print(s, file=sys.stderr, flush=True)
         ) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true",
                        help="a few messages per setup: checks that it runs, not how fast")
    parser.add_argument("--json", type=Path, help="also write the figures to this file")
    parser.add_argument("--runs", type=int, default=1,
                        help="measure every setup this many times, one run after the other, "
                             "and end with the spread of the ratios and how many runs met "
                             "each target (the report above it is the last run's)")
    parser.add_argument("--run-on-arrival", action="store_true",
                        help="servolab's subscriptions between processes run a message that "
                             "finds the executor idle on the thread that received it "
                             "(Subscription's run_on_arrival), a thread wake-up sooner")
    parser.add_argument("--child", choices=("servolab", "zenoh"), help=argparse.SUPPRESS)
    parser.add_argument("--type", default=TWIST, help=argparse.SUPPRESS)
    parser.add_argument("--flood", type=int, default=1, help=argparse.SUPPRESS)
    parser.add_argument("--connect", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        return run_child(args.child, args.type, args.flood, args.connect,
                         args.run_on_arrival)

    keep_freed_memory()  # the same heap for every setup (the module docstring)
    sizes = QUICK if args.quick else FULL
    types = MessageTypes()
    print(f"servolab middleware benchmark: Python {platform.python_version()}, "
          f"eclipse-zenoh {_version('eclipse-zenoh')}, rosbags {_version('rosbags')}, "
          f"{platform.machine()}{' (quick)' if args.quick else ''}"
          f"{'; run_on_arrival between processes' if args.run_on_arrival else ''}")
    if args.runs < 1:
        parser.error(f"--runs must be at least 1, got {args.runs}")
    runs: list[list[Figures]] = []
    for run in range(args.runs):
        rows: list[Figures] = []
        for type_name in (TWIST, IMAGE):
            for engine, processes in SETUPS:
                progress(f"  run {run + 1}/{args.runs}, measuring {SHORT_NAMES[type_name]}: "
                         f"{engine}, {processes} process(es)...")
                rows.append(run_setup(engine, processes, type_name, sizes[type_name], types,
                                      args.run_on_arrival))
        runs.append(rows)

    print()
    print("latency = half a ping-pong round trip; throughput = one way, N back to back")
    print(f"{'message':8} {'setup':26} {'bytes':>7} {'p50 us':>9} {'p99 us':>9} "
          f"{'msg/s':>10} {'MB/s':>8}")
    for r in rows:
        print(f"{r.message:8} {r.setup:26} {r.cdr_bytes:7d} {r.latency_p50_us:9.1f} "
              f"{r.latency_p99_us:9.1f} {r.throughput_msg_s:10.0f} {r.throughput_mb_s:8.1f}")
    print()
    print("servolab / bare zenoh (> 1: servolab costs more):")
    found = ratios(rows)
    for q in found:
        where = "one process" if q["processes"] == 1 else "two processes"
        print(f"ratio {q['message']} {where}: latency p50 x{q['latency_p50']:.2f}, "
              f"p99 x{q['latency_p99']:.2f}, messages per second x{q['rate']:.2f} "
              f"(time per message x{q['time_per_message']:.2f})")
    twist = next(q for q in found if q["message"] == SHORT_NAMES[TWIST] and q["processes"] == 2)
    # issue 15's targets for a Twist between two processes (docs/middleware.md, "How fast")
    for what, value, target, met in (
            ("p50 latency", twist["latency_p50"], "<= x1.5", twist["latency_p50"] <= 1.5),
            ("messages per second", twist["rate"], ">= x0.5", twist["rate"] >= 0.5)):
        print(f"target Twist two processes, {what}: x{value:.2f} of bare zenoh "
              f"(target {target}): {'met' if met else 'NOT met'}")

    print()
    print("Python work per message, each timed alone (us):")
    costs = {SHORT_NAMES[t]: python_costs(types, t, sizes[t]) for t in (TWIST, IMAGE)}
    for message, c in costs.items():
        one = next(r for r in rows if (r.message, r.engine, r.processes)
                   == (message, "servolab", 1))
        two = next(r for r in rows if (r.message, r.engine, r.processes)
                   == (message, "servolab", 2))
        bare = next(r for r in rows if (r.message, r.engine, r.processes)
                    == (message, "zenoh", 2))
        print(f"{message}: serialize {c['serialize_us']:.2f}, deserialize "
              f"{c['deserialize_us']:.2f}, copy_message {c['copy_us']:.1f}")
        print(f"  CDR codec {message}: serialize {c['serialize_us']:.2f} us vs rosbags "
              f"{c['rosbags_serialize_us']:.2f} us (x{ratio(c, 'serialize'):.2f}), deserialize "
              f"{c['deserialize_us']:.2f} us vs rosbags {c['rosbags_deserialize_us']:.2f} us "
              f"(x{ratio(c, 'deserialize'):.2f})")
        print(f"  value semantics, one process: the copy per publish is "
              f"{c['copy_us'] / (1e6 / one.throughput_msg_s):.0%} of servolab's time per "
              f"message ({1e6 / one.throughput_msg_s:.1f} us) and "
              f"{c['copy_us'] / one.latency_p50_us:.0%} of its p50 latency")
        print(f"  two processes: servolab {1e6 / two.throughput_msg_s:.1f} us per message "
              f"one way, bare zenoh {1e6 / bare.throughput_msg_s:.1f} us; CDR alone "
              f"(serialize + deserialize) is {c['serialize_us'] + c['deserialize_us']:.1f} us")
    sending = publish_costs(types, quick=args.quick)
    print(f"Twist publish over Zenoh: bare put {sending['put_us']:.2f} us, with rmw_zenoh's "
          f"attachment {sending['put_attachment_us']:.2f} us; servolab's publish "
          f"{sending['publish_us']:.2f} us (CDR, attachment, put)")
    if twist["rate"] < 0.5:
        c = costs[SHORT_NAMES[TWIST]]
        bare = next(r for r in rows if (r.message, r.engine, r.processes)
                    == (SHORT_NAMES[TWIST], "zenoh", 2))
        bare_us = 1e6 / bare.throughput_msg_s
        cdr_us = c["serialize_us"] + c["deserialize_us"]
        print(f"what remains (Twist rate): CDR is no longer the main cost (serialize "
              f"{c['serialize_us']:.2f} + deserialize {c['deserialize_us']:.2f} us, generated "
              f"codec, x{cdr_us / bare_us:.2f} of bare zenoh's whole time per message, "
              f"{bare_us:.1f} us, whose receiver only counts); the rest is per-message work "
              "no Python receiver avoids: taking each sample from Zenoh's channel and copying "
              "its payload out, the executor's turn and the callback, and the rmw_zenoh "
              "attachment on every put (docs/middleware.md, \"How fast\")")
        # a bound, not a measurement: each side needs at least bare zenoh's time per message
        # plus its own CDR work, whatever else the middleware costs
        best = bare_us / (bare_us + max(c["serialize_us"], c["deserialize_us"]))
        print(f"best Twist rate the CDR codec allows: x{best:.2f} of bare zenoh (each side "
              f"at least bare zenoh's {bare_us:.1f} us plus its CDR; everything else free)")
    every = [ratios(run_rows) for run_rows in runs]
    if len(runs) > 1:
        print()
        print(f"over {len(runs)} runs (each ratio within its run): min to max, median")
        for index, q in enumerate(found):
            values = {k: [run_ratios[index][k] for run_ratios in every]
                      for k in ("latency_p50", "rate")}
            where = "one process" if q["processes"] == 1 else "two processes"
            print(f"spread {q['message']} {where}: latency p50 "
                  f"x{min(values['latency_p50']):.2f} to x{max(values['latency_p50']):.2f} "
                  f"(median x{statistics.median(values['latency_p50']):.2f}), messages per "
                  f"second x{min(values['rate']):.2f} to x{max(values['rate']):.2f} "
                  f"(median x{statistics.median(values['rate']):.2f})")
        met = [(t["latency_p50"] <= 1.5, t["rate"] >= 0.5) for t in (
            next(q for q in run_ratios if q["message"] == SHORT_NAMES[TWIST]
                 and q["processes"] == 2) for run_ratios in every)]
        print(f"targets met, Twist two processes: p50 latency in {sum(a for a, _ in met)} of "
              f"{len(met)} runs, messages per second in {sum(b for _, b in met)} of "
              f"{len(met)}, both in {sum(a and b for a, b in met)} of {len(met)}")
    if args.json:
        args.json.write_text(json.dumps({"rows": [asdict(r) for r in rows], "ratios": found,
                                         "runs": [{"rows": [asdict(r) for r in run_rows],
                                                   "ratios": run_ratios}
                                                  for run_rows, run_ratios in zip(
                                                      runs, every, strict=True)],
                                         "python_costs_us": costs,
                                         "publish_costs_us": sending,
                                         "sizes": {SHORT_NAMES[k]: asdict(v)
                                                   for k, v in sizes.items()}}, indent=2))
    if not all(math.isfinite(v) and v > 0 for run_ratios in every for q in run_ratios
               for k, v in q.items() if k.startswith(("latency", "time", "rate"))):
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
