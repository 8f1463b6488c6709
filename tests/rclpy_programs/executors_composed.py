# ruff: noqa: UP031  (rclpy's idiom, as upstream writes it)
"""executors/composed.py: a talker and a listener node in one SingleThreadedExecutor."""

from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from std_msgs.msg import String

import rclpy

COUNT = 4


class Talker(Node):

    def __init__(self):
        super().__init__('talker')
        self.i = 0
        self.pub = self.create_publisher(String, 'chatter', 10)
        self.timer = self.create_timer(0.5, self.timer_callback)

    def timer_callback(self):
        if self.i >= COUNT or self.pub.get_subscription_count() == 0:
            return
        msg = String(data='Hello World: %d' % self.i)
        self.i += 1
        self.get_logger().info('Publishing: "%s"' % msg.data)
        self.pub.publish(msg)


class Listener(Node):

    def __init__(self):
        super().__init__('listener')
        self.heard = 0
        self.sub = self.create_subscription(String, 'chatter', self.chatter_callback, 10)

    def chatter_callback(self, msg):
        self.heard += 1
        self.get_logger().info('I heard: "%s"' % msg.data)


def main(args=None):
    rclpy.init(args=args)
    talker = Talker()
    listener = Listener()
    executor = SingleThreadedExecutor()
    executor.add_node(talker)
    executor.add_node(listener)
    while rclpy.ok() and listener.heard < COUNT:
        executor.spin_once()
    executor.shutdown()
    talker.destroy_node()
    listener.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
