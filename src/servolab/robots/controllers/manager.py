"""The controller manager of ROS ``dynamixel_motor`` (``controller_manager.py``), as a node.

What it does, as seed 001 shows it (section 3.2.2, Figures 3.1 to 3.4):

- pings the configured ID range and says what it found: ``pan_tilt_port: Found 20 motors -
  20 RX-28 [11, 12, ...], initialization complete.``;
- starts a :class:`~.joint_position_controller.JointPositionController` per configured controller
  whose motor answered, and says which could not start (``controller_m62``, whose motor is not
  on Armstrong's bus) while the others run;
- publishes every motor's state on ``/motor_states/<port>`` (``dynamixel_msgs/MotorStateList``)
  at the update rate, and each controller's joint state.

Faster than the original in two ways: each motor's state is one READ of its contiguous state
registers (the original's driver read 17 bytes from the goal position; one packet per register
would be six), and the goals the controllers were given since the last update leave in one
SYNC_WRITE rather than one WRITE each.

The wire decides the rate. At 57142 bps one READ of an RX-28's 11 state bytes is 8 + 17 bytes,
4.4 ms, plus the return delay (0.5 ms at the factory setting): 20 motors take about 97 ms, so
the seed's ``update_rate: 20`` cannot be met whatever the driver (its ROS driver managed 3 to
4 Hz). The manager computes that time at start, says so, and updates as fast as the wire
allows instead; at 1 Mbps with return delay 0 the same reads take about 5 ms.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from collections.abc import Sequence
from typing import TYPE_CHECKING

from ...dynamixel.errors import CommError
from ...dynamixel.wire import byte_time
from ...middleware.node import Node
from .config import ControllerConfig, SerialPortConfig
from .joint_position_controller import JointPositionController
from .motor_state import STATE_REGISTERS, MotorReading

if TYPE_CHECKING:
    from ...dynamixel.bus import Bus
    from ...middleware.context import Context

MOTOR_STATE_LIST = "dynamixel_msgs/msg/MotorStateList"
#: Motors read per timer tick (see DynamixelManager.__init__).
MOTORS_PER_TICK = 4


class DynamixelManager(Node):
    """One bus (``serial_ports: <port>:``), its motors and the controllers started on it."""

    def __init__(self, context: Context, bus: Bus, port: SerialPortConfig,
                 controllers: Sequence[ControllerConfig] = (), *,
                 name: str = "dynamixel_manager") -> None:
        super().__init__(context, name)
        self.bus = bus
        self.port = port
        log = self.get_logger()
        log.info(f"{port.name}: Pinging motor IDs {port.min_motor_id} through "
                 f"{port.max_motor_id}...")
        found = []
        for motor_id in range(port.min_motor_id, port.max_motor_id + 1):
            try:
                found.append(bus.ping(motor_id, retries=0))
            except CommError:  # no answer (or a garbled one): not there
                continue
        #: motor ID -> model name, of every motor that answered
        self.motors = {r.id: r.model_name for r in found}
        counts = ", ".join(f"{n} {model}" for model, n in Counter(self.motors.values()).items())
        ids = ", ".join(str(i) for i in self.motors)
        log.info(f"{port.name}: Found {len(self.motors)} motors - {counts} [{ids}], "
                 "initialization complete." if self.motors else
                 f"{port.name}: no motor answered between IDs {port.min_motor_id} and "
                 f"{port.max_motor_id}: check the port, the baud rate and the power")
        #: raw goal position of each motor, as read now and then as written
        self.goals = {i: int(bus.read(i, "goal_position", raw=True)) for i in self.motors}
        self.update_time = self.wire_time()
        self.rate = min(port.update_rate, 1.0 / self.update_time) if self.motors else \
            port.update_rate
        if self.rate < port.update_rate:
            log.warning(
                f"{port.name}: update_rate {port.update_rate:g} Hz cannot be met: reading "
                f"{len(self.motors)} motors takes {self.update_time * 1e3:.0f} ms at "
                f"{bus.baudrate} bps; updating at {self.rate:.1f} Hz (a faster bus and "
                "return delay 0 raise it: see docs/biped.md)")
        self.controllers: dict[str, JointPositionController] = {}
        self.failed: list[str] = []
        self._pending: dict[int, float] = {}
        self._torque_on: set[int] = set()
        self.motor_states = self.create_publisher(MOTOR_STATE_LIST,
                                                  f"/motor_states/{port.name}", 10)
        for config in controllers:
            self.start_controller(config)
        self.updates = 0
        # One update is read in ticks of a few motors each, with the goals given meanwhile
        # written before every tick: a command waits for a few READs, not for all twenty.
        self._order = list(self.motors)
        self._next = 0
        self._round: list[MotorReading] = []
        ticks = max(1, math.ceil(len(self._order) / MOTORS_PER_TICK))
        self.create_timer(1.0 / (self.rate * ticks), self._tick)

    def wire_time(self) -> float:
        """Seconds one update takes on the wire: one READ of the state registers per motor
        (instruction, status, return delay) and one SYNC_WRITE of every motor's goal."""
        bus, proto = self.bus, self.bus.proto
        seconds_per_byte = byte_time(bus.baudrate)
        total = 0.0
        for motor_id in self.motors:
            registers = [bus.model_of(motor_id).register(n) for n in STATE_REGISTERS]
            start = registers[0].address
            length = registers[-1].address + registers[-1].size - start
            packet = proto.encode_instruction(proto.read(motor_id, start, length))
            total += (len(packet) + proto.status_size(length)) * seconds_per_byte
            total += float(bus.read(motor_id, "return_delay_time"))
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
        if config.motor.id not in self.motors:
            log.error(f"Initialization failed. Unable to start controller {config.name}: "
                      f"motor {config.motor.id} did not answer on {self.port.name}")
            self.failed.append(config.name)
            return None
        position = self.bus.model_of(config.motor.id).register("goal_position")
        top = position.maximum if position.maximum is not None else position.minimum
        outside = [f"{k} {getattr(config.motor, k)}" for k in ("init", "min", "max")
                   if not position.minimum <= getattr(config.motor, k) <= top]
        if outside:
            log.error(f"Initialization failed. Unable to start controller {config.name}: "
                      f"motor {', '.join(outside)} outside the "
                      f"{self.motors[config.motor.id]}'s positions {position.minimum}..{top}")
            self.failed.append(config.name)
            return None
        controller = JointPositionController(self, config, self.bus, self._set_goal)
        self.controllers[config.name] = controller
        log.info(f"Controller {config.name} successfully started.")
        return controller

    def _set_goal(self, motor_id: int, angle: float) -> None:
        self._pending[motor_id] = angle

    def flush_goals(self) -> None:
        """Write the goals given since the last update, in one SYNC_WRITE (a motor's torque
        is switched on before its first goal, so that it holds the pose it is sent to)."""
        if not self._pending:
            return
        goals = self._pending
        first = goals.keys() - self._torque_on
        if first:
            self.bus.sync_write("torque_enable", dict.fromkeys(first, 1))
            self._torque_on |= first
        self.bus.sync_write("goal_position", goals)
        self._pending = {}  # only once written: a bus error leaves them to be sent again
        for motor_id, angle in goals.items():
            self.goals[motor_id] = self.bus.from_si(motor_id, "goal_position", angle)

    # -- the update ------------------------------------------------------------------------

    def _now(self) -> float:
        """Stamps as ROS has them: the simulation's time on a simulated robot, else the
        epoch."""
        clock = self.context.clock
        return clock.now() if clock.virtual else time.time()

    def _tick(self) -> None:
        """Write pending goals, read the next few motors; publish when all have been read."""
        self.flush_goals()
        chunk = self._order[self._next:self._next + MOTORS_PER_TICK]
        self._round += [MotorReading.read(self.bus, i, self.goals[i], self._now()) for i in chunk]
        self._next += len(chunk)
        if self._next >= len(self._order):
            readings, self._round, self._next = self._round, [], 0
            self._publish(readings)

    def update(self) -> list[MotorReading]:
        """One whole update at once: write pending goals, read every motor's state, publish
        it all (what the timer does in ticks)."""
        self.flush_goals()
        readings = [MotorReading.read(self.bus, i, self.goals[i], self._now())
                    for i in self.motors]
        self._publish(readings)
        return readings

    def _publish(self, readings: list[MotorReading]) -> None:
        self.motor_states.publish(self.message(
            MOTOR_STATE_LIST, motor_states=[r.as_message() for r in readings]))
        by_id = {r.id: r for r in readings}
        for controller in self.controllers.values():
            reading = by_id[controller.motor_id]
            controller.publish_state(reading, int(reading.timestamp * 1e9))
        self.updates += 1
