"""``servolab router``: a Zenoh router, as ROS 2's ``ros2 run rmw_zenoh_cpp rmw_zenohd`` runs
one, for servolab's (and ROS 2's) sessions on several machines to meet at (docs/fleets.md).

Argument parsing only: the router is :mod:`servolab.middleware.router`'s, imported inside
:func:`_run` so that ``servolab --help`` does not load Zenoh.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from .registry import Command


def _add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--listen", action="append", default=[], metavar="ENDPOINT",
                   help="Zenoh endpoint to listen on (repeatable; default tcp/localhost:7447, "
                   "this machine only: tcp/0.0.0.0:7447 opens it to the network); replaces "
                   "the configuration file's")
    p.add_argument("--config", type=Path, default=None, metavar="FILE",
                   help="a Zenoh json5 router configuration replacing rmw_zenohd's defaults "
                   "(default: $ZENOH_ROUTER_CONFIG_URI, as rmw_zenohd reads it)")
    p.add_argument("--security", type=Path, default=None, metavar="FILE",
                   help="a fleet security file: mutual TLS with the fleet's certificates "
                   "(servolab certs) and which members may publish which topics; the router "
                   "then listens on tls/ endpoints only (default tls/localhost:7447)")


def _run(args: argparse.Namespace) -> int:
    from servolab.middleware.router import RouterOptions, serve

    serve(RouterOptions(listen=tuple(args.listen), config=args.config, security=args.security),
          lambda line: print(line, flush=True))
    return 0


COMMAND = Command(
    name="router", group="graph", help="a Zenoh router for processes on several machines",
    description="Run a Zenoh router configured as ROS 2's rmw_zenohd configures its own, until "
    "Ctrl-C, SIGTERM or SIGHUP. servolab and rmw_zenoh sessions look for it at "
    "tcp/localhost:7447; on other machines, --connect tcp/HOST:7447 (docs/fleets.md). "
    "$ZENOH_ROUTER_CONFIG_URI or --config names a json5 file that replaces the defaults.",
    examples=("servolab router",
              "servolab router --listen tcp/0.0.0.0:7447",
              "servolab router --config my_router.json5",
              "servolab router --security fleet_security.yaml --listen tls/0.0.0.0:7447"),
    add_arguments=_add_arguments, run=_run)
