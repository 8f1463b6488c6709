"""Two small nodes to try the middleware with, and to test it: a ``cmd_vel`` talker and a
listener. They are the "hello world" of a launch file::

    nodes:
      - {name: talker, node: servolab.middleware.demo_nodes:Talker, parameters: {rate: 10.0}}
      - {name: listener, node: servolab.middleware.demo_nodes:Listener}
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping
from typing import Any

from .context import Context
from .errors import ParameterError
from .node import Node

TWIST = "geometry_msgs/msg/Twist"
#: The messages a :class:`Listener` keeps (the newest): it may listen for days.
HEARD_KEPT = 1000


def positive_rate(name: str, value: Any) -> float:
    """``value`` as a rate in Hz: a finite number > 0, else a one-line
    :class:`~.errors.ParameterError` naming the parameter (0 would divide by zero, a
    negative or NaN rate make no timer, infinity a timer of period 0)."""
    rate = float(value)
    if not (math.isfinite(rate) and rate > 0):
        raise ParameterError(f"parameter {name}: must be a finite number > 0 Hz, not {rate!r}")
    return rate


class Talker(Node):
    """Publishes a slowly turning ``cmd_vel`` at ``rate`` Hz; after ``count`` messages (0:
    never) it stops its context, so a launch file can end when it is done."""

    def __init__(self, context: Context, name: str = "talker", namespace: str = "/", *,
                 parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        self.rate = positive_rate("rate", self.declare_parameter(
            "rate", 10.0, description="messages per second").value)
        self.count = self.declare_parameter("count", 0,
                                            description="stop after this many").value
        if self.count < 0:
            raise ParameterError(f"parameter count: must be >= 0 (0: never stop), not "
                                 f"{self.count}")
        self.declare_parameter("speed", 0.1, description="linear.x in m/s (live)")
        self.sent = 0
        self.publisher = self.create_publisher(TWIST, "cmd_vel")
        self.create_timer(1.0 / self.rate, self._tick)

    def _tick(self) -> None:
        if self.count and self.sent >= self.count:
            return
        self.sent += 1
        turn = 0.5 * math.sin(self.sent / 10)
        self.publisher.publish(self.message(
            TWIST, linear={"x": self.get_parameter("speed").value}, angular={"z": turn}))
        self.get_logger().info("sent cmd_vel %d", self.sent)
        if self.count and self.sent >= self.count:
            self.context.shutdown()


class Listener(Node):
    """Logs every ``cmd_vel`` it hears; keeps the newest :data:`HEARD_KEPT` in ``heard`` and
    counts them all in ``count``."""

    def __init__(self, context: Context, name: str = "listener", namespace: str = "/", *,
                 parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        self.heard: deque[Any] = deque(maxlen=HEARD_KEPT)
        self.count = 0
        self.create_subscription(TWIST, "cmd_vel", self._on_cmd_vel)

    def _on_cmd_vel(self, msg: Any) -> None:
        self.heard.append(msg)
        self.count += 1
        self.get_logger().info("heard linear.x=%.3f angular.z=%.3f", msg.linear.x,
                               msg.angular.z)
