# ruff: noqa: UP031  (rclpy's idiom, as upstream writes it)
"""demo_nodes_py/topics/listener.py: prints what comes on chatter."""

from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from std_msgs.msg import String

import rclpy

COUNT = 5


class Listener(Node):

    def __init__(self):
        super().__init__('listener')
        self.heard = 0
        self.sub = self.create_subscription(String, 'chatter', self.chatter_callback, 10)

    def chatter_callback(self, msg):
        self.get_logger().info('I heard: [%s]' % msg.data)
        self.heard += 1


def main(args=None):
    rclpy.init(args=args)
    node = Listener()
    try:
        while rclpy.ok() and node.heard < COUNT:
            rclpy.spin_once(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
