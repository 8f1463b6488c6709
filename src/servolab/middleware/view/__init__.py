"""servolab view: a running graph seen from Foxglove or Lichtblick.

:class:`ViewServer` speaks the Foxglove WebSocket protocol v1 (:mod:`.protocol`) over a
:class:`~servolab.middleware.context.Context`, as foxglove_bridge does over a ROS 2 graph::

    with Context.open() as ctx, ViewServer(ctx, ViewConfig(port=8765)) as view:
        ...                     # open ws://127.0.0.1:8765 in Foxglove or Lichtblick
        ctx.spin()
"""

from typing import TYPE_CHECKING

from ..._lazy import lazy_exports

#: Each public name and its module, imported on first use (PEP 562): the command line reads
#: :mod:`.defaults` without loading the server and its WebSocket library.
_EXPORTS = {"SUBPROTOCOLS": "protocol", "ClientMessageError": "protocol",
            "ViewConfig": "server", "ViewServer": "server"}
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
__all__ = ["SUBPROTOCOLS", "ClientMessageError", "ViewConfig", "ViewServer"]

if TYPE_CHECKING:
    from .protocol import SUBPROTOCOLS, ClientMessageError
    from .server import ViewConfig, ViewServer
