"""``servolab view``: a running graph, or a recorded run, served to Foxglove or Lichtblick.

The command only parses: :mod:`servolab.middleware.view` serves (its :mod:`.player` plays a
bag), and :mod:`servolab.robots.registry` finds each robot's layout in its plug-in.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from servolab.errors import UsageError
from servolab.middleware.view.defaults import DEFAULT_HOST, DEFAULT_PORT

from .arguments import (
    add_transport,
    nonnegative_float,
    positive_float,
    positive_int,
    transport_options,
)
from .registry import Command

if TYPE_CHECKING:
    from servolab.middleware.view.run_view import ViewRequest



def add_view_arguments(p: argparse.ArgumentParser) -> None:
    """``--ws-port``, ``--ws-host`` and who may do what (``--ws-allow-origin``,
    ``--ws-read-only``, ``--ws-token``) of a command that serves the view (``--port`` is a
    serial port in every servolab command)."""
    p.add_argument("--ws-port", type=tcp_port, default=DEFAULT_PORT, metavar="PORT",
                   help=f"TCP port to serve on (default {DEFAULT_PORT}, Foxglove's; 0: any free "
                   "one, printed)")
    p.add_argument("--ws-host", default=DEFAULT_HOST, metavar="ADDRESS",
                   help=f"address to listen on (default {DEFAULT_HOST}: this computer only; "
                   "0.0.0.0 lets other computers watch, and control with the token printed "
                   "at start)")
    add_access_arguments(p)
    p.add_argument("--ws-token", type=view_token, default=None, metavar="TOKEN",
                   help="beyond this computer, the token that gives control (default: "
                   "$SERVOLAB_VIEW_TOKEN, else a random one, printed; the environment "
                   "variable keeps it out of the process list); given on 127.0.0.1, "
                   "control needs it there too")


def add_access_arguments(p: argparse.ArgumentParser) -> None:
    """``--ws-allow-origin`` and ``--ws-read-only``: which web pages may connect, and whether
    any client may control."""
    p.add_argument("--ws-allow-origin", type=view_origin, action="append", default=None,
                   metavar="ORIGIN",
                   help="also let in web pages from ORIGIN (scheme://host[:port]; repeatable; "
                   "null: a page opened from a file may control too; *: any page). "
                   "Foxglove's and Lichtblick's web apps, localhost, the desktop apps and "
                   "programs that send no origin are let in; other pages are refused")
    p.add_argument("--ws-read-only", action="store_true", default=None,
                   help="clients may watch, not set parameters, call services or control "
                   "playback")


def view_origin(text: str) -> str:
    from servolab.middleware.view.access import check_origin

    try:
        return check_origin(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def view_token(text: str) -> str:
    from servolab.middleware.view.access import check_token

    try:
        return check_token(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def access_options(args: argparse.Namespace) -> dict[str, Any]:
    """What ``--ws-allow-origin``, ``--ws-read-only`` and ``--ws-token`` asked for, as
    :class:`~servolab.middleware.view.ViewConfig` fields."""
    return {"allow_origins": tuple(getattr(args, "ws_allow_origin", None) or ()),
            "read_only": bool(getattr(args, "ws_read_only", None)),
            "token": getattr(args, "ws_token", None)}


def tcp_port(text: str) -> int:
    try:
        port = int(text)
    except ValueError:
        port = -1
    if not 0 <= port <= 65535:
        raise argparse.ArgumentTypeError(f"{text!r} is not a TCP port (0..65535)")
    return port


def view_port(text: str) -> int:
    """``--view``'s port; a word that is not one was most likely meant for the command (the
    port is optional, so ``--view`` goes after the other arguments)."""
    try:
        return tcp_port(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a TCP port (0..65535); --view takes an optional port, so put "
            "it after the other arguments") from None


def view_speed(text: str) -> float:
    from servolab.middleware.view.pacing import MAX_SPEED, MIN_SPEED

    value = positive_float(text)
    if not MIN_SPEED <= value <= MAX_SPEED:
        raise argparse.ArgumentTypeError(f"{text} must be {MIN_SPEED:g} to {MAX_SPEED:g} "
                                         "(times real time)")
    return value


def add_view_flag(p: argparse.ArgumentParser) -> None:
    """``--view [PORT]`` and ``--view-speed X`` of a robot command: serve the run to
    Foxglove while it runs."""
    p.add_argument("--view", nargs="?", type=view_port, const=DEFAULT_PORT, default=None,
                   metavar="PORT", help="serve the run to Foxglove or Lichtblick on "
                   f"ws://127.0.0.1:PORT (default {DEFAULT_PORT}) while it runs; a simulated "
                   "run waits for the first viewer, then keeps to real time")
    p.add_argument("--view-speed", type=view_speed, default=None, metavar="X",
                   help="with --view, a simulated run: X times real time (default 1)")
    add_access_arguments(p)


def view_request(args: argparse.Namespace) -> ViewRequest | None:
    """What ``--view`` asked for, or None (also for a subcommand without it)."""
    port, speed = getattr(args, "view", None), getattr(args, "view_speed", None)
    if port is None:
        for given, option in ((speed, "--view-speed"),
                              (getattr(args, "ws_allow_origin", None), "--ws-allow-origin"),
                              (getattr(args, "ws_read_only", None), "--ws-read-only")):
            if given is not None:
                raise UsageError(f"{option} goes with --view")
        return None
    from servolab.middleware.view.run_view import ViewRequest

    access = access_options(args)
    return ViewRequest(port=port, speed=speed or 1.0, allow_origins=access["allow_origins"],
                       read_only=access["read_only"])


def _add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("bag", nargs="?", metavar="BAG",
                   help="a recorded run (a run folder's *_bag directory or an .mcap file), "
                   "played to the app as the live run was shown, with its play, pause, seek "
                   "and speed controls; without it, the running graph is served")
    add_view_arguments(p)
    p.add_argument("--rate", type=nonnegative_float, default=1.0, metavar="X",
                   help="with BAG: playback speed (default 1: as recorded; 0: as fast as "
                   "possible)")
    p.add_argument("--loop", action="store_true", help="with BAG: play it again at the end")
    p.add_argument("--max-qos-depth", type=positive_int, default=25, metavar="N",
                   help="the longest history a topic is read with (default 25, as "
                   "foxglove_bridge's max_qos_depth): each topic keeps what its publishers "
                   "keep, up to N; raise it for bursts longer than that")
    p.add_argument("--min-qos-depth", type=positive_int, default=1, metavar="N",
                   help="the shortest (default 1, as foxglove_bridge's min_qos_depth); raise "
                   "it for publishers whose depth the middleware does not tell (DDS)")
    p.add_argument("--layout", metavar="NAME",
                   help="write a robot's Foxglove/Lichtblick layout (a robot's name, as "
                   "servolab robots lists them, or base) and exit; import it in the app's "
                   "Layouts menu")
    p.add_argument("-o", "--output", metavar="FILE",
                   help="with --layout: the file to write (default: standard output)")
    add_transport(p)


def write_layout(name: str, output: str | None) -> int:
    from servolab.robots.registry import layout_named

    text = json.dumps(layout_named(name).to_json(), indent=2) + "\n"
    if output is None:
        sys.stdout.write(text)
    else:
        try:
            Path(output).write_text(text)
        except OSError as exc:
            raise UsageError(f"cannot write the layout to {output}: {exc.strerror}") from None
        print(f"wrote the {name} layout to {output}: in Foxglove or Lichtblick, "
              "Layouts > Import from file")
    return 0


def serve_graph(args: argparse.Namespace) -> int:
    """Serve the running graph (Zenoh by default) until a stop signal."""
    from servolab.middleware.context import Context
    from servolab.middleware.view import ViewConfig, ViewServer

    if args.min_qos_depth > args.max_qos_depth:
        raise UsageError(f"--min-qos-depth {args.min_qos_depth} is more than --max-qos-depth "
                         f"{args.max_qos_depth}")
    with Context.open(transport_options(args)) as ctx, \
            ViewServer(ctx, ViewConfig(host=args.ws_host, port=args.ws_port,
                                       min_qos_depth=args.min_qos_depth,
                                       max_qos_depth=args.max_qos_depth,
                                       **access_options(args))) as view:
        print(f"serving the graph on {view.control_url}: open it in Foxglove or Lichtblick "
              "(Open connection > Foxglove WebSocket); Ctrl-C stops", flush=True)
        for line in view.access:
            print(f"  {line}", flush=True)
        with ctx.stop_on_signals():
            ctx.spin()
    return 0


def _run(args: argparse.Namespace) -> int:
    if args.layout is not None:
        return write_layout(args.layout, args.output)
    if args.output is not None:
        raise UsageError("-o/--output goes with --layout")
    if args.bag is None and (args.rate != 1.0 or args.loop):
        raise UsageError("--rate and --loop go with BAG, a recorded run to play")
    if args.bag is not None:
        if args.listen or args.connect:
            raise UsageError("a bag is played in this process: --listen and --connect go "
                             "without BAG")
        from servolab.middleware.view.player import serve_bag

        serve_bag(args.bag, host=args.ws_host, port=args.ws_port, rate=args.rate,
                  loop=args.loop, keep_serving=True, **access_options(args))
        return 0
    return serve_graph(args)


COMMAND = Command(
    name="view", group="graph", help="watch a running graph or a recorded run in Foxglove",
    description="Serve a running graph (or, given BAG, a recorded run) over the Foxglove "
    "WebSocket protocol, so Foxglove or Lichtblick can show it: every topic with its ROS 2 "
    "message definition, the nodes' parameters and services. Both the app's protocol names "
    "are accepted (foxglove.sdk.v1 and foxglove.websocket.v1). A robot command's --view does "
    "the same for its own run. docs/view.md shows how.",
    examples=("servolab view",
              "servolab view runs/walk/walk_bag",
              "servolab view --layout armstrong -o armstrong.json",
              "servolab walk --view"),
    add_arguments=_add_arguments, run=_run)
