"""A Zenoh router in this process, configured as ROS 2's ``rmw_zenohd`` configures its own: the
meeting point of servolab's (and ROS 2's) Zenoh sessions on several machines.

``rmw_zenohd`` (rmw_zenoh's ``src/zenohd/main.cpp``) reads the router configuration, opens one
Zenoh session with it, prints "Started Zenoh router with id ...", and waits for SIGINT or
SIGTERM. Its configuration is ``DEFAULT_RMW_ZENOH_ROUTER_CONFIG.json5`` unless
``$ZENOH_ROUTER_CONFIG_URI`` names another file, which then replaces it whole
(:mod:`.zenoh_config`). :class:`Router` does the same with zenoh-python's own router (``mode:
"router"``, the engine ``zenohd`` and ``rmw_zenohd`` run), and ``--config FILE`` names the file
as the variable does, taking precedence over it.

The defaults (:data:`RMW_ZENOHD_DEFAULTS`) are the keys of rmw_zenoh's router file that change
what Zenoh would do by itself, with two exceptions:

* it listens on ``tcp/localhost:7447`` (:data:`~.zenoh_transport.DEFAULT_ROUTER`, where every
  servolab and rmw_zenoh session looks for a router), not on rmw_zenoh's ``tcp/[::]:7447``
  (every interface): nothing servolab opens reaches beyond the machine unless the user says so
  (``--listen tcp/0.0.0.0:7447``, ``docs/fleets.md``);
* ``routing/router/peers_failover_brokering: false`` is left out: the Zenoh servolab runs
  (eclipse-zenoh 1.10) says the key "is deprecated and has no effect" (rmw_zenoh issue #995
  reports the same warning). Its router forwards no data between two *peers*: peers that
  cannot reach each other directly (robots on other machines, whose sessions listen on their
  own loopback) must be the router's *clients* (rmw_zenoh's README, "Connecting to the Zenoh
  router on another host"; ``docs/fleets.md``).

``rmw_zenohd`` exits with 0 on SIGINT and SIGTERM (and knows no SIGHUP); ``servolab router``
stops on all three and exits with 128 + the signal's number, as every servolab command that
runs until stopped does (:func:`serve`, :mod:`servolab.harness`).

``$ZENOH_CONFIG_OVERRIDE`` (rmw_zenoh's ``key=value;...``, :mod:`.zenoh_config`) goes on top
of the configuration, the file's or the defaults; ``--listen`` endpoints go on top of both (the
command line is the user's latest word). A file without a ``mode`` gets ``"router"``, and one
(or an override) that asks for another mode is refused.
"""

from __future__ import annotations

import json
import os
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any

import zenoh

from . import fleet_security
from .errors import TransportError
from .zenoh_config import (
    OVERRIDE_ENV,
    ROUTER_CONFIG_ENV,
    apply_override,
    config_file_from_env,
    load_config_file,
    overridden_keys,
    zenoh_error_text,
)
from .zenoh_transport import DEFAULT_ROUTER, check_endpoint, left_unset

#: Where a router with ``--security`` listens unless told: the usual port, this machine, TLS.
DEFAULT_SECURE_ROUTER = "tls/localhost:7447"

#: rmw_zenohd's router configuration as json5 values by key: the keys of
#: ``rmw_zenoh_cpp/config/DEFAULT_RMW_ZENOH_ROUTER_CONFIG.json5`` whose values differ from Zenoh's
#: own defaults or that ROS depends on (each marked "ROS setting" there), but for the two
#: exceptions of the module docstring. The listen endpoints are set apart
#: (:class:`RouterOptions`).
RMW_ZENOHD_DEFAULTS: dict[str, str] = {
    "mode": '"router"',
    # no other router to connect to: each machine's sessions come to this one
    "connect/endpoints": "[]",
    # "ROS setting: disable multicast discovery by default"
    "scouting/multicast/enabled": "false",
    # peers learn of each other from the router (gossip), one hop, and link directly; the
    # router connects to no one it hears of
    "scouting/gossip/enabled": "true",
    "scouting/gossip/multihop": "false",
    "scouting/gossip/target": '{router: ["router", "peer"], peer: ["router"]}',
    "scouting/gossip/autoconnect": '{router: [], peer: ["router", "peer"]}',
    # "ROS setting: PublicationCache which is required for transient_local durability only
    # works when time-stamping is enabled"
    "timestamping/enabled": "{router: true, peer: true, client: true}",
    # "ROS setting": 10 minutes, longer than any service call waits
    "queries_default_timeout": "600000",
    # "ROS setting": room for many nodes starting at once
    "transport/unicast/open_timeout": "60000",
    "transport/unicast/accept_timeout": "60000",
    "transport/unicast/accept_pending": "10000",
    "transport/unicast/max_sessions": "10000",
    "transport/link/tx/lease": "60000",
}


@dataclass(frozen=True)
class RouterOptions:
    """What ``servolab router`` is asked for.

    ``listen``: endpoints that replace the configuration's (none given: the file's, else
    ``tcp/localhost:7447``). ``config``: a json5 file (``--config``) that replaces the defaults
    whole, as ``$ZENOH_ROUTER_CONFIG_URI`` does for ``rmw_zenohd``; it takes precedence over
    that variable. ``security``: a fleet security file (``--security``,
    :mod:`.fleet_security`) whose mutual TLS and access control go on top; every endpoint is
    then ``tls/`` (default ``tls/localhost:7447``)."""

    listen: tuple[str, ...] = ()
    config: Path | None = None
    security: Path | None = None
    environ: Mapping[str, str] = field(default_factory=lambda: dict(os.environ), repr=False)

    def config_file(self) -> tuple[Path, str] | None:
        """The configuration file to read and where its name came from, or None for
        rmw_zenohd's defaults."""
        if self.config is not None:
            return self.config, "--config"
        found = config_file_from_env(ROUTER_CONFIG_ENV, self.environ)
        return (found, f"${ROUTER_CONFIG_ENV}") if found is not None else None


def router_config(options: RouterOptions) -> zenoh.Config:
    """The router's configuration (module docstring): endpoints checked and the file read
    before anything opens, each problem one line naming the endpoint or the file."""
    listen = [check_endpoint(e) for e in options.listen]
    security = fleet_security.load(options.security) if options.security else None
    default_listen = DEFAULT_SECURE_ROUTER if security else DEFAULT_ROUTER
    found = options.config_file()
    if found is None:
        config = zenoh.Config()
        for key, value in RMW_ZENOHD_DEFAULTS.items():
            config.insert_json5(key, value)
        listen = listen or [default_listen]
    else:
        path, source = found
        config = load_config_file(path, source)
        mode = json.loads(config.get_json("mode"))
        if mode not in (None, "router"):
            raise TransportError(f"{path}: mode {mode!r}: servolab router runs a Zenoh router "
                                 '(remove mode from the file, or set it to "router")')
        config.insert_json5("mode", '"router"')
        if not listen and left_unset(config, "listen/endpoints"):
            listen = [default_listen]   # this machine only, not Zenoh's every-network default
    apply_override(config, options.environ)
    if json.loads(config.get_json("mode")) != "router":
        raise TransportError(f"${OVERRIDE_ENV}: sets mode "
                             f"{json.loads(config.get_json('mode'))!r}: servolab router runs a "
                             "Zenoh router")
    if listen and (options.listen
                   or "listen/endpoints" not in overridden_keys(options.environ)):
        config.insert_json5("listen/endpoints", json.dumps(listen))
    if security is not None:
        insecure = [e for e in listen_endpoints(config) if not e.startswith("tls/")]
        if insecure:
            raise TransportError(f"{options.security}: the router would also listen on "
                                 f"{', '.join(insecure)}, where anyone gets in: with --security "
                                 "every endpoint is tls/HOST:PORT")
        fleet_security.secure(config, security)
    return config


def listen_endpoints(config: zenoh.Config) -> list[str]:
    """The endpoints a router with ``config`` listens on (the router's list where the file
    gives one per mode)."""
    value: Any = json.loads(config.get_json("listen/endpoints"))
    if isinstance(value, dict):
        value = value.get("router", [])
    return [str(e) for e in value]


class Router:
    """A Zenoh router open in this process until :meth:`close` (or the ``with`` block's end).

    Opening fails in one line (:class:`TransportError`) when an endpoint cannot be listened
    on (another router has the port): Zenoh's own ``listen/exit_on_failure`` is true."""

    def __init__(self, options: RouterOptions | None = None) -> None:
        self.options = options or RouterOptions()
        config = router_config(self.options)
        self.endpoints = listen_endpoints(config)
        try:
            self.session = zenoh.open(config)
        except zenoh.ZError as exc:
            raise TransportError(f"cannot start a Zenoh router on "
                                 f"{', '.join(self.endpoints) or 'no endpoint'}: "
                                 f"{zenoh_error_text(exc)} (another router there? stop it, or "
                                 "give --listen another endpoint)") from None
        self.zid = str(self.session.zid())

    def close(self) -> None:
        """Close the router's session: every session connected to it loses it (and retries)."""
        self.session.close()

    def __enter__(self) -> Router:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


def serve(options: RouterOptions, say: Callable[[str], None],
          stop: threading.Event | None = None) -> None:
    """Run a router until ``stop`` is set, or until a stop signal raises in the main thread
    (the ``servolab`` command's harness turns SIGINT, SIGTERM and SIGHUP into
    :class:`~servolab.harness.StopSignal`, and exits with 128 + its number); the router is
    closed either way. ``say`` gets one line once it listens: where, and how to stop it."""
    stop = stop or threading.Event()
    with Router(options) as router:
        say(f"router {router.zid} listening on {', '.join(router.endpoints)}; Ctrl-C stops it")
        while not stop.wait(1.0):  # a signal's handler raises in here, between two waits
            pass
