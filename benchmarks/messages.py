"""What building a message from plain values costs: ``MessageTypes.from_value``'s fast path
(``servolab.middleware.message_build``, one builder per type) beside the walk it replaced for
every value it takes (the anchor, timed in the same run).

Every robot builds its messages this way (``node.message(TYPE, **fields)``): a controller's
``dynamixel_msgs/JointState`` per motor per sweep, the base's odometry and TF, the view's
images. The figures are microseconds per message, the median of several rounds, and the ratio
walk / fast path: how many times faster the same message is built.

Run: ``.venv/bin/python benchmarks/messages.py [--quick] [--json PATH]``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any

from servolab.middleware.message_build import Slow
from servolab.middleware.messages import MessageTypes

#: (label, type, plain value): what the robots build most
CASES: list[tuple[str, str, dict[str, Any]]] = [
    ("Float64", "std_msgs/msg/Float64", {"data": 0.5}),
    ("Twist", "geometry_msgs/msg/Twist", {"linear": {"x": 0.1}, "angular": {"z": 0.5}}),
    ("dynamixel JointState", "dynamixel_msgs/msg/JointState", {
        "header": {"stamp": {"sec": 1, "nanosec": 2}}, "name": "m14", "motor_ids": [14],
        "motor_temps": [40], "goal_pos": 0.4, "current_pos": 0.5, "error": 0.1,
        "velocity": 0.0, "load": 0.1, "is_moving": False}),
    ("TFMessage", "tf2_msgs/msg/TFMessage", {"transforms": [{
        "header": {"frame_id": "odom", "stamp": {"sec": 1}}, "child_frame_id": "base_link",
        "transform": {"translation": {"x": 1.0, "y": 2.0}, "rotation": {"w": 1.0}}}]}),
    ("Odometry", "nav_msgs/msg/Odometry", {
        "header": {"frame_id": "odom"}, "child_frame_id": "base_link",
        "pose": {"pose": {"position": {"x": 1.0}, "orientation": {"w": 1.0}}},
        "twist": {"twist": {"linear": {"x": 0.2}}}}),
]


def per_call_us(work: Callable[[], Any], calls: int, rounds: int) -> float:
    """The median over ``rounds`` of the time per call, in microseconds."""
    times = []
    for _ in range(rounds):
        start = time.perf_counter()
        for _ in range(calls):
            work()
        times.append((time.perf_counter() - start) / calls * 1e6)
    return statistics.median(times)


def walked() -> MessageTypes:
    """A MessageTypes whose fast path declines everything: the walk alone (the anchor)."""
    slow = MessageTypes()

    def declines(name: str) -> Callable[[Any], Any]:
        def build(value: Any) -> Any:
            raise Slow
        return build
    slow.builder = declines  # type: ignore[method-assign]
    return slow


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="few calls (a smoke test)")
    parser.add_argument("--json", help="write the figures to this file")
    args = parser.parse_args(argv)
    calls, rounds = (50, 2) if args.quick else (2000, 5)
    fast = MessageTypes()
    slow = walked()
    rows = []
    print(f"{'message':22s} {'fast µs':>9s} {'walk µs':>9s} {'walk/fast':>10s}")
    for label, name, value in CASES:
        built = fast.from_value(name, value)
        assert fast.serialize(built) == slow.serialize(slow.from_value(name, value))
        figures = {f"{how}_us": per_call_us(
            lambda types=types, name=name, value=value: types.from_value(name, value),  # type: ignore[misc]
            calls, rounds) for how, types in (("fast", fast), ("walk", slow))}
        figures["walk_over_fast"] = figures["walk_us"] / figures["fast_us"]
        rows.append({"message": label, **figures})
        print(f"{label:22s} {figures['fast_us']:9.1f} {figures['walk_us']:9.1f} "
              f"{figures['walk_over_fast']:9.1f}x")
    print("walk/fast: how many times faster the fast path builds the same message")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
