"""``servolab robots``: the robots servolab ships, and ``servolab robots show NAME``: the
configuration file one starts from, printed to copy and edit.

The command only parses; :mod:`servolab.robots.registry` knows the robots.
"""

from __future__ import annotations

import argparse

from .registry import Command


def _add_arguments(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="action", metavar="show")
    show = sub.add_parser("show", help="print a shipped configuration file",
                          description="Print a configuration file servolab ships: a robot's "
                          "(armstrong, seed000, seed000_4motor, turtlebot3_waffle) or one of "
                          "the navigation's (costmap_params, dwa_params, move_base_params, "
                          "nav_scene). Redirect it to a file, edit it, and give the file to "
                          "the command's option (--config, --base, --costmap, ...). "
                          "armstrong.urdf and armstrong.mjcf print the biped's robot "
                          "description for viewers and for MuJoCo.")
    show.add_argument("name", metavar="NAME", help="a robot or a shipped file's name")


def _run(args: argparse.Namespace) -> int:
    from ..errors import UsageError
    from ..robots.registry import ROBOTS, robot_models, shipped_files

    files = shipped_files()
    if args.action == "show":
        models = robot_models()
        if args.name in models:
            print(models[args.name](), end="")
            return 0
        if args.name not in files:
            hint = (f"{args.name} has no configuration file: its parameters are in code"
                    if args.name in ROBOTS else f"no shipped file {args.name!r}")
            raise UsageError(f"{hint}; there are {', '.join([*files, *models])}")
        print(files[args.name].read_text(), end="")
        return 0
    for name, entry in ROBOTS.items():
        config = entry.config()
        print(f"{name}: {entry.summary}")
        print(f"  bus:     {entry.bus()}")
        print(f"  on stop: {entry.stops_by}")
        print(f"  config:  {config if config is not None else '(in code)'}")
    print("\n'servolab robots show NAME' prints a configuration file to copy and edit; "
          "servolab.robots.load(NAME, port=None) opens a robot from Python.")
    return 0


COMMAND = Command(
    name="robots", group="robots", help="the robots servolab ships, and their configurations",
    description="List the robots servolab ships with their motors, bus and default "
    "configuration file (installed with servolab), or print one of those files.",
    examples=("servolab robots", "servolab robots show armstrong > my_armstrong.yaml",
              "servolab robots show armstrong.urdf > armstrong.urdf",
              "servolab walk --config my_armstrong.yaml"),
    add_arguments=_add_arguments, run=_run)
