"""Zenoh configuration files and the router check, read from the environment variables
rmw_zenoh reads, with rmw_zenoh's meaning (its ``zenoh_config.cpp`` and
``rmw_context_impl_s.cpp``), so one shell set up for ROS 2 on Zenoh sets up servolab too.

Facts from ros2/rmw_zenoh (its ``jazzy`` branch could not be fetched here: the sources read
were the repository's ``rolling`` of 2024-10-16 and later stored copies of the same files, and
the pull requests named below, which were backported to ``jazzy``):

* ``ZENOH_SESSION_CONFIG_URI`` and ``ZENOH_ROUTER_CONFIG_URI`` name a json5 file that *replaces*
  the default session or router configuration (``zenoh_config.cpp``: ``envar_map``, and
  ``_get_z_config``'s ``configured_uri = envar_uri[0] != '\\0' ? envar_uri : default_uri``).
  An empty variable counts as unset; a file Zenoh cannot read is an error ("Invalid
  configuration file %s") and nothing starts.
* ``ZENOH_CONFIG_OVERRIDE`` (rmw_zenoh PR #551, in its README's examples): ``key=value`` pairs
  separated by ``;``, each key a Zenoh configuration path and each value json5
  (``connect/endpoints=["tcp/192.168.0.3:7447"];scouting/multicast/enabled=true``), applied
  on top of the configuration, the file's or the default, of sessions and the router alike.
  rmw_zenoh warns about a bad one and goes on without it; servolab refuses it in one line.
* ``ZENOH_ROUTER_CHECK_ATTEMPTS`` (``zenoh_config.cpp``, ``zenoh_router_check_attempts()``): unset
  means 1 (rmw_zenoh PR #308, "Don't block in rmw_init checking for the router", and PR #427,
  which made the README say so); 0 means check indefinitely; a negative number skips the check;
  N > 0 means N checks. The text is read by ``strtoll``, so text that is no number reads as 0.
* The check (``rmw_context_impl_s.cpp``, the constructor of ``rmw_context_impl_s::Data``) runs
  once the session is open: it asks the session for the routers it is connected to, at most N
  times, 1 s apart (``sleep_time(1000)`` ms). Each check that finds none warns
  :data:`WAITING` (``ticks_between_print`` is 1 s / 1 s, so every check); after the N-th it
  warns :data:`GAVE_UP` and initialisation goes on: the router is never an error.

servolab differs in two places, on purpose: unset means *no check* (see :func:`router_check`
for why), and text that is not a whole number is refused in one line rather than read as 0
(no silent defaults: a typo must not make a robot wait for ever). Its waiting message names
``servolab router`` beside ROS 2's router, keeping rmw_zenoh's words before it, so a search
for rmw_zenoh's message finds servolab's too.
"""

from __future__ import annotations

import logging
import math
import os
import re
import time
from collections.abc import Callable, Mapping
from pathlib import Path

import zenoh

from ..errors import ConfigFileError
from ..limits import clip, quoted, read_limited
from .errors import TransportError

#: rmw_zenoh's variable naming a session's json5 configuration file.
SESSION_CONFIG_ENV = "ZENOH_SESSION_CONFIG_URI"
#: rmw_zenoh's variable naming the router's json5 configuration file.
ROUTER_CONFIG_ENV = "ZENOH_ROUTER_CONFIG_URI"
#: rmw_zenoh's variable of ``key=value`` pairs applied on top of the configuration, sessions'
#: and the router's alike (rmw_zenoh PR #551, "feat: support zenoh config override").
OVERRIDE_ENV = "ZENOH_CONFIG_OVERRIDE"
#: rmw_zenoh's variable saying how many times a session checks for a router.
CHECK_ATTEMPTS_ENV = "ZENOH_ROUTER_CHECK_ATTEMPTS"
#: Seconds between two checks (rmw_context_impl_s.cpp: ``sleep_time(1000)``, milliseconds).
CHECK_INTERVAL_S = 1.0

#: What each check that finds no router says (rmw_context_impl_s.cpp's first warning, with
#: servolab's router named first).
WAITING = ("Unable to connect to a Zenoh router. Have you started a router with "
           "`servolab router` (or ROS 2's `ros2 run rmw_zenoh_cpp rmw_zenohd`)?")
#: What the last check says before the session goes on without a router (rmw_zenoh's words,
#: rmw_context_impl_s.cpp's second warning; ``{attempts}`` is the number of checks).
GAVE_UP = ("Unable to connect to a Zenoh router after {attempts} attempt(s). Please ensure "
           "that a Zenoh router is running and can be reached. You may increase the number of "
           "attempts to check for a router by setting the ZENOH_ROUTER_CHECK_ATTEMPTS "
           "environment variable. Proceeding with initialization but other peers will not "
           "discover or receive data from peers in this session until a router is started.")

log = logging.getLogger(__name__)

#: A Zenoh json5 parse error's position (``--> 3:17``) and reason (``= expected ...``).
_POSITION = re.compile(r"-->\s*(\d+):(\d+)")
_REASON = re.compile(r"^\s*=\s*(.+)$", re.MULTILINE)


def config_file_from_env(variable: str, environ: Mapping[str, str] | None = None) -> Path | None:
    """The file ``variable`` names, or None when it is unset or empty (rmw_zenoh: an empty
    variable means the default configuration)."""
    environ = os.environ if environ is None else environ
    text = environ.get(variable, "").strip()
    return Path(text) if text else None


def zenoh_error_text(error: BaseException) -> str:
    """A Zenoh error as one short line: its position and reason for a json5 syntax error
    (Zenoh prints them on five lines), else its first line without the Rust source location
    Zenoh appends (`` at /root/.cargo/...``)."""
    text = str(error)
    position, reason = _POSITION.search(text), _REASON.search(text)
    if position and reason:
        return f"line {position[1]}, column {position[2]}: {reason[1].strip()}"
    first = text.strip().splitlines()[0] if text.strip() else type(error).__name__
    return clip(first.split(" at /")[0].strip(), 160)


def load_config_file(path: Path, source: str) -> zenoh.Config:
    """The Zenoh configuration in the json5 file ``path``; ``source`` says where its name came
    from (``--config``, ``$ZENOH_ROUTER_CONFIG_URI``) for the error, which is one line naming
    the file and what is wrong with it. Its size is checked before it is read, as every user
    file's is (:mod:`servolab.limits`)."""
    def refused(message: str, line: int = 0) -> ConfigFileError:
        return ConfigFileError(path, line, "", f"{message} (the Zenoh configuration {source} "
                               "names: fix the file or name another)")

    try:
        data = read_limited(path, "zenoh_config_mb", "Zenoh configuration", refused)
    except OSError as exc:
        raise refused(f"cannot read it: {exc.strerror or exc}") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise refused(f"not UTF-8 text (byte {exc.start})") from None
    try:
        return zenoh.Config.from_json5(text)
    except zenoh.ZError as exc:
        text = str(exc)
        position, reason = _POSITION.search(text), _REASON.search(text)
        if position and reason:  # a json5 syntax error: its line goes into path:line
            raise refused(f"column {position[2]}: not a Zenoh configuration: "
                          f"{reason[1].strip()}", int(position[1])) from None
        raise refused(f"not a Zenoh configuration: {zenoh_error_text(exc)}") from None


def _pairs(text: str) -> list[str]:
    """``text`` split at each ``;`` that is not inside a json5 string, list or object."""
    parts, depth, quote, start = [], 0, "", 0
    for k, c in enumerate(text):
        if quote:
            quote = "" if c == quote and text[k - 1] != "\\" else quote
        elif c in "\"'":
            quote = c
        elif c in "[{":
            depth += 1
        elif c in "]}":
            depth -= 1
        elif c == ";" and depth == 0:
            parts.append(text[start:k])
            start = k + 1
    parts.append(text[start:])
    return [p.strip() for p in parts if p.strip()]


def overridden_keys(environ: Mapping[str, str] | None = None) -> set[str]:
    """The keys ``$ZENOH_CONFIG_OVERRIDE`` sets (``listen/endpoints``, ...)."""
    environ = os.environ if environ is None else environ
    return {pair.partition("=")[0].strip() for pair in _pairs(environ.get(OVERRIDE_ENV, ""))}


def apply_override(config: zenoh.Config, environ: Mapping[str, str] | None = None) -> None:
    """Apply ``$ZENOH_CONFIG_OVERRIDE`` to ``config`` (module docstring); a pair that is not
    ``key=json5`` or that Zenoh refuses is one line naming it."""
    environ = os.environ if environ is None else environ
    for pair in _pairs(environ.get(OVERRIDE_ENV, "")):
        key, equals, value = pair.partition("=")
        if not equals or not key.strip() or not value.strip():
            raise TransportError(f"{OVERRIDE_ENV}: {quoted(pair, 60)} is not key=value (e.g. "
                                 "'connect/endpoints=[\"tcp/192.168.0.3:7447\"]')")
        try:
            config.insert_json5(key.strip(), value.strip())
        except zenoh.ZError as exc:
            raise TransportError(f"{OVERRIDE_ENV}: {quoted(pair, 60)}: "
                                 f"{zenoh_error_text(exc)}") from None


def router_check(environ: Mapping[str, str] | None = None) -> float | None:
    """How many times a session checks for a router once it is open, from
    ``$ZENOH_ROUTER_CHECK_ATTEMPTS``: None for no check, ``math.inf`` for until one answers.

    rmw_zenoh's meanings (module docstring) but one: **unset means no check**, where rmw_zenoh
    checks once and warns. A servolab process runs its nodes in itself by default and, on
    Zenoh, meets the others through endpoints it is given (``--listen``/``--connect``) as
    well as through a router; the router is optional, so its absence is not worth a warning
    on every command (``servolab topic list`` in a lab without a router). Set it to 1 for
    rmw_zenoh's default. A value that is not a whole number is refused in one line."""
    environ = os.environ if environ is None else environ
    text = environ.get(CHECK_ATTEMPTS_ENV)
    if text is None or not text.strip():
        return None
    try:
        attempts = int(text.strip())
    except ValueError:
        raise TransportError(
            f"{CHECK_ATTEMPTS_ENV}={quoted(text, 40)} is not a whole number: 0 waits for a "
            "router for ever, N > 0 checks N times a second apart, a negative number skips "
            "the check") from None
    if attempts < 0:
        return None
    return math.inf if attempts == 0 else float(attempts)


def wait_for_router(session: zenoh.Session, attempts: float, *,
                    warn: Callable[[str], None] = log.warning,
                    sleep: Callable[[float], None] = time.sleep,
                    interval: float = CHECK_INTERVAL_S) -> bool:
    """Check up to ``attempts`` times, ``interval`` s apart, that ``session`` is connected to
    a router, as rmw_zenoh does after opening a session: each check that finds none warns
    :data:`WAITING`, the last one :data:`GAVE_UP` too. Returns whether a router answered;
    never raises for its absence (a stop signal in ``sleep`` goes through)."""
    done = 0
    while True:
        if list(session.info.routers_zid()):
            return True
        warn(WAITING)
        done += 1
        if done >= attempts:
            warn(GAVE_UP.format(attempts=done))
            return False
        sleep(interval)
