# ruff: noqa: UP031  (rclpy's idiom, as upstream writes it)
"""services/minimal_client/client_async_member_function.py: call_async, then
spin_until_future_complete."""

from rclpy.node import Node
from std_srvs.srv import SetBool

import rclpy


class MinimalClientAsync(Node):

    def __init__(self):
        super().__init__('minimal_client_async')
        self.cli = self.create_client(SetBool, 'set_bool')
        while not self.cli.wait_for_service(timeout_sec=1.0):
            pass
        self.req = SetBool.Request()

    def send_request(self, data):
        self.req.data = data
        return self.cli.call_async(self.req)


def main(args=None):
    rclpy.init(args=args)
    minimal_client = MinimalClientAsync()
    for data in (True, False, True):
        future = minimal_client.send_request(data)
        rclpy.spin_until_future_complete(minimal_client, future)
        response = future.result()
        minimal_client.get_logger().info(
            'Result of set_bool(%s): success=%s message=%s'
            % (data, response.success, response.message))
    minimal_client.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
