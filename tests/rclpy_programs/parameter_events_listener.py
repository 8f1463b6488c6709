# ruff: noqa: UP031  (rclpy's idiom, as upstream writes it)
"""demo_nodes_py's parameter-event listener: prints param_talker's parameter events."""

from rcl_interfaces.msg import ParameterEvent
from rclpy.parameter import Parameter
from std_msgs.msg import Empty

import rclpy

EVENTS = 4


def describe(kind, params):
    return ['%s %s=%r' % (kind, p.name, Parameter.from_parameter_msg(p).value)
            for p in params
            if p.name not in ('use_sim_time', 'start_type_description_service', 'ping')]


def main(args=None):
    rclpy.init(args=args)
    node = rclpy.create_node('param_watcher')
    seen = []
    ready = node.create_publisher(Empty, 'watcher_ready', 10)

    def on_event(event):
        if event.node != '/param_talker':
            return
        ready.publish(Empty())
        lines = (describe('new', event.new_parameters)
                 + describe('changed', event.changed_parameters)
                 + describe('deleted', event.deleted_parameters))
        if lines:
            node.get_logger().info('event: ' + ', '.join(lines))
            seen.append(event)

    node.create_subscription(ParameterEvent, '/parameter_events', on_event, 1000)
    while rclpy.ok() and len(seen) < EVENTS:
        rclpy.spin_once(node)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
