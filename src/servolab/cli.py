"""The ``servolab`` command: a parser built from the commands of :mod:`servolab.apps`, and the
one place where errors become a line on stderr and an exit status.

Each command is a module of :mod:`servolab.apps` that registers itself
(:mod:`servolab.apps.registry`); nothing here names a command, so adding one does not touch
this file. Errors in what the user typed come back as one line naming the bad value, exit
status 2; errors on the bus (no answer, a motor's error bits) or of a service as one line,
exit status 1; Ctrl-C as exit status 130. Anything else is a bug and keeps its traceback.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import textwrap
from collections.abc import Sequence

from . import __version__
from .apps.registry import GROUPS, Command, commands
from .errors import ServolabError


def build_parser(registered: Sequence[Command] | None = None) -> argparse.ArgumentParser:
    """The parser of ``servolab`` with one subcommand per registered command.

    argparse can list subcommands only as one flat block, so the commands are left out of
    that block and listed by group in the epilog instead (:func:`command_list`).
    """
    registered = commands() if registered is None else registered
    parser = argparse.ArgumentParser(
        prog="servolab", description="Build, simulate and run robots of Dynamixel servos.",
        epilog=command_list(registered), formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"servolab {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND",
                                help="one of the commands below")
    for command in registered:
        p = sub.add_parser(command.name,
                           description=_fill(command.description or command.help),
                           epilog=_examples(command.examples),
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        command.add_arguments(p)
    return parser


def command_list(registered: Sequence[Command]) -> str:
    """The commands under their group headings, in :data:`GROUPS` order, each with its one
    line of help; a group without commands says so rather than vanish, so a reader learns
    that it exists."""
    width = max((len(c.name) for c in registered), default=0) + 2
    blocks = []
    for group in GROUPS:
        lines = [f"{group.title}:"]
        members = [c for c in registered if c.group == group.name]
        lines += [f"  {c.name:<{width}}{c.help}" for c in members] or ["  (none yet)"]
        blocks.append("\n".join(lines))
    blocks.append("Run 'servolab COMMAND --help' for a command's arguments and examples.")
    return "\n\n".join(blocks)


def _fill(text: str) -> str:
    """``text`` wrapped as argparse wraps the rest of ``--help`` (to the terminal, less 2),
    since the raw formatter that keeps the examples' lines would not wrap it."""
    return textwrap.fill(text, max(shutil.get_terminal_size().columns - 2, 40))


def _examples(examples: Sequence[str]) -> str | None:
    if not examples:
        return None
    return "examples:\n" + "\n".join(f"  {line}" for line in examples)


def main(argv: Sequence[str] | None = None) -> int:
    """Parse ``argv`` (default: ``sys.argv[1:]``), run the command, return the exit status."""
    registered = commands()
    args = build_parser(registered).parse_args(argv)
    command = next(c for c in registered if c.name == args.command)
    try:
        return command.run(args)
    except KeyboardInterrupt:
        print(f"servolab {args.command}: interrupted", file=sys.stderr)
        return 130
    except ServolabError as exc:
        status, label = _report(exc)
        name = f"{args.command} {getattr(args, 'action', '')}".strip()
        print(f"servolab {name}: {label}: {exc}", file=sys.stderr)
        return status
    # Anything else was not raised on purpose: a bug, whose traceback is the useful report.


def _report(exc: ServolabError) -> tuple[int, str]:
    """The exit status and label of an error servolab raised on purpose: ``(2, "error")`` for
    bad input — a value, an argument or a file of the user's, all value errors —,
    ``(1, "error")`` for a service that failed, ``(1, class name)`` for a failure at run time
    such as the bus's (``NoResponse``, ``MotorError``: the name says what went wrong).

    The layers' classes are imported here rather than at the top: the Dynamixel package
    takes some 70 ms to import, which ``servolab --help`` need not pay, and when one of its
    errors is in flight it is loaded already.
    """
    from .middleware.errors import MiddlewareError, ServiceError

    if isinstance(exc, ServiceError):
        return 1, "error"
    if isinstance(exc, ValueError | MiddlewareError):
        return 2, "error"
    return 1, type(exc).__name__


if __name__ == "__main__":
    sys.exit(main())
