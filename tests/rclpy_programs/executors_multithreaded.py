# ruff: noqa: UP031  (rclpy's idiom, as upstream writes it)
"""executors/callback_group.py's idea: under a MultiThreadedExecutor, the callbacks of a
ReentrantCallbackGroup run at once, those of a MutuallyExclusiveCallbackGroup one at a time.
Each pair of timers meets at a barrier: only callbacks that run at once pass it."""

import threading

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from rclpy.task import Future

import rclpy


class GroupsNode(Node):

    def __init__(self, group, done):
        super().__init__('groups')
        self.done = done
        self.barrier = threading.Barrier(2, timeout=1.0)
        self.outcomes = []
        self.lock = threading.Lock()
        self.group_timers = [self.create_timer(0.05, self.make_callback(i), callback_group=group)
                       for i in range(2)]

    def make_callback(self, index):
        def callback():
            self.group_timers[index].cancel()
            try:
                self.barrier.wait()
                outcome = 'met'
            except threading.BrokenBarrierError:
                outcome = 'alone'
            with self.lock:
                self.outcomes.append(outcome)
                if len(self.outcomes) == 2:
                    self.done.set_result(sorted(self.outcomes))
        return callback


def run(group_class):
    done = Future()
    node = GroupsNode(group_class(), done)
    executor = MultiThreadedExecutor(num_threads=3)
    executor.add_node(node)
    executor.spin_until_future_complete(done)
    node.get_logger().info('%s: %s' % (group_class.__name__, done.result()))
    executor.shutdown()
    node.destroy_node()


def main(args=None):
    rclpy.init(args=args)
    run(ReentrantCallbackGroup)
    run(MutuallyExclusiveCallbackGroup)
    rclpy.shutdown()


if __name__ == '__main__':
    main()
