"""A robot of Dynamixel joints described by its URDF: what ``servolab.robots.load`` gives for a
robot folder (or any plug-in built on :func:`urdf_plugin`).

The URDF's ``<ros2_control>`` block says which Dynamixel drives which joint
(:mod:`.dynamixel_system`); the robot opens that bus — emulated motors by default, a serial port
when named — and moves its joints by name, in radians, within the URDF's limits. A joint's
angle is its horn's, 0 at the model's centre tick, as both ros2_control plugins for Dynamixels
count it (no gear between servo and joint). ``view()`` serves it live: ``/joint_states`` read
from the bus, and a robot_state_publisher's ``/robot_description``, ``/tf`` and ``/tf_static``.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .dynamixel_system import DynamixelSystem, dynamixel_system
from .errors import RobotError, RobotValueError
from .plugin import BusSummary, RobotPlugin, ServedRobot, ShownFile

if TYPE_CHECKING:
    from ..clock import Clock
    from ..dynamixel.bus import Bus
    from ..middleware.context import Context
    from ..middleware.view.server import ViewServer
    from ..sim.simulation import Simulation

#: what stopping a robot folder's robot does, by its ``on_stop`` (robot.yaml)
ON_STOP = {"hold": "the joints hold where they are (torque on, goal = present position)",
           "torque_off": "the motors' torque goes off (the joints go limp)"}
#: how close (rad) a joint must come to its goal for :meth:`UrdfRobot.move_to` to return
TOLERANCE = 0.02
#: how often (s of the robot's clock) :meth:`UrdfRobot.move_to` reads the joints while it waits
POLL_PERIOD = 0.01
#: how often (Hz) the live view's joint states are read from the bus
JOINT_STATE_RATE = 50.0


class UrdfRobot:
    """The joints of a URDF, on their Dynamixel bus.

    Open it with :meth:`open` (or ``servolab.robots.load(NAME)``), move it with
    :meth:`move_to`, read it with :meth:`positions`, watch it with :meth:`view`, and
    :meth:`close` it (also a context manager), which stops its motors as ``on_stop`` says."""

    def __init__(self, name: str, urdf: str, system: DynamixelSystem, bus: Bus, clock: Clock,
                 *, simulation: Simulation | None = None, on_stop: str = "hold") -> None:
        if on_stop not in ON_STOP:
            raise RobotValueError(f"on_stop {on_stop!r}: one of {', '.join(ON_STOP)}")
        self.name = name
        self.urdf = urdf
        self.system = system
        self.bus = bus
        self.clock = clock
        #: the emulated motors' simulation (None on a real bus)
        self.simulation = simulation
        self.on_stop = on_stop
        self._view: _LiveView | None = None
        self._closed = False

    @classmethod
    def open(cls, name: str, urdf: str, port: str | None = None, *, source: str = "<urdf>",
             default_model: str | None = None, on_stop: str = "hold") -> UrdfRobot:
        """The robot of the URDF text ``urdf`` on emulated motors (``port`` None), each at
        its centre, or on the serial port / pyserial URL ``port``, every motor checked."""
        from ..dynamixel.bus import Bus

        system = dynamixel_system(urdf, source, default_model=default_model)
        if port is None:
            from ..dynamixel.errors import ConfigError
            from ..sim.emulated import emulated_port
            from ..sim.simulation import Simulation

            simulation = Simulation()
            try:
                spec = system.bus().motor_spec().at_baudrate(system.baudrate)
            except ConfigError as exc:
                raise RobotValueError(f"{source}: {exc}") from None
            bus = Bus(emulated_port(spec, simulation=simulation), system.protocol)
            robot = cls(name, urdf, system, bus, simulation, simulation=simulation,
                        on_stop=on_stop)
        else:
            from ..clock import WallClock

            bus = Bus.open(port, protocol=system.protocol, baudrate=system.baudrate)
            robot = cls(name, urdf, system, bus, WallClock(), on_stop=on_stop)
        try:
            robot._check_motors()
        except BaseException:
            bus.close()
            raise
        return robot

    def _check_motors(self) -> None:
        """Every joint's motor answers, and is the model the URDF names."""
        for joint in self.system.joints:
            found = self.bus.ping(joint.id)
            if found.model is None or found.model.number != joint.model.number:
                what = found.model.name if found.model else f"model number {found.model_number}"
                raise RobotError(f"{self.name}: joint {joint.name}'s motor (ID {joint.id}) is "
                                 f"a {what}, not the {joint.model.name} the URDF names")

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.system.joints)

    def positions(self) -> dict[str, float]:
        """Every joint's present position (rad), by name."""
        return {j.name: float(self.bus.read(j.id, "present_position"))
                for j in self.system.joints}

    def torque(self, on: bool) -> None:
        """Torque on or off on every joint's motor; every motor is tried before a failure is
        raised, so one that does not answer leaves none of the others as they were."""
        self._each_joint(lambda motor_id: self.bus.write(motor_id, "torque_enable", int(on)))

    def _each_joint(self, act: Callable[[int], object]) -> None:
        """``act`` on every joint's motor ID, all of them tried; then the first failure,
        naming each motor that failed."""
        failed: list[tuple[int, Exception]] = []
        for joint in self.system.joints:
            try:
                act(joint.id)
            except Exception as exc:  # the next motor must still stop
                failed.append((joint.id, exc))
        if failed:
            raise RobotError(f"{self.name}: " + "; ".join(_naming_motor(i, e) for i, e in failed)
                             ) from failed[0][1]

    def _checked(self, goals: Mapping[str, float]) -> dict[int, float]:
        """The goals by motor ID, each refused in one line if it names no joint, is not a
        number or lies outside the joint's URDF limits — before anything moves."""
        from ..dynamixel.errors import ConfigError

        by_id: dict[int, float] = {}
        for name, value in goals.items():
            joint = self.system.joint(name)
            try:
                goal = float(value)
            except (TypeError, ValueError):
                goal = math.nan
            if not math.isfinite(goal) or isinstance(value, bool):
                raise RobotValueError(f"{self.name}: joint {name}: goal {value!r} is not a "
                                      "number (rad)")
            lower = -math.inf if joint.lower is None else joint.lower
            upper = math.inf if joint.upper is None else joint.upper
            if not lower <= goal <= upper:
                raise RobotValueError(f"{self.name}: joint {name}: goal {goal:g} rad is outside "
                                      f"its URDF limits [{lower:g}, {upper:g}]")
            try:  # what the motor itself refuses (its position limits in its mode)
                self.bus.check_write(joint.id, {"goal_position": goal})
            except ConfigError as exc:
                raise RobotValueError(f"{self.name}: joint {name}: {exc}") from None
            by_id[joint.id] = goal
        return by_id

    def move_to(self, goals: Mapping[str, float], *, wait: bool = True,
                tolerance: float = TOLERANCE, timeout: float = 10.0) -> dict[str, float]:
        """Drive the named joints to ``goals`` (rad), torque on; with ``wait``, return once
        every one is within ``tolerance`` of its goal and its motor has stopped moving
        (RobotError after ``timeout`` s of the robot's clock, naming the joints short of it).
        Returns the positions then."""
        by_id = self._checked(goals)
        sent: list[int] = []
        try:
            for motor_id, goal in by_id.items():
                self.bus.write(motor_id, "torque_enable", 1)   # not adjacent on Protocol 2.0
                sent.append(motor_id)
                self.bus.write(motor_id, "goal_position", goal)
        except BaseException:  # a motor that stopped answering, or a Ctrl-C between two
            # writes: the motors already sent hold where they are
            for motor_id in sent:
                with contextlib.suppress(Exception):
                    self.bus.write(motor_id, "goal_position",
                                   float(self.bus.read(motor_id, "present_position")))
            raise
        if not wait:
            return self.positions()
        deadline = self.clock.now() + timeout
        while True:
            now = self.positions()
            short = {n: now[n] for n, g in goals.items() if abs(now[n] - float(g)) > tolerance}
            if not short and not self._moving(by_id):
                return now
            if self.clock.now() > deadline:
                far = ", ".join(f"{n} at {p:.3f} (goal {float(goals[n]):.3f})"
                                for n, p in short.items())
                raise RobotError(f"{self.name}: not at its goal after {timeout:g} s: {far}")
            self.clock.sleep(POLL_PERIOD)

    def _moving(self, ids: Iterable[int]) -> bool:
        """Whether any of the motors ``ids`` still moves (its Moving register, which every
        Dynamixel has: address 46 on Protocol 1.0, 122 on the X-series)."""
        return any(self.bus.read(i, "moving") for i in ids)

    def stop(self) -> None:
        """What stopping does to the motors (``on_stop``): hold where they are, or torque off."""
        if self.on_stop == "torque_off":
            self.torque(False)
            return
        self._each_joint(lambda motor_id: self.bus.write(
            motor_id, "goal_position", float(self.bus.read(motor_id, "present_position"))))

    def view(self, port: int = 0, host: str = "127.0.0.1") -> ViewServer:
        """Serve the robot live to Foxglove or Lichtblick on ``ws://host:port`` (0: a free
        port; the server's ``url`` says which): ``/joint_states`` read from the bus at
        :data:`JOINT_STATE_RATE`, ``/robot_description``, ``/tf`` and ``/tf_static``. Emulated
        motors move in real time from then on, as the viewer expects. Closed with the robot."""
        if self._view is None:
            if self.simulation is not None:
                self.simulation.start_real_time()
            self._view = _LiveView(self, port, host)
        return self._view.server

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            try:
                if self._view is not None:
                    self._view.close()
            finally:
                self.stop()
        finally:
            if self.simulation is not None:
                self.simulation.stop_real_time()
            self.bus.close()

    def __enter__(self) -> UrdfRobot:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class _LiveView:
    """The graph :meth:`UrdfRobot.view` serves: a context spun on its own thread, the joint
    states node, a robot_state_publisher and the Foxglove server over them."""

    def __init__(self, robot: UrdfRobot, port: int, host: str) -> None:
        from ..middleware.context import Context
        from ..middleware.view import ViewConfig, ViewServer
        from .joint_state_node import JointStateNode
        from .state_publisher import RobotStatePublisher

        self.context: Context = Context.open()
        try:
            JointStateNode(self.context, robot.joint_names, robot.positions,
                           rate=JOINT_STATE_RATE)
            RobotStatePublisher(self.context, robot.urdf)
            self.thread = self.context.executor.spin_in_thread()
            self.server = ViewServer(self.context, ViewConfig(host=host, port=port,
                                                              name=f"servolab {robot.name}"))
        except BaseException:
            self.context.shutdown()
            raise

    def close(self) -> None:
        try:
            self.server.close()
        finally:
            self.context.shutdown()
            self.thread.join()


def urdf_plugin(name: str, summary: str, urdf: Callable[[], str], *, source: str = "<urdf>",
                config: Callable[[], Path | None] | None = None,
                files: Callable[[], Mapping[str, ShownFile]] | None = None,
                default_model: str | None = None, on_stop: str = "hold",
                aliases: tuple[str, ...] = ()) -> RobotPlugin:
    """A robot plug-in for the URDF ``urdf()`` returns (the text, read when needed): what a
    robot folder becomes, and what a Python plug-in can return from its entry point."""
    if on_stop not in ON_STOP:
        raise RobotValueError(f"{source}: on_stop {on_stop!r}: one of {', '.join(ON_STOP)}")

    def system() -> DynamixelSystem:
        return dynamixel_system(urdf(), source, default_model=default_model)

    def bus() -> BusSummary:
        return system().bus()

    def open_robot(port: str | None) -> Any:
        return UrdfRobot.open(name, urdf(), port, source=source, default_model=default_model,
                              on_stop=on_stop)

    def served(baudrate: int | None) -> ServedRobot:
        from ..dynamixel.errors import ConfigError
        from .urdf_world import mujoco_placement

        text, found = urdf(), system()
        try:
            spec = found.bus().motor_spec().at_baudrate(baudrate or found.baudrate)
        except ConfigError as exc:
            raise RobotValueError(f"{source}: {exc}") from None
        place = mujoco_placement(text, found, source)
        return ServedRobot(spec, place=place,
                           what="moving its URDF in MuJoCo" if place is not None else "")

    def layout() -> Any:
        from .urdf_layout import urdf_layout

        return urdf_layout(name, urdf(), system())

    kwargs: dict[str, Any] = {}
    if config is not None:
        kwargs["config"] = config
    if files is not None:
        kwargs["files"] = files
    return RobotPlugin(name, summary, bus=bus, open=open_robot, on_stop=ON_STOP[on_stop],
                       description=urdf, served=served, layout=layout, aliases=aliases,
                       default_model=default_model, **kwargs)


def _naming_motor(motor_id: int, error: Exception) -> str:
    """``error`` on one line, starting with its motor (the bus's own errors already do)."""
    text = " ".join(str(error).split())
    return text if text.startswith(f"motor {motor_id}") else f"motor {motor_id}: {text}"
