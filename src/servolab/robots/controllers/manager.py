"""The controller manager of ROS ``dynamixel_motor`` (``controller_manager.py``), as a node.

What it does, as seed 001 shows it (section 3.2.2, Figures 3.1 to 3.4):

- pings the configured ID range, each ID up to ``ping_retries`` times (5, as
  ``dynamixel_serial_proxy``), and says what it found: ``pan_tilt_port: Found 20 motors -
  20 RX-28 [11, 12, ...], initialization complete.``;
- starts a :class:`~.joint_position_controller.JointPositionController` per configured controller
  whose motor answered, and says which could not start (``controller_m62``, whose motor is not
  on Armstrong's bus) while the others run;
- publishes every motor's state on ``/motor_states/<port>`` (``dynamixel_msgs/MotorStateList``)
  at the update rate, and each controller's joint state;
- publishes ``/diagnostics`` at ``diagnostics_rate`` (:mod:`.diagnostics`);
- offers ``start_controller``, ``stop_controller`` and ``restart_controller`` under
  ``/<namespace>/<port>/`` (``/dxl_manager/pan_tilt_port/start_controller``), as
  ``controller_manager.py`` does.

Its bus time belongs to a :class:`~servolab.robots.bus_owner.BusOwner`: the controllers'
goals go out between single READs of the state sweep, the newest goal per motor. A READ
that fails after ``read_retries`` retries is counted against its motor
(:mod:`.motor_health`) and the motor skipped for that sweep, as ROS counts such errors and
goes on; whoever supervises the robot reads :attr:`DynamixelManager.health` after each
sweep (:attr:`DynamixelManager.sweep_listeners`).

It works on any model servolab knows: each motor's state is read by role
(:mod:`.motor_state`), one READ of its contiguous state registers where its table allows (on
an RX-28 the 17 bytes from the goal position that the original's driver reads, the goal read
back, so a goal lost on the way shows; on an XM430 the 47 bytes from Goal PWM(100) to Present
Temperature(146)), and the goals the controllers were given leave in one SYNC_WRITE rather
than one WRITE each. A motor whose model lacks a state role is left out, with one line
naming the register it lacks.

The wire decides the rate. At 57142 bps one READ of an RX-28's 17 state bytes is 8 + 23
bytes, 5.4 ms, plus the return delay (0.5 ms at the factory setting): 20 motors take about
120 ms, so
the seed's ``update_rate: 20`` cannot be met whatever the driver (its ROS driver managed 3 to
4 Hz). The manager computes that time at start, says so, and updates as fast as the wire
allows instead; at 1 Mbps with return delay 0 the same reads take about 7 ms.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import partial
from typing import TYPE_CHECKING, Any

from ...dynamixel.errors import CommError, ConfigError, MotorError
from ...dynamixel.wire import byte_time
from ...middleware.node import Node
from ..bus_owner import BusOwner
from ..errors import RobotValueError
from .config import JOINT_POSITION_CONTROLLER, ControllerConfig, SerialPortConfig
from .diagnostics import DIAGNOSTIC_ARRAY, diagnostics
from .joint_position_controller import JointPositionController
from .motor_health import MotorHealth
from .motor_state import MotorReading, StatePlan

if TYPE_CHECKING:
    from ...dynamixel.bus import Bus
    from ...middleware.context import Context

MOTOR_STATE_LIST = "dynamixel_msgs/msg/MotorStateList"
START_CONTROLLER = "dynamixel_controllers/srv/StartController"
STOP_CONTROLLER = "dynamixel_controllers/srv/StopController"
RESTART_CONTROLLER = "dynamixel_controllers/srv/RestartController"


class DynamixelManager(Node):
    """One bus (``serial_ports: <port>:``), its motors and the controllers started on it."""

    def __init__(self, context: Context, bus: Bus, port: SerialPortConfig,
                 controllers: Sequence[ControllerConfig] = (), *,
                 name: str = "dynamixel_manager", namespace: str = "dxl_manager") -> None:
        super().__init__(context, name)
        self.bus = bus
        self.port = port
        self.configured = {c.name: c for c in controllers}
        # Start-up is retried as pinging is: a transaction lost now (a busy machine, a pty
        # server that answered late) must not keep a motor out of the walk.
        retries, bus.retries = bus.retries, max(bus.retries, port.ping_retries - 1)
        try:
            self._start(controllers, namespace)
        finally:
            bus.retries = retries

    def _start(self, controllers: Sequence[ControllerConfig], namespace: str) -> None:
        bus, port, context = self.bus, self.port, self.context
        #: motor ID -> model name, of every motor that answered and can be read
        self.motors = self._find_motors()
        #: motor ID -> how its state is read (the registers of its model's roles)
        self.plans = self._plan_reads()
        self.started = self.context.clock.now()
        self.health = {i: MotorHealth(i) for i in self.motors}
        #: the last reading of each motor
        self.latest: dict[int, MotorReading] = {}
        self.update_time = self.wire_time()
        self.rate = min(port.update_rate, 1.0 / self.update_time) if self.motors else \
            port.update_rate
        log = self.get_logger()
        if self.rate < port.update_rate:
            log.warning(
                f"{port.name}: update_rate {port.update_rate:g} Hz cannot be met: reading "
                f"{len(self.motors)} motors takes {self.update_time * 1e3:.0f} ms at "
                f"{bus.baudrate} bps; updating at {self.rate:.1f} Hz (a faster bus and "
                "return delay 0 raise it: see docs/biped.md)")
        self.controllers: dict[str, JointPositionController] = {}
        self.failed: list[str] = []
        self._torque_on: set[int] = set()
        self.motor_states = self.create_publisher(MOTOR_STATE_LIST,
                                                  f"/motor_states/{port.name}", 10)
        self.diagnostics = self.create_publisher(DIAGNOSTIC_ARRAY, "/diagnostics", 10)
        for config in controllers:
            self.start_controller(config)
        self.updates = 0
        #: called with the clock's time after every sweep, once the states are published
        self.sweep_listeners: list[Callable[[float], object]] = []
        self._sweep: list[MotorReading] = []
        self.owner = BusOwner(context, bus, rate=self.rate,
                              steps=[partial(self._read, i) for i in self.motors],
                              on_sweep=self._end_sweep)
        self.create_timer(1.0 / port.diagnostics_rate, self.publish_diagnostics)
        base = f"/{namespace.strip('/')}/{port.name}"
        self.create_service(START_CONTROLLER, f"{base}/start_controller", self._on_start)
        self.create_service(STOP_CONTROLLER, f"{base}/stop_controller", self._on_stop)
        self.create_service(RESTART_CONTROLLER, f"{base}/restart_controller",
                            self._on_restart)

    def _find_motors(self) -> dict[int, str]:
        """Ping every ID of the range, each up to ``ping_retries`` times, and say what was
        found as seed 001 Figure 3.1 shows it."""
        port, log = self.port, self.get_logger()
        log.info(f"{port.name}: Pinging motor IDs {port.min_motor_id} through "
                 f"{port.max_motor_id}...")
        found = {}
        for motor_id in range(port.min_motor_id, port.max_motor_id + 1):
            try:
                result = self.bus.ping(motor_id, retries=port.ping_retries - 1)
            except CommError:  # no answer (or a garbled one) every time: not there
                continue
            found[result.id] = result.model_name
        by_model: dict[str, list[int]] = {}
        for motor_id, model in found.items():
            by_model.setdefault(model, []).append(motor_id)
        counts = ", ".join(f"{len(ids)} {model} [{', '.join(map(str, ids))}]"
                           for model, ids in by_model.items())
        if found:
            log.info(f"{port.name}: Found {len(found)} motors - {counts}, "
                     "initialization complete.")
        else:
            log.error(f"{port.name}: no motor answered between IDs {port.min_motor_id} and "
                      f"{port.max_motor_id} ({port.ping_retries} pings each): check the "
                      "port, the baud rate and the power")
        return found

    def _plan_reads(self) -> dict[int, StatePlan]:
        """Each motor's state plan; a motor whose model lacks a state role is left out, with
        one line saying which register it lacks (its controller then cannot start)."""
        plans = {}
        #: motor ID -> why a motor that answered cannot be driven
        self.unreadable: dict[int, str] = {}
        for motor_id in list(self.motors):
            try:
                plans[motor_id] = StatePlan.for_motor(self.bus, motor_id)
            except ConfigError as error:
                self.unreadable[motor_id] = str(error)
                self.get_logger().error(f"{self.port.name}: motor {motor_id} cannot be read "
                                        f"as dynamixel_motor does: {error}")
                del self.motors[motor_id]
        return plans

    def wire_time(self) -> float:
        """Seconds one update takes on the wire: the READs of each motor's state registers
        (instruction, status, return delay) and one SYNC_WRITE of every motor's goal."""
        bus, proto = self.bus, self.bus.proto
        seconds_per_byte = byte_time(bus.baudrate)
        total = 0.0
        for motor_id in self.motors:
            delay = float(bus.read(motor_id, "return_delay_time"))
            for start, length in self.plans[motor_id].spans():
                packet = proto.encode_instruction(proto.read(motor_id, start, length))
                total += (len(packet) + proto.status_size(length)) * seconds_per_byte + delay
        if self.motors:
            goal = bus.model_of(next(iter(self.motors))).register("goal_position")
            sync = proto.sync_write(goal.address, goal.size,
                                    [(i, bytes(goal.size)) for i in self.motors])
            total += len(proto.encode_instruction(sync)) * seconds_per_byte
        return total

    # -- controllers -----------------------------------------------------------------------

    def start_controller(self, config: ControllerConfig) -> JointPositionController | None:
        """Start a joint controller, or say why it cannot start (its motor did not answer)."""
        log = self.get_logger()
        if config.name in self.controllers:
            log.error(f"Controller {config.name} already started. If you want to restart "
                      "it, call restart.")
            return None
        if config.motor.id not in self.motors:
            why = self.unreadable.get(config.motor.id,
                                      f"motor {config.motor.id} did not answer on "
                                      f"{self.port.name}")
            log.error(f"Initialization failed. Unable to start controller {config.name}: "
                      f"{why}")
            self._note_failed(config.name)
            return None
        position = self.bus.model_of(config.motor.id).register("goal_position")
        top = position.maximum if position.maximum is not None else position.minimum
        outside = [f"{k} {getattr(config.motor, k)}" for k in ("init", "min", "max")
                   if not position.minimum <= getattr(config.motor, k) <= top]
        if outside:
            log.error(f"Initialization failed. Unable to start controller {config.name}: "
                      f"motor {', '.join(outside)} outside the "
                      f"{self.motors[config.motor.id]}'s positions {position.minimum}..{top}")
            self._note_failed(config.name)
            return None
        try:
            controller = JointPositionController(self, config, self.bus, self._set_goal)
        except RobotValueError as error:  # its configuration asks what the model lacks
            log.error(f"Initialization failed. Unable to start controller {config.name}: "
                      f"{error}")
            self._note_failed(config.name)
            return None
        self.controllers[config.name] = controller
        if config.name in self.failed:
            self.failed.remove(config.name)
        log.info(f"Controller {config.name} successfully started.")
        return controller

    def _note_failed(self, name: str) -> None:
        if name not in self.failed:
            self.failed.append(name)

    def stop_controller(self, name: str) -> bool:
        """Stop a running controller: its topics and services go; its motor keeps its last
        goal. False if no controller of that name runs."""
        controller = self.controllers.pop(name, None)
        if controller is None:
            return False
        controller.destroy()
        self.get_logger().info(f"Controller {name} successfully stopped.")
        return True

    def _set_goal(self, motor_id: int, angle: float) -> None:
        """A controller's goal: written at the bus owner's next transaction, the newest per
        motor (a motor's torque is switched on before its first goal, so that it holds the
        pose it is sent to)."""
        if motor_id not in self._torque_on:
            self._torque_on.add(motor_id)
            self.owner.set_goals("torque_enable", {motor_id: 1})
        self.owner.set_goals("goal_position", {motor_id: angle})

    def flush_goals(self) -> None:
        """Write the goals given and not yet written, now."""
        self.owner.flush()

    # -- services (controller_manager.py) ------------------------------------------------

    def _controller_request(self, request: Any, response: Any, *, typed: bool
                            ) -> ControllerConfig | None:
        """The configured controller a start/restart request names, or None with the
        response's reason set."""
        name = str(request.controller_name)
        config = self.configured.get(name)
        if config is None:
            response.success, response.reason = False, (
                f"no controller {name!r} in the configuration (there are "
                f"{', '.join(self.configured) or 'none'})")
            return None
        if typed:
            asked = (str(request.package_path), str(request.module_name),
                     str(request.class_name))
            if any(asked) and asked != JOINT_POSITION_CONTROLLER:
                response.success, response.reason = False, (
                    f"{'/'.join(asked)} is not supported; servolab runs "
                    f"{'/'.join(JOINT_POSITION_CONTROLLER)}")
                return None
            if request.port_name and str(request.port_name) != self.port.name:
                response.success, response.reason = False, (
                    f"port {request.port_name!r} is not this manager's ({self.port.name})")
                return None
        return config

    def _on_start(self, request: Any, response: Any) -> Any:
        config = self._controller_request(request, response, typed=True)
        if config is None:
            return response
        if config.name in self.controllers:
            response.success, response.reason = False, (
                f"Controller {config.name} already started. If you want to restart it, "
                "call restart.")
            return response
        started = self.start_controller(config) is not None
        response.success = started
        response.reason = "" if started else \
            f"controller {config.name} could not start: its motor did not answer"
        return response

    def _on_stop(self, request: Any, response: Any) -> Any:
        name = str(request.controller_name)
        response.success = self.stop_controller(name)
        response.reason = "" if response.success else f"controller {name} is not running"
        return response

    def _on_restart(self, request: Any, response: Any) -> Any:
        config = self._controller_request(request, response, typed=True)
        if config is None:
            return response
        self.stop_controller(config.name)
        response.success = self.start_controller(config) is not None
        response.reason = "" if response.success else \
            f"controller {config.name} could not start: its motor did not answer"
        return response

    # -- the update ------------------------------------------------------------------------

    def _now(self) -> float:
        """Stamps as ROS has them (:meth:`Context.ros_time`): the simulation's time on a
        simulated robot, else the epoch's, from the one source every node of the context
        stamps with."""
        return self.context.ros_time()

    def _read(self, motor_id: int) -> None:
        """One step of the sweep: one READ of ``motor_id``'s state, retried up to
        ``read_retries`` times; failing that, counted and skipped for this sweep."""
        record = self.health[motor_id]
        stats = self.bus.stats
        retried = stats.retries
        try:
            reading = MotorReading.read(self.bus, motor_id, self._now(),
                                        retries=self.port.read_retries,
                                        plan=self.plans[motor_id])
        except (CommError, MotorError) as error:
            record.retried += stats.retries - retried
            record.failed(error)
            self.get_logger().debug(f"motor {motor_id}: {error}")
            return
        record.retried += stats.retries - retried
        alert = self.bus.alerts.get(motor_id, 0)
        record.heard(self.context.clock.now(), reading.temperature,
                     self.bus.proto.error_names(alert) if alert else ())
        self.latest[motor_id] = reading
        self._sweep.append(reading)

    def _end_sweep(self) -> None:
        readings, self._sweep = self._sweep, []
        self._publish(readings)
        now = self.context.clock.now()
        for listener in list(self.sweep_listeners):
            listener(now)

    @property
    def sweep_rate(self) -> float:
        """State sweeps a second achieved lately (0 before two)."""
        return self.owner.sweep_rate

    def update(self) -> list[MotorReading]:
        """One whole update at once: write pending goals, read every motor's state, publish
        it all (what the bus owner does a transaction at a time)."""
        self.flush_goals()
        for motor_id in self.motors:
            self._read(motor_id)
        readings = list(self._sweep)
        self._end_sweep()
        return readings

    def _publish(self, readings: list[MotorReading]) -> None:
        self.motor_states.publish(self.message(
            MOTOR_STATE_LIST, motor_states=[r.as_message() for r in readings]))
        by_id = {r.id: r for r in readings}
        for controller in self.controllers.values():
            reading = by_id.get(controller.motor_id)
            if reading is not None:
                controller.publish_state(reading, int(reading.timestamp * 1e9))
        self.updates += 1

    def publish_diagnostics(self) -> None:
        """One ``/diagnostics`` message from what the last sweeps read (no bus time), and,
        once any came, what the process dropped as malformed (:mod:`servolab.middleware.
        malformed`: a peer that floods a command topic with garbage is seen here)."""
        fields = diagnostics(
            self.port, baud_rate=self.bus.baudrate, actual_rate=self.sweep_rate,
            models=self.motors, health=self.health, readings=self.latest,
            now=self.context.clock.now(), since=self.started,
            stamp_ns=int(self._now() * 1e9))
        dropped = self.context.malformed.diagnostic_status(self.get_fully_qualified_name())
        if dropped is not None:
            fields["status"] = [*fields["status"], dropped]  # type: ignore[misc]
        self.diagnostics.publish(self.message(DIAGNOSTIC_ARRAY, **fields))

    def error_counts(self) -> dict[int, dict[str, object]]:
        """Per motor with any: the reads sent again, the errors of those that failed every
        time and the sweeps it was skipped."""
        return {i: h.as_dict() for i, h in self.health.items() if h.errors or h.retried}

    def destroy(self) -> None:
        owner = getattr(self, "owner", None)  # None if start-up failed before it existed
        if owner is not None:
            owner.close()
        super().destroy()
