"""Against a stock ROS 2, in the same run. First, discovery: a talker that publishes from
start-up at 10 Hz (``std_msgs/msg/String`` "0", "1", ...) to a real rclpy listener already
running, on Fast DDS in loopback discovery; how many of its first messages the listener never
got. The talker is the real rclpy's, then servolab's on ``--transport ros2`` (its own rmw, the same
Fast DDS), then servolab's on ``--transport dds`` (Cyclone DDS), alternating, ``--runs`` times
each; the real talker's loss is the anchor the others are read against.

Then large messages (``--frames``): 150 ``sensor_msgs/msg/Image`` 640x480 rgb8 at 30 Hz, reliable,
depth 10, to a real rclpy subscriber, from a real publisher (the anchor), servolab on ``ros2`` and
servolab on ``dds``; how many arrived, over how long, and how many UDP datagrams the kernel
dropped for want of socket buffer meanwhile (``RcvbufErrors``, /proc/net/snmp), with the
machine's ``net.core.rmem_default`` beside them (docs/middleware.md).

Needs the oracle venv (``make ros-oracle``). Run: ``.venv/bin/python benchmarks/ros2_transport.py
[--runs N] [--frames]``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from tests.middleware.test_ros2_transport import (  # noqa: E402 - the tests' own programs
    IMAGE_PUBLISHER,
    REAL,
    SERVOLAB,
)
from tests.rosoracle import (  # noqa: E402 - the oracle's environment, as the tests make it
    free_domain_id,
    ros_env,
    ros_python,
    servolab_on_ros_env,
)

FRAME_COUNTER = """
import time
import rclpy
from sensor_msgs.msg import Image
rclpy.init()
node = rclpy.create_node("frame_counter")
seen, last = [], [0.0]
def on_image(msg):
    seen.append(int(msg.header.frame_id))
    last[0] = time.monotonic()
node.create_subscription(Image, "/camera/image_raw", on_image, 10)
print("ready", flush=True)
start = time.monotonic()
while (not seen and time.monotonic() - start < 30) or (seen and time.monotonic() - last[0] < 3):
    rclpy.spin_once(node, timeout_sec=0.1)
print(len(seen), round(last[0] - start, 2) if seen else 0, flush=True)
"""

LISTENER = """
import rclpy
from std_msgs.msg import String
rclpy.init()
node = rclpy.create_node("listener")
heard = []
node.create_subscription(String, "/chatter", lambda m: heard.append(int(m.data)), 10)
print("ready", flush=True)
while not heard or heard[-1] < 30:
    rclpy.spin_once(node, timeout_sec=10.0)
print("first", heard[0], flush=True)
"""

TALKER = """
import time
import {rclpy} as rclpy
from {msgs}std_msgs.msg import String
rclpy.init()
node = rclpy.create_node("talker")
publisher = node.create_publisher(String, "/chatter", 10)
for i in range(40):
    publisher.publish(String(data=str(i)))
    time.sleep(0.1)
"""


def lost(talker: list[str], talker_env: dict[str, str], domain: int) -> int:
    env = ros_env(domain)
    listener = subprocess.Popen([str(ros_python()), "-c", LISTENER], env=env,
                                stdout=subprocess.PIPE, text=True)
    try:
        assert listener.stdout is not None
        assert listener.stdout.readline().strip() == "ready"
        time.sleep(1.0)  # the listener's participant is up and announced
        subprocess.run(talker, env=talker_env, timeout=60, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        out, _ = listener.communicate(timeout=30)
    finally:
        listener.kill()
        listener.wait()
    return int(out.split()[-1])


def environments(domain: int) -> dict[str, dict[str, str]]:
    """Each side's environment, in the order they run: the real rclpy (the anchor), servolab
    on ``--transport ros2`` (the oracle's rmw), servolab on ``--transport dds``."""
    return {"real rclpy": ros_env(domain), "servolab ros2": servolab_on_ros_env(domain),
            "servolab dds": {**ros_env(domain), "SERVOLAB_TRANSPORT": "dds",
                             "LD_LIBRARY_PATH": os.environ.get("LD_LIBRARY_PATH", "")}}


def udp_receive_buffer_errors() -> int:
    lines = [line.split() for line in Path("/proc/net/snmp").read_text().splitlines()
             if line.startswith("Udp:")]
    return int(dict(zip(lines[0][1:], lines[1][1:], strict=True))["RcvbufErrors"])


def frames(publisher: list[str], publisher_env: dict[str, str], domain: int
           ) -> tuple[int, float, int]:
    """Frames a real subscriber got, over how many seconds, and the UDP drops meanwhile."""
    before = udp_receive_buffer_errors()
    counter = subprocess.Popen([str(ros_python()), "-c", FRAME_COUNTER], env=ros_env(domain),
                               stdout=subprocess.PIPE, text=True)
    sender = None
    try:
        assert counter.stdout is not None
        assert counter.stdout.readline().strip() == "ready"
        sender = subprocess.Popen(publisher, env=publisher_env, stdout=subprocess.DEVNULL,
                                  stderr=subprocess.DEVNULL)
        out, _ = counter.communicate(timeout=90)
    finally:
        for proc in (counter, sender):
            if proc is not None:
                proc.kill()
                proc.wait()
    got, span = out.split()
    return int(got), float(span), udp_receive_buffer_errors() - before


def large_frames(runs: int) -> None:
    real = [str(ros_python()), "-c", IMAGE_PUBLISHER.format(**REAL)]
    ours = [sys.executable, "-c", IMAGE_PUBLISHER.format(**SERVOLAB)]
    rows: dict[str, list[tuple[int, float, int]]] = {
        "real rclpy": [], "servolab ros2": [], "servolab dds": []}
    for _ in range(runs):
        domain = free_domain_id()
        for name, env in environments(domain).items():
            rows[name].append(frames(real if name == "real rclpy" else ours, env, domain))
    rmem = Path("/proc/sys/net/core/rmem_default").read_text().strip()
    anchor = statistics.median(got for got, _, _ in rows["real rclpy"])
    print(f"150 Image frames 640x480 at 30 Hz -> a real subscriber ({runs} runs each; "
          f"net.core.rmem_default {rmem} B)")
    for name, results in rows.items():
        got = statistics.median(g for g, _, _ in results)
        print(f"  {name:14s} frames {[g for g, _, _ in results]}  over "
              f"{[s for _, s, _ in results]} s  UDP RcvbufErrors {[e for _, _, e in results]}"
              + (f"  median x{got / anchor:.2f} of the real publisher's" if anchor
                 else "  (the real publisher delivered none: no ratio)"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--frames", action="store_true",
                        help="also the large-message runs (about 20 s a run)")
    args = parser.parse_args()
    real = [str(ros_python()), "-c", TALKER.format(rclpy="rclpy", msgs="")]
    ours = [sys.executable, "-c", TALKER.format(rclpy="servolab.rclpy",
                                                msgs="servolab.interfaces.")]
    results: dict[str, list[int]] = {"real rclpy": [], "servolab ros2": [], "servolab dds": []}
    for _ in range(args.runs):
        domain = free_domain_id()
        for name, env in environments(domain).items():
            results[name].append(lost(real if name == "real rclpy" else ours, env, domain))
    anchor = statistics.median(results["real rclpy"])
    print(f"messages lost at start-up, 10 Hz talker -> real listener ({args.runs} runs each; "
          "a run's outlier shows in the mean, the median is compared)")
    for name, losses in results.items():
        median = statistics.median(losses)
        against = f"x{median / anchor:.2f}" if anchor else f"{median - anchor:+.1f} messages"
        print(f"  {name:14s} {losses}  mean {statistics.mean(losses):.1f}  median "
              f"{median:g}  vs the real talker's median: {against}")
    if args.frames:
        large_frames(args.runs)


if __name__ == "__main__":
    main()
