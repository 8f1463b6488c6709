"""A controller as ros2_control runs it: ``controller_interface::ControllerInterface``.

Each controller is a node named after it (in the controller manager's namespace), whose
parameters come from the controllers file's ``<name>: ros__parameters:`` section, and which
goes through lifecycle_msgs' states as the controller manager asks:

``load`` (``on_init``: declare parameters) -> unconfigured -> ``configure`` (``on_configure``:
read them, make topics) -> inactive -> ``activate`` (interfaces loaned, ``on_activate``) ->
active -> ``deactivate`` -> inactive -> ``cleanup`` -> unconfigured.

The manager calls :meth:`ControllerInterface.update` of the active ones each update; a
controller reads its loaned state interfaces and sets its loaned command interfaces, nothing
else. Commands from topics reach it through its own subscriptions, which keep only the newest
(ros2_controllers' realtime buffers).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

from ...middleware.errors import ParameterError
from ...middleware.node import Node
from ...middleware.parameters import STRING_ARRAY
from ..errors import RobotValueError
from .resources import ACTIVE, INACTIVE, STATE_LABELS, UNCONFIGURED, Handle

if TYPE_CHECKING:
    from ...middleware.context import Context

#: interface_configuration_type: every interface, those named, or none
ALL, INDIVIDUAL, NONE = "all", "individual", "none"


class ControllerError(RobotValueError):
    """A controller's parameters or request that it refuses (one line, naming it)."""


@dataclass(frozen=True)
class InterfaceConfiguration:
    """Which interfaces a controller needs (``controller_interface::InterfaceConfiguration``)."""

    type: str = NONE
    names: tuple[str, ...] = ()


class ControllerInterface:
    """The base of every controller. Subclasses set :attr:`TYPE` (the plugin name a
    controllers file gives as ``type``), declare their parameters in :meth:`on_init`, and
    implement the configurations, the lifecycle callbacks they need and :meth:`update`."""

    TYPE: ClassVar[str] = ""

    def __init__(self, name: str, context: Context, namespace: str = "/",
                 manager_rate: float = 100.0) -> None:
        self.name = name
        self.node = Node(context, name, namespace)
        self.state = UNCONFIGURED
        self.command_interfaces: list[Handle] = []
        self.state_interfaces: list[Handle] = []
        self.manager_rate = manager_rate
        rate = self.node.declare_parameter("update_rate", 0).value
        #: Hz; 0 runs at the controller manager's rate (ros2_control's default)
        self.update_rate = float(rate or 0) or manager_rate
        self.is_async = bool(self.node.declare_parameter("is_async", False).value)
        self.on_init()

    # -- what a subclass gives --------------------------------------------------------------

    def on_init(self) -> None:
        """Declare the parameters (with their defaults)."""

    def command_interface_configuration(self) -> InterfaceConfiguration:
        return InterfaceConfiguration()

    def state_interface_configuration(self) -> InterfaceConfiguration:
        return InterfaceConfiguration()

    def on_configure(self) -> None:
        """Read the parameters (raise :class:`ControllerError` to refuse) and make topics."""

    def on_activate(self) -> None:
        """The loaned interfaces are set: take the present state as the first command."""

    def on_deactivate(self) -> None:
        """Stop acting; the manager releases the interfaces after."""

    def on_cleanup(self) -> None:
        """Undo :meth:`on_configure`."""

    def update(self, time: float, period: float) -> bool:
        """One control step; False says it failed (logged by the manager)."""
        return True

    # -- helpers ----------------------------------------------------------------------------

    @property
    def label(self) -> str:
        return STATE_LABELS[self.state]

    @property
    def is_active(self) -> bool:
        return self.state == ACTIVE

    def parameter(self, name: str, default: Any, kind: int | None = None) -> Any:
        """A parameter's value, declared with ``default`` (of type ``kind``, a ParameterType,
        where the default cannot say) if it is not yet."""
        node = self.node
        if not node.has_parameter(name):
            try:
                return node.declare_parameter(name, default, kind=kind).value
            except ParameterError as exc:
                raise ControllerError(f"{self.name}: {exc}") from None
        return node.get_parameter(name).value

    def strings(self, name: str, *, required: bool = True) -> tuple[str, ...]:
        value = self.parameter(name, [], STRING_ARRAY)
        if isinstance(value, str):
            value = [value]
        if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
            raise ControllerError(f"{self.name}: parameter '{name}' is a list of names, not "
                                  f"{value!r}")
        if required and not value:
            raise ControllerError(f"{self.name}: parameter '{name}' is empty "
                                  f"(the controllers file gives {self.name}: ros__parameters: "
                                  f"{name}: [...])")
        return tuple(value)

    def interfaces_by_name(self, handles: Sequence[Handle]) -> dict[str, Handle]:
        return {h.name: h for h in handles}

    def destroy(self) -> None:
        self.node.destroy()


def is_configured(controller: ControllerInterface) -> bool:
    return controller.state in (INACTIVE, ACTIVE)
