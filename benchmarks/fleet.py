"""How servolab's graph grows with nodes and routers, against bare Zenoh doing the same in the
same run: graph discovery time, memory per node and message rate at 10, 50 and 200 nodes, peer
to peer, through one Zenoh router and through two routers chained.

**What a node is.** A *fleet* process (a child) hosts ``n`` nodes, as a robot's process hosts
its nodes: with servolab, ``n`` :class:`~servolab.middleware.node.Node` in one context on the
Zenoh transport, each with a publisher on ``/fleet/chatter`` and a subscription on its own
``in`` topic (and whatever else a servolab node declares: its parameter services); with bare
Zenoh, one session declaring for each node what rmw_zenoh declares at the least (a liveliness
token for the node, one for its publisher and one for its subscription, a publisher and a
subscriber). The anchor is not an rclpy: it is the engine with nothing of ROS on top, so the
ratio is what servolab's nodes cost over the wire protocol they speak.

**Who measures.** The same *observer* for both engines, a bare Zenoh session in this process:
it counts the nodes' liveliness tokens (``@ros2_lv/<domain>/**/NN/**``, what ``ros2 node list``
reads over rmw_zenoh) and the samples on ``<domain>/fleet/chatter/**``, so that the two engines
are judged by one ruler.

- **Discovery**: from the moment the child starts making its nodes (its ``time.time()``, one
  clock on one machine; with several robots, the last one to start) until the observer's
  liveliness query returns all the nodes' tokens.
- **Memory per node**: the child's resident set (``/proc/self/statm``) after making the nodes
  minus before, over ``n``.
- **Message rate**: the child's nodes publish ``per_node`` ``std_msgs/msg/String`` each, round
  robin, as fast as they can; the observer's samples over the time from its first to its last.
  Messages lost are counted: the publishers are KEEP_LAST (depth 10), which rmw_zenoh (and
  servolab, ``zenoh_transport.congestion_control``) declares with Zenoh's DROP congestion
  control, so that a stalled subscriber never stalls a control loop; the anchor's are set
  alike. A flood can outrun the observer (more likely through routers, an extra hop, and on a
  busy machine), and then some are dropped, on either engine.

**Topologies.** ``peer``: the child connects to the observer's listening endpoint (servolab's
default, peer to peer). ``router``: a Zenoh router in its own process (``servolab router``'s
engine: zenoh-python in router mode), the child and the observer each connecting to it alone.
``two routers``: router B connects to router A; the child connects to A, the observer to B, so
discovery crosses both routers. Peers still link to each other directly once they learn of each
other (Zenoh's gossip, as rmw_zenoh's peers do), so the routers carry discovery, not data.

**Robots.** The same through one router with 1 and 10 robots (2 with ``--quick``): a process
each, of 5 nodes each, as a lab's robots each run their own process.

The ratios servolab / bare Zenoh are measured in the same run; each figure's growth from the
fewest nodes to the most says how it scales (1 per node: linear in the nodes).

Run: ``.venv/bin/python benchmarks/fleet.py [--quick] [--json PATH]``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import select
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator, Sequence
from contextlib import ExitStack, contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import zenoh

#: the ROS domain the fleet is on (what rmw_zenoh puts first in its key expressions)
DOMAIN = 0
#: the nodes of a fleet, the full run's and --quick's
NODES, QUICK_NODES = (10, 50, 200), (5, 20)
#: robots (processes) of :data:`ROBOT_NODES` nodes each through one router, full and --quick
ROBOTS, QUICK_ROBOTS, ROBOT_NODES = (1, 10), (1, 2), 5
#: messages all nodes of a fleet publish together, whatever their number
MESSAGES, QUICK_MESSAGES = 20_000, 1_000
TOPOLOGIES = ("peer", "router", "two routers")
#: --quick's: one router is measured by the robots' sweep
QUICK_TOPOLOGIES = ("peer", "two routers")
ENGINES = ("servolab", "zenoh")
#: s a step may take before the benchmark gives up on it
TIMEOUT = 120.0
PAGE = os.sysconf("SC_PAGE_SIZE")


@dataclass
class Figures:
    """One fleet measured: its engine, topology and size, and what was seen."""

    engine: str
    topology: str
    nodes: int
    discovery_s: float
    rss_per_node_kib: float
    messages_per_s: float
    messages_lost: int
    #: processes the nodes are spread over (robots), ``nodes`` each
    robots: int = 1


def free_endpoint() -> str:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{s.getsockname()[1]}"


def rss_bytes() -> int:
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * PAGE


def _config(mode: str, listen: Sequence[str], connect: Sequence[str]) -> zenoh.Config:
    """A session or router as servolab opens them: no multicast scouting, timestamps on."""
    config = zenoh.Config()
    config.insert_json5("mode", json.dumps(mode))
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("listen/endpoints", json.dumps(list(listen)))
    config.insert_json5("connect/endpoints", json.dumps(list(connect)))
    config.insert_json5("timestamping/enabled", "true")
    return config


# -- the processes -----------------------------------------------------------------------------


@contextmanager
def process(args: Sequence[str], wanted: str
            ) -> Iterator[tuple[subprocess.Popen[str], str]]:
    """This script run again with ``args`` until the block ends (stdin closed, then killed),
    once it has printed a line starting with ``wanted``; the process and that line."""
    # rmw_zenoh's variables would change the servolab side only (bare Zenoh reads none)
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENOH_")}
    proc = subprocess.Popen([sys.executable, str(Path(__file__).resolve()), *args],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)
    try:
        line = read_line(proc, wanted)
        if not line:
            proc.kill()
            err = (proc.stderr.read() if proc.stderr else "").strip().splitlines()
            raise RuntimeError(f"{' '.join(args)}: did not start: "
                               f"{err[-1] if err else 'no output'}")
        yield proc, line
    finally:
        try:
            if proc.stdin:
                proc.stdin.close()
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def read_line(proc: subprocess.Popen[str], wanted: str, timeout: float = TIMEOUT) -> str:
    """The first line of ``proc``'s output starting with ``wanted``, or "" at its end or after
    ``timeout`` s."""
    assert proc.stdout is not None
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        ready, _, _ = select.select([proc.stdout], [], [], deadline - time.monotonic())
        if not ready:
            return ""
        line = proc.stdout.readline()
        if not line:
            return ""
        if line.startswith(wanted):
            return line.strip()
    return ""


def run_router(listen: str, connect: Sequence[str]) -> int:
    """A Zenoh router until stdin closes."""
    router = zenoh.open(_config("router", [listen], connect))
    print("router", flush=True)
    sys.stdin.read()
    router.close()
    return 0


def run_fleet(engine: str, nodes: int, per_node: int, connect: str) -> int:
    """Open the session, then make ``nodes`` nodes (reporting when that began and the memory
    they took), publish on the word ``go``, and stay until stdin closes."""
    fleet: ServolabFleet | ZenohFleet = (ServolabFleet(connect) if engine == "servolab"
                                         else ZenohFleet(connect))
    began = time.time()
    before = rss_bytes()
    fleet.make(nodes)
    print(f"made {began:.6f} {rss_bytes() - before}", flush=True)
    if sys.stdin.readline().strip() == "go":
        wait_for_observer(fleet.session)
        for _ in range(per_node):
            fleet.publish()
        print("sent", flush=True)
        sys.stdin.read()
    fleet.close()
    return 0


def wait_for_observer(session: zenoh.Session) -> None:
    """Until this session knows the observer's subscriber (Zenoh's matching status of a
    publisher on the observer's key), so that no message is sent before there is a route to
    it: a message lost is then a message the engine lost."""
    probe = session.declare_publisher(f"{DOMAIN}/fleet/chatter/probe")
    deadline = time.monotonic() + TIMEOUT
    # zenoh 1.10 gives a MatchingStatus (its stub says bool)
    while not probe.matching_status.matching and time.monotonic() < deadline:  # type: ignore[attr-defined]
        time.sleep(0.005)
    probe.undeclare()


class ServolabFleet:
    """servolab nodes in one context on the Zenoh transport."""

    def __init__(self, connect: str) -> None:
        from servolab.middleware.context import Context
        from servolab.middleware.node import Node
        from servolab.middleware.transport import TransportOptions

        self.node_class = Node
        self.context = Context.open(TransportOptions("zenoh", connect=[connect]))
        self.session: zenoh.Session = self.context.transport.session  # type: ignore[attr-defined]
        self.publishers: list[Any] = []
        self.message: Any = None

    def make(self, nodes: int) -> None:
        for k in range(nodes):
            node = self.node_class(self.context, f"node_{k:03d}", namespace="/fleet")
            self.publishers.append(node.create_publisher("std_msgs/msg/String",
                                                         "/fleet/chatter", 10))
            node.create_subscription("std_msgs/msg/String", "in", lambda _: None, 10)
            self.message = node.message("std_msgs/msg/String", data="x" * 16)

    def publish(self) -> None:
        for publisher in self.publishers:
            publisher.publish(self.message)

    def close(self) -> None:
        self.context.close()


class ZenohFleet:
    """What rmw_zenoh declares for such nodes at the least, on one bare Zenoh session."""

    #: a String "xxxxxxxxxxxxxxxx" in CDR: encapsulation, length 17, the bytes and a NUL
    PAYLOAD = bytes([0, 1, 0, 0, 17, 0, 0, 0]) + b"x" * 16 + b"\0"

    def __init__(self, connect: str) -> None:
        self.session = zenoh.open(_config("peer", ["tcp/127.0.0.1:0"], [connect]))
        self.zid = str(self.session.info.zid())
        self.kept: list[Any] = []
        self.publishers: list[Any] = []

    def make(self, nodes: int) -> None:
        session, kind = self.session, "std_msgs::msg::dds_::String_/x/x"
        for k in range(nodes):
            name, base = f"node_{k:03d}", f"@ros2_lv/{DOMAIN}/{self.zid}/0/{k}"
            self.kept += [
                session.liveliness().declare_token(f"{base}/NN/%/%fleet/{name}"),
                session.liveliness().declare_token(
                    f"{base}1/MP/%/%fleet/{name}/%fleet%chatter/{kind}"),
                session.liveliness().declare_token(
                    f"{base}2/MS/%/%fleet/{name}/%fleet%{name}%in/{kind}"),
                session.declare_subscriber(f"{DOMAIN}/fleet/{name}/in/String",
                                           lambda _: None)]
            self.publishers.append(session.declare_publisher(
                f"{DOMAIN}/fleet/chatter/String",
                congestion_control=zenoh.CongestionControl.DROP))   # as servolab's KEEP_LAST

    def publish(self) -> None:
        for publisher in self.publishers:
            publisher.put(self.PAYLOAD)

    def close(self) -> None:
        for thing in (*self.publishers, *self.kept):
            thing.undeclare()
        self.session.close()


# -- the observer ------------------------------------------------------------------------------


class Observer:
    """A bare Zenoh session that counts the fleet's node tokens and chatter samples."""

    def __init__(self, listen: Sequence[str], connect: Sequence[str]) -> None:
        self.session = zenoh.open(_config("peer", listen, connect))
        self.count = 0
        self.first = self.last = 0.0
        self.lock = threading.Lock()
        self.subscriber = self.session.declare_subscriber(f"{DOMAIN}/fleet/chatter/**",
                                                          self._heard)

    def _heard(self, _sample: zenoh.Sample) -> None:
        now = time.perf_counter()
        with self.lock:
            if not self.count:
                self.first = now
            self.count += 1
            self.last = now

    def nodes(self) -> int:
        replies = self.session.liveliness().get(f"@ros2_lv/{DOMAIN}/**/NN/**", timeout=1.0)
        return sum(1 for r in replies if r.ok is not None and "fleet" in str(r.ok.key_expr))

    def wait_nodes(self, n: int) -> float:
        """time.time() when all ``n`` nodes are seen."""
        deadline = time.monotonic() + TIMEOUT
        while time.monotonic() < deadline:
            if self.nodes() >= n:
                return time.time()
            time.sleep(0.005)
        raise RuntimeError(f"the observer saw {self.nodes()} of {n} nodes in {TIMEOUT:g} s")

    def wait_messages(self, n: int, quiet: float = 1.0) -> None:
        """Until ``n`` samples came or none came for ``quiet`` s after the last."""
        deadline = time.monotonic() + TIMEOUT
        while time.monotonic() < deadline:
            with self.lock:
                count, last = self.count, self.last
            if count >= n or (count and time.perf_counter() - last > quiet):
                return
            time.sleep(0.01)

    def close(self) -> None:
        self.subscriber.undeclare()
        self.session.close()


def measure(engine: str, topology: str, nodes: int, messages: int, robots: int = 1
            ) -> Figures:
    """One fleet: ``robots`` processes of ``nodes`` nodes each (see the module docstring)."""
    per_node = max(1, messages // (nodes * robots))
    with ExitStack() as stack:
        observer_listen = [free_endpoint()]
        if topology == "peer":
            fleet_connect, observer_connect = observer_listen[0], []
        else:
            router_a = free_endpoint()
            stack.enter_context(process(["--router", router_a], "router"))
            fleet_connect, observer_connect = router_a, [router_a]
            if topology == "two routers":
                router_b = free_endpoint()
                stack.enter_context(process(["--router", router_b, "--connect", router_a],
                                            "router"))
                observer_connect = [router_b]
        observer = Observer(observer_listen, observer_connect)
        stack.callback(observer.close)
        fleets = [stack.enter_context(process(
            ["--fleet", engine, "--nodes", str(nodes), "--per-node", str(per_node),
             "--connect", fleet_connect], "made")) for _ in range(robots)]
        made = [line.split() for _, line in fleets]
        seen = observer.wait_nodes(nodes * robots)
        for fleet, _ in fleets:
            assert fleet.stdin is not None
            fleet.stdin.write("go\n")
            fleet.stdin.flush()
        sent = nodes * robots * per_node
        observer.wait_messages(sent)
        with observer.lock:
            count, first, last = observer.count, observer.first, observer.last
        rate = (count - 1) / (last - first) if count > 1 and last > first else 0.0
        return Figures(engine, topology, nodes, seen - max(float(m[1]) for m in made),
                       sum(int(m[2]) for m in made) / (nodes * robots) / 1024, rate,
                       sent - count, robots)


# -- report ------------------------------------------------------------------------------------


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true",
                        help="5 and 20 nodes, fewer messages, no one-router sweep: checks "
                        "that it runs")
    parser.add_argument("--json", type=Path, help="also write the figures to this file")
    parser.add_argument("--router", help=argparse.SUPPRESS)
    parser.add_argument("--fleet", choices=ENGINES, help=argparse.SUPPRESS)
    parser.add_argument("--nodes", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--per-node", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--connect", action="append", default=[], help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.router:
        return run_router(args.router, args.connect)
    if args.fleet:
        return run_fleet(args.fleet, args.nodes, args.per_node, args.connect[0])
    sizes = QUICK_NODES if args.quick else NODES
    messages = QUICK_MESSAGES if args.quick else MESSAGES
    print(f"servolab fleet benchmark: Python {platform.python_version()}, eclipse-zenoh "
          f"{zenoh.__version__ if hasattr(zenoh, '__version__') else '?'}, "
          f"{os.cpu_count()} cores{' (quick)' if args.quick else ''}")
    rows: list[Figures] = []
    topologies = QUICK_TOPOLOGIES if args.quick else TOPOLOGIES
    for topology in topologies:
        for nodes in sizes:
            for engine in ENGINES:
                print(f"  measuring {engine}, {topology}, {nodes} nodes...", file=sys.stderr,
                      flush=True)
                rows.append(measure(engine, topology, nodes, messages))
    for robots in QUICK_ROBOTS if args.quick else ROBOTS:
        for engine in ENGINES:
            print(f"  measuring {engine}, {robots} robots of {ROBOT_NODES} nodes through a "
                  "router...", file=sys.stderr, flush=True)
            rows.append(measure(engine, "router", ROBOT_NODES, messages, robots))
    report(rows, sizes, topologies)
    if args.json:
        args.json.write_text(json.dumps([asdict(r) for r in rows], indent=2) + "\n")
    return 0


def report(rows: list[Figures], sizes: Sequence[int], topologies: Sequence[str]) -> None:
    print()
    print(f"{'topology':12} {'nodes':>5} {'engine':9} {'discovery s':>11} "
          f"{'KiB/node':>9} {'msg/s':>9} {'lost':>5}")
    for r in rows:
        print(f"{r.topology if r.robots == 1 else f'{r.robots} robots':12} {r.nodes:5d} "
              f"{r.engine:9} {r.discovery_s:11.3f} "
              f"{r.rss_per_node_kib:9.1f} {r.messages_per_s:9.0f} {r.messages_lost:5d}")
    print()
    print("servolab / bare zenoh (> 1: servolab costs more; for msg/s, < 1: fewer):")
    by = {(r.engine, r.topology, r.nodes): r for r in rows if r.robots == 1}
    for topology in topologies:
        for nodes in sizes:
            s, z = by["servolab", topology, nodes], by["zenoh", topology, nodes]
            print(f"ratio {topology}, {nodes} nodes: discovery x{s.discovery_s / z.discovery_s:.2f}"
                  f", memory per node x{s.rss_per_node_kib / max(z.rss_per_node_kib, 1e-9):.2f}"
                  f", messages per second x{s.messages_per_s / max(z.messages_per_s, 1e-9):.2f}")
    print()
    few, many = sizes[0], sizes[-1]
    print(f"growth from {few} to {many} nodes (x{many / few:g} the nodes):")
    for topology in topologies:
        for engine in ENGINES:
            a, b = by[engine, topology, few], by[engine, topology, many]
            print(f"growth {engine}, {topology}: discovery x{b.discovery_s / a.discovery_s:.2f}"
                  f", memory per node x{b.rss_per_node_kib / max(a.rss_per_node_kib, 1e-9):.2f}"
                  f", messages per second x{b.messages_per_s / max(a.messages_per_s, 1e-9):.2f}")
    fleets = {(r.engine, r.robots): r for r in rows
              if r.nodes == ROBOT_NODES and r.topology == "router"}
    counts = sorted({robots for _, robots in fleets})
    if len(counts) < 2:
        return
    print()
    print(f"robots of {ROBOT_NODES} nodes each, one process each, through one router:")
    for robots in counts:
        s, z = fleets["servolab", robots], fleets["zenoh", robots]
        print(f"ratio {robots} robots: discovery x{s.discovery_s / z.discovery_s:.2f}, "
              f"memory per node x{s.rss_per_node_kib / max(z.rss_per_node_kib, 1e-9):.2f}, "
              f"messages per second x{s.messages_per_s / max(z.messages_per_s, 1e-9):.2f}")
    for engine in ENGINES:
        a, b = fleets[engine, counts[0]], fleets[engine, counts[-1]]
        print(f"growth {engine}, {counts[0]} to {counts[-1]} robots: discovery "
              f"x{b.discovery_s / a.discovery_s:.2f}, messages per second "
              f"x{b.messages_per_s / max(a.messages_per_s, 1e-9):.2f}")


if __name__ == "__main__":
    sys.exit(main())
