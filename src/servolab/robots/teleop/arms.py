"""One arm of a teleoperation rig on its own bus: the joints its URDF's ``<ros2_control>`` block
names (:mod:`servolab.robots.dynamixel_system`: IDs, models, transmissions, limits, the
control-table items to write at start), read and written in joint units (rad; m for a
prismatic joint), one SYNC_READ or SYNC_WRITE for all its motors.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ...dynamixel.errors import DynamixelError
from ..control.dynamixel_hardware import torque_constant
from ..errors import RobotError

if TYPE_CHECKING:
    from ...dynamixel.bus import Bus
    from ..dynamixel_system import DynamixelJoint, DynamixelSystem

#: what a follower's motors are given on top of their block's items: no profile. A
#: teleoperation loop streams goals hundreds of times a second, and an X-series plans a new
#: profile at every Goal Position written (e-Manual, Profile Velocity(112)), from where the
#: horn is: a 20 ms profile restarted every 1.5 ms would never leave the horn, and the joint
#: would hang on its gains. The stream is the trajectory; LeRobot's followers run so too.
STREAMING = (("profile_velocity", 0), ("profile_acceleration", 0))
#: the operating modes that follow a position goal (position, extended, current-based), and
#: Position Control Mode, whose goals the firmware keeps within its position limits
POSITION_MODES = (3, 4, 5)
POSITION_MODE = 3

#: what :meth:`TeleopArm.state` reads, Goal Position to Present Position on the X-series: the
#: goals the motors hold (to check the last ones arrived) and the state
STATE = ("goal_position", "present_current", "present_velocity", "present_position")


@dataclass(frozen=True)
class ArmState:
    """An arm's state in joint units, the joints in the arm's order; ``goals`` are the raw
    Goal Position registers, as the motors hold them."""

    position: tuple[float, ...]
    velocity: tuple[float, ...]
    effort: tuple[float, ...]
    goals: tuple[int, ...]


class TeleopArm:
    """``system``'s joints on ``bus`` (open; the arm closes it). ``role`` (leader, follower)
    names it in errors."""

    def __init__(self, role: str, system: DynamixelSystem, bus: Bus) -> None:
        self.role = role
        self.system = system
        self.bus = bus
        self.joints: tuple[DynamixelJoint, ...] = system.joints
        self.names = tuple(j.name for j in self.joints)
        self.ids = [j.id for j in self.joints]
        #: N m (N) a unit of present current, by joint: the torque constant through the joint
        self._effort = [torque_constant(j.model) / j.scale for j in self.joints]
        self._state_names = list(STATE) if all(j.model.has(r) for j in self.joints
                                               for r in STATE) else None
        #: ID -> (min, max) horn angle (rad) of the motors in Position Control Mode
        self._limits: dict[int, tuple[float, float]] = {}

    def check(self) -> None:
        """Every motor answers and is the model the block names (before anything moves)."""
        for joint in self.joints:
            try:
                found = self.bus.ping(joint.id)
            except DynamixelError as exc:
                raise RobotError(f"{self.role}: joint {joint.name}'s motor (ID {joint.id}) "
                                 f"does not answer on {self.bus.port.name}: "
                                 f"{' '.join(str(exc).split())}") from None
            if found.model is None or found.model.number != joint.model.number:
                what = found.model.name if found.model else f"model {found.model_number}"
                raise RobotError(f"{self.role}: joint {joint.name}'s motor (ID {joint.id}) is "
                                 f"a {what}, not the {joint.model.name} its URDF names")

    def configure(self, *, streaming: bool = False) -> None:
        """Torque off, then the block's control-table items, as ros2_control's plugins write
        them at start (operating mode, gains, profile, drive mode, return delay); with
        ``streaming``, :data:`STREAMING` after them on the joints in a position mode. Then
        the position limits of the motors in Position Control Mode, which :meth:`horns`
        keeps goals within (the firmware refuses a goal past them)."""
        self.torque(False)
        self._limits = {}
        for joint in self.joints:
            for register, value in joint.settings:
                self.bus.write(joint.id, register, value, raw=True)
            mode = (int(self.bus.read(joint.id, "operating_mode", raw=True))
                    if joint.model.has("operating_mode") else POSITION_MODE)
            if streaming and mode in POSITION_MODES:
                for register, value in STREAMING:
                    if joint.model.has(register):
                        self.bus.write(joint.id, register, value, raw=True)
            if mode == POSITION_MODE and joint.model.has("min_position_limit"):
                low, high = (float(self.bus.read(joint.id, r))
                             for r in ("min_position_limit", "max_position_limit"))
                self._limits[joint.id] = (low, high)

    def torque(self, on: bool) -> None:
        self.bus.sync_write("torque_enable", {i: int(on) for i in self.ids})

    def return_delay(self) -> float:
        """The longest return delay of its motors (s), as they are set now."""
        return max(float(self.bus.read(i, "return_delay_time")) for i in self.ids)

    def positions(self) -> list[float]:
        """Each joint's position: one SYNC_READ of Present Position."""
        read = self.bus.sync_read("present_position", self.ids)
        return [j.to_joint(float(read[j.id])) for j in self.joints]

    def state(self) -> ArmState:
        """Position, velocity and effort of each joint and the goals the motors hold: one
        SYNC_READ of :data:`STATE` (a model without those registers: positions only)."""
        if self._state_names is None:
            positions = tuple(self.positions())
            n = len(positions)
            return ArmState(positions, (0.0,) * n, (0.0,) * n, (-1,) * n)
        read = self.bus.sync_read(self._state_names, self.ids, raw=True)
        position, velocity, effort, goals = [], [], [], []
        for joint, per_amp in zip(self.joints, self._effort, strict=True):
            row, motor = read[joint.id], joint.id
            si = {name: float(self.bus.to_si(motor, name, int(row[name])))
                  for name in STATE[1:]}
            position.append(joint.to_joint(si["present_position"]))
            velocity.append(joint.scale * si["present_velocity"])
            effort.append(per_amp * si["present_current"])
            goals.append(int(row["goal_position"]))
        return ArmState(tuple(position), tuple(velocity), tuple(effort), tuple(goals))

    def horns(self, goals: Sequence[float]) -> dict[int, float]:
        """Each motor's goal (rad of horn) for the joints' ``goals``, within its position
        limits."""
        horns = {}
        limits = self._limits
        for joint, goal in zip(self.joints, goals, strict=True):
            horn = joint.to_horn(goal)
            if joint.id in limits:
                low, high = limits[joint.id]
                horn = min(max(horn, low), high)
            horns[joint.id] = horn
        return horns

    def send(self, horns: dict[int, float]) -> None:
        """The goals (:meth:`horns`) in one SYNC_WRITE."""
        self.bus.sync_write("goal_position", horns)

    def goal_ticks(self, horns: dict[int, float]) -> tuple[int, ...]:
        """The raw Goal Position each motor holds once sent ``horns``, in the arm's order."""
        return tuple(self.bus.from_si(i, "goal_position", horns[i]) for i in self.ids)

    def hold(self) -> list[float]:
        """Hold where it is: the goals set to the present positions, torque on. Returns the
        positions held."""
        here = self.positions()
        self.send(self.horns(here))
        self.torque(True)
        return here

    def close(self) -> None:
        self.bus.close()
