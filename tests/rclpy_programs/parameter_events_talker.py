# ruff: noqa: UP031  (rclpy's idiom, as upstream writes it)
"""demo_nodes_py/parameters (parameter events): a node that declares and sets parameters;
each declare and set publishes a rcl_interfaces/ParameterEvent on /parameter_events.

Before the parameters that count, it sets ``ping`` until the watcher says it sees its events
(``watcher_ready``): from then on, none is lost to start-up."""

from rclpy.parameter import Parameter
from std_msgs.msg import Empty

import rclpy


def main(args=None):
    rclpy.init(args=args)
    node = rclpy.create_node('param_talker')
    ready = []
    node.create_subscription(Empty, 'watcher_ready', ready.append, 10)
    node.declare_parameter('ping', 0)
    ping = 0
    while rclpy.ok() and not ready:
        ping += 1
        node.set_parameters([Parameter('ping', value=ping)])
        rclpy.spin_once(node, timeout_sec=0.05)
    node.declare_parameter('speed', 1.0)
    node.set_parameters([Parameter('speed', Parameter.Type.DOUBLE, 2.5)])
    node.declare_parameter('name', 'robot')
    node.set_parameters_atomically([Parameter('speed', value=3.0), Parameter('name', value='bot')])
    node.get_logger().info('parameters: speed=%s name=%s' % (
        node.get_parameter('speed').value, node.get_parameter('name').value))
    while rclpy.ok() and node.count_subscribers('/parameter_events') > 0:
        rclpy.spin_once(node, timeout_sec=0.05)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
