# ruff: noqa: UP031  (rclpy's idiom, as upstream writes it)
"""demo_nodes_py/parameters/async_param_client.py's idea: another node's parameters through
its rcl_interfaces services (list, get, describe, set), asynchronously."""

from rcl_interfaces.srv import DescribeParameters, GetParameters, ListParameters, SetParameters
from rclpy.parameter import Parameter, parameter_value_to_python

import rclpy


def main(args=None):
    rclpy.init(args=args)
    node = rclpy.create_node('async_param_client')
    log = node.get_logger()

    def call(srv_type, name, request):
        cli = node.create_client(srv_type, '/param_server/' + name)
        while not cli.wait_for_service(timeout_sec=1.0):
            pass
        future = cli.call_async(request)
        rclpy.spin_until_future_complete(node, future)
        return future.result()

    listed = call(ListParameters, 'list_parameters', ListParameters.Request())
    log.info('names: %s' % list(listed.result.names))
    got = call(GetParameters, 'get_parameters', GetParameters.Request(names=['gain', 'mode']))
    log.info('values: %s' % [parameter_value_to_python(v) for v in got.values])
    described = call(DescribeParameters, 'describe_parameters',
                     DescribeParameters.Request(names=['gain', 'mode']))
    for d in described.descriptors:
        log.info('%s: type=%d read_only=%s description=%r range=%s' % (
            d.name, d.type, d.read_only, d.description,
            [(r.from_value, r.to_value, r.step) for r in d.floating_point_range]))
    request = SetParameters.Request(parameters=[
        Parameter('gain', value=2.0).to_parameter_msg(),
        Parameter('gain', value=20.0).to_parameter_msg(),
        Parameter('gain', value='high').to_parameter_msg(),
        Parameter('mode', value='manual').to_parameter_msg(),
        Parameter('nothere', value=True).to_parameter_msg(),
    ])
    for result in call(SetParameters, 'set_parameters', request).results:
        log.info('set: successful=%s reason=%r' % (result.successful, result.reason))
    node.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
