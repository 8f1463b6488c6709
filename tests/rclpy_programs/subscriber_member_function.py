# ruff: noqa: UP031  (rclpy's idiom, as upstream writes it)
"""topics/minimal_subscriber/subscriber_member_function.py: a Node subclass."""

from rclpy.node import Node
from std_msgs.msg import String

import rclpy

COUNT = 5


class MinimalSubscriber(Node):

    def __init__(self):
        super().__init__('minimal_subscriber')
        self.subscription = self.create_subscription(
            String, 'topic', self.listener_callback, 10)
        self.heard = 0

    def listener_callback(self, msg):
        self.get_logger().info('I heard: "%s"' % msg.data)
        self.heard += 1


def main(args=None):
    rclpy.init(args=args)
    minimal_subscriber = MinimalSubscriber()
    while rclpy.ok() and minimal_subscriber.heard < COUNT:
        rclpy.spin_once(minimal_subscriber)
    minimal_subscriber.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
