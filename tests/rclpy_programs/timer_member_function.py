# ruff: noqa: UP031  (rclpy's idiom, as upstream writes it)
"""timers/minimal_timer/timer_member_function.py, with rclpy's timer controls: cancel(),
is_canceled(), reset()."""

from rclpy.node import Node

import rclpy


class TimerNode(Node):

    def __init__(self):
        super().__init__('minimal_timer')
        self.ticks = 0
        self.timer = self.create_timer(0.02, self.timer_callback)

    def timer_callback(self):
        self.ticks += 1
        self.get_logger().info('tick %d' % self.ticks)
        if self.ticks == 3:
            self.timer.cancel()
            self.get_logger().info('canceled: %s' % self.timer.is_canceled())


def main(args=None):
    rclpy.init(args=args)
    node = TimerNode()
    while rclpy.ok() and node.ticks < 3:
        rclpy.spin_once(node)
    for _ in range(5):  # a canceled timer does not tick
        rclpy.spin_once(node, timeout_sec=0.02)
    node.get_logger().info('after cancel: %d ticks' % node.ticks)
    node.timer.reset()
    node.get_logger().info('canceled after reset: %s' % node.timer.is_canceled())
    while rclpy.ok() and node.ticks < 5:
        rclpy.spin_once(node)
    node.timer.cancel()
    node.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
