"""Turn parsed ``topic`` / ``param`` / ``bag`` / ``launch`` arguments into calls.

Kept apart from :mod:`servolab.cli` so the parser module does not import the middleware (and
Zenoh) for the Dynamixel commands.
"""

from __future__ import annotations

import argparse
import os
import sys

from servolab.middleware.context import Context
from servolab.middleware.errors import TransportError
from servolab.middleware.transport import TransportOptions


def transport_options(args: argparse.Namespace, default: str = "zenoh") -> TransportOptions:
    domain = args.domain_id
    if domain is None:
        text = os.environ.get("ROS_DOMAIN_ID", "0") or "0"
        if not text.isdigit():
            raise TransportError(f"ROS_DOMAIN_ID={text!r} is not a number")
        domain = int(text)
    if not 0 <= domain <= 232:
        raise TransportError(f"--domain-id {domain} is outside 0..232")
    kind = args.transport or default
    return TransportOptions(kind, list(args.listen), list(args.connect), domain)


def say(text: str) -> None:
    print(text, flush=True)


def dispatch(args: argparse.Namespace) -> int:
    from . import graphtools

    if args.command == "bag":
        from . import bagtools

        return bagtools.dispatch(args, transport_options, say)
    if args.command == "launch":
        from . import launchtools

        return launchtools.dispatch(args, transport_options, say)
    with Context.open(transport_options(args)) as ctx:
        if args.command == "topic":
            if args.action == "list":
                graphtools.topic_list(ctx, say, show_types=args.show_types,
                                      verbose=args.verbose)
            elif args.action == "echo":
                graphtools.topic_echo(ctx, args.topic, say, type_name=args.type_name,
                                      count=args.count, no_arrays=args.no_arr)
            elif args.action == "pub":
                sent = graphtools.topic_pub(ctx, args.topic, args.type_name, args.values, say,
                                            rate=args.rate, count=args.count)
                print(f"published {sent} message(s)", file=sys.stderr)
            elif args.action == "hz":
                graphtools.topic_hz(ctx, args.topic, say, type_name=args.type_name,
                                    window=args.window)
        elif args.command == "param":
            if args.action == "list":
                graphtools.param_list(ctx, say, args.node)
            elif args.action == "get":
                graphtools.param_get(ctx, args.node, args.name, say)
            elif args.action == "set":
                graphtools.param_set(ctx, args.node, args.name, args.value, say)
    return 0
