"""The ``servolab`` command: a parser built from the commands of :mod:`servolab.apps`, and the
one place where errors become a line on stderr and an exit status.

Each command is a module of :mod:`servolab.apps` that registers itself
(:mod:`servolab.apps.registry`); nothing here names a command, so adding one does not touch
this file. Errors in what the user typed come back as one line naming the bad value, exit
status 2; errors on the bus (no answer, a motor's error bits) or of a service as one line,
exit status 1; a stop signal as 128 + its number (130 for Ctrl-C, 143 for SIGTERM, 129 for
SIGHUP). Anything else is a bug and keeps its traceback (:mod:`servolab.harness`).
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
from .harness import (
    exit_status,
    hangup_safe_output,
    interruption,
    is_bad_input,
    stop_signals_raise,
)


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
    """Parse ``argv`` (default: ``sys.argv[1:]``), run the command, return the exit status.

    The one place where a command's end becomes an exit status and a line on stderr
    (:mod:`servolab.harness`): every command runs with SIGINT, SIGTERM and SIGHUP raising
    :class:`~servolab.harness.StopSignal`; an error servolab raised on purpose is one line;
    anything else is a bug and keeps its traceback."""
    registered = commands()
    args = build_parser(registered).parse_args(argv)
    command = next(c for c in registered if c.name == args.command)
    name = f"{args.command} {getattr(args, 'action', None) or ''}".strip()
    with hangup_safe_output():  # a closed terminal must not fail the stop's last lines
        try:
            with stop_signals_raise():
                return command.run(args)
        except KeyboardInterrupt as stop:
            print(f"servolab {name}: stopped by {interruption(stop)}", file=sys.stderr)
            return exit_status(stop)
        except ServolabError as exc:
            print(f"servolab {name}: {_label(exc)}: {exc}", file=sys.stderr)
            return exit_status(exc)
    # Anything else was not raised on purpose: a bug, whose traceback is the useful report.


def _label(exc: ServolabError) -> str:
    """``error`` for bad input and for a service that failed; a failure at run time such as
    the bus's is labelled with its class (``NoResponse``, ``MotorError``: the name says what
    went wrong)."""
    from .middleware.errors import ServiceError

    if is_bad_input(exc) or isinstance(exc, ServiceError):
        return "error"
    return type(exc).__name__


if __name__ == "__main__":
    sys.exit(main())
