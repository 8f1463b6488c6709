"""What ``servolab launch`` does: hand the file and flags to the launch supervisor."""

from __future__ import annotations

import argparse
from collections.abc import Callable

from servolab.middleware.launch import launch_main
from servolab.middleware.transport import TransportOptions


def dispatch(args: argparse.Namespace,
             options: Callable[[argparse.Namespace], TransportOptions],
             say: Callable[[str], None]) -> int:
    return launch_main(args.file, machine=args.machine, process=args.process,
                       transport=args.transport or None, listen=args.listen,
                       connect=args.connect, domain_id=args.domain_id, out=say)
