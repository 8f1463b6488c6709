"""Armstrong, the biped of seed 001: its configuration and its bus, emulated by default or
real on a named port. (Its motions, built on its description, are :mod:`.motions`.)

The emulated robot is what the seed's robot is on its bus: 20 RX-28 on one Protocol 1.0 bus at
57142 bps with the IDs of Table 2.2, each standing at its configured ``init`` position; motor
62 (the camera) is not there, as in the seed (001 Figure 3.4), so its controller fails to
start while the others run. Emulated motors live in a :class:`~servolab.sim.Simulation`, whose
virtual time the nodes' executor shares, so a walk runs as fast as the CPU allows.
"""

from __future__ import annotations

import math
from collections.abc import Collection
from dataclasses import replace
from pathlib import Path

from ...configfile import shipped
from ...dynamixel import units
from ...dynamixel.bus import Bus
from ...dynamixel.emulator import Faults
from ...dynamixel.models import model
from ...dynamixel.motorspec import MotorEntry, MotorSpec
from ...sim.emulated import emulated_port
from ...sim.simulation import Simulation
from ..controllers.config import ControllerConfigError, RobotConfig, SerialPortConfig, load

#: armstrong.yaml beside this module (Listing 3.3 + Appendix A): the default configuration
CONFIG = shipped(__package__ or "servolab.robots.armstrong", "armstrong.yaml")
#: The model of every motor of Armstrong (001 section 2).
MODEL = "RX-28"
#: Configured but not on the robot's bus (001 Figure 3.4).
ABSENT = (62,)


def load_config(path: str | Path | None = None) -> RobotConfig:
    """The robot's configuration (the shipped ``armstrong.yaml`` unless another is named)."""
    config = load(path or CONFIG)
    if not config.manager.serial_ports:
        # a controllers-only file, as Appendix A is: in ROS the manager's settings come from
        # controller_manager.launch (Listing 3.3), which the shipped file carries
        shipped = load(CONFIG)
        config = replace(config, manager=shipped.manager, warnings=(
            *config.warnings,
            f"{config.path}: no dynamixel_manager in it: the seed's (Listing 3.3) from the "
            "shipped armstrong.yaml is used ('servolab robots show armstrong' prints it)"))
    position = model(MODEL).register("goal_position")
    top = position.maximum if position.maximum is not None else 1023
    for c in config.controllers:
        for key in ("init", "min", "max"):
            raw = getattr(c.motor, key)
            if not position.minimum <= raw <= top:
                raise ControllerConfigError(
                    config.path, c.motor.line, f"{c.name}.motor.{key}",
                    f"controller {c.name!r}: motor {key} {raw} is outside the {MODEL}'s "
                    f"positions {position.minimum}..{top}")
    return config


def joint_limits(config: RobotConfig) -> dict[str, tuple[float, float]]:
    """Each controller's joint range in degrees, keyed by motor column (``m14``), as its
    joint controller will clamp commands: what a motion file is checked against before any
    motor moves. From the configuration and the RX-28's units alone (no bus needed)."""
    rx28 = model(MODEL)
    position = rx28.register("goal_position")
    limits = {}
    for c in config.controllers:
        init, low, high = (units.to_si(rx28, position, raw)
                           for raw in (c.motor.init, c.motor.min, c.motor.max))
        sign = -1.0 if c.motor.flipped else 1.0
        ends = sorted((math.degrees(sign * (low - init)), math.degrees(sign * (high - init))))
        limits[f"m{c.motor.id}"] = (ends[0], ends[1])
    return limits


def emulated_spec(config: RobotConfig, *, absent: Collection[int] = ABSENT,
                  baudrate: int | None = None) -> MotorSpec:
    """The emulated bus of ``config``: one RX-28 per controller's motor except ``absent``,
    standing at its ``init`` position, at the port's baud rate (or ``baudrate``)."""
    rx28 = model(MODEL)
    position = rx28.register("goal_position")
    port = config.manager.serial_ports[0]
    motors = tuple(MotorEntry(rx28, c.motor.id, units.to_si(rx28, position, c.motor.init))
                   for c in config.controllers if c.motor.id not in absent)
    return MotorSpec(rx28.protocol, baudrate or port.baud_rate, motors)


def open_bus(config: RobotConfig, *, port_name: str | None = None,
             simulation: Simulation | None = None, absent: Collection[int] = ABSENT,
             baudrate: int | None = None, faults: Faults | None = None
             ) -> tuple[Bus, SerialPortConfig]:
    """The robot's bus: the real one on ``port_name`` (a serial device), else the emulated
    robot in ``simulation`` (a new one if None; ``faults`` injected into its answers).
    Returns the bus and the port settings it runs with (the configured ones, with the device
    and baud rate used)."""
    port = config.manager.serial_ports[0]
    baud = baudrate or port.baud_rate
    if port_name is not None:
        bus = Bus.open(port_name, protocol=1, baudrate=baud)
    else:
        spec = emulated_spec(config, absent=absent, baudrate=baud)
        bus = Bus(emulated_port(spec, baud, simulation=simulation, faults=faults))
    return bus, replace(port, port_name=port_name or bus.port.name, baud_rate=baud)
