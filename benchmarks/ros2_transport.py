"""Discovery against a stock ROS 2, in the same run: a talker that publishes from start-up at
10 Hz (``std_msgs/msg/String`` "0", "1", ...) to a real rclpy listener already running, on
Fast DDS in loopback discovery; how many of its first messages the listener never got. The
talker is the real rclpy's, then servolab's on ``--transport ros2`` (its own rmw, the same
Fast DDS), then servolab's on ``--transport dds`` (Cyclone DDS), alternating, ``--runs`` times
each; the real talker's loss is the anchor the others are read against.

Needs the oracle venv (``make ros-oracle``). Run: ``.venv/bin/python benchmarks/ros2_transport.py
[--runs N]``.
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

from tests.rosoracle import (  # noqa: E402 - the oracle's environment, as the tests make it
    free_domain_id,
    ros_env,
    ros_python,
    servolab_on_ros_env,
)

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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    real = [str(ros_python()), "-c", TALKER.format(rclpy="rclpy", msgs="")]
    ours = [sys.executable, "-c", TALKER.format(rclpy="servolab.rclpy",
                                                msgs="servolab.interfaces.")]
    results: dict[str, list[int]] = {"real rclpy": [], "servolab ros2": [], "servolab dds": []}
    for _ in range(args.runs):
        domain = free_domain_id()
        results["real rclpy"].append(lost(real, ros_env(domain), domain))
        results["servolab ros2"].append(lost(ours, servolab_on_ros_env(domain), domain))
        dds = {**ros_env(domain), "SERVOLAB_TRANSPORT": "dds",
               "LD_LIBRARY_PATH": os.environ.get("LD_LIBRARY_PATH", "")}
        results["servolab dds"].append(lost(ours, dds, domain))
    anchor = statistics.median(results["real rclpy"])
    print(f"messages lost at start-up, 10 Hz talker -> real listener ({args.runs} runs each; "
          "a run's outlier shows in the mean, the median is compared)")
    for name, losses in results.items():
        median = statistics.median(losses)
        against = f"x{median / anchor:.2f}" if anchor else f"{median - anchor:+.1f} messages"
        print(f"  {name:14s} {losses}  mean {statistics.mean(losses):.1f}  median "
              f"{median:g}  vs the real talker's median: {against}")


if __name__ == "__main__":
    main()
