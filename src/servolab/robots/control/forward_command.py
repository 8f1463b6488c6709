"""``forward_command_controller`` and its group controllers, as ros2_controllers' (Jazzy).

- ``forward_command_controller/ForwardCommandController``: ``joints`` and ``interface_name``;
- ``position_controllers/JointGroupPositionController`` (and ``velocity_controllers/``,
  ``effort_controllers/JointGroupVelocityController`` / ``JointGroupEffortController``): the
  same with the interface fixed;
- ``forward_command_controller/MultiInterfaceForwardCommandController``: one ``joint``, many
  ``interface_names``.

Each claims its command interfaces and subscribes ``~/commands``
(std_msgs/Float64MultiArray), keeping the newest message; each update writes it to the
interfaces in order. Nothing is written before the first message (activation resets it), and
a message of the wrong length is refused with the original's words and written nowhere.
"""

from __future__ import annotations

from typing import Any, ClassVar

from .controller import INDIVIDUAL, ControllerInterface, InterfaceConfiguration
from .hardware import EFFORT, POSITION, VELOCITY


class ForwardCommandController(ControllerInterface):
    TYPE = "forward_command_controller/ForwardCommandController"
    #: the interface the group controllers fix (None: the ``interface_name`` parameter)
    INTERFACE: ClassVar[str | None] = None

    def on_init(self) -> None:
        self.strings("joints", required=False)
        if self.INTERFACE is None:
            self.parameter("interface_name", "")

    def _names(self) -> tuple[str, ...]:
        joints = self.strings("joints")
        interface = self.INTERFACE or str(self.parameter("interface_name", ""))
        if not interface:
            from .controller import ControllerError

            raise ControllerError(f"{self.name}: parameter 'interface_name' is empty")
        return tuple(f"{j}/{interface}" for j in joints)

    def command_interface_configuration(self) -> InterfaceConfiguration:
        return InterfaceConfiguration(INDIVIDUAL, self._names())

    def on_configure(self) -> None:
        self._names()
        self._command: Any = None
        self.node.create_subscription("std_msgs/msg/Float64MultiArray", "~/commands",
                                      self._on_command, 10)

    def _on_command(self, msg: Any) -> None:
        self._command = msg

    def on_activate(self) -> None:
        self._command = None

    def on_deactivate(self) -> None:
        self._command = None

    def update(self, time: float, period: float) -> bool:
        command = self._command
        if command is None:
            return True
        data = command.data
        if len(data) != len(self.command_interfaces):
            self.node.get_logger().error(
                f"command size ({len(data)}) does not match number of interfaces "
                f"({len(self.command_interfaces)})", throttle_duration_sec=1.0)
            return False
        for handle, value in zip(self.command_interfaces, data, strict=True):
            handle.set_value(float(value))
        return True


class JointGroupPositionController(ForwardCommandController):
    TYPE = "position_controllers/JointGroupPositionController"
    INTERFACE = POSITION


class JointGroupVelocityController(ForwardCommandController):
    TYPE = "velocity_controllers/JointGroupVelocityController"
    INTERFACE = VELOCITY


class JointGroupEffortController(ForwardCommandController):
    TYPE = "effort_controllers/JointGroupEffortController"
    INTERFACE = EFFORT


class MultiInterfaceForwardCommandController(ForwardCommandController):
    TYPE = "forward_command_controller/MultiInterfaceForwardCommandController"

    def on_init(self) -> None:
        self.parameter("joint", "")
        self.strings("interface_names", required=False)

    def _names(self) -> tuple[str, ...]:
        from .controller import ControllerError

        joint = str(self.parameter("joint", ""))
        if not joint:
            raise ControllerError(f"{self.name}: parameter 'joint' is empty")
        return tuple(f"{joint}/{i}" for i in self.strings("interface_names"))
