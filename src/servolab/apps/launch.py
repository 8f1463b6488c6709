"""``servolab launch``: start the nodes of a launch file, handing the file and flags to the
launch supervisor (:func:`servolab.middleware.launch.launch_main`).

The supervisor runs each process group as ``servolab launch FILE --process GROUP``, so
``--process`` is an argument here too, hidden from ``--help``. The middleware (and Zenoh) is
imported inside the run function, so that ``servolab --help`` does not load it.
"""

from __future__ import annotations

import argparse

from servolab.middleware.view.defaults import DEFAULT_PORT

from .arguments import add_log_level, add_transport, log_level
from .registry import Command
from .view import view_port


def _add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", help="a launch file, e.g. configs/talker_listener.launch.yaml")
    p.add_argument("launch_arguments", nargs="*", metavar="NAME:=VALUE",
                   help="the file's launch arguments, as ros2 launch takes them (robots:=3)")
    p.add_argument("--machine", help="start this machine's nodes (default: this host's)")
    p.add_argument("--process", help=argparse.SUPPRESS)
    add_transport(p, default="")
    p.add_argument("--view", nargs="?", type=view_port, const=DEFAULT_PORT, default=None,
                   metavar="PORT", help="serve the launch's graph to Foxglove or Lichtblick on "
                   f"ws://127.0.0.1:PORT (default {DEFAULT_PORT})")
    add_log_level(p)


def _run(args: argparse.Namespace) -> int:
    from servolab.middleware.launch import launch_main
    from servolab.middleware.launch_arguments import command_line_arguments

    from ._graph import say

    log_level(args)  # the children inherit it through the environment
    return launch_main(args.file, machine=args.machine, process=args.process,
                       transport=args.transport or None, listen=args.listen,
                       connect=args.connect, domain_id=args.domain_id, out=say,
                       view=args.view,
                       arguments=command_line_arguments(args.launch_arguments))


COMMAND = Command(
    name="launch", group="graph", help="start the nodes of a launch file",
    description="Start the nodes a launch file gives this machine (the format is in "
    "docs/middleware.md); Ctrl-C stops them all.",
    examples=("servolab launch configs/talker_listener.launch.yaml",
              "servolab launch configs/fleet.launch.yaml robots:=3"),
    add_arguments=_add_arguments, run=_run)
