"""How much of a file servolab reads, and how much of a bad value it echoes.

Why: a file given on the command line, named in a launch file or found in a robot folder
comes from outside. Without a limit, a 240 MB motion file is read whole (3 GB of memory, half
a minute) before anything looks at it, and a bad cell of 100 kB is printed back as a 100 kB
error line. So every loader of a user's file checks its size *before* reading its content
(``os.stat``; a device or pipe, which stat cannot size, is read no further than the limit),
and every error quotes at most :data:`ECHO_WIDTH` characters of a value, cut with "…".

The limits (:class:`InputLimits`) are generous for real use, and each can be raised for one
run through the environment, ``SERVOLAB_MAX_<FIELD>`` (``SERVOLAB_MAX_MOTION_MB=512``;
``inf`` lifts it):

============================  =======  =============================================================
variable                      default  what it bounds
============================  =======  =============================================================
SERVOLAB_MAX_MOTION_MB        64       a motion file (CSV) in MB (10**6 bytes)
SERVOLAB_MAX_MOTION_ROWS      100000   its poses: 6.2 h at the seed's 4.5 rows a second, 2.8 h at
                                       the ZMP walk's 10
SERVOLAB_MAX_YAML_MB          1        every YAML file: launch, parameter, map.yaml, robot and
                                       navigation configurations
SERVOLAB_MAX_MAP_MB           32       a map's image, in MB and in millions of pixels
SERVOLAB_MAX_URDF_MB          16       a URDF (or a .urdf.xacro, and what xacro makes of it)
SERVOLAB_MAX_ZENOH_CONFIG_MB  1        a Zenoh json5 configuration (``servolab router --config``,
                                       ``$ZENOH_SESSION_CONFIG_URI``): rmw_zenoh's is 43 kB
============================  =======  =============================================================

Why the environment, and not an option: the loaders run under many commands (``walk``,
``gait``, ``launch``, ``navigate``, ``sim --robot``, ``robots show``, ...), in the processes a
launch starts and from Python programs; a variable reaches all of them, child processes
included, with no option added to each command, and the error says its name. A program can
also pass an :class:`InputLimits` of its own where a loader takes ``limits=``.
"""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass, fields
from pathlib import Path

from .errors import ServolabValueError

__all__ = ["ECHO_WIDTH", "InputLimits", "clip", "quoted", "read_limited", "too_big"]

#: The most characters of a value an error line quotes.
ECHO_WIDTH = 80
_MB = 1_000_000


def clip(text: str, width: int = ECHO_WIDTH) -> str:
    """``text`` cut to ``width`` characters, the cut marked with "…" (kept whole if it fits)."""
    return text if len(text) <= width else text[:max(width - 1, 0)] + "…"


def quoted(value: object, width: int = ECHO_WIDTH) -> str:
    """``repr(value)`` in at most ``width`` characters: a long string keeps its closing quote
    after the "…" (``'aaaa…'``), so the cut is plain."""
    shown = repr(value)
    if len(shown) <= width:
        return shown
    if isinstance(value, str) and shown[-1] in "'\"":
        return shown[:max(width - 2, 1)] + "…" + shown[-1]
    return clip(shown, width)


@dataclass(frozen=True)
class InputLimits:
    """The largest input each loader takes (see the module docstring for why and how much).
    ``InputLimits.current()`` is the defaults with the environment's overrides."""

    motion_mb: float = 64.0
    motion_rows: float = 100_000
    yaml_mb: float = 1.0
    map_mb: float = 32.0
    urdf_mb: float = 16.0
    zenoh_config_mb: float = 1.0

    @staticmethod
    def variable(name: str) -> str:
        """The environment variable that raises the limit ``name`` (a field's name)."""
        return f"SERVOLAB_MAX_{name.upper()}"

    @classmethod
    def current(cls, environ: Mapping[str, str] | None = None) -> InputLimits:
        """The defaults, each replaced by its ``SERVOLAB_MAX_<FIELD>`` when that is set; a
        value that is not a number > 0 is refused in one line naming the variable."""
        environ = os.environ if environ is None else environ
        values: dict[str, float] = {}
        for field in fields(cls):
            variable = cls.variable(field.name)
            text = environ.get(variable)
            if text is None or not text.strip():
                continue
            try:
                value = float(text)
            except ValueError:
                value = math.nan
            if not value > 0:
                raise ServolabValueError(f"{variable}={quoted(text, 40)}: must be a number > 0 "
                                         f"(or inf), the default is {getattr(cls, field.name):g}")
            # beyond what a file read can take (or hold), a limit is no limit
            values[field.name] = math.inf if value * _MB > sys.maxsize / 2 else value
        return cls(**values)

    def bytes(self, name: str) -> float:
        """The limit ``name`` (a ``*_mb`` field) in bytes."""
        return float(getattr(self, name)) * _MB

    def over(self, name: str, amount: float, unit: str, what: str, *,
             done: str = "not read") -> str:
        """The message for ``amount`` over the limit ``name`` (``what`` names the file's
        kind; ``done``, what was not done with it), saying how to raise it."""
        limit = float(getattr(self, name))
        shown = f"{amount / _MB:.1f} MB" if unit == "MB" else f"{amount:.0f} {unit}"
        return (f"{shown}: over the limit of {limit:g} {unit} for {_a(what)} ({done}; "
                f"{self.variable(name)} raises it)")


def _a(noun: str) -> str:
    return f"an {noun}" if noun[:1] in "aeioAEIO" else f"a {noun}"  # a URDF, an image


def too_big(path: str | Path, name: str, what: str,
            limits: InputLimits | None = None) -> str | None:
    """The message refusing ``path`` if ``os.stat`` says it is larger than the limit ``name``
    (a ``*_mb`` field of :class:`InputLimits`), else None (also when it cannot be stat'ed:
    reading it then says why)."""
    limits = InputLimits.current() if limits is None else limits
    try:
        size = os.stat(path).st_size
    except (OSError, ValueError):
        return None
    return limits.over(name, size, "MB", what) if size > limits.bytes(name) else None


def read_limited(path: str | Path, name: str, what: str, fail: Callable[[str], Exception],
                 limits: InputLimits | None = None) -> bytes:
    """The bytes of ``path``, or ``fail(message)`` raised when it is larger than the limit
    ``name``: checked with ``os.stat`` before anything is read, and again while reading (a
    device or a pipe is read no further than the limit). An OSError goes to the caller."""
    limits = InputLimits.current() if limits is None else limits
    message = too_big(path, name, what, limits)
    if message is not None:
        raise fail(message)
    most = limits.bytes(name)
    with open(path, "rb") as file:
        data = file.read() if math.isinf(most) else file.read(int(most) + 1)
    if len(data) > most:
        raise fail(f"more than {most / _MB:g} MB, the limit for {_a(what)} (not read further; "
                   f"{limits.variable(name)} raises it)")
    return data
