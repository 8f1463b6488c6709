# ruff: noqa: UP031  (rclpy's idiom, as upstream writes it)
"""A node with use_sim_time: its clock reads /clock's simulated time (rclpy's TimeSource),
not the system's, and its timers count simulated seconds."""

from rclpy.clock import ClockType
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.time import Time

import rclpy


def main(args=None):
    rclpy.init(args=args)
    node = Node('sim_time_listener',
                parameter_overrides=[Parameter('use_sim_time', Parameter.Type.BOOL, True)])
    clock = node.get_clock()
    log = node.get_logger()
    log.info('use_sim_time: %s, ROS time active: %s' % (
        node.get_parameter('use_sim_time').value, clock.ros_time_is_active))
    log.info('before any /clock: %s' % (clock.now().nanoseconds == 0))
    ticks = []
    node.create_timer(1.0, lambda: ticks.append(clock.now()))
    target = Time(seconds=101, clock_type=ClockType.ROS_TIME)
    while rclpy.ok() and (clock.now() < target or len(ticks) < 3):
        rclpy.spin_once(node, timeout_sec=0.1)
    now = clock.now()
    log.info('simulated time reached 101 s: %s (clock type %s)' % (
        now >= target, now.clock_type.name))
    log.info('far from the system time: %s' % (now.nanoseconds < 10**12))
    # /clock runs 25 times faster than the wall clock: a listener the CPU leaves waiting
    # for half a second sees 12.5 simulated seconds go by, so the bound allows for a loaded
    # machine (the three ticks themselves need 3 s)
    start = Time(seconds=100, clock_type=ClockType.ROS_TIME)
    log.info('a 1 s timer ticked %d times in at most 20 simulated seconds: %s' % (
        len(ticks), now - start <= Duration(seconds=20)))
    node.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
