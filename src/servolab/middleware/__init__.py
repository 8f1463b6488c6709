"""The middleware: ROS 2-style nodes, topics, parameters, services, bags and launch files, with
no ROS installation.

- :mod:`.context` — :class:`Context`: what the nodes of one process share (transport, types,
  clock, executor, parameter overrides)
- :mod:`.node` — :class:`Node`; one module per entity it makes: :mod:`.publisher`,
  :mod:`.subscription`, :mod:`.service`, :mod:`.client`, :mod:`.rate`; :mod:`.qos` (profiles),
  :mod:`.logger` (rclpy's throttle / once / skip_first)
- :mod:`.default_context` — the one context rclpy-shaped code shares (``servolab.rclpy``)
- :mod:`.executor` — callbacks on one thread; virtual time asked of its owner
- :mod:`.messages` — ROS 2 message types and CDR (rosbags), dynamixel_msgs
- :mod:`.local`, :mod:`.zenoh_transport`, :mod:`.rmw_zenoh` — in-process and Zenoh transports
- :mod:`.bag`, :mod:`.recorder` — MCAP bags in the rosbag2 layout
- :mod:`.launch_file`, :mod:`.launch` — launch files and the supervisor that runs them

``docs/middleware.md`` is the user's guide.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

#: Each public name and the module it lives in. They are imported on first use (PEP 562), so
#: that importing one light module of the package (its errors, say, as ``servolab --help``
#: does) does not load the bag, the launch supervisor and the message types with it.
_EXPORTS: dict[str, str] = {
    **dict.fromkeys(("BagInfo", "BagMessage", "BagReader", "BagWriter", "play"), "bag"),
    "Context": "context",
    **dict.fromkeys(("BagError", "LaunchError", "MessageError", "MiddlewareError",
                     "NameValidationError", "ParameterError", "ServiceError",
                     "TransportError"), "errors"),
    **dict.fromkeys(("Executor", "Timer"), "executor"),
    **dict.fromkeys(("launch_main", "run_launch"), "launch"),
    **dict.fromkeys(("LaunchFile", "load_launch"), "launch_file"),
    "MessageTypes": "messages",
    "Client": "client",
    "Node": "node",
    "Publisher": "publisher",
    **dict.fromkeys(("DurabilityPolicy", "HistoryPolicy", "QoSProfile", "ReliabilityPolicy"),
                    "qos"),
    "Rate": "rate",
    "Service": "service",
    "Subscription": "subscription",
    **dict.fromkeys(("Parameter", "ParameterOverrides"), "parameters"),
    "Recorder": "recorder",
    **dict.fromkeys(("MessageInfo", "TransportOptions"), "transport"),
}

__all__ = [
    "BagError", "BagInfo", "BagMessage", "BagReader", "BagWriter", "Client", "Context",
    "DurabilityPolicy", "Executor", "HistoryPolicy", "LaunchError", "LaunchFile",
    "MessageError", "MessageInfo", "MessageTypes", "MiddlewareError", "NameValidationError",
    "Node", "Parameter", "ParameterError", "ParameterOverrides", "Publisher", "QoSProfile",
    "Rate", "Recorder", "ReliabilityPolicy", "Service", "ServiceError", "Subscription", "Timer",
    "TransportError", "TransportOptions", "launch_main", "load_launch", "play", "run_launch",
]


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

if TYPE_CHECKING:
    from .bag import BagInfo, BagMessage, BagReader, BagWriter, play
    from .client import Client
    from .context import Context
    from .errors import (
        BagError,
        LaunchError,
        MessageError,
        MiddlewareError,
        NameValidationError,
        ParameterError,
        ServiceError,
        TransportError,
    )
    from .executor import Executor, Timer
    from .launch import launch_main, run_launch
    from .launch_file import LaunchFile, load_launch
    from .messages import MessageTypes
    from .node import Node
    from .parameters import Parameter, ParameterOverrides
    from .publisher import Publisher
    from .qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from .rate import Rate
    from .recorder import Recorder
    from .service import Service
    from .subscription import Subscription
    from .transport import MessageInfo, TransportOptions
