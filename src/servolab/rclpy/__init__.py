"""rclpy's module-level API on servolab, so that rclpy code runs with only its imports changed.

=============================================  ===============================================
rclpy                                          servolab
=============================================  ===============================================
``import rclpy``                               ``from servolab import rclpy``
``from rclpy.node import Node``                ``from servolab.rclpy.node import Node``
``from rclpy.qos import QoSProfile, ...``      ``from servolab.rclpy.qos import QoSProfile, ...``
``from std_msgs.msg import String``            ``from servolab.interfaces.std_msgs.msg import
                                               String``
=============================================  ===============================================

Everything here works on the default context (:mod:`servolab.middleware.default_context`);
``docs/from_rclpy.md`` says what differs and where servolab's own API is the better tool.
"""

from __future__ import annotations

from concurrent.futures import Future
from typing import Any

from servolab.middleware.context import Context
from servolab.middleware.default_context import default_context, is_initialized
from servolab.middleware.default_context import init as _init
from servolab.middleware.default_context import shutdown as _shutdown
from servolab.middleware.node import Node
from servolab.middleware.transport import TransportOptions

__all__ = ["create_node", "get_default_context", "init", "ok", "shutdown", "spin", "spin_once",
           "spin_until_future_complete", "try_shutdown"]


def init(args: list[str] | None = None, *, context: Any = None, domain_id: int | None = None,
         options: TransportOptions | None = None) -> None:
    """Open the default context. ``args`` (ROS's ``--ros-args``) and ``context`` are accepted
    for rclpy's signature and not used; ``domain_id`` is the ROS domain, as in rclpy."""
    if context is not None:
        raise ValueError("servolab.rclpy.init uses the default context; for another one, "
                         "open a servolab.middleware.Context and pass it to Node(context, name)")
    if domain_id is not None:
        from servolab.middleware.default_context import options_from_environment
        options = options or options_from_environment()
        options.domain_id = domain_id
    _init(options)


def get_default_context() -> Context:
    return default_context()


def ok(context: Any = None) -> bool:
    """True while the default context is open and not shut down (Ctrl-C makes it False)."""
    return is_initialized() and default_context().ok()


def shutdown(context: Any = None) -> None:
    _shutdown()


def try_shutdown(context: Any = None) -> None:
    _shutdown()


def create_node(node_name: str, *, namespace: str | None = None, **kwargs: Any) -> Node:
    return Node(node_name, namespace=namespace, **kwargs)


def spin(node: Node, executor: Any = None) -> None:
    """Run the node's callbacks until Ctrl-C or :func:`shutdown` (all nodes of its context
    spin: servolab has one executor per context)."""
    node.context.spin()


def spin_once(node: Node, *, executor: Any = None, timeout_sec: float | None = None) -> None:
    node.context.spin_once(timeout_sec)


def spin_until_future_complete(node: Node, future: Future[Any], executor: Any = None,
                               timeout_sec: float | None = None) -> None:
    node.context.spin_until(future.done, timeout_sec)
