"""A robot brought up under ros2_control from its URDF and controllers file, as a launch file
with ``ros2_control_node``, ``robot_state_publisher`` and spawners brings it up.

The URDF's ``<ros2_control>`` blocks become hardware components:

- a Dynamixel block (``dynamixel_hardware/DynamixelHardware``,
  ``dynamixel_hardware_interface/DynamixelHardware``) becomes :class:`.DynamixelHardware` on
  a servolab bus: emulated motors by default (each at its centre), the URDF moved in MuJoCo
  under its servos' firmware with ``world="mujoco"``, or the serial port / pyserial URL
  ``port`` (the block's own ``port_name`` / ``usb_port`` is a ROS machine's device path and
  is used only when asked: ``port="urdf"``);
- ``mock_components/GenericSystem`` becomes :class:`.GenericSystem`.

The controllers file is read as the ROS 2 parameter file it is: ``controller_manager``'s
section gives ``update_rate`` and each controller's ``type``, each controller's own section
its parameters. ``spawn`` controllers are loaded, configured and activated in order (as the
spawner does), ``inactive`` ones loaded and configured only.

In a ``namespace`` (``/robot1``) every node is there: the controller manager
(``/robot1/controller_manager``), the controllers (``/robot1/diff_drive_controller/cmd_vel``,
``/robot1/joint_states``) and robot_state_publisher (``/robot1/robot_description``); the
controllers file applies to them there, as nav2's ``RewrittenYaml(root_key=namespace)``
rewrites one robot's file for each robot; and the robot's tf frames take the namespace as
their prefix on the shared ``/tf`` and ``/tf_static`` (``robot1/base_link``:
robot_state_publisher's ``frame_prefix`` and diff_drive_controller's default
``tf_frame_prefix``, both :func:`~servolab.middleware.names.frame_prefix`), as TurtleBot3's
multi-robot launch runs its robots. Two robots so brought up share a graph and never see each
other's topics.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import RobotError, RobotValueError
from ..hardware_info import HardwareInfo, parse_control_resources
from .hardware import SystemInterface
from .manager import STRICT, ControllerManager
from .mock_system import PLUGIN as MOCK_PLUGIN
from .mock_system import GenericSystem

if TYPE_CHECKING:
    from ...dynamixel.bus import Bus
    from ...dynamixel.emulator import Emulator
    from ...middleware.context import Context
    from ...middleware.parameters import ParameterOverrides
    from ...middleware.transport import TransportOptions
    from ...sim.simulation import Simulation

#: the worlds an emulated Dynamixel robot runs in: its motors alone, its URDF in MuJoCo under
#: them, or the world its plug-in puts it in (``place``: the floor for a base, as ``servolab sim
#: --robot NAME`` serves it)
WORLDS = ("emulated", "mujoco", "robot")
#: what ``port`` says to use the port the URDF's block names
PORT_FROM_URDF = "urdf"


@dataclass
class BringUpOptions:
    """How to bring a robot up; the defaults are a student's first run."""

    port: str | None = None
    world: str = "emulated"
    spawn: Sequence[str] = ()
    inactive: Sequence[str] = ()
    namespace: str = "/"
    #: run the emulated motors in real time (False: the context's clock is the simulation's,
    #: for tests that step it)
    real_time: bool = True
    transport: TransportOptions | None = None
    state_publisher: bool = True
    #: the model of the motors whose block names none (ROBOTIS's dialect names none)
    default_model: str | None = None
    #: with ``world="robot"``: how the robot's plug-in puts its emulated motors in its world
    #: (:attr:`servolab.robots.plugin.ServedRobot.place`)
    place: Callable[[Emulator], tuple[Simulation, Emulator, Any]] | None = None


class ControlSystem:
    """The controller manager, its hardware and what they run on; :meth:`close` stops it
    all (controllers deactivated, the joints holding, the bus closed)."""

    def __init__(self, urdf: str, source: str, parameters: ParameterOverrides,
                 options: BringUpOptions | None = None) -> None:
        from ...clock import WallClock
        from ...middleware.context import Context
        from ...middleware.names import node_namespace

        self.options = options = options or BringUpOptions()
        if options.world not in WORLDS:
            raise RobotValueError(f"world {options.world!r}: one of {', '.join(WORLDS)}")
        #: where every node of the robot is (module docstring)
        self.namespace = node_namespace(options.namespace)
        parameters = parameters.in_namespace(self.namespace)
        self.urdf = urdf
        self.buses: list[Bus] = []
        self.simulation: Simulation | None = None
        self.world: Any = None
        #: the emulated motors (None on a port)
        self.emulator: Emulator | None = None
        blocks = parse_control_resources(urdf, source)
        if not blocks:
            raise RobotValueError(f"{source}: no <ros2_control> block: ros2_control needs one "
                                  "naming the hardware plugin and the joints")
        try:
            hardware = [self._component(b, source) for b in blocks]
            clock = self.simulation if (self.simulation is not None and
                                        not options.real_time) else WallClock()
            self.context: Context = Context.open(options.transport, clock=clock,
                                                 parameter_overrides=parameters)
        except BaseException:
            self._close_buses()
            raise
        try:
            if self.simulation is not None and options.real_time:
                self.simulation.start_real_time()
            self.manager = ControllerManager(self.context, hardware, namespace=self.namespace)
            if options.state_publisher:
                from ...middleware.names import frame_prefix
                from ..state_publisher import RobotStatePublisher

                RobotStatePublisher(self.context, urdf, namespace=self.namespace,
                                    frame_prefix=frame_prefix(self.namespace))
            for name in options.spawn:
                self.spawn(name, activate=True)
            for name in options.inactive:
                self.spawn(name, activate=False)
        except BaseException:
            self.close()
            raise

    def _component(self, block: HardwareInfo, source: str) -> SystemInterface:
        if block.plugin == MOCK_PLUGIN:
            return GenericSystem(block)
        if "dynamixel" in block.plugin.lower():
            return self._dynamixel(block, source)
        raise RobotValueError(
            f"{block.where(source)}: hardware plugin {block.plugin!r} is not one servolab "
            f"has; it runs {MOCK_PLUGIN}, dynamixel_hardware/DynamixelHardware and "
            "dynamixel_hardware_interface/DynamixelHardware")

    def _dynamixel(self, block: HardwareInfo, source: str) -> SystemInterface:
        from ...dynamixel.bus import Bus
        from ..dynamixel_system import block_system
        from .dynamixel_hardware import DynamixelHardware

        system = block_system(self.urdf, block, source,
                              default_model=self.options.default_model)
        port = self.options.port
        if port == PORT_FROM_URDF:
            if system.port_name is None:
                raise RobotValueError(f"{block.where(source)}: the block names no port "
                                      "(port_name or usb_port)")
            port = system.port_name
        if port is not None:
            bus = Bus.open(port, protocol=system.protocol, baudrate=system.baudrate)
        else:
            bus = self._emulated_bus(system, source)
        self.buses.append(bus)
        for joint in system.joints:  # every motor answers and is the model the URDF names
            found = bus.ping(joint.id)
            if found.model is None or found.model.number != joint.model.number:
                what = found.model.name if found.model else f"model {found.model_number}"
                raise RobotError(f"{block.where(source)}: joint {joint.name}'s motor (ID "
                                 f"{joint.id}) is a {what}, not the {joint.model.name} the "
                                 "URDF names")
        return DynamixelHardware(block, system, bus)

    def _emulated_bus(self, system: Any, source: str) -> Bus:
        from ...dynamixel.bus import Bus
        from ...dynamixel.emulator import build_emulator
        from ...dynamixel.errors import ConfigError
        from ...sim.emulated import port_to
        from ...sim.simulation import Simulation

        if self.simulation is not None:
            raise RobotValueError(f"{source}: two emulated Dynamixel blocks; servolab emulates "
                                  "one bus a robot")
        try:
            spec = system.bus().motor_spec().at_baudrate(system.baudrate)
        except ConfigError as exc:
            raise RobotValueError(f"{source}: {exc}") from None
        emulator = build_emulator(spec)
        if self.options.world == "robot":
            if self.options.place is None:
                raise RobotValueError(f"{source}: --world robot needs a robot whose plug-in "
                                      "has a world of its own (servolab robots show NAME)")
            simulation, emulator, self.world = self.options.place(emulator)
        elif self.options.world == "mujoco":
            from ..urdf_world import mujoco_placement

            place = mujoco_placement(self.urdf, system, source)
            if place is None:
                raise RobotValueError(f"{source}: --world mujoco needs the links' masses (each "
                                      "moved link's <inertial>); this URDF has none")
            simulation, emulator, self.world = place(emulator)
        else:
            simulation = Simulation()
            simulation.add_emulator(emulator)
        self.simulation = simulation
        self.emulator = emulator
        return Bus(port_to(emulator, simulation, system.baudrate), system.protocol)

    def spawn(self, name: str, *, activate: bool = True) -> None:
        """Load, configure and (``activate``) activate ``name``, as the spawner does; a step
        that fails raises :class:`RobotValueError` with the manager's message."""
        for ok, message in self._spawn_steps(name, activate):
            if not ok:
                raise RobotValueError(f"spawner {name}: {message}")

    def _spawn_steps(self, name: str, activate: bool) -> Any:
        manager = self.manager
        if name not in manager.controllers:
            yield manager.load_controller(name)
        yield manager.configure_controller(name)
        if activate:
            yield manager.switch_controller([name], [], STRICT)

    def spin(self) -> None:
        self.context.spin()

    def close(self) -> None:
        try:
            manager = getattr(self, "manager", None)
            if manager is not None:
                manager.close()
        finally:
            try:
                if hasattr(self, "context"):
                    self.context.close()
            finally:
                if self.simulation is not None:
                    self.simulation.stop_real_time()
                self._close_buses()

    def _close_buses(self) -> None:
        for bus in self.buses:
            bus.close()
        self.buses.clear()

    def __enter__(self) -> ControlSystem:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def load_urdf(path: Path, xacro_args: dict[str, str] | None = None) -> str:
    """A URDF file's text (``.xacro`` expanded by ROS's own xacro)."""
    from ..robot_folder import urdf_text

    return urdf_text(path, xacro_args)
