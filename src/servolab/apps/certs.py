"""``servolab certs``: a fleet's certificates for Zenoh's mutual TLS (docs/fleets.md, "Who may
join"): the authority, and for each member a certificate, its key and a client session
configuration to name in ``$ZENOH_SESSION_CONFIG_URI``.

Argument parsing only: :mod:`servolab.middleware.certificates` makes the files.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from .arguments import positive_int
from .registry import Command


def _add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("folder", type=Path, help="where the certificates go (made if missing; its "
                   "ca.pem and ca-key.pem are the fleet's authority, made once and reused)")
    p.add_argument("names", nargs="+", metavar="NAME",
                   help="a member: the router, a robot, the fleet manager (its certificate's "
                   "common name, which the security file's members name)")
    p.add_argument("--router", action="store_true",
                   help="the names are routers: their certificates name the --host they are "
                   "reached at and may serve TLS (a member's may only be shown by a client)")
    p.add_argument("--host", action="append", default=[], metavar="HOST",
                   help="with --router: a host name or address the router is reached at "
                   "(repeatable; default localhost and 127.0.0.1): clients check the one "
                   "they connect to")
    p.add_argument("--days", type=positive_int, default=365,
                   help="how long the certificates are valid (default 365 days)")


def _run(args: argparse.Namespace) -> int:
    from servolab.middleware.certificates import (
        CA_CERTIFICATE,
        DEFAULT_HOSTS,
        CertificateError,
        check_name,
        issue,
    )
    from servolab.middleware.fleet_security import client_json5

    if args.host and not args.router:
        raise CertificateError("--host names where a router is reached: give --router too")
    hosts = tuple(args.host) or DEFAULT_HOSTS
    for name in args.names:   # every name and file checked before any is made
        check_name(name)
        for path in (args.folder / f"{name}{end}" for end in (".json5", ".pem", "-key.pem")):
            if path.exists():
                raise CertificateError(f"{path} exists: servolab never overwrites a member's "
                                       "files (delete them to make new ones)")
    for name in args.names:
        session = args.folder / f"{name}.json5"
        made = issue(args.folder, name, hosts, args.days, router=args.router)
        text = client_json5(args.folder / CA_CERTIFICATE, made.certificate, made.private_key)
        with os.fdopen(os.open(session, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600), "w",
                       encoding="utf-8") as file:
            file.write(text)
        print(f"{name}: {made.certificate}, {made.private_key} (private), {session} "
              "(private: all a member needs, for ZENOH_SESSION_CONFIG_URI)", flush=True)
    print(f"authority: {args.folder / CA_CERTIFICATE}; keep ca-key.pem private", flush=True)
    return 0


COMMAND = Command(
    name="certs", group="tools", help="certificates for a fleet's mutual TLS",
    description="Make a fleet's certificate authority (once) and, for each NAME, a "
    "certificate and private key whose common name is NAME, signed by it, plus NAME.json5: "
    "a Zenoh client session configuration that shows them (export "
    "ZENOH_SESSION_CONFIG_URI=FOLDER/NAME.json5). The router takes its own through "
    "'servolab router --security FILE' (docs/fleets.md). Existing files are never "
    "overwritten.",
    examples=("servolab certs certs router --router --host router.lab.local",
              "servolab certs certs fleet_manager robot1 robot2"),
    add_arguments=_add_arguments, run=_run)
