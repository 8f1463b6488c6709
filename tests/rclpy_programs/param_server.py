# ruff: noqa: UP031  (rclpy's idiom, as upstream writes it)
"""A node with parameters for async_param_client.py to read and change (demo_nodes_py's
async parameter client talks to such a node through its parameter services)."""

from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor

import rclpy


def main(args=None):
    rclpy.init(args=args)
    node = rclpy.create_node('param_server')
    node.declare_parameter('gain', 1.5, ParameterDescriptor(
        description='how strong', floating_point_range=[
            FloatingPointRange(from_value=0.0, to_value=10.0, step=0.0)]))
    node.declare_parameter('mode', 'auto', ParameterDescriptor(read_only=True))
    node.declare_parameter('ids', [1, 2, 3])
    changed = []
    node.add_post_set_parameters_callback(changed.extend)
    while rclpy.ok() and not (changed and node.count_clients('/param_server/set_parameters') == 0):
        rclpy.spin_once(node, timeout_sec=0.1)
    node.get_logger().info('gain is now %s' % node.get_parameter('gain').value)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
