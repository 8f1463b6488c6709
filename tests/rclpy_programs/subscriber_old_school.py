# ruff: noqa: B018, UP031  (rclpy's idiom, as upstream writes it)
"""topics/minimal_subscriber/subscriber_old_school.py: a global node and a function."""

from std_msgs.msg import String

import rclpy

COUNT = 5
g_node = None
g_heard = 0


def chatter_callback(msg):
    global g_heard
    g_node.get_logger().info('I heard: "%s"' % msg.data)
    g_heard += 1


def main(args=None):
    global g_node
    rclpy.init(args=args)
    g_node = rclpy.create_node('minimal_subscriber')
    subscription = g_node.create_subscription(String, 'topic', chatter_callback, 10)
    subscription  # prevent unused variable warning
    while rclpy.ok() and g_heard < COUNT:
        rclpy.spin_once(g_node)
    g_node.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
