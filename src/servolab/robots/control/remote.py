"""A controller manager reached through its services, from any process: what ``ros2 control``
and the spawner do (``controller_manager/controller_manager_services.py``), on servolab's
middleware. :mod:`servolab.apps.control` prints what these return.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from ...middleware.errors import MiddlewareError
from ..errors import RobotError
from .defaults import CALL_TIMEOUT, DEFAULT_MANAGER
from .manager import SRV, STRICT

if TYPE_CHECKING:
    from ...middleware.context import Context
    from ...middleware.node import Node



class RemoteManager:
    """The services of the controller manager ``name`` (``/controller_manager``), called
    from ``node``'s context; each method returns the response."""

    def __init__(self, context: Context, name: str = DEFAULT_MANAGER, *,
                 timeout: float = CALL_TIMEOUT, node: Node | None = None) -> None:
        import os

        from ...middleware.node import Node

        self.name = name if name.startswith("/") else f"/{name}"
        # hidden (a leading _), as ros2cli's own nodes are
        self.node = node or Node(context, f"_servolab_control_{os.getpid()}")
        self.timeout = timeout
        self._clients: dict[str, Any] = {}

    def call(self, service: str, **fields: Any) -> Any:
        kind = "".join(p.capitalize() for p in service.split("_"))
        client = self._clients.get(service)
        if client is None:
            client = self._clients[service] = self.node.create_client(
                SRV + kind, f"{self.name}/{service}")
        request = self.node.message(f"{SRV}{kind}_Request", **fields)
        try:
            return client.call(request, timeout=self.timeout)
        except MiddlewareError as exc:
            raise RobotError(f"{self.name}/{service}: {exc} (is a controller manager running? "
                             "start one with: servolab control run ROBOT --params FILE)"
                             ) from None

    def wait(self, timeout: float) -> bool:
        """Whether the manager's services answer within ``timeout`` s."""
        client = self.node.create_client(SRV + "ListControllers",
                                         f"{self.name}/list_controllers")
        try:
            return bool(client.wait_for_service(timeout_sec=timeout))
        finally:
            self.node.destroy_entity(client)

    def list_controllers(self) -> list[Any]:
        return list(self.call("list_controllers").controller)

    def switch(self, activate: Sequence[str], deactivate: Sequence[str],
               strictness: int = STRICT, *, asap: bool = True,
               timeout: float = 5.0) -> Any:
        seconds = int(timeout)
        return self.call("switch_controller", activate_controllers=list(activate),
                         deactivate_controllers=list(deactivate), strictness=strictness,
                         activate_asap=asap,
                         timeout={"sec": seconds, "nanosec": int((timeout - seconds) * 1e9)})
