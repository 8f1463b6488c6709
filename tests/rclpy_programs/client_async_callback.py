# ruff: noqa: UP031  (rclpy's idiom, as upstream writes it)
"""services/minimal_client/client_async_callback.py: the response comes to a done-callback,
run by the executor while the node spins."""

from std_srvs.srv import SetBool

import rclpy


def main(args=None):
    rclpy.init(args=args)
    node = rclpy.create_node('minimal_client_async_callback')
    cli = node.create_client(SetBool, 'set_bool')
    while not cli.wait_for_service(timeout_sec=1.0):
        pass
    answers = []

    def on_response(future):
        response = future.result()
        node.get_logger().info('Result: success=%s message=%s'
                               % (response.success, response.message))
        answers.append(response)
        if len(answers) < 3:
            send(len(answers) % 2 == 0)

    def send(data):
        future = cli.call_async(SetBool.Request(data=data))
        future.add_done_callback(on_response)

    send(True)
    while rclpy.ok() and len(answers) < 3:
        rclpy.spin_once(node)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
