# ruff: noqa: UP031  (rclpy's idiom, as upstream writes it)
"""demo_nodes_py/services/add_two_ints_server.py, with std_srvs/Trigger for AddTwoInts."""

from rclpy.node import Node
from std_srvs.srv import Trigger

import rclpy

COUNT = 2


class TriggerServer(Node):

    def __init__(self):
        super().__init__('trigger_server')
        self.calls = 0
        self.srv = self.create_service(Trigger, 'trigger', self.trigger_callback)

    def trigger_callback(self, request, response):
        self.calls += 1
        response.success = True
        response.message = 'call %d' % self.calls
        self.get_logger().info('Incoming request, answering: %s' % response.message)
        return response


def main(args=None):
    rclpy.init(args=args)
    node = TriggerServer()
    while rclpy.ok() and not (node.calls >= COUNT and node.count_clients('trigger') == 0):
        rclpy.spin_once(node, timeout_sec=0.1)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
