"""A simulator's /clock (rosgraph_msgs/Clock), for sim_time_listener.py: simulated time
from 100 s on, half a second a step, until the listener has gone."""

from time import sleep

from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.time import Time
from rosgraph_msgs.msg import Clock

import rclpy


def main(args=None):
    rclpy.init(args=args)
    node = rclpy.create_node('clock_source')
    pub = node.create_publisher(
        Clock, '/clock', QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT))
    while pub.get_subscription_count() == 0:
        sleep(0.02)
    step = 0
    while pub.get_subscription_count() > 0:
        pub.publish(Clock(clock=Time(seconds=100 + 0.5 * step).to_msg()))
        step += 1
        sleep(0.02)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
