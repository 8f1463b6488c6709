"""A joint position controller, as ``dynamixel_controllers``' ``JointPositionController``.

Topics and services under the controller's name (``controller_m14``), named as ROS
``dynamixel_motor`` names them (seed 001 section 3.2.2):

- ``/controller_m14/command`` (``std_msgs/msg/Float64``): the joint angle in radians, 0 being
  the motor's ``init``; clamped to the joint's range with a warning; NaN or infinity refused;
- ``/controller_m14/state`` (``dynamixel_msgs/msg/JointState``, 001 Figure 3.2), published at
  every update of the manager;
- ``/controller_m14/set_speed`` (``dynamixel_controllers/srv/SetSpeed``, rad/s),
  ``/controller_m14/torque_enable`` (``TorqueEnable``), ``set_compliance_slope``,
  ``set_compliance_margin``, ``set_compliance_punch`` (raw, both directions alike, clamped to
  the register's range as ``joint_position_controller.py`` clamps them) and
  ``set_torque_limit`` (``SetTorqueLimit``: a fraction 0..1 of the maximum torque).

The arithmetic is ``dynamixel_controllers``' (joint_position_controller.py): ``min > max``
flips the joint; the joint's range is ``min``..``max`` seen from ``init``. It is done here in
radians: the configuration's raw positions are turned into the motor's angles once, by the
Dynamixel layer's units (:meth:`Bus.to_si`), and goals leave as angles, so ticks never leave
the Dynamixel layer. One difference: the state is the joint's in the joint's own sense.
``error`` is ``current_pos - goal_pos``, and on a flipped joint ``velocity`` and ``load`` have
the motor's signs inverted; the original (``process_motor_states``) scaled the motor's raw
error and copied its speed and load, so a flipped joint showed all three with the wrong sign
(a velocity that was not the way ``current_pos`` moved). ``/motor_states`` stays the motor's,
raw, as ``dynamixel_driver`` publishes it.

It drives any model servolab knows, by the registers' roles
(:data:`~servolab.dynamixel.models.ROLES`): ``set_speed`` writes Moving Speed(32) on
AX/RX/EX/MX(1.0) and Profile Velocity(112) on the X-series and MX(2.0) (0 is full speed on
both, so never written); ``set_torque_limit`` writes Torque Limit(34), or Goal PWM(100) on
2.0 models; the compliance services write the AX/RX/EX compliance registers and are refused,
one line naming the model and the register it lacks, on a model that has PID gains instead
(MX, X-series): the service answers with that error and the controller runs on. A
``joint_compliance_*`` in the configuration of such a motor keeps its controller from
starting, with the same line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING, Any

from ...dynamixel.errors import ConfigError
from ..errors import RobotValueError
from .config import ControllerConfig
from .motor_state import MotorReading

if TYPE_CHECKING:
    from ...dynamixel.bus import Bus
    from ...middleware.node import Node

FLOAT64 = "std_msgs/msg/Float64"
JOINT_STATE = "dynamixel_msgs/msg/JointState"
SET_SPEED = "dynamixel_controllers/srv/SetSpeed"
TORQUE_ENABLE = "dynamixel_controllers/srv/TorqueEnable"
SET_COMPLIANCE_SLOPE = "dynamixel_controllers/srv/SetComplianceSlope"
SET_COMPLIANCE_MARGIN = "dynamixel_controllers/srv/SetComplianceMargin"
SET_COMPLIANCE_PUNCH = "dynamixel_controllers/srv/SetCompliancePunch"
SET_TORQUE_LIMIT = "dynamixel_controllers/srv/SetTorqueLimit"
#: The compliance services: request field -> the roles written (both directions alike).
COMPLIANCE = {"slope": ("cw_compliance_slope", "ccw_compliance_slope"),
              "margin": ("cw_compliance_margin", "ccw_compliance_margin"),
              "punch": ("punch",)}


@dataclass(frozen=True)
class JointGeometry:
    """A controller's joint in the motor's angles (rad): where 0 is, which way is positive,
    how far it may go, and the speeds it may be given."""

    init: float         # motor angle of joint angle 0
    flipped: bool
    min_angle: float    # joint angles, rad
    max_angle: float
    min_speed: float    # rad/s: the slowest the motor can be told (0 would mean full speed)
    max_speed: float

    @classmethod
    def of(cls, config: ControllerConfig, bus: Bus) -> JointGeometry:
        motor = config.motor

        def angle(raw: int) -> float:
            return float(bus.to_si(motor.id, "goal_position", raw))

        init = angle(motor.init)
        sign = -1.0 if motor.flipped else 1.0
        full = bus.model_of(motor.id).role("moving_speed")
        min_speed = float(bus.to_si(motor.id, full.name, 1))
        # the register's largest raw value is its largest speed (on a 1.0 model with the
        # direction in bit 10, the largest magnitude: hence abs)
        top = abs(float(bus.to_si(motor.id, full.name, full.maximum if full.maximum
                                  is not None else 1023)))
        max_speed = min(top, config.joint_max_speed or top)
        return cls(init, motor.flipped, sign * (angle(motor.min) - init),
                   sign * (angle(motor.max) - init), min_speed, max_speed)

    def goal(self, joint_angle: float) -> float:
        """The motor angle for a joint angle (already within range)."""
        return self.init - joint_angle if self.flipped else self.init + joint_angle

    def joint(self, motor_angle: float) -> float:
        """The joint angle of a motor angle."""
        return self.init - motor_angle if self.flipped else motor_angle - self.init

    def clamp_speed(self, speed: float) -> float:
        return min(max(speed, self.min_speed), self.max_speed)


class JointPositionController:
    """One controller: see the module docstring. ``set_goal(motor_id, angle)`` hands a goal
    to the manager, which writes the goals of all its controllers in one SYNC_WRITE."""

    def __init__(self, node: Node, config: ControllerConfig, bus: Bus,
                 set_goal: Any) -> None:
        self.config = config
        self.name = config.name
        self.motor_id = config.motor.id
        self.model = bus.model_of(self.motor_id)
        #: role -> register name, of the roles the controller writes
        self.registers = {role: self.model.role(role).name
                          for role in ("moving_speed", "torque_enable", "torque_limit")}
        self.geometry = JointGeometry.of(config, bus)
        tuning = self._tuning(config)  # refused here, before anything is on the graph
        self._node = node
        self._bus = bus
        self._set_goal = set_goal
        self._log = node.get_logger()
        #: the joint angle last commanded (rad); at start, the motor's own goal
        self.goal_angle = self.geometry.joint(float(bus.read(self.motor_id, "goal_position")))
        self.state_pub = node.create_publisher(JOINT_STATE, f"/{self.name}/state", 10)
        base = f"/{self.name}"
        self._entities: list[Any] = [
            self.state_pub,
            node.create_subscription(FLOAT64, f"{base}/command", self._on_command, 10),
            node.create_service(SET_SPEED, f"{base}/set_speed", self._on_set_speed),
            node.create_service(TORQUE_ENABLE, f"{base}/torque_enable", self._on_torque_enable),
            node.create_service(SET_TORQUE_LIMIT, f"{base}/set_torque_limit",
                                self._on_set_torque_limit)]
        for field_name, srv in (("slope", SET_COMPLIANCE_SLOPE),
                                ("margin", SET_COMPLIANCE_MARGIN),
                                ("punch", SET_COMPLIANCE_PUNCH)):
            self._entities.append(node.create_service(
                srv, f"{base}/set_compliance_{field_name}",
                partial(self._on_compliance, field_name)))
        self.set_speed(config.joint_speed)
        for names, value in tuning:
            self._bus.write(self.motor_id, dict.fromkeys(names, value), raw=True)
        if config.torque_limit is not None:
            self.set_torque_limit(config.torque_limit)

    def _tuning(self, config: ControllerConfig) -> list[tuple[tuple[str, ...], int]]:
        """The joint_compliance_* the configuration gives, as dynamixel_controllers writes
        them (the motor's raw units, both directions alike): (registers, value) each; a
        model without the registers refuses the controller (:meth:`compliance_registers`)."""
        given = (("slope", config.compliance_slope), ("margin", config.compliance_margin),
                 ("punch", config.compliance_punch))
        return [(self.compliance_registers(which), value) for which, value in given
                if value is not None]

    def compliance_registers(self, which: str) -> tuple[str, ...]:
        """The registers compliance ``which`` (slope, margin or punch) writes; on a model
        without them (MX, X-series: PID gains instead) RobotValueError, one line naming the
        model and the register it lacks."""
        try:
            return tuple(self.model.role(role).name for role in COMPLIANCE[which])
        except ConfigError as error:
            instead = ""
            if self.model.has_role("p_gain"):
                instead = (f"; it has PID gains ({self.model.role('p_gain').name}, ...) "
                           "instead, which dynamixel_controllers does not set")
            raise RobotValueError(f"{self.name}: compliance {which} refused: {error}"
                                  f"{instead}") from None

    # -- commands --------------------------------------------------------------------------

    def command(self, joint_angle: float) -> float:
        """Drive the joint to ``joint_angle`` (rad), clamped to its range with a warning;
        returns the angle commanded. NaN or infinity raises ValueError and moves nothing."""
        if not math.isfinite(joint_angle):
            raise RobotValueError(f"{self.name}: command {joint_angle!r} is not a finite angle; "
                                  "ignored")
        g = self.geometry
        clamped = min(max(joint_angle, g.min_angle), g.max_angle)
        if clamped != joint_angle:
            self._log.warning(f"{self.name}: command {joint_angle:.4f} rad is outside "
                              f"{g.min_angle:.4f}..{g.max_angle:.4f} rad; "
                              f"clamped to {clamped:.4f}", throttle_duration_sec=1.0)
        self.goal_angle = clamped
        self._set_goal(self.motor_id, g.goal(clamped))
        return clamped

    def _on_command(self, msg: Any) -> None:
        try:
            self.command(float(msg.data))
        except ValueError as exc:
            self._log.error(str(exc))

    def set_speed(self, speed: float) -> float:
        """The motor's moving speed for the joint (rad/s), kept within what the motor can be
        told (never 0, which an RX-28 reads as full speed); returns the speed set."""
        if not math.isfinite(speed):
            raise RobotValueError(f"{self.name}: speed {speed!r} is not a finite number")
        chosen = self.geometry.clamp_speed(abs(speed))
        self._bus.write(self.motor_id, self.registers["moving_speed"], chosen)
        return chosen

    def _on_set_speed(self, request: Any, response: Any) -> Any:
        self.set_speed(float(request.speed))
        return response

    def torque_enable(self, on: bool) -> None:
        self._bus.write(self.motor_id, self.registers["torque_enable"], 1 if on else 0)

    def _on_torque_enable(self, request: Any, response: Any) -> Any:
        self.torque_enable(bool(request.torque_enable))
        return response

    def set_compliance(self, which: str, value: int) -> int:
        """Write compliance ``which`` (slope, margin or punch) in the motor's raw units,
        clamped to the register's range; returns the value written."""
        names = self.compliance_registers(which)
        register = self.model.register(names[0])
        top = register.maximum if register.maximum is not None else value
        chosen = min(max(int(value), register.minimum), top)
        if chosen != value:
            self._log.warning(f"{self.name}: compliance {which} {value} outside "
                              f"{register.minimum}..{top}; set to {chosen}")
        self._bus.write(self.motor_id, dict.fromkeys(names, chosen), raw=True)
        return chosen

    def _on_compliance(self, which: str, request: Any, response: Any) -> Any:
        self.set_compliance(which, int(getattr(request, which)))
        return response

    def set_torque_limit(self, fraction: float) -> float:
        """The most torque the motor may use, a fraction 0..1 of its maximum (clamped):
        Torque Limit(34) on AX/RX/EX/MX(1.0) (1,023 = 100 %), Goal PWM(100) on the X-series
        and MX(2.0) (885 = 100 %, the limit that acts in position mode; see
        :data:`~servolab.dynamixel.models.ROLES`)."""
        if not math.isfinite(fraction):
            raise RobotValueError(f"{self.name}: torque limit {fraction!r} is not a number")
        chosen = min(max(fraction, 0.0), 1.0)
        self._bus.write(self.motor_id, self.registers["torque_limit"], chosen)
        return chosen

    def _on_set_torque_limit(self, request: Any, response: Any) -> Any:
        self.set_torque_limit(float(request.torque_limit))
        return response

    def destroy(self) -> None:
        """Take the controller's topics and services off the graph."""
        for entity in self._entities:
            self._node.destroy_entity(entity)
        self._entities.clear()

    # -- state -----------------------------------------------------------------------------

    def publish_state(self, motor: MotorReading, stamp_ns: int) -> None:
        """Publish the joint's state from its motor's reading of this update."""
        g = self.geometry
        current = g.joint(motor.position_si)
        goal = self.goal_angle
        sign = -1.0 if g.flipped else 1.0  # a flipped joint turns against its motor
        velocity = sign * motor.speed_si
        load = sign * float(motor.load)
        self.state_pub.publish(self._node.message(
            JOINT_STATE,
            header={"stamp": {"sec": stamp_ns // 1_000_000_000,
                              "nanosec": stamp_ns % 1_000_000_000}},
            name=self.config.joint_name, motor_ids=[self.motor_id],
            motor_temps=[int(motor.temperature)], goal_pos=goal, current_pos=current,
            error=current - goal, velocity=velocity, load=load,
            is_moving=bool(motor.moving)))
