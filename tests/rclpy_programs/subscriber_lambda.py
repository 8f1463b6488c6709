# ruff: noqa: B018, UP031  (rclpy's idiom, as upstream writes it)
"""topics/minimal_subscriber/subscriber_lambda.py: the callback is a lambda."""

from std_msgs.msg import String

import rclpy

COUNT = 5


def main(args=None):
    rclpy.init(args=args)
    node = rclpy.create_node('minimal_subscriber')
    heard = []
    subscription = node.create_subscription(
        String, 'topic',
        lambda msg: (node.get_logger().info('I heard: "%s"' % msg.data), heard.append(msg)),
        10)
    subscription  # prevent unused variable warning
    while rclpy.ok() and len(heard) < COUNT:
        rclpy.spin_once(node)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
