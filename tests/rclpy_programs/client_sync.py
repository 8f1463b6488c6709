# ruff: noqa: UP031  (rclpy's idiom, as upstream writes it)
"""The synchronous client of the ROS 2 docs ("Synchronous vs. asynchronous service
clients"): an executor spins in a thread while the main thread calls ``cli.call()``."""

import threading

from rclpy.executors import SingleThreadedExecutor
from std_srvs.srv import SetBool

import rclpy


def main(args=None):
    rclpy.init(args=args)
    node = rclpy.create_node('minimal_client_sync')
    cli = node.create_client(SetBool, 'set_bool')
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    spin_thread = threading.Thread(target=executor.spin, daemon=True)
    spin_thread.start()
    while not cli.wait_for_service(timeout_sec=1.0):
        pass
    for data in (True, False, True):
        response = cli.call(SetBool.Request(data=data))
        node.get_logger().info('Result of set_bool(%s): success=%s message=%s'
                               % (data, response.success, response.message))
    executor.shutdown()
    spin_thread.join()
    node.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
