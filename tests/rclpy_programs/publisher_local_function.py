# ruff: noqa: UP031  (rclpy's idiom, as upstream writes it)
"""topics/minimal_publisher/publisher_local_function.py: a timer callback that is a local
function."""

from std_msgs.msg import String

import rclpy

COUNT = 5


def main(args=None):
    rclpy.init(args=args)
    node = rclpy.create_node('minimal_publisher')
    publisher = node.create_publisher(String, 'topic', 10)
    msg = String()
    i = 0

    def timer_callback():
        nonlocal i
        if i >= COUNT or publisher.get_subscription_count() == 0:
            return
        msg.data = 'Hello World: %d' % i
        i += 1
        node.get_logger().info('Publishing: "%s"' % msg.data)
        publisher.publish(msg)

    timer_period = 0.05  # seconds
    timer = node.create_timer(timer_period, timer_callback)
    while rclpy.ok() and not (i >= COUNT and publisher.get_subscription_count() == 0):
        rclpy.spin_once(node, timeout_sec=0.1)
    node.destroy_timer(timer)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
