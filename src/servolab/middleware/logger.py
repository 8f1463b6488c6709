"""A node's logger, with rclpy's call shape on top of :mod:`logging`.

rclpy's ``node.get_logger().info(text, throttle_duration_sec=1.0)`` keeps a control loop's
log readable: ``throttle_duration_sec`` logs a call site at most once per that many seconds,
``once`` logs it only the first time, ``skip_first`` skips its first time. Like rcutils, a
*call site* (file and line) is what is throttled, and time is the steady clock, not the
node's (a paused simulation must not silence its log). Everything else is the standard
library's: records go to ``logging.getLogger("servolab.node/<fully qualified name>")``, so
handlers, levels and ``--log-level`` work as for any Python logger, and ``%``-style arguments
(``info("at %d", n)``) are kept for servolab's own code.
"""

from __future__ import annotations

import logging
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from .errors import MiddlewareValueError


class NodeLogger:
    """See the module docstring."""

    def __init__(self, logger: logging.Logger) -> None:
        self.logger = logger
        self._lock = threading.Lock()
        self._last: dict[tuple[str, int], float] = {}   # call site -> when it last logged
        self._seen: set[tuple[str, int]] = set()        # call sites that came once

    @property
    def name(self) -> str:
        return self.logger.name

    def get_child(self, name: str) -> NodeLogger:
        """rclpy's child logger: ``<this name>.<name>``."""
        return NodeLogger(self.logger.getChild(name))

    def set_level(self, level: int | str) -> None:
        self.logger.setLevel(level)

    def get_effective_level(self) -> int:
        return self.logger.getEffectiveLevel()

    def is_enabled_for(self, level: int) -> bool:
        return self.logger.isEnabledFor(level)

    def log(self, level: int, message: Any, *args: Any, throttle_duration_sec: float | None = None,
            once: bool = False, skip_first: bool = False, **kwargs: Any) -> bool:
        """Log ``message`` at ``level`` unless a condition holds it back; True if logged.
        ``throttle_duration_sec``, ``once`` and ``skip_first`` are rclpy's conditions."""
        depth = 2 if kwargs.pop("_from_level", False) else 1  # frames up to the caller
        if not self.logger.isEnabledFor(level):
            return False
        if throttle_duration_sec is not None or once or skip_first:
            frame = sys._getframe(depth)
            if not self._may_log((frame.f_code.co_filename, frame.f_lineno),
                                 throttle_duration_sec, once, skip_first):
                return False
        kwargs.setdefault("stacklevel", depth + 1)
        self.logger.log(level, message, *args, **kwargs)
        return True

    def _may_log(self, site: tuple[str, int], throttle: float | None, once: bool,
                 skip_first: bool) -> bool:
        with self._lock:
            first = site not in self._seen
            self._seen.add(site)
            if once and not first:
                return False
            if skip_first and first:
                return False
            if throttle is not None:
                if throttle < 0:
                    raise MiddlewareValueError("throttle_duration_sec must be >= 0, got "
                                               f"{throttle}")
                now = time.monotonic()
                last = self._last.get(site)
                if last is not None and now - last < throttle:
                    return False
                self._last[site] = now
            return True

    def debug(self, message: Any, *args: Any, **kwargs: Any) -> bool:
        return self.log(logging.DEBUG, message, *args, _from_level=True, **kwargs)

    def info(self, message: Any, *args: Any, **kwargs: Any) -> bool:
        return self.log(logging.INFO, message, *args, _from_level=True, **kwargs)

    def warning(self, message: Any, *args: Any, **kwargs: Any) -> bool:
        return self.log(logging.WARNING, message, *args, _from_level=True, **kwargs)

    warn = warning  # rclpy spells it both ways

    def error(self, message: Any, *args: Any, **kwargs: Any) -> bool:
        return self.log(logging.ERROR, message, *args, _from_level=True, **kwargs)

    def fatal(self, message: Any, *args: Any, **kwargs: Any) -> bool:
        return self.log(logging.CRITICAL, message, *args, _from_level=True, **kwargs)

    critical = fatal

    def exception(self, message: Any, *args: Any, **kwargs: Any) -> bool:
        kwargs.setdefault("exc_info", True)
        return self.log(logging.ERROR, message, *args, _from_level=True, **kwargs)


@contextmanager
def console_log(stream: Any = None, *, logger: str = "servolab") -> Iterator[None]:
    """While inside, write ``logger``'s records (all of servolab's, nodes' included) to
    ``stream`` (stderr) as rospy writes them: ``[INFO] [WallTime: 1391262404.008801]
    pan_tilt_port: Pinging motor IDs 1 through 65...`` (seed 001 Figure 3.1). Levels below
    the logger's own are not written (``--log-level``)."""
    handler = logging.StreamHandler(stream if stream is not None else sys.stderr)
    handler.setFormatter(logging.Formatter("[%(levelname)s] [WallTime: %(created).6f] "
                                           "%(message)s"))
    target = logging.getLogger(logger)
    target.addHandler(handler)
    try:
        yield
    finally:
        target.removeHandler(handler)
