# ruff: noqa: B905, RUF007, UP031  (rclpy's idiom, as upstream writes it)
"""timers/minimal_timer/timer_local_function.py: a timer whose callback is a local function,
the node's clock giving the time."""

from rclpy.duration import Duration

import rclpy


def main(args=None):
    rclpy.init(args=args)
    node = rclpy.create_node('minimal_timer')
    start = node.get_clock().now()
    ticks = []

    def timer_callback():
        ticks.append(node.get_clock().now())
        node.get_logger().info('tick %d' % len(ticks))

    timer = node.create_timer(0.05, timer_callback)
    while rclpy.ok() and len(ticks) < 4:
        rclpy.spin_once(node)
    elapsed = ticks[-1] - start
    node.get_logger().info('at least 0.2 s passed: %s' % (elapsed >= Duration(seconds=0.2)))
    node.get_logger().info('ticks in order: %s' % all(
        a < b for a, b in zip(ticks, ticks[1:])))
    node.destroy_timer(timer)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
