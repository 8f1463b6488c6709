"""The default context: the one :class:`~.context.Context` that rclpy-shaped code shares.

rclpy keeps one process-wide context (``rclpy.init()``, ``Node("name")``, ``rclpy.spin``).
servolab's own code passes its context explicitly and keeps no global state; this module is
the single exception, so that code written for rclpy runs with only its imports changed
(see ``docs/from_rclpy.md``). It opens on :func:`init`, or on the first ``Node("name")``
made without one, and closes on :func:`shutdown` or at interpreter exit.

Which transport it opens comes from :func:`init`'s arguments, else from the environment:
``SERVOLAB_TRANSPORT`` (``local``, the default, ``zenoh`` or ``dds``), ``SERVOLAB_LISTEN`` and
``SERVOLAB_CONNECT`` (comma-separated Zenoh endpoints, or DDS peers), as the CLI's ``--transport``,
``--listen`` and ``--connect`` would give them.
"""

from __future__ import annotations

import atexit
import os
import threading

from .context import Context
from .errors import TransportError
from .messages import MessageTypes
from .transport import TransportOptions, environment_domain_id
from .transports import TRANSPORTS


class _Holder:
    """The default context, its message types and the lock that guards opening them."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.context: Context | None = None
        self.types: MessageTypes | None = None


_HOLDER = _Holder()


def options_from_environment() -> TransportOptions:
    """The transport ``SERVOLAB_TRANSPORT`` / ``_LISTEN`` / ``_CONNECT`` ask for, in the ROS
    domain ``ROS_DOMAIN_ID`` names (issue 32, D3: rclpy reads it; so must its stand-in)."""
    def endpoints(name: str) -> list[str]:
        return [e.strip() for e in os.environ.get(name, "").split(",") if e.strip()]

    kind = os.environ.get("SERVOLAB_TRANSPORT", "local").strip() or "local"
    if kind not in TRANSPORTS:
        raise TransportError(f"SERVOLAB_TRANSPORT={kind!r}: use {', '.join(TRANSPORTS)}")
    return TransportOptions(kind=kind, listen=endpoints("SERVOLAB_LISTEN"),
                            connect=endpoints("SERVOLAB_CONNECT"),
                            domain_id=environment_domain_id())


def init(options: TransportOptions | None = None) -> Context:
    """Open the default context (again, after :func:`shutdown`); an error if it is open."""
    with _HOLDER.lock:
        if _HOLDER.context is not None and not _HOLDER.context.closed:
            raise RuntimeError("the default context is already initialized "
                               "(call shutdown() first)")
        return _open_locked(options)


def _open_locked(options: TransportOptions | None) -> Context:
    _HOLDER.context = Context.open(options or options_from_environment(),
                                   types=_types_locked())
    return _HOLDER.context


def default_types() -> MessageTypes:
    """The message types of the default context, which :mod:`servolab.interfaces`' classes
    build their messages with (made once: building them parses every ``.msg`` text)."""
    with _HOLDER.lock:
        return _types_locked()


def _types_locked() -> MessageTypes:
    if _HOLDER.types is None:
        _HOLDER.types = MessageTypes()
    return _HOLDER.types


def default_context() -> Context:
    """The default context, opened from the environment if :func:`init` was not called."""
    with _HOLDER.lock:  # one check-and-open: two threads never open two contexts
        context = _HOLDER.context
        if context is not None and not context.closed:
            return context
        return _open_locked(None)


def is_initialized() -> bool:
    with _HOLDER.lock:
        return _HOLDER.context is not None and not _HOLDER.context.closed


def ok_now() -> bool:
    """True while the default context is open and not shut down; never opens it."""
    with _HOLDER.lock:
        context = _HOLDER.context
    return context is not None and context.ok()


def shutdown() -> None:
    """Close the default context (its nodes, its transport); nothing if it is not open."""
    with _HOLDER.lock:
        context, _HOLDER.context = _HOLDER.context, None
    if context is not None:
        context.close()


atexit.register(shutdown)
