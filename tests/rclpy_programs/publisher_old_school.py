# ruff: noqa: UP031  (rclpy's idiom, as upstream writes it)
"""topics/minimal_publisher/publisher_old_school.py: no class, a loop with sleeps."""

from time import sleep

from std_msgs.msg import String

import rclpy

COUNT = 5


def main(args=None):
    rclpy.init(args=args)
    node = rclpy.create_node('minimal_publisher')
    publisher = node.create_publisher(String, 'topic', 10)
    while publisher.get_subscription_count() == 0:
        sleep(0.05)
    msg = String()
    for i in range(COUNT):
        msg.data = 'Hello World: %d' % i
        node.get_logger().info('Publishing: "%s"' % msg.data)
        publisher.publish(msg)
        sleep(0.05)
    while publisher.get_subscription_count() > 0:
        sleep(0.05)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
