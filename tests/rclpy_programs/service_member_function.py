# ruff: noqa: UP031  (rclpy's idiom, as upstream writes it)
"""services/minimal_service/service_member_function.py, with std_srvs/SetBool for
AddTwoInts. It serves COUNT requests, then ends once its client has gone."""

from rclpy.node import Node
from std_srvs.srv import SetBool

import rclpy

COUNT = 3


class MinimalService(Node):

    def __init__(self):
        super().__init__('minimal_service')
        self.srv = self.create_service(SetBool, 'set_bool', self.set_bool_callback)
        self.served = 0

    def set_bool_callback(self, request, response):
        response.success = request.data
        response.message = 'request %d was %s' % (self.served, request.data)
        self.get_logger().info('Incoming request: data=%s' % request.data)
        self.served += 1
        return response


def main(args=None):
    rclpy.init(args=args)
    minimal_service = MinimalService()
    while rclpy.ok() and not (minimal_service.served >= COUNT
                              and minimal_service.count_clients('set_bool') == 0):
        rclpy.spin_once(minimal_service, timeout_sec=0.1)
    minimal_service.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
