"""``/clock``: a virtual-time run's simulated time, for ROS tools that run with
``use_sim_time``.

A ROS 2 node with ``use_sim_time`` true takes its time from ``rosgraph_msgs/msg/Clock``
messages on ``/clock`` (rclpy's ``TimeSource``, rclpy/time_source.py; the ROS 2 design article
"Clock and Time", design.ros2.org/articles/clock_and_time.html), which a simulator (Gazebo's
``gazebo_ros_init``) or a bag player (``ros2 bag play --clock``) publishes. A servolab run in
virtual time stamps its messages in simulated seconds (:meth:`Context.ros_time
<servolab.middleware.context.Context.ros_time>`), so it publishes that time too: rviz2, tf2 or
``ros2 topic echo`` with ``use_sim_time`` then see the data at the time it was made, not in
1970. A real-time run stamps the epoch's time, which ROS nodes read from the system clock, and
publishes no ``/clock`` (:func:`start_clock` returns None for it).

Where the values come from and when, and why:

- **from the clock's owner, not from a timer.** The owner of virtual time (a
  :class:`~servolab.sim.Simulation`, a :class:`~servolab.clock.VirtualClock`) calls back as
  its time passes each period (``call_every``), as Gazebo publishes ``/clock`` from its world
  update rather than from a ROS timer. An executor timer would be one more callback among the
  robot's own, and could change the order they run in, hence what a deterministic run does;
  a call from the clock adds no work to the executor at all while no one in the process
  subscribes. (A virtual clock that cannot call back gets a timer instead.)
- **the time reached, when it is reached.** Once a period has passed, the next move of the
  clock publishes the time it reached: never a tick time already passed, so a subscriber's
  time never lags behind the messages stamped after it, and a move across several periods
  publishes once. Virtual time moves only when something is due (a timer, a transaction on an
  emulated bus), so ``/clock`` comes at most ``rate`` times a simulated second, and as often
  as the run has something to date.
- **40 Hz of simulated time**, the rate ``ros2 bag play --clock`` uses when given no rate
  (ros2bag/verb/play.py: ``--clock`` const 40); Gazebo's ``gazebo_ros_init`` publishes at
  10 Hz of wall time (``DEFAULT_PUBLISH_FREQUENCY``), too coarse beside the treadmill's
  66 frames/s. Parameter ``rate`` changes it; a rate of simulated time keeps the messages the
  same from run to run, however fast the machine.
- **QoS as rclcpp's ``ClockQoS``**, what rosbag2's player publishes ``/clock`` with
  (rclcpp/qos.cpp: the sensor-data profile with depth 1: BEST_EFFORT, KEEP_LAST 1, VOLATILE)
  and what rclpy's ``TimeSource`` subscribes with (depth 1, BEST_EFFORT): only the newest
  time matters.

One simulation, one ``/clock``: start one publisher per run, on the context of its nodes.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any, Protocol

from .context import Context
from .errors import MiddlewareValueError
from .node import Node
from .qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

CLOCK_TOPIC = "/clock"
CLOCK_TYPE = "rosgraph_msgs/msg/Clock"
#: ``ros2 bag play --clock``'s rate when none is given (Hz)
DEFAULT_RATE = 40.0
#: rclcpp's ``ClockQoS``: the sensor-data profile (best effort, volatile) with depth 1
CLOCK_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                       reliability=ReliabilityPolicy.BEST_EFFORT,
                       durability=DurabilityPolicy.VOLATILE)


class _Cancellable(Protocol):
    def cancel(self) -> None: ...


class ClockPublisher(Node):
    """Publishes the context's virtual time on ``/clock`` (see the module docstring).
    Parameter ``rate`` (Hz of simulated time, default :data:`DEFAULT_RATE`). The current time
    is published once when the node starts, so a subscriber that is already there has a time
    at once."""

    def __init__(self, context: Context, name: str = "clock_publisher", namespace: str = "/",
                 *, parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        clock = context.clock
        if not clock.virtual:  # before the node exists: nothing to undo
            raise MiddlewareValueError(
                "/clock is simulated time: this context's clock is a wall clock, whose "
                "stamps are the epoch's and need no /clock (start_clock gives None for it)")
        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        self._tick: _Cancellable | None = None
        self.rate = float(self.declare_parameter(
            "rate", DEFAULT_RATE, description="Hz of simulated time, at most").value)
        if not (math.isfinite(self.rate) and self.rate > 0):
            self.destroy()
            raise MiddlewareValueError(f"clock publisher: rate {self.rate!r} must be a number "
                                       "> 0 Hz")
        #: messages published
        self.published = 0
        self.publisher = self.create_publisher(CLOCK_TYPE, CLOCK_TOPIC, CLOCK_QOS)
        # the classes, not MessageTypes.from_value: a message at every tick of a long run
        types = context.types
        self._clock_class = types.get(CLOCK_TYPE)
        self._time_class = types.get("builtin_interfaces/msg/Time")
        self._publish(clock.now())
        call_every: Callable[[float, Callable[[float], None]], _Cancellable] | None = getattr(
            clock, "call_every", None)
        if call_every is not None:
            self._tick = call_every(1.0 / self.rate, self._on_time)
        else:
            self._tick = self.create_timer(1.0 / self.rate, lambda: self._on_time(self.now()))

    def _on_time(self, t: float) -> None:
        if self.context.closed or not self.context.clock.virtual:
            return  # a simulation now in real time stamps the epoch: no /clock
        self._publish(t)

    def _publish(self, t: float) -> None:
        ns = round(self.context.ros_time(t) * 1e9)
        self.publisher.publish(self._clock_class(clock=self._time_class(
            sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)))
        self.published += 1

    def destroy(self) -> None:
        if self._tick is not None:
            self._tick.cancel()
            self._tick = None
        super().destroy()


def start_clock(context: Context, *, rate: float | None = None) -> ClockPublisher | None:
    """``/clock`` for a run on ``context``: a :class:`ClockPublisher` when its clock is
    virtual (simulated time), None when it keeps the wall's time (a real robot, a simulation
    in real time), whose stamps ROS reads without ``/clock``. The node lives as long as the
    context (closing the context destroys it)."""
    if not context.clock.virtual:
        return None
    overrides = None if rate is None else {"rate": float(rate)}
    return ClockPublisher(context, parameter_overrides=overrides)
