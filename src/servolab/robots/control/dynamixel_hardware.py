"""The Dynamixel joints of a URDF as a ros2_control hardware component, on a servolab bus.

What ROBOTIS's ``dynamixel_hardware_interface`` and the community ``dynamixel_hardware`` do,
on servolab's driver: the block's joints (:mod:`..dynamixel_system` reads both plugins'
parameters) are read each update in one SYNC_READ of their present position, velocity and
current (one BULK_READ or READ each on Protocol 1.0 models, as :meth:`Bus.sync_read` chooses)
and written in one SYNC_WRITE per goal register. What a joint obeys follows the command
interfaces its controllers claim, as ``perform_command_mode_switch`` does in both plugins:

================================  =======================================  ===============
command interfaces claimed         X-series / MX(2.0) ``operating_mode``    goal register
================================  =======================================  ===============
position                           3 position                               goal_position
velocity                           1 velocity                               goal_velocity
effort                             0 current                                goal_current
position and effort                5 current-based position                 both
================================  =======================================  ===============

A model without operating modes (AX, RX, EX, MX 1.0) takes position only. Effort is N·m
through the model's torque constant (stall torque over stall current, the e-Manual's
figures): an X-series' present current times it, a 1.0 model's present load (a fraction of
its stall torque) times its stall torque. (ROBOTIS's plugin gives a joint's effort as raw
current units; servolab keeps SI above the Dynamixel layer.)

A joint is ``scale`` x its horn + ``offset`` (:class:`~..dynamixel_system.DynamixelJoint`: a
``mechanical_reduction``, a sign or ratio of the transmission matrix, a ``mechanical_offset``);
velocities scale with it and efforts inversely. The control-table items the block gives each
motor (``Profile_Velocity``, ``Position P Gain``, ``Operating Mode``, ...) are written, raw,
with torque off, when the component is configured, as both plugins write them at start.
A ``<gpio type="dxl">``'s state interfaces (``dxl1/Present Position``) are read each update
in ROBOTIS's units (rad, rad/s, V; current and the rest raw); its command interfaces are not
exported (the joints command the motors), and a ``<joint>`` with a ``mimic`` parameter gets
the state of the joint it names times ``multiplier``.

Changing a mode turns torque off for the write (Operating Mode is EEPROM, e-Manual
control_table_operating_mode) and on again, with the position command set to where the
joint is: a switch never makes a joint jump.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

from ...dynamixel import units
from ...dynamixel.errors import ConfigError, DynamixelError
from ...dynamixel.models import OPERATING_MODES, Model
from ..dynamixel_system import DynamixelJoint, DynamixelSystem, register_name
from ..hardware_info import HardwareInfo, HardwareInfoError
from .hardware import EFFORT, POSITION, VELOCITY, SystemInterface, initial_value

if TYPE_CHECKING:
    from ...dynamixel.bus import Bus

#: the operating mode a set of claimed command interfaces asks for
MODES: dict[frozenset[str], str] = {
    frozenset({POSITION}): "position",
    frozenset({VELOCITY}): "velocity",
    frozenset({EFFORT}): "current",
    frozenset({POSITION, EFFORT}): "current_based_position",
}
#: the goal register each command interface writes
GOALS = {POSITION: "goal_position", VELOCITY: "goal_velocity", EFFORT: "goal_current"}


#: the units in which a motor gpio's state interfaces are read, as dynamixel_hardware_interface
#: gives them (its model files' "[unit info]": rad, rad/s, V; everything else raw)
GPIO_SI_UNITS = ("position", "velocity", "voltage")


def gpio_value(model: Model, register: str, raw: int) -> float:
    found = model.register(register)
    return float(units.to_si(model, found, raw)) if found.unit in GPIO_SI_UNITS else float(raw)


def torque_constant(model: Model) -> float:
    """N·m per ampere: the e-Manual's stall torque over its stall current (0 when the model
    file gives neither)."""
    if model.stall_current_a > 0 and model.stall_torque_nm > 0:
        return model.stall_torque_nm / model.stall_current_a
    return 0.0


class DynamixelHardware(SystemInterface):
    """See the module docstring. ``bus`` is open; the component owns no port."""

    def __init__(self, info: HardwareInfo, system: DynamixelSystem, bus: Bus) -> None:
        super().__init__(info)
        self.system = system
        self.bus = bus
        self.joints: dict[str, DynamixelJoint] = {j.name: j for j in system.joints}
        #: joint -> the command interfaces it obeys now
        self.obeys: dict[str, frozenset[str]] = {j: frozenset({POSITION}) for j in self.joints}
        self._reads = self._read_groups()
        self._gpio_reads = self._gpio_groups()
        self._mimics = [self._mimic(c.name, c.parameters) for c in info.joints
                        if "mimic" in c.parameters]
        #: the command interfaces of its joints that controllers hold now
        self.claimed: set[str] = set()
        #: (ID, command interface) -> the motor's limit for it, SI
        self._limits: dict[tuple[int, str], float] = {}
        self.reads = 0
        self.writes = 0

    def _read_groups(self) -> list[tuple[list[str], list[int], list[str]]]:
        """(register names, IDs, joint names) for each group of joints read at once: the
        joints whose models name their state registers alike."""
        groups: dict[tuple[str, ...], tuple[list[int], list[str]]] = {}
        for joint in self.system.joints:
            m = joint.model
            names = tuple(m.role(r).name for r in ("present_position", "present_speed",
                                                   "present_load"))
            ids, joints = groups.setdefault(names, ([], []))
            ids.append(joint.id)
            joints.append(joint.name)
        return [(list(names), ids, joints) for names, (ids, joints) in groups.items()]

    def _gpio_groups(self) -> list[tuple[str, int, Model, list[tuple[str, str]]]]:
        """(gpio, ID, model, [(state interface, register)]) of each motor gpio with state
        interfaces."""
        by_element = {j.element: j for j in self.system.joints}
        found = []
        for gpio in self.info.gpios:
            joint = by_element.get(f'<gpio name="{gpio.name}">')
            if joint is None or not gpio.state_interfaces:
                continue
            names = []
            for interface in gpio.state_interfaces:
                register = register_name(interface.name)
                if not joint.model.has(register):
                    raise HardwareInfoError(
                        f'{self.name}: <gpio name="{gpio.name}"> <state_interface name='
                        f'"{interface.name}">: the {joint.model.name} has no {register} register')
                names.append((f"{gpio.name}/{interface.name}", register))
            found.append((gpio.name, joint.id, joint.model, names))
        return found

    def _mimic(self, joint: str, parameters: Mapping[str, str]) -> tuple[str, str, float]:
        """(joint, the joint it follows, multiplier) of a ``<param name="mimic">`` joint, as
        dynamixel_hardware_interface reads it; refused in one line when the joint it names
        has no motor in the block or the multiplier is not a number."""
        leader = parameters["mimic"].strip()
        here = f'{self.name} <joint name="{joint}">'
        if leader not in self.joints:
            raise HardwareInfoError(f"{here}: mimic {leader!r} is not a joint of the block "
                                    f"with a motor (it has {', '.join(self.joints)})")
        text = parameters.get("multiplier", "1").strip() or "1"
        try:
            multiplier = float(text)
        except ValueError:
            raise HardwareInfoError(f"{here}: multiplier {text[:40]!r} is not a number") from None
        if not math.isfinite(multiplier):
            raise HardwareInfoError(f"{here}: multiplier {text[:40]!r} is not finite")
        return joint, leader, multiplier

    def export_command_interfaces(self) -> list[tuple[str, float]]:
        """The joints' command interfaces (a motor gpio's are the joints' to write)."""
        return [(f"{c.name}/{i.name}", initial_value(i.parameters))
                for c in self.info.joints for i in c.command_interfaces]

    # -- lifecycle --------------------------------------------------------------------------

    def on_configure(self) -> bool:
        """Write each motor's control-table items from the block, torque off (EEPROM items
        need it), in the order given."""
        try:
            for joint in self.system.joints:
                if not joint.settings:
                    continue
                self.bus.write(joint.id, "torque_enable", 0)
                for register, value in joint.settings:
                    self.bus.write(joint.id, register, value, raw=True)
        except (DynamixelError, ConfigError) as exc:
            self.error = f"{self.name}: {' '.join(str(exc).split())}"
            return False
        return True

    def on_activate(self) -> bool:
        """Torque on; every command set to where its joint is, so nothing moves."""
        if not self.read(0.0, 0.0):
            return False
        self.claimed = set()
        for name in self.joints:
            self._hold(name)
        try:
            self._read_limits()
            for joint in self.system.joints:
                self.bus.write(joint.id, "torque_enable", 1)
        except DynamixelError as exc:
            self.error = f"{self.name}: {exc}"
            return False
        return True

    def on_deactivate(self) -> bool:
        """Every joint stops or holds, torque on: a position joint keeps its last goal (a
        deactivated arm must not fall; rewriting the goal as the measured position would let
        a loaded joint sag by its compliance error), a velocity joint is given 0 (a wheel
        stops), a current joint goes back to position mode holding where it is (a current of
        0 would let it fall). Neither plugin does the last two (their on_deactivate leaves
        the last goal in the motor, so a wheel keeps turning); servolab's rule is that motors
        stop or hold on any stop."""
        failed: list[str] = []
        for joint in self.system.joints:  # each on its own: one silent motor stops no other
            obeys = self.obeys[joint.name]
            try:
                if obeys == frozenset({VELOCITY}):
                    self.bus.write(joint.id, "goal_velocity", 0.0)
                elif obeys == frozenset({EFFORT}):
                    self._set_mode(joint, "position")
                    self.obeys[joint.name] = frozenset({POSITION})
            except DynamixelError as exc:
                failed.append(f"{joint.name}: {' '.join(str(exc).split())}")
        if failed:
            self.error = f"{self.name}: could not stop {'; '.join(failed)}"
            return False
        return True

    def _hold(self, joint: str) -> None:
        for interface in (POSITION, VELOCITY, EFFORT):
            key = f"{joint}/{interface}"
            if key in self.commands:
                self.commands[key] = self.states.get(key, math.nan) if interface == POSITION \
                    else 0.0

    def _wanted(self, start: Sequence[str], stop: Sequence[str]) -> dict[str, frozenset[str]]:
        """Per joint whose claims change: the command interfaces it will obey, from what
        its controllers hold now, less ``stop``, plus ``start``."""
        future = (self.claimed - set(stop)) | set(start)
        changed = {n.rpartition("/")[0] for n in (*start, *stop)}
        claimed: dict[str, set[str]] = {j: set() for j in self.joints if j in changed}
        for name in future:
            joint, _, interface = name.rpartition("/")
            if joint in claimed:
                claimed[joint].add(interface)
        return {j: frozenset(c) for j, c in claimed.items() if c}

    def prepare_command_mode_switch(self, start: Sequence[str], stop: Sequence[str]) -> bool:
        for joint, interfaces in self._wanted(start, stop).items():
            model = self.joints[joint].model
            mode = MODES.get(interfaces)
            if mode is None:
                self.error = (f"{self.name}: joint {joint} cannot obey "
                              f"{' and '.join(sorted(interfaces))} at once")
                return False
            if mode != "position" and OPERATING_MODES[mode] not in model.operating_modes:
                self.error = (f"{self.name}: joint {joint}'s {model.name} has no {mode} mode "
                              f"(it takes position only)")
                return False
        return True

    def perform_command_mode_switch(self, start: Sequence[str], stop: Sequence[str]) -> bool:
        try:
            for joint, interfaces in self._wanted(start, stop).items():
                if interfaces == self.obeys[joint]:
                    continue
                motor = self.joints[joint]
                self._set_mode(motor, MODES[interfaces])
                self.obeys[joint] = interfaces
                self._hold(joint)
        except DynamixelError as exc:
            self.error = f"{self.name}: {exc}"
            return False
        self.claimed = (self.claimed - set(stop)) | {n for n in start
                                                     if n.rpartition("/")[0] in self.joints}
        return True

    def _set_mode(self, joint: DynamixelJoint, mode: str) -> None:
        if not joint.model.operating_modes:
            return
        bus = self.bus
        present = float(bus.read(joint.id, "present_position"))
        bus.write(joint.id, "torque_enable", 0)
        bus.write(joint.id, "operating_mode", OPERATING_MODES[mode])
        if mode in ("position", "current_based_position"):
            bus.write(joint.id, "goal_position", present)
        bus.write(joint.id, "torque_enable", 1)
        self.states[f"{joint.name}/{POSITION}"] = joint.to_joint(present)

    # -- the update loop --------------------------------------------------------------------

    def read(self, time: float, period: float) -> bool:
        states = self.states
        try:
            for names, ids, joints in self._reads:
                values = self.bus.sync_read(names, ids)
                for motor_id, joint in zip(ids, joints, strict=True):
                    row = values[motor_id]
                    position, velocity, load = (float(row[n]) for n in names)
                    motor = self.joints[joint]
                    states[f"{joint}/{POSITION}"] = motor.to_joint(position)
                    key = f"{joint}/{VELOCITY}"
                    if key in states:
                        states[key] = motor.scale * velocity
                    key = f"{joint}/{EFFORT}"
                    if key in states:
                        states[key] = self._effort(motor.model, names[2], load) / motor.scale
            for _gpio, motor_id, model_, interfaces in self._gpio_reads:
                raw = self.bus.read(motor_id, [r for _, r in interfaces], raw=True)
                for name, register in interfaces:
                    states[name] = gpio_value(model_, register, int(raw[register]))
            for joint, leader, multiplier in self._mimics:
                for interface in (POSITION, VELOCITY, EFFORT):
                    key, source = f"{joint}/{interface}", f"{leader}/{interface}"
                    if key in states and source in states:
                        states[key] = multiplier * states[source]
        except DynamixelError as exc:
            self.error = f"{self.name}: {' '.join(str(exc).split())}"
            return False
        self.reads += 1
        return True

    @staticmethod
    def _effort(model: Model, register: str, value: float) -> float:
        if register == "present_current":
            return value * torque_constant(model)
        return value * model.stall_torque_nm  # present_load: a fraction of the stall torque

    def write(self, time: float, period: float) -> bool:
        goals: dict[str, dict[int, float]] = {}
        commands = self.commands
        for name, joint in self.joints.items():
            for interface in self.obeys[name]:
                value = commands.get(f"{name}/{interface}", math.nan)
                if not math.isfinite(value):
                    continue
                value = self._within(joint, interface, value)
                if interface == POSITION:
                    value = joint.to_horn(value)
                elif interface == VELOCITY:
                    value /= joint.scale
                else:  # effort: the horn's torque, as a current
                    kt = torque_constant(joint.model)
                    if kt <= 0:
                        continue
                    value = value * joint.scale / kt
                goals.setdefault(GOALS[interface], {})[joint.id] = value
        try:
            for register, values in goals.items():
                self.bus.sync_write(register, values)
        except DynamixelError as exc:
            self.error = f"{self.name}: {' '.join(str(exc).split())}"
            return False
        self.writes += 1
        return True

    def _within(self, joint: DynamixelJoint, interface: str, value: float) -> float:
        """A goal kept inside the URDF's joint limits and the motor's own (Velocity Limit,
        Current Limit, read at activation), as both plugins clamp: a controller's overshoot
        never reaches the motor as a refused write."""
        if interface == POSITION:
            if joint.lower is not None:
                value = max(value, joint.lower)
            if joint.upper is not None:
                value = min(value, joint.upper)
            return value
        top = self._limits.get((joint.id, interface), math.inf)
        if interface == VELOCITY:
            top *= abs(joint.scale)
        elif interface == EFFORT:
            top *= torque_constant(joint.model) / abs(joint.scale)
        return min(max(value, -top), top)

    def _read_limits(self) -> None:
        """Each motor's Velocity Limit and Current Limit (SI), where its model has them."""
        for joint in self.system.joints:
            for interface, register in ((VELOCITY, "velocity_limit"),
                                        (EFFORT, "current_limit")):
                if joint.model.has(register):
                    self._limits[(joint.id, interface)] = abs(float(
                        self.bus.read(joint.id, register)))
