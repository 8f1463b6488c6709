# ruff: noqa: UP031  (rclpy's idiom, as upstream writes it)
"""Parameters as rclpy has them: declare (with descriptors: read-only, ranges), get, set,
and the pre-set, on-set and post-set callbacks; what each refusal says."""

from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    SetParametersResult,
)
from rclpy.node import Node
from rclpy.parameter import Parameter

import rclpy


class ParamNode(Node):

    def __init__(self):
        super().__init__('param_node', parameter_overrides=[Parameter('overridden', value=7)])
        self.declare_parameter('speed', 1.5, ParameterDescriptor(
            floating_point_range=[FloatingPointRange(from_value=0.0, to_value=5.0, step=0.5)]))
        self.declare_parameter('count', 4, ParameterDescriptor(
            integer_range=[IntegerRange(from_value=0, to_value=10, step=2)]))
        self.declare_parameter('frame', 'base', ParameterDescriptor(read_only=True))
        self.declare_parameters('camera', [('width', 640), ('height', 480),
                                           ('names', ['left', 'right'])])
        self.declare_parameter('overridden', 1)
        self.add_pre_set_parameters_callback(self.pre_set)
        self.add_on_set_parameters_callback(self.on_set)
        self.add_post_set_parameters_callback(self.post_set)

    def pre_set(self, parameters):
        out = list(parameters)
        if any(p.name == 'speed' for p in parameters):
            out.append(Parameter('count', value=4))
        return out

    def on_set(self, parameters):
        for p in parameters:
            if p.name == 'count' and p.value == 8:
                return SetParametersResult(successful=False, reason='8 is unlucky')
        return SetParametersResult(successful=True)

    def post_set(self, parameters):
        self.get_logger().info('set: %s' % ', '.join(
            '%s=%r' % (p.name, p.value) for p in parameters))


def main(args=None):
    rclpy.init(args=args)
    node = ParamNode()
    log = node.get_logger()
    for name in ('speed', 'count', 'frame', 'camera.width', 'camera.names', 'overridden'):
        p = node.get_parameter(name)
        log.info('%s: %r (%s)' % (p.name, p.value, p.type_.name))
    log.info('by prefix: %s' % sorted(
        (k, v.value) for k, v in node.get_parameters_by_prefix('camera').items()))
    for param in (Parameter('speed', value=2.5), Parameter('speed', value=7.0),
                  Parameter('speed', value=2.2), Parameter('count', value=8),
                  Parameter('count', value=5), Parameter('count', value='five'),
                  Parameter('frame', value='odom')):
        result = node.set_parameters([param])[0]
        log.info('set %s=%r: successful=%s reason=%r' % (
            param.name, param.value, result.successful, result.reason))
    result = node.set_parameters_atomically([Parameter('camera.width', value=320),
                                             Parameter('camera.height', value=240)])
    log.info('atomically: %s' % result.successful)
    for attempt in (lambda: node.get_parameter('missing'),
                    lambda: node.declare_parameter('speed', 2.0),
                    lambda: node.declare_parameter('bad', 11, ParameterDescriptor(
                        integer_range=[IntegerRange(from_value=0, to_value=10, step=1)])),
                    lambda: node.set_parameters([Parameter('missing', value=1)]),
                    lambda: node.undeclare_parameter('frame')):
        try:
            attempt()
            log.info('no error')
        except Exception as e:
            log.info('%s: %s' % (type(e).__name__, e))
    log.info('count is %d, use_sim_time is %s' % (
        node.get_parameter('count').value, node.get_parameter('use_sim_time').value))
    node.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
