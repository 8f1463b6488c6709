"""A robot run served to Foxglove while it runs (every robot command's ``--view``).

A simulated run waits for the first viewer before it moves, then keeps to the wall clock
(``speed`` times it) while someone watches (:mod:`.pacing`): what a person sees moves at the
robot's speed, from its first step. A run on real motors is served as it goes, without
waiting: the robot does not wait for a laptop.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from .defaults import DEFAULT_HOST, DEFAULT_PORT
from .pacing import PaceConfig, Pacer
from .server import ViewConfig, ViewServer

if TYPE_CHECKING:
    from ..context import Context


@dataclass(frozen=True)
class ViewRequest:
    """What a robot command's ``--view [PORT]`` (and ``--view-speed X``,
    ``--ws-allow-origin ORIGIN``, ``--ws-read-only``) asked for."""

    port: int = DEFAULT_PORT
    host: str = DEFAULT_HOST
    speed: float = 1.0
    wait_for_viewer: bool = True
    allow_origins: tuple[str, ...] = ()
    read_only: bool = False


def serve_run(context: Context, request: ViewRequest, say: Callable[[str], None], *,
              name: str = "servolab run") -> ViewServer:
    """Serve ``context``'s graph on ``ws://host:port``; in a virtual run, wait (until a stop
    signal) for the first viewer unless told not to. The caller closes the server."""
    pacer = Pacer(context.clock, PaceConfig(speed=request.speed))
    server = ViewServer(context, ViewConfig(host=request.host, port=request.port, name=name,
                                            allow_origins=request.allow_origins,
                                            read_only=request.read_only),
                        pacer=pacer)
    say(f"serving the run on {server.control_url}: open it in Foxglove or Lichtblick "
        "(Open connection > Foxglove WebSocket)")
    for line in server.access:  # who may connect, and control
        say(f"  {line}")
    if context.clock.virtual and request.wait_for_viewer:
        say("waiting for a viewer to connect; the simulated run then keeps to real time"
            + (f" x{request.speed:g}" if request.speed != 1.0 else ""))
        try:
            server.wait_for_viewer()
        except BaseException:
            server.close()
            raise
    return server
