"""servolab view: a running graph seen from Foxglove or Lichtblick.

:class:`ViewServer` speaks the Foxglove WebSocket protocol v1 (:mod:`.protocol`) over a
:class:`~servolab.middleware.context.Context`, as foxglove_bridge does over a ROS 2 graph::

    with Context.open() as ctx, ViewServer(ctx, ViewConfig(port=8765)) as view:
        ...                     # open ws://127.0.0.1:8765 in Foxglove or Lichtblick
        ctx.spin()
"""

from .protocol import SUBPROTOCOLS, ClientMessageError
from .server import ViewConfig, ViewServer

__all__ = ["SUBPROTOCOLS", "ClientMessageError", "ViewConfig", "ViewServer"]
