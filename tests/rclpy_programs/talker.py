# ruff: noqa: UP030, UP032  (rclpy's idiom, as upstream writes it)
"""demo_nodes_py/topics/talker.py: "Hello World: N" on chatter."""

from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from std_msgs.msg import String

import rclpy

COUNT = 5


class Talker(Node):

    def __init__(self):
        super().__init__('talker')
        self.i = 0
        self.pub = self.create_publisher(String, 'chatter', 10)
        self.tmr = self.create_timer(0.05, self.timer_callback)

    def timer_callback(self):
        if self.i >= COUNT or self.pub.get_subscription_count() == 0:
            return
        msg = String()
        msg.data = 'Hello World: {0}'.format(self.i)
        self.i += 1
        self.get_logger().info('Publishing: "{0}"'.format(msg.data))
        self.pub.publish(msg)


def main(args=None):
    rclpy.init(args=args)
    node = Talker()
    try:
        while rclpy.ok() and not (node.i >= COUNT and node.pub.get_subscription_count() == 0):
            rclpy.spin_once(node, timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
