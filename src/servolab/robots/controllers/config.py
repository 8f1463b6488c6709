"""Dynamixel controller configuration as ROS ``dynamixel_motor`` users write it.

Two parts, each optional in a file but both needed to run a robot:

- the controller manager's parameters (seed 001, Listing 3.3, the ``<rosparam>`` of
  ``controller_manager.launch``), under the key ``dynamixel_manager``::

      dynamixel_manager:
        namespace: dxl_manager
        serial_ports:
          pan_tilt_port:
            port_name: /dev/ttyUSB0
            baud_rate: 57142.0
            min_motor_id: 1
            max_motor_id: 65
            update_rate: 20

- one entry per joint controller, as ``dynamixel_controllers``' YAML has them (001 Listing 3.1,
  Appendix A)::

      controller_m14:
        controller:
          package: dynamixel_controllers
          module: joint_position_controller
          type: JointPositionController
        joint_name: pan_joint_14
        joint_speed: 1.0
        motor: {id: 14, init: 512, min: 0, max: 1023}

``motor.init``, ``min`` and ``max`` are the motor's raw positions, as ``dynamixel_controllers``
reads them: a command of 0 rad is ``init``, and ``min > max`` means the joint turns the other
way (the controller is *flipped*). They stay raw here; the joint controller turns them into
radians through the motor's model, in the Dynamixel layer.

Appendix A as printed nests ``joint_name``, ``joint_speed`` and ``motor`` under ``controller:``
for its first four controllers and beside it for the others: both load (ROS's parameter server
would not have found the nested ones, which is a slip of the document's layout, not a format).
Two controllers of one motor ID are refused naming both: each would fight the other for the
same motor. Two of one joint name load, with a warning naming both (:attr:`RobotConfig.
warnings`): in ``dynamixel_controllers`` a joint name is only the label of the joint's state
message and each controller drives its own motor, and Appendix A as printed gives
``pan_joint_33`` to m31..m51, which the seed's Figure 3.4 shows starting.

Beside ROS's keys of a serial port, servolab reads three of its own, each with a default
that works: ``ping_retries`` (5: how many times each ID is pinged before it is taken as
absent, ``dynamixel_serial_proxy``'s ``num_ping_retries``), ``silent_timeout`` (0.5 s: a
motor that has not answered for longer raises an alarm) and ``read_retries`` (2: how many
times a failed READ of a motor's state is sent again before the motor is skipped for that
sweep).

Errors are :class:`ControllerConfigError`, one line ``file:line: message``, raised by
:mod:`servolab.configfile` before anything opens a port.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ...configfile import ConfigMapping, ConfigValue
from ...configfile import load as load_config
from ...errors import ConfigFileError
from ..errors import RobotValueError

#: What ``dynamixel_controllers`` offers and servolab implements.
JOINT_POSITION_CONTROLLER = ("dynamixel_controllers", "joint_position_controller",
                             "JointPositionController")
MANAGER_KEY = "dynamixel_manager"
#: What dynamixel_controllers' JointController reads beside the motor (joint_controller.py).
_TUNING = ("joint_compliance_slope", "joint_compliance_margin", "joint_compliance_punch",
           "joint_torque_limit")
_CONTROLLER_KEYS = ("controller", "joint_name", "joint_speed", "joint_max_speed", "motor",
                    *_TUNING)
_NESTABLE = ("joint_name", "joint_speed", "joint_max_speed", "motor", *_TUNING)
#: dynamixel_controllers' default joint_speed (rad/s) when a controller gives none.
DEFAULT_JOINT_SPEED = 1.0
_TYPE_KEYS = ("package", "module", "type")
_MOTOR_KEYS = ("id", "init", "min", "max")
_PORT_KEYS = ("port_name", "baud_rate", "min_motor_id", "max_motor_id", "update_rate",
              "diagnostics_rate", "error_level_temp", "warn_level_temp", "readback_echo",
              "ping_retries", "silent_timeout", "read_retries")


class ControllerConfigError(ConfigFileError):
    """A controller configuration file that cannot be used."""


@dataclass(frozen=True)
class MotorConfig:
    """One motor of a joint, in its raw position units (``motor:`` of the YAML)."""

    id: int
    init: int
    min: int
    max: int
    line: int = field(default=0, compare=False)  # where ``motor:`` is written

    @property
    def flipped(self) -> bool:
        """``min > max``: positive joint angles turn the motor towards lower positions
        (``dynamixel_controllers``' rule)."""
        return self.min > self.max


@dataclass(frozen=True)
class ControllerConfig:
    """One joint position controller (``controller_m14:`` and what it holds)."""

    name: str
    joint_name: str
    joint_speed: float          # rad/s, set as the motor's moving speed at start
    motor: MotorConfig
    joint_max_speed: float | None = None  # rad/s; None: the motor's maximum
    line: int = 0               # where it is written, for messages about it
    #: joint_compliance_slope/_margin/_punch (raw, as ROS writes them) and joint_torque_limit
    #: (0..1 of the maximum torque), each None when not given: the motor keeps its own
    compliance_slope: int | None = None
    compliance_margin: int | None = None
    compliance_punch: int | None = None
    torque_limit: float | None = None


@dataclass(frozen=True)
class SerialPortConfig:
    """One bus the manager drives (``serial_ports: pan_tilt_port:``)."""

    name: str
    port_name: str
    baud_rate: int
    min_motor_id: int = 1
    max_motor_id: int = 25
    update_rate: float = 5.0    # Hz; dynamixel_driver's default
    #: Hz of /diagnostics, and the temperatures (deg C) from which a motor's diagnostic
    #: status is WARN ("VERY HOT") and ERROR ("OVERHEATING"): dynamixel_serial_proxy's
    #: defaults (1, 70, 75)
    diagnostics_rate: float = 1.0
    warn_level_temp: float = 70.0
    error_level_temp: float = 75.0
    ping_retries: int = 5       # servolab's; see the module docstring
    silent_timeout: float = 0.5
    read_retries: int = 2


@dataclass(frozen=True)
class ManagerConfig:
    namespace: str = "dxl_manager"
    serial_ports: tuple[SerialPortConfig, ...] = ()


@dataclass(frozen=True)
class RobotConfig:
    """What a controller configuration file says: the manager and the joint controllers,
    in the order they are written."""

    manager: ManagerConfig
    controllers: tuple[ControllerConfig, ...]
    path: str = ""
    #: what loads but should be said once (``file:line: ...``): two controllers of one joint
    #: name
    warnings: tuple[str, ...] = ()

    def controller(self, name: str) -> ControllerConfig:
        for c in self.controllers:
            if c.name == name:
                return c
        raise RobotValueError(f"no controller {name!r} in {self.path or 'the configuration'}")



def load(path: str | Path) -> RobotConfig:
    """Read a controller configuration file (see the module docstring)."""
    top = load_config(path, what="controller configuration", error=ControllerConfigError)
    return parse(top, str(path))


def parse(top: ConfigValue, path: str = "") -> RobotConfig:
    """The configuration in an already composed file (``top``)."""
    mapping = top.as_mapping("a controller configuration")
    manager = ManagerConfig()
    controllers: list[ControllerConfig] = []
    for name, value in mapping.items():
        if name == MANAGER_KEY:
            manager = _manager(value)
        else:
            controllers.append(_controller(name, value))
    _check_unique(mapping, controllers)
    return RobotConfig(manager, tuple(controllers), path,
                       _shared_joint_names(controllers, path))


def _manager(value: ConfigValue) -> ManagerConfig:
    m = value.as_mapping(f"key {MANAGER_KEY!r}")
    m.check_keys(("namespace", "serial_ports"), what=MANAGER_KEY)
    namespace = m.get("namespace")
    ports_value = m.get("serial_ports")
    ports: list[SerialPortConfig] = []
    if ports_value is not None:
        for port_name, port_value in ports_value.as_mapping().items():
            ports.append(_port(port_name, port_value))
    return ManagerConfig(namespace.as_str(nonempty=True) if namespace is not None
                         else "dxl_manager", tuple(ports))


def _port(name: str, value: ConfigValue) -> SerialPortConfig:
    what = f"serial port {name!r}"
    p = value.as_mapping(what)
    p.check_keys(_PORT_KEYS, required=("port_name", "baud_rate"), what=what)
    baud = p.require("baud_rate").as_float()
    if baud <= 0 or baud != int(baud):
        raise p.require("baud_rate").error(f"{what}: baud_rate must be a positive whole number "
                                           f"of bits per second, not {baud:g}")
    low = _int(p, "min_motor_id", 1, 0, 253, what)
    high = _int(p, "max_motor_id", 25, 0, 253, what)
    if low > high:
        raise p.require("max_motor_id").error(
            f"{what}: max_motor_id {high} is below min_motor_id {low}")
    rate = _positive(p, "update_rate", 5.0, what, "Hz")
    diagnostics = _positive(p, "diagnostics_rate", 1.0, what, "Hz")
    warn = _positive(p, "warn_level_temp", 70.0, what, "deg C")
    error = _positive(p, "error_level_temp", 75.0, what, "deg C")
    if warn > error:
        raise p.require("warn_level_temp").error(
            f"{what}: warn_level_temp {warn:g} is above error_level_temp {error:g}")
    return SerialPortConfig(name, p.require("port_name").as_str(nonempty=True), int(baud),
                            low, high, rate, diagnostics, warn, error,
                            _int(p, "ping_retries", 5, 1, 100, what),
                            _positive(p, "silent_timeout", 0.5, what, "s"),
                            _int(p, "read_retries", 2, 0, 100, what))


def _positive(m: ConfigMapping, key: str, default: float, what: str, unit: str) -> float:
    value = m.get(key)
    if value is None:
        return default
    number = value.as_float()
    if not number > 0:
        raise value.error(f"{what}: {key} must be > 0 {unit}, not {number:g}")
    return number


def _int(m: ConfigMapping, key: str, default: int, low: int, high: int, what: str) -> int:
    value = m.get(key)
    if value is None:
        return default
    number = value.as_int()
    if not low <= number <= high:
        raise value.error(f"{what}: {key} {number} is outside {low}..{high}")
    return number


def _controller(name: str, value: ConfigValue) -> ControllerConfig:
    what = f"controller {name!r}"
    c = value.as_mapping(what)
    c.check_keys(_CONTROLLER_KEYS, required=("controller",), what=what)
    kind = c.require("controller").as_mapping(f"{what}: key 'controller'")
    # Appendix A nests the joint's keys under 'controller:' for some controllers
    kind.check_keys((*_TYPE_KEYS, *_NESTABLE), required=_TYPE_KEYS, what=f"{what}: controller")
    written = tuple(kind.require(k).as_str(nonempty=True) for k in _TYPE_KEYS)
    if written != JOINT_POSITION_CONTROLLER:
        raise kind.error(f"{what}: controller {'/'.join(written)} is not supported; servolab "
                         f"runs {'/'.join(JOINT_POSITION_CONTROLLER)}")
    fields: dict[str, ConfigValue] = {}
    for key in _NESTABLE:
        outer, inner = c.get(key), kind.get(key)
        if outer is not None and inner is not None:
            raise inner.error(f"{what}: {key} is given twice (beside and under 'controller:', "
                              f"line {outer.line})")
        found = outer if outer is not None else inner
        if found is not None:
            fields[key] = found
    for key in ("joint_name", "motor"):
        if key not in fields:
            raise c.error(f"{what}: key {key!r} missing")
    speed = DEFAULT_JOINT_SPEED
    if "joint_speed" in fields:
        speed = fields["joint_speed"].as_float(f"{what}: joint_speed")
        if speed <= 0:
            raise fields["joint_speed"].error(f"{what}: joint_speed must be > 0 rad/s, "
                                              f"not {speed:g}")
    max_speed = None
    if "joint_max_speed" in fields:
        max_speed = fields["joint_max_speed"].as_float(f"{what}: joint_max_speed")
        if max_speed <= 0:
            raise fields["joint_max_speed"].error(
                f"{what}: joint_max_speed must be > 0 rad/s, not {max_speed:g}")
    return ControllerConfig(name, fields["joint_name"].as_str(f"{what}: joint_name",
                                                              nonempty=True),
                            speed, _motor(fields["motor"], what), max_speed, c.line,
                            _optional_int(fields, "joint_compliance_slope", 254, what),
                            _optional_int(fields, "joint_compliance_margin", 254, what),
                            _optional_int(fields, "joint_compliance_punch", 1023, what),
                            _optional_fraction(fields, "joint_torque_limit", what))


def _optional_int(fields: dict[str, ConfigValue], key: str, high: int,
                  what: str) -> int | None:
    value = fields.get(key)
    if value is None:
        return None
    number = value.as_int(f"{what}: {key}")
    if not 0 <= number <= high:
        raise value.error(f"{what}: {key} {number} is outside 0..{high}")
    return number


def _optional_fraction(fields: dict[str, ConfigValue], key: str, what: str) -> float | None:
    value = fields.get(key)
    if value is None:
        return None
    number = value.as_float(f"{what}: {key}")
    if not 0.0 <= number <= 1.0:
        raise value.error(f"{what}: {key} must be within 0..1 (a fraction of the maximum "
                          f"torque), not {number:g}")
    return number


def _motor(value: ConfigValue, what: str) -> MotorConfig:
    m = value.as_mapping(f"{what}: motor")
    m.check_keys(_MOTOR_KEYS, required=_MOTOR_KEYS, what=f"{what}: motor")
    motor_id = m.require("id").as_int(f"{what}: motor id")
    if not 0 <= motor_id <= 253:
        raise m.require("id").error(f"{what}: motor id {motor_id} is outside 0..253")
    init, low, high = (m.require(k).as_int(f"{what}: motor {k}") for k in ("init", "min", "max"))
    for key, raw in (("init", init), ("min", low), ("max", high)):
        if raw < 0:
            raise m.require(key).error(f"{what}: motor {key} {raw} is a raw position, >= 0")
    if low == high:
        raise m.require("max").error(f"{what}: motor min and max are both {low}: the joint "
                                     "could not move")
    if not min(low, high) <= init <= max(low, high):
        raise m.require("init").error(f"{what}: motor init {init} is outside min..max "
                                      f"({low}..{high})")
    return MotorConfig(motor_id, init, low, high, m.line)


def _check_unique(mapping: ConfigMapping, controllers: list[ControllerConfig]) -> None:
    """Refuse two controllers of one motor, naming both."""
    seen: dict[int, ControllerConfig] = {}
    for c in controllers:
        if c.motor.id in seen:
            first = seen[c.motor.id]
            raise mapping.key_of(c.name).error(
                f"controllers {first.name!r} (line {first.line}) and {c.name!r} drive the "
                f"same motor id {c.motor.id}: each motor needs its own controller")
        seen[c.motor.id] = c


def _shared_joint_names(controllers: list[ControllerConfig], path: str) -> tuple[str, ...]:
    """One warning per controller whose joint name an earlier one has already."""
    seen: dict[str, ControllerConfig] = {}
    warnings = []
    for c in controllers:
        first = seen.setdefault(c.joint_name, c)
        if first is not c:
            warnings.append(f"{path or '<config>'}:{c.line}: controllers {first.name!r} (line "
                            f"{first.line}) and {c.name!r} share joint name {c.joint_name!r}: "
                            "both run (a joint name only labels the state message), but their "
                            "states cannot be told apart by name")
    return tuple(warnings)
