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

import logging
import sys
from concurrent.futures import Future
from dataclasses import replace
from typing import Any

from servolab.middleware.context import Context
from servolab.middleware.default_context import (
    default_context,
    is_initialized,
    ok_now,
    options_from_environment,
)
from servolab.middleware.default_context import init as _init
from servolab.middleware.default_context import shutdown as _shutdown
from servolab.middleware.errors import MiddlewareValueError
from servolab.middleware.node import LOGGER_PREFIX
from servolab.middleware.transport import TransportOptions

from . import utilities
from ._arguments import Global
from ._arguments import parse as _parse_arguments
from .node import Node

__all__ = ["InitContextManager", "create_node", "get_default_context", "get_global_executor",
           "init", "ok", "shutdown",
           "spin", "spin_once",
           "spin_until_future_complete", "try_shutdown", "utilities"]


class InitContextManager:
    """What :func:`init` returns, as in rclpy: ``with rclpy.init():`` shuts the default
    context down when the block ends."""

    def __enter__(self) -> InitContextManager:
        return self

    def __exit__(self, *exc: object) -> None:
        try_shutdown()


def init(*, args: list[str] | None = None, context: Any = None, domain_id: int | None = None,
         options: TransportOptions | None = None, **_: Any) -> InitContextManager:
    """Open the default context. ``args``' ROS arguments (``--ros-args -p name:=value -r
    old:=new ...``, see :mod:`servolab.rclpy._arguments`) apply to every node made until
    :func:`shutdown`, as rcl's global arguments; ``domain_id`` is the ROS domain, as in
    rclpy. The transport is ``options``, else the environment's (``SERVOLAB_TRANSPORT``
    etc., see :mod:`servolab.middleware.default_context`)."""
    if context is not None:
        raise MiddlewareValueError("servolab.rclpy.init uses the default context; for another one, "
                                   "open a servolab.middleware.Context and pass it to "
                                   "Node(context, name)")
    arguments = _parse_arguments(sys.argv if args is None else args)  # as rclpy: sys.argv
    if domain_id is not None:
        options = replace(options or options_from_environment(), domain_id=domain_id)
    _init(options)
    Global.arguments = arguments
    _console_logging()
    return InitContextManager()


class _RclpyFormatter(logging.Formatter):
    """rcutils' default console format: ``[INFO] [1700000000.123456789] [talker]: text``."""

    def format(self, record: logging.LogRecord) -> str:
        name = record.name.removeprefix(LOGGER_PREFIX).strip("/").replace("/", ".")
        level = "WARN" if record.levelname == "WARNING" else (
            "FATAL" if record.levelname == "CRITICAL" else record.levelname)
        text = f"[{level}] [{record.created:.9f}] [{name}]: {record.getMessage()}"
        if record.exc_info:
            text += "\n" + self.formatException(record.exc_info)
        return text


class _Console:
    """The stderr handler :func:`init` adds (and :func:`shutdown` removes) when the program
    set up no logging of its own."""

    handler: logging.Handler | None = None
    level: int = logging.NOTSET


def _console_logging() -> None:
    """Nodes' INFO and above to stderr, as rclpy prints them, unless the program set up
    logging itself (then its handlers decide)."""
    servolab = logging.getLogger("servolab")
    if logging.getLogger().handlers or servolab.handlers:
        return
    _Console.handler = logging.StreamHandler()
    _Console.handler.setFormatter(_RclpyFormatter())
    _Console.level = servolab.level
    servolab.addHandler(_Console.handler)
    if servolab.level == logging.NOTSET:
        servolab.setLevel(logging.INFO)


def _console_logging_off() -> None:
    if _Console.handler is not None:
        servolab = logging.getLogger("servolab")
        servolab.removeHandler(_Console.handler)
        servolab.setLevel(_Console.level)
        _Console.handler = None


def get_default_context() -> Context:
    return default_context()


def ok(context: Any = None) -> bool:
    """True while the default context is open and not shut down (Ctrl-C makes it False)."""
    return ok_now()


def shutdown(context: Any = None) -> None:
    """Close the default context; a RuntimeError if it is not open, as in rclpy."""
    if not is_initialized():
        raise RuntimeError("rclpy.shutdown(): the default context is not initialized "
                           "(was rclpy.init() called, or shutdown() twice?)")
    _shutdown()
    _console_logging_off()
    Global.arguments = type(Global.arguments)()


def try_shutdown(context: Any = None) -> None:
    """:func:`shutdown`, silent if the context is not open."""
    _shutdown()
    _console_logging_off()
    Global.arguments = type(Global.arguments)()


def create_node(node_name: str, *, namespace: str | None = None, **kwargs: Any) -> Node:
    if not is_initialized():
        init()
    return Node(node_name, namespace=namespace, **kwargs)


def get_global_executor() -> Any:
    """The executor :func:`spin` uses when given none (one per process, as rclpy's)."""
    from .executors import _global_executor
    return _global_executor()


def spin(node: Node, executor: Any = None) -> None:
    """Run the node's callbacks until Ctrl-C or :func:`shutdown` (all nodes of its context
    spin: servolab has one queue of work per context), on ``executor`` if given (a
    :class:`~servolab.rclpy.executors.MultiThreadedExecutor` runs them on several threads)."""
    if executor is not None:
        executor.add_node(node)
        executor.spin()
        return
    with node.context.executor.spinning():  # a call() on another thread waits for this one
        node.context.spin()


def spin_once(node: Node, *, executor: Any = None, timeout_sec: float | None = None) -> None:
    if executor is not None:
        executor.add_node(node)
        executor.spin_once(timeout_sec=timeout_sec)
        return
    node.context.spin_once(timeout_sec)


def spin_until_future_complete(node: Node, future: Future[Any] | Any, executor: Any = None,
                               timeout_sec: float | None = None) -> None:
    if executor is not None:
        executor.add_node(node)
        executor.spin_until_future_complete(future, timeout_sec)
        return
    node.context.spin_until(future.done, timeout_sec)
