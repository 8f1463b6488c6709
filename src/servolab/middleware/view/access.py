"""Who may reach the view, and what they may do: the rules, apart from the server.

An open view lets a client watch every topic and parameter and, unless told otherwise, set
parameters and call services: drive the robot. Three rules keep that to the people meant:

- **Browser pages** say where they come from (the ``Origin`` header of the WebSocket
  handshake, which a page cannot forge). Only the apps' pages are let in
  (:data:`DEFAULT_ORIGINS`: Foxglove's and Lichtblick's web apps, pages of this computer
  served from ``localhost``, the desktop apps' ``file://``), and programs that send no
  ``Origin`` (foxglove's SDKs, ``@foxglove/ws-protocol`` in Node, scripts); any other page
  is refused at the handshake, HTTP 403. Without this, any web site open in the operator's
  browser could connect to ``ws://127.0.0.1:8765`` and drive the robot.
- ``Origin: null`` is an opaque origin: a page opened from a local file in Chromium or
  Firefox, but also a sandboxed frame any web site may embed. It is let in to **watch
  only**, unless ``--ws-allow-origin null`` trusts it (or it brings the token).
- **Beyond this computer** (a ``--ws-host`` that is not a loopback address) control needs a
  **token**: a random one made at start, or ``--ws-token`` / ``$SERVOLAB_VIEW_TOKEN``, sent as
  the URL's query parameter ``?token=...`` (the one part of the URL every client, the apps
  included, passes on as typed). Without it a client may watch, not control.

``--ws-read-only`` makes every client a watcher, wherever the server listens.
"""

from __future__ import annotations

import hmac
import ipaddress
import re
import secrets
import socket
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, cast
from urllib.parse import parse_qs, quote, urlsplit

from ..errors import MiddlewareValueError

if TYPE_CHECKING:  # the command line reads this module without loading websockets
    from websockets.typing import Origin

#: Pages let in besides localhost's: Foxglove's web app, Lichtblick's (its GitHub Pages build,
#: https://lichtblick-suite.github.io/lichtblick/, linked from its README) and ``file://``,
#: the origin an Electron desktop app (Foxglove's, Lichtblick's) serves its page from.
DEFAULT_ORIGINS = ("https://app.foxglove.dev", "https://lichtblick-suite.github.io",
                   "file://")
#: a page served from this computer, on any port (a locally served Lichtblick, a dev server)
LOCAL_ORIGIN = re.compile(r"https?://(localhost|127(\.\d{1,3}){3}|\[::1\])(:\d{1,5})?",
                          re.IGNORECASE)
#: the opaque origin: a local file's page, or a sandboxed frame of any site
NULL_ORIGIN = "null"
#: ``--ws-allow-origin *``: any page (what the view did before it checked)
ANY_ORIGIN = "*"
#: where the control token may be given instead of ``--ws-token`` (not seen by ``ps``)
TOKEN_ENV = "SERVOLAB_VIEW_TOKEN"
#: the query parameter of the WebSocket URL that carries the token
TOKEN_PARAMETER = "token"
#: a token given shorter than this is refused: it would be guessed
MIN_TOKEN = 8

_ORIGIN = re.compile(r"[a-z][a-z0-9+.-]*://[^/?#\s]*", re.IGNORECASE)


def check_origin(text: str) -> str:
    """An origin as ``--ws-allow-origin`` takes it (``scheme://host[:port]``, ``null`` or
    ``*``), or :class:`MiddlewareValueError` saying what is wrong with it."""
    origin = text.strip()
    if origin in (NULL_ORIGIN, ANY_ORIGIN):
        return origin
    if _ORIGIN.fullmatch(origin):
        return origin
    parts = urlsplit(origin)
    if parts.scheme and parts.netloc and (parts.path not in ("", "/") or parts.query):
        raise MiddlewareValueError(f"{text!r} is not an origin: an origin has no path "
                                   f"({parts.scheme}://{parts.netloc})")
    if parts.scheme and parts.netloc:  # a trailing slash
        return f"{parts.scheme}://{parts.netloc}"
    raise MiddlewareValueError(f"{text!r} is not an origin: scheme://host[:port] as the "
                               "browser's address bar shows it (https://app.foxglove.dev), "
                               "null or *")


def handshake_origins(allowed: Iterable[str]) -> list[Origin | re.Pattern[str] | None] | None:
    """What the WebSocket library's ``origins`` check lets through: the default pages, the
    ``allowed`` ones, localhost's, ``null`` (watch only unless allowed: see
    :func:`trusted_null`) and a handshake without ``Origin`` (None); None: any (``*``)."""
    extra = list(allowed)
    if ANY_ORIGIN in extra:
        return None
    origins: list[Origin | re.Pattern[str] | None] = [
        *(cast("Origin", o) for o in (*DEFAULT_ORIGINS, *extra)), LOCAL_ORIGIN,
        cast("Origin", NULL_ORIGIN), None]
    return list(dict.fromkeys(origins))


def trusted_null(allowed: Iterable[str]) -> bool:
    """Whether ``Origin: null`` was trusted with control (``--ws-allow-origin null`` or
    ``*``)."""
    return any(o in (NULL_ORIGIN, ANY_ORIGIN) for o in allowed)


def is_loopback(host: str) -> bool:
    """Whether listening on ``host`` keeps the server to this computer: a loopback address,
    or a name all of whose addresses are. ``""``, ``0.0.0.0`` and ``::`` are every
    interface."""
    if not host:
        return False
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        pass
    try:
        infos = socket.getaddrinfo(host, None)
    except OSError:
        return False
    return bool(infos) and all(ipaddress.ip_address(str(info[4][0]).split("%")[0]).is_loopback
                               for info in infos)


def check_token(token: str) -> str:
    """A token given by the user: long enough, and one that a URL carries as it is."""
    if len(token) < MIN_TOKEN:
        raise MiddlewareValueError(f"the view's token must be at least {MIN_TOKEN} "
                                   f"characters (got {len(token)}): it is all that keeps "
                                   "others from driving the robot")
    if any(c.isspace() for c in token):
        raise MiddlewareValueError("the view's token may not contain spaces")
    return token


def new_token() -> str:
    """A random token: 128 bits, URL-safe."""
    return secrets.token_urlsafe(16)


def token_in(path: str) -> str | None:
    """The token in a handshake's request path (``/?token=...``), or None."""
    values = parse_qs(urlsplit(path).query).get(TOKEN_PARAMETER)
    return values[0] if values else None


def token_matches(given: str | None, token: str | None) -> bool:
    """Whether ``given`` is the token (compared in constant time)."""
    if given is None or token is None:
        return False
    return hmac.compare_digest(given.encode(), token.encode())


def with_token(url: str, token: str) -> str:
    """``url`` with the token as its query: ``ws://host:port/?token=...``."""
    return f"{url.rstrip('/')}/?{TOKEN_PARAMETER}={quote(token, safe='')}"


def refused_ops(reason: str, ops: Sequence[str] = ("setParameters", "callService",
                                                    "playbackControlRequest")) -> str:
    """The line a watching client gets at connect."""
    return f"this connection may watch, not control ({', '.join(ops)} are refused): {reason}"
