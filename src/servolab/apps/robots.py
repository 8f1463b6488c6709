"""``servolab robots``: the robots servolab finds (its own, installed plug-ins, robot folders on
``SERVOLAB_ROBOT_PATH``), and ``servolab robots show NAME``: a file one starts from, printed to
copy and edit.

The command only parses and prints; :mod:`servolab.robots.registry` finds the robots.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from .registry import Command


def _add_arguments(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="action", metavar="show")
    show = sub.add_parser("show", help="print a robot's configuration file or description",
                          description="Print a file a robot starts from: NAME is its "
                          "configuration, NAME.urdf its robot description, and a robot may name "
                          "more (servolab robots lists them). Redirect it to a file, edit it, "
                          "and give the file to the command's option (--config, --base, "
                          "--costmap, ...).")
    show.add_argument("name", metavar="NAME", help="a robot's or one of its files' name")


def _show(name: str) -> None:
    from ..errors import UsageError
    from ..robots.registry import discover

    found = discover()
    files = {n: f for p in found.plugins.values() for n, f in p.shown_files().items()}
    if name not in files:
        robot = found.plugins.get(found.aliases.get(name, name))
        hint = (f"{name} has no configuration file: its parameters are in code"
                if robot is not None else f"no file {name!r}")
        raise UsageError(f"{hint}; there are {', '.join(files)}")
    shown = files[name]
    print(shown.read_text() if isinstance(shown, Path) else shown(), end="")


def _list() -> None:
    from ..robots.registry import discover

    found = discover()
    for name, plugin in found.plugins.items():
        config = plugin.config()
        print(f"{name}: {plugin.summary}")
        print(f"  bus:     {plugin.bus()}")
        print(f"  on stop: {plugin.on_stop}")
        print(f"  config:  {config if config is not None else '(in code)'}")
        more = [n for n in plugin.shown_files() if n != name]
        if more:
            print(f"  files:   {', '.join(more)}")
        if plugin.commands:
            print(f"  run by:  {', '.join(f'servolab {c}' for c in plugin.commands)}")
        if plugin.aliases:
            print(f"  also:    {', '.join(plugin.aliases)}")
        if plugin.origin != "servolab":
            print(f"  from:    {plugin.origin}")
    for name, problem in found.problems.items():
        print(f"{name}: cannot be loaded: {problem}")
    print("\n'servolab robots show NAME' prints a file to copy and edit; "
          "servolab.robots.load(NAME, port=None) opens a robot from Python; a robot of your "
          "own: a folder on SERVOLAB_ROBOT_PATH or a 'servolab.robots' entry point.")


def _run(args: argparse.Namespace) -> int:
    if args.action == "show":
        _show(args.name)
    else:
        _list()
    return 0


COMMAND = Command(
    name="robots", group="robots", help="the robots servolab finds, and their files",
    description="List the robots servolab finds — its own, those of installed packages "
    "(the 'servolab.robots' entry point) and robot folders on SERVOLAB_ROBOT_PATH — with their "
    "motors, bus and files, or print one of those files.",
    examples=("servolab robots", "servolab robots show armstrong > my_armstrong.yaml",
              "servolab robots show armstrong.urdf > armstrong.urdf",
              "servolab walk --config my_armstrong.yaml"),
    add_arguments=_add_arguments, run=_run)
