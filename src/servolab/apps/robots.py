"""``servolab robots``: the robots servolab finds (its own, installed plug-ins, robot folders on
``SERVOLAB_ROBOT_PATH``), and ``servolab robots show NAME``: a file one starts from, printed to
copy and edit.

The command only parses and prints; :mod:`servolab.robots.registry` finds the robots.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from .registry import Command

if TYPE_CHECKING:
    from ..robots.plugin import RobotPlugin


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
    from ..robots.registry import discover, shipped_files

    found = discover()
    files = shipped_files(found.plugins)
    if name not in files:
        robot = found.plugins.get(found.aliases.get(name, name))
        hint = (f"{name} has no configuration file: its parameters are in code"
                if robot is not None else f"no file {name!r}")
        raise UsageError(f"{hint}; there are {', '.join(files)}")
    shown = files[name]
    print(shown.read_text() if isinstance(shown, Path) else shown(), end="")


def _described(name: str, plugin: RobotPlugin) -> list[str]:
    """What ``servolab robots`` prints of one robot. Its bus is read from its description (a
    robot folder's URDF), so this is where a broken robot shows."""
    config = plugin.config()
    lines = [f"{name}: {plugin.summary}", f"  bus:     {plugin.bus()}",
             f"  on stop: {plugin.on_stop}",
             f"  config:  {config if config is not None else '(in code)'}"]
    more = [n for n in plugin.shown_files() if n != name]
    if more:
        lines.append(f"  files:   {', '.join(more)}")
    if plugin.commands:
        lines.append(f"  run by:  {', '.join(f'servolab {c}' for c in plugin.commands)}")
    if plugin.aliases:
        lines.append(f"  also:    {', '.join(plugin.aliases)}")
    if plugin.origin != "servolab":
        lines.append(f"  from:    {plugin.origin}")
    return lines


def _list() -> None:
    from ..errors import ServolabError
    from ..robots.registry import discover

    found = discover()
    problems = dict(found.problems)
    for name, plugin in found.plugins.items():
        try:
            print("\n".join(_described(name, plugin)))
        except Exception as exc:  # one robot's fault must not hide the rest
            problems[name] = (str(exc) if isinstance(exc, ServolabError)
                              else f"{plugin.origin}: {type(exc).__name__}: {exc}")
    for name, problem in problems.items():
        print(f"{name}: cannot be loaded: {' '.join(problem.split())}")
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
