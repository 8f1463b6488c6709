"""Pick a protocol version by number."""

from __future__ import annotations

from .errors import ConfigError
from .packets import Protocol
from .protocol1 import PROTOCOL1
from .protocol2 import PROTOCOL2


def protocol(version: int | float | str) -> Protocol:
    """The :class:`Protocol` for version 1 (1.0) or 2 (2.0)."""
    try:
        number = float(version)
    except (TypeError, ValueError):
        number = -1.0
    if number == 1.0:
        return PROTOCOL1
    if number == 2.0:
        return PROTOCOL2
    raise ConfigError(f"protocol {version!r} is not 1 (1.0) or 2 (2.0)")
