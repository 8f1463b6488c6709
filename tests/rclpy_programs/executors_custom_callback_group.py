# ruff: noqa: UP031  (rclpy's idiom, as upstream writes it)
"""executors/custom_callback_group.py's idea, as the ROS 2 docs' "Using Callback Groups"
shows it: a timer callback calls a service synchronously; timer and client are in
different callback groups and a MultiThreadedExecutor runs them, so the response can come
while the timer callback waits."""

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from rclpy.task import Future
from std_srvs.srv import SetBool

import rclpy

CALLS = 3


class CallerNode(Node):

    def __init__(self, done):
        super().__init__('caller')
        self.done = done
        self.results = []
        self.srv = self.create_service(SetBool, 'flip', self.flip)
        self.client_group = MutuallyExclusiveCallbackGroup()
        self.timer_group = MutuallyExclusiveCallbackGroup()
        self.cli = self.create_client(SetBool, 'flip', callback_group=self.client_group)
        self.timer = self.create_timer(0.05, self.timer_callback,
                                       callback_group=self.timer_group)

    def flip(self, request, response):
        response.success = not request.data
        response.message = 'flipped %s' % request.data
        return response

    def timer_callback(self):
        if self.done.done() or not self.cli.service_is_ready():
            return
        data = len(self.results) % 2 == 0
        response = self.cli.call(SetBool.Request(data=data))
        self.results.append(response.success)
        self.get_logger().info('call %d: %s' % (len(self.results), response.message))
        if len(self.results) == CALLS:
            self.done.set_result(self.results)


def main(args=None):
    rclpy.init(args=args)
    done = Future()
    node = CallerNode(done)
    executor = MultiThreadedExecutor(num_threads=4)
    executor.add_node(node)
    executor.spin_until_future_complete(done)
    node.get_logger().info('results: %s' % done.result())
    executor.shutdown()
    node.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
