"""``rclpy.logging``: ``get_logger(name)``, a logger with rclpy's call shape (servolab's
:class:`~servolab.middleware.logger.NodeLogger`), printed as rclpy prints it."""

from __future__ import annotations

import logging as _logging

from servolab.middleware.logger import NodeLogger
from servolab.middleware.node import LOGGER_PREFIX


class LoggingSeverity:
    """rcutils' severities."""

    UNSET = 0
    DEBUG = 10
    INFO = 20
    WARN = 30
    ERROR = 40
    FATAL = 50


def get_logger(name: str) -> NodeLogger:
    return NodeLogger(_logging.getLogger(f"{LOGGER_PREFIX}/{name.replace('.', '/')}"))


__all__ = ["LoggingSeverity", "get_logger"]
