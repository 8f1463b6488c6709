"""What came from outside and did not deserialize: counted, said once, never a crash.

Every transport that carries bytes hands a subscription what any peer on the graph put on
the topic's key or wrote to its DDS topic. Bytes that are not the topic's type (a length
field that says 2³¹, data cut short, a string without its NUL, bad UTF-8) are data from
outside, not a failure of the node. rclcpp's executor logs such a take and goes on
(``rclcpp/src/rclcpp/executor.cpp``, ``take_and_do_error_handling``: "executor taking a
message from topic '%s' unexpectedly failed"). rclpy over rmw_zenoh does not: ``rmw_take``
returns ``RMW_RET_ERROR`` ("could not deserialize ROS message") and ``rclpy/executors.py``'s
``_take_subscription`` lets the exception stop the spin, the crash this module prevents.
So here a malformed message is dropped, counted against the topic and the publisher that
sent it, and said on the node's logger the first time that publisher sends one: a peer that
sends ten thousand costs one log line, and the run's summary says how many it sent
(:meth:`MalformedMessages.as_figures`).
"""

from __future__ import annotations

import threading

#: what a count is kept under when the transport cannot say who published (a plain Zenoh put
#: without rmw_zenoh's attachment)
UNKNOWN_PUBLISHER = b""
#: what the publishers past :data:`MAX_PUBLISHERS` of a topic are counted under together: a
#: GID is the sender's own word (rmw_zenoh's attachment), and a peer that forged a new one for
#: every message would otherwise earn a log line and a table entry each
OTHER_PUBLISHERS = b"others"
MAX_PUBLISHERS = 64


def publisher_name(gid: bytes) -> str:
    """A publisher's GID as ROS 2 prints one (``ros2 topic info -v``: dotted hex bytes),
    ``"unknown"`` when the transport gave none, ``"others"`` for those past the limit."""
    if gid == OTHER_PUBLISHERS:
        return f"others (past {MAX_PUBLISHERS} publishers, counted together)"
    return ".".join(f"{b:02x}" for b in gid) if gid else "unknown"


class MalformedMessages:
    """Malformed messages and requests a context received, per (topic or service,
    publisher). Shared by every node of the context; any thread may count."""

    def __init__(self) -> None:
        self._counts: dict[tuple[str, bytes], int] = {}
        self._publishers: dict[str, int] = {}  # distinct publishers counted per name
        self._lock = threading.Lock()

    def count(self, name: str, publisher: bytes = UNKNOWN_PUBLISHER) -> tuple[int, bytes]:
        """Count one dropped message on ``name`` from ``publisher``; returns how many have
        been counted under its key so far (1: the first, the one to log) and that key: the
        publisher, or :data:`OTHER_PUBLISHERS` past :data:`MAX_PUBLISHERS` of them."""
        key = (name, bytes(publisher))
        with self._lock:
            if key not in self._counts:
                if self._publishers.get(name, 0) >= MAX_PUBLISHERS:
                    key = (name, OTHER_PUBLISHERS)
                else:
                    self._publishers[name] = self._publishers.get(name, 0) + 1
            n = self._counts[key] = self._counts.get(key, 0) + 1
        return n, key[1]

    @property
    def total(self) -> int:
        with self._lock:
            return sum(self._counts.values())

    def of(self, name: str) -> int:
        """How many were dropped on one topic or service, from every publisher."""
        with self._lock:
            return sum(n for (where, _), n in self._counts.items() if where == name)

    def as_figures(self) -> dict[str, dict[str, int]]:
        """``{topic: {publisher GID: dropped}}``, what a run's summary shows."""
        figures: dict[str, dict[str, int]] = {}
        with self._lock:
            for (name, gid), n in sorted(self._counts.items()):
                figures.setdefault(name, {})[publisher_name(gid)] = n
        return figures

    def diagnostic_status(self, hardware_id: str) -> dict[str, object] | None:
        """The fields of one ``diagnostic_msgs/msg/DiagnosticStatus`` saying what was dropped,
        WARN (the node goes on; a peer on the graph speaks another type or is hostile), for a
        node that publishes ``/diagnostics``; None while nothing was."""
        figures = self.as_figures()
        if not figures:
            return None
        values = [{"key": f"{name} from {publisher}", "value": str(n)}
                  for name, publishers in figures.items() for publisher, n in publishers.items()]
        total = sum(int(v["value"]) for v in values)
        return {"level": 1, "name": "servolab: malformed messages",
                "message": f"{total} dropped (not their topic's type)",
                "hardware_id": hardware_id, "values": values}
