# ruff: noqa: UP031  (rclpy's idiom, as upstream writes it)
"""demo_nodes_py/services/add_two_ints_client_async.py, with std_srvs/Trigger."""

from std_srvs.srv import Trigger

import rclpy


def main(args=None):
    rclpy.init(args=args)
    node = rclpy.create_node('trigger_client')
    cli = node.create_client(Trigger, 'trigger')
    while not cli.wait_for_service(timeout_sec=1.0):
        pass
    for _ in range(2):
        future = cli.call_async(Trigger.Request())
        rclpy.spin_until_future_complete(node, future)
        result = future.result()
        node.get_logger().info('Result: success=%s message=%s' % (result.success, result.message))
    node.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
