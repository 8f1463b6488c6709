# ruff: noqa: UP031  (rclpy's idiom, as upstream writes it)
"""topics/minimal_publisher/publisher_member_function.py: a Node subclass with a timer."""

from rclpy.node import Node
from std_msgs.msg import String

import rclpy

COUNT = 5


class MinimalPublisher(Node):

    def __init__(self):
        super().__init__('minimal_publisher')
        self.publisher_ = self.create_publisher(String, 'topic', 10)
        self.timer = self.create_timer(0.05, self.timer_callback)
        self.i = 0

    def timer_callback(self):
        if self.i >= COUNT or self.publisher_.get_subscription_count() == 0:
            return
        msg = String()
        msg.data = 'Hello World: %d' % self.i
        self.publisher_.publish(msg)
        self.get_logger().info('Publishing: "%s"' % msg.data)
        self.i += 1

    def done(self):
        return self.i >= COUNT and self.publisher_.get_subscription_count() == 0


def main(args=None):
    rclpy.init(args=args)
    minimal_publisher = MinimalPublisher()
    while rclpy.ok() and not minimal_publisher.done():
        rclpy.spin_once(minimal_publisher, timeout_sec=0.1)
    minimal_publisher.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
