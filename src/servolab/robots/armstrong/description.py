"""Armstrong's robot description: one model of the biped of seed 001, from which the URDF
(``/robot_description``, for viewers) and the MJCF (for MuJoCo's physics) are generated.

Why one model: a URDF and an MJCF kept by hand drift apart, and then a viewer shows one robot
while the physics simulates another. Here both are written from :class:`Description`, and the
description takes every fact the seed gives from the module that already holds it:

- the leg's lengths L1..L4, its joint axes and the signs of its motor columns from
  :mod:`servolab.kinematics.leg` (Table 5.2, Table 4.2), so that the model's forward kinematics
  is the code's (the tests check it, joint angle by joint angle);
- the motors' IDs, ``init`` positions and ranges from the robot's configuration
  (``armstrong.yaml``: Table 2.2 and Appendix A) through :mod:`.hardware`;
- which motor turns which joint about which axis from Table 4.1 (:data:`.poses.JOINTS`), the
  stand pose from Table 4.2 (:data:`.poses.STAND_POSE`), the missing camera motor (62) from
  :data:`.hardware.ABSENT`;
- the RX-28's stall torque, no-load speed and default compliance slope from its model table
  (``dynamixel/model_tables/rx-28.yaml``, the e-Manual).

Everything the seed does not give (masses, centres of mass, inertias, hip width, foot size,
the upper body's dimensions) is an :class:`Assumptions` field whose metadata says its unit and
its source, or that it is a guess and why that value; the two placements that are guesses
without a number (a servo's case centred on its joint, on the link nearer the pelvis; the
shoulder's roll motor one servo further out than its pitch motor) say so where they are made.
A link's mass, centre of mass and inertia are not guessed separately: each link is a set of
uniform boxes (its servos at 72 g each and its frame), and they follow from those.

Frames and units: SI (metres, kilograms, radians). Every link frame sits on its joint's axis
and, with all joints at 0, is parallel to the pelvis frame: x forward, y to the robot's left,
z up (REP 103). Joints at 0 are the motors at their ``init`` positions, the pose the robot was
calibrated to stand in (001 section 4.2.3): legs straight; the arms are taken to hang down
(the figures that showed it are lost).

Joint angles: a leg joint's angle is :mod:`servolab.kinematics.leg`'s (``leg_inverse``'s output
is a pose of the model as it stands); an upper-body joint's angle is its motor's. A joint's
``motor.direction`` is the sign between the two: motor angle (``/controller_mXX/command``, the
motion files' degrees) = direction x joint angle. The URDF says it in each joint's
``<transmission>`` (``mechanicalReduction``), the MJCF in each actuator's ``gear``, so an
actuator's control *is* the motor's angle.

Where the seed disagrees with itself: Table 2.2 says motor 11 turns the left hip "inwards"
and motor 21 the right hip "out" when their positions increase, a clockwise turn seen from
above for both; Appendix E (lines 7-8 and 36) turns both counter-clockwise (``m11 = q1``), and
:mod:`servolab.kinematics.leg` follows Appendix E. The seed's gait never turns the hip yaw, so
nothing it does tells them apart; this description takes leg.py's signs (one fact, one place)
and docs/biped.md says so.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from ...configfile import suggest
from ...dynamixel import units
from ...dynamixel.models import model
from ...kinematics.leg import (
    ARMSTRONG_LEG,
    JOINT_NAMES,
    Side,
    foot_position,
    leg_motor_angles,
    leg_transform,
)
from ..controllers.config import RobotConfig
from ..description import (
    Box,
    Contact,
    Drive,
    Drives,
    Joint,
    Keyframe,
    Link,
    Vec3,
    vec3,
)
from ..description import Description as GenericDescription
from ..description import Motor as GenericMotor
from ..description import mjcf as generic_mjcf
from ..description import urdf as generic_urdf
from ..errors import RobotValueError
from .hardware import ABSENT, MODEL, joint_limits, load_config
from .poses import JOINTS, MOTORS, STAND_POSE

MM = 1e-3  # leg.py's lengths are in mm

# -- the RX-28, from the ROBOTIS e-Manual (docs/en/dxl/rx/rx-28.md, "Specifications") -----
# The figures servolab's Dynamixel layer uses (stall torque, speed, register defaults) are in
# the model table; these three only the physics needs, so they live here.
RX28_MASS = 0.072                            # kg: "Weight 72g"
RX28_SIZE: Vec3 = (0.0356, 0.0506, 0.0355)   # m: "Dimensions (W x H x D) 35.6 x 50.6 x 35.5 mm"
RX28_GEAR_RATIO = 193.0                      # "Gear Ratio 193 : 1"

#: Table 4.1 names a joint's motors by the coordinate they move along; the hip's x is m12,
#: which Appendix E and kinematics.leg make the hip *pitch*, its y (m13) the roll, z (m11)
#: the yaw. A joint function with one motor keeps its name (``left_knee``, ``trunk``).
_TABLE_4_1_AXES = {"x": "pitch", "y": "roll", "z": "yaw"}

#: The upper body's motors: the axis (parent frame, joints at 0) about which the motor turns
#: the child, right-handed, as its position increases. From Table 2.2's words, read with the
#: arms hanging down: "Down" of a shoulder's y motor brings the arm in towards the body, "Up"
#: of an elbow bends it (forearm forwards).
_UPPER_BODY_AXES: dict[str, Vec3] = {
    "m51": (0.0, 1.0, 0.0),    # trunk: increasing = "Down", the chest leans forwards
    "m31": (0.0, 1.0, 0.0),    # left shoulder x: "Backwards", the arm swings back
    "m32": (-1.0, 0.0, 0.0),   # left shoulder y: "Down", the arm comes in (hand to -y)
    "m33": (0.0, 1.0, 0.0),    # left elbow: "Down", the forearm straightens (backwards)
    "m41": (0.0, -1.0, 0.0),   # right shoulder x: "Forwards"
    "m42": (-1.0, 0.0, 0.0),   # right shoulder y: "Up", the arm goes out (hand to -y)
    "m43": (0.0, -1.0, 0.0),   # right elbow: "Up", the forearm bends forwards
    "m61": (0.0, 0.0, 1.0),    # neck: "Left", the head turns to the left
    "m62": (0.0, -1.0, 0.0),   # camera: "Up", the camera looks up
}

#: Colours of the boxes (URDF materials, MJCF materials), by what the box is.
MATERIALS: dict[str, tuple[float, float, float, float]] = {
    "servo": (0.15, 0.15, 0.15, 1.0),
    "frame": (0.75, 0.75, 0.78, 1.0),
    "sole": (0.85, 0.45, 0.10, 1.0),
    "camera": (0.10, 0.30, 0.70, 1.0),
}


def _assumed(default: float, unit: str, source: str, *, signed: bool = False) -> float:
    """A field of :class:`Assumptions`: its unit and where its value comes from travel with it
    (``dataclasses.fields(Assumptions)[i].metadata``), so a table of them can be printed."""
    value: float = field(default=default, metadata={"unit": unit, "source": source,
                                                    "signed": signed})
    return value


@dataclass(frozen=True)
class Assumptions:
    """Every quantity of the model the seed does not give. Change one with
    ``dataclasses.replace(Assumptions(), hip_width=0.12)``; a value that cannot be is refused
    at once, in one line naming it."""

    # -- lengths (m): the figures that showed the robot (001 Figures 2.7, 4.3-4.6, 5.1-5.5)
    #    are lost, so every one is a guess
    hip_width: float = _assumed(
        0.100, "m", "guess: between the hip-yaw axes; two RX-28 (35.6 mm wide) side by side "
        "with their brackets need ~75 mm, and the seed's gait brings the feet's centres to "
        "hip width - 19 mm (Appendix D, y = ±9.5 mm), which 70 mm feet must clear")
    foot_length: float = _assumed(
        0.120, "m", "guess: about 0.4 of the 310 mm leg, three times the step's 40 mm")
    foot_width: float = _assumed(
        0.070, "m", "guess: two RX-28 widths, leaving 11 mm between the feet at their closest "
                    "in the seed's gait")
    foot_thickness: float = _assumed(0.005, "m", "guess: the sole plate")
    foot_forward: float = _assumed(
        0.0, "m", "guess: the foot's centre ahead of the ankle axis (0: centred under it)",
        signed=True)
    limb_section: float = _assumed(
        0.030, "m", "guess: the square cross-section of the thigh, shank and arm frames")
    pelvis_depth: float = _assumed(0.050, "m", "guess: the pelvis frame's length front to back")
    trunk_height: float = _assumed(
        0.040, "m", "guess: from the hip-yaw axes' height up to the trunk axis (m51)")
    chest_depth: float = _assumed(0.060, "m", "guess: the chest's length front to back")
    shoulder_height: float = _assumed(
        0.110, "m", "guess: from the trunk axis up to the shoulder axes")
    shoulder_width: float = _assumed(
        0.180, "m", "guess: between the two shoulder-pitch motors (m31, m41)")
    upper_arm: float = _assumed(0.100, "m", "guess: shoulder to elbow, as the thigh (L2)")
    forearm: float = _assumed(0.100, "m", "guess: elbow to the hand's end")
    neck_height: float = _assumed(
        0.140, "m", "guess: from the trunk axis up to the neck motor (m61), above the "
                    "shoulders")
    camera_height: float = _assumed(
        0.030, "m", "guess: neck axis to the camera's tilt axis (m62)")
    head_size: float = _assumed(0.040, "m", "guess: the camera's housing, a cube")
    # -- masses (kg) of everything but the 21 RX-28 (72 g each, the e-Manual)
    pelvis_mass: float = _assumed(0.100, "kg", "guess: the hip plate and brackets")
    chest_mass: float = _assumed(
        0.200, "kg", "guess: the chest frame, the USB-RS485 adapter and cables; a Raspberry "
                     "Pi (the seed's target computer, about 45 g) would sit here too")
    thigh_mass: float = _assumed(0.040, "kg", "guess: two aluminium side plates, 100 mm")
    shank_mass: float = _assumed(0.040, "kg", "guess: as the thigh")
    foot_mass: float = _assumed(0.060, "kg", "guess: the sole plate and the ankle bracket")
    upper_arm_mass: float = _assumed(0.020, "kg", "guess: brackets")
    forearm_mass: float = _assumed(0.030, "kg", "guess: brackets and the hand")
    head_mass: float = _assumed(0.050, "kg", "guess: the camera and its mount")
    # -- the servos' drive
    rotor_inertia: float = _assumed(
        1.0e-7, "kg m²", "guess: the order of a small coreless motor's rotor (the e-Manual "
                         "gives none); times the gear ratio (193) squared it is the joint's "
                         "armature")
    gear_friction: float = _assumed(
        0.1, "N m", "guess: the torque that turns an RX-28's 193:1 metal gear train from its "
                    "horn with the motor off (ROBOTIS give none): what holds a joint whose "
                    "torque is off; about 3 % of the stall torque, as the firmware's punch")

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            signed = bool(f.metadata["signed"])
            number = isinstance(value, int | float) and not isinstance(value, bool)
            if not number or not math.isfinite(value) or (not signed and value <= 0):
                kind = "a finite number" if signed else "a positive, finite number"
                raise RobotValueError(f"Armstrong's description: assumption {f.name} = "
                                      f"{value!r} {f.metadata['unit']} must be {kind}")
        if self.foot_width >= self.hip_width:
            raise RobotValueError(
                f"Armstrong's description: foot_width {self.foot_width:g} m is not less than "
                f"hip_width {self.hip_width:g} m: the feet would overlap standing straight")
        sole_to_ankle = ARMSTRONG_LEG.l4 * MM
        if self.foot_thickness >= sole_to_ankle:
            raise RobotValueError(
                f"Armstrong's description: foot_thickness {self.foot_thickness:g} m does not "
                f"fit under the ankle axis, L4 = {sole_to_ankle:g} m above the sole (Table 5.2)")

    @classmethod
    def with_values(cls, values: Mapping[str, float]) -> Assumptions:
        """The stated assumptions with ``values`` (name -> number, in the field's unit) put
        in their place: an unknown name is refused with the names it may have meant."""
        names = [f.name for f in fields(cls)]
        for name in values:
            if name not in names:
                raise RobotValueError(_unknown("assumption", name, names).replace(
                    "Armstrong has no", "Armstrong's description has no"))
        return cls(**dict(values))

    def table(self) -> Iterator[tuple[str, float, str, str]]:
        """(name, value, unit, source) of every assumption, in order."""
        for f in fields(self):
            yield f.name, getattr(self, f.name), str(f.metadata["unit"]), str(f.metadata["source"])


@dataclass(frozen=True)
class Motor(GenericMotor):
    """The RX-28 that turns a joint: its ID (Table 2.2, Appendix A), motor angle = direction x
    joint angle (+1 or -1), Table 4.1's joint function and coordinate (``"left_hip x"``), and
    whether it is on the bus (motor 62 is not, 001 Figure 3.4)."""

    function: str = ""
    on_bus: bool = True

    @property
    def column(self) -> str:
        """The motion files' column and the controller's suffix (``m14``)."""
        return self.actuator


@dataclass(frozen=True)
class Description(GenericDescription):
    """Armstrong as one tree of links and joints, rooted at the pelvis, with the assumptions
    it was built under."""

    assumptions: Assumptions = field(default_factory=Assumptions)

    @property
    def motors(self) -> tuple[tuple[Joint, GenericMotor], ...]:
        """The 21 joints with a motor and their motors, in the order of the motion files'
        columns."""
        by_column = {j.motor.actuator: (j, j.motor) for j in self.joints
                     if j.motor is not None}
        return tuple(by_column[c] for c in MOTORS)

    def mjcf(self, drive: Drives = "position", **options: Any) -> str:
        """Armstrong's MJCF (:func:`mjcf`: a floor, the pelvis free at standing height, the
        stand keyframe); with ``options``, the generic writer's (:func:`~servolab.robots.
        description.mjcf`) instead."""
        return generic_mjcf(self, drive, **options) if options else mjcf(self, drive)

    def motor(self, joint: Joint) -> Motor:
        """``joint``'s motor, with Armstrong's facts (function, on the bus)."""
        if not isinstance(joint.motor, Motor):
            raise RobotValueError(f"Armstrong's joint {joint.name!r} has no motor")
        return joint.motor

    def joint_positions(self, pose: Mapping[str, float]) -> dict[str, float]:
        """A pose of motor columns in degrees (Table 4.2, a motion file's row) as joint
        angles in radians, by joint name; columns the pose leaves out are 0."""
        unknown = sorted(set(pose) - set(MOTORS))
        if unknown:
            raise RobotValueError(_unknown("motor column", unknown[0], MOTORS))
        return {j.name: motor.direction * math.radians(pose.get(motor.actuator, 0.0))
                for j, motor in self.motors}

    def leg_joints(self, positions: Mapping[str, float], side: str) -> np.ndarray:
        """One leg's joint angles, ordered as ``kinematics.leg.JOINT_NAMES``."""
        return np.array([positions.get(f"{side}_{n}", 0.0) for n in JOINT_NAMES])

    def standing_height(self, pose: Mapping[str, float]) -> float:
        """How high the pelvis frame stands above the floor (m) in a pose of motor columns
        (degrees), pelvis upright: above the lower sole, by leg.py's forward kinematics."""
        positions = self.joint_positions(pose)
        soles = [foot_position(self.leg_joints(positions, side))[2] for side in ("left", "right")]
        return -float(min(soles)) * MM


def _unknown(what: str, name: str, known: list[str] | tuple[str, ...]) -> str:
    close = suggest(name, known)
    return f"Armstrong has no {what} {name!r}" + (f" (did you mean {close!r}?)" if close else "")


def _servo(name: str, pos: Vec3, axis: Vec3) -> Box:
    """An RX-28 centred on its joint's axis at ``pos`` (a guess: the case's mounting is not in
    the seed), its depth D along the axis and its height H upright (along x for a vertical
    axis), on the link its case is fixed to: the one on the torso's side of the joint."""
    w, h, d = RX28_SIZE
    along = int(np.argmax(np.abs(axis)))
    size = [w, w, w]
    size[along] = d
    size[2 if along != 2 else 0] = h
    return Box(name, vec3(size), pos, mass=RX28_MASS, material="servo")


def _leg_axes() -> list[Vec3]:
    """Each leg joint's axis, read off kinematics.leg's DH chain: turning joint j alone by a
    quarter turn rotates the sole's frame about that axis, so leg.py and the model cannot
    disagree on it (nor on its sign)."""
    zero = leg_transform(np.zeros(6))[:3, :3]
    axes = []
    for j in range(6):
        q = np.zeros(6)
        q[j] = math.pi / 2
        turn = leg_transform(q)[:3, :3] @ zero.T
        axis = np.array([turn[2, 1] - turn[1, 2], turn[0, 2] - turn[2, 0],
                         turn[1, 0] - turn[0, 1]]) / 2.0
        axes.append(vec3(np.round(axis, 12) + 0.0))
    return axes


def _leg_direction(side: Side, joint: int, column: str) -> int:
    """The sign of motor ``column`` against leg joint ``joint``, from leg.py's motor map
    (Table 4.2's signs); Table 4.1 and leg.py must agree on which column that is."""
    unit = leg_motor_angles(np.radians(np.eye(6)), side)   # row j: joint j at 1 degree
    index = int(column[2]) - 1                             # m?1..m?6 -> 0..5
    sign = round(float(unit[joint, index]))
    if sign not in (-1, 1):
        raise RobotValueError(f"Table 4.1 gives {column} to the {side} {JOINT_NAMES[joint]}, "
                              "kinematics.leg another motor")
    return sign


def _functions() -> dict[str, tuple[str, str]]:
    """Motor column -> (joint name, Table 4.1's function and coordinate)."""
    names = {}
    for function, axes in JOINTS.items():
        for coordinate, column in axes.items():
            name = function if len(axes) == 1 else f"{function}_{_TABLE_4_1_AXES[coordinate]}"
            names[column] = (name, f"{function} {coordinate}")
    return names


def describe(assumptions: Assumptions | None = None,
             config: RobotConfig | None = None) -> Description:
    """Armstrong's description under ``assumptions`` (the stated defaults if None), with the
    motors' IDs and ranges of ``config`` (the shipped ``armstrong.yaml`` if None)."""
    a = assumptions if assumptions is not None else Assumptions()
    config = config if config is not None else load_config()
    limits = joint_limits(config)  # degrees of each motor column, as its controller clamps
    missing = [c for c in MOTORS if c not in limits]
    if missing:
        raise RobotValueError(f"{config.path or 'the configuration'}: no controller for motor "
                              f"{', '.join(missing)}; Armstrong has all of {', '.join(MOTORS)}")
    rx28 = model(MODEL)
    slope = rx28.register("cw_compliance_slope").default
    if not slope:
        raise RobotValueError(f"the {MODEL}'s model table gives no default compliance slope")
    drive = Drive(
        stall_torque=rx28.stall_torque_nm,
        no_load_speed=rx28.no_load_speed,
        kp=rx28.stall_torque_nm / (slope * rx28.rad_per_tick),
        damping=rx28.stall_torque_nm / rx28.no_load_speed,
        armature=a.rotor_inertia * RX28_GEAR_RATIO**2,
        friction=a.gear_friction)
    functions = _functions()
    boxes: dict[str, list[Box]] = {}
    joints: list[Joint] = []

    def add(column: str | None, parent: str, child: str, origin: Vec3,
            axis: Vec3 = (0.0, 0.0, 1.0), direction: int = 1) -> None:
        """Joint ``parent`` -> ``child`` (fixed without a motor column); a motor's joint also
        puts the servo's case on the parent, centred on the joint."""
        boxes.setdefault(child, [])
        if column is None:
            joints.append(Joint(f"{child}_joint", "fixed", parent, child, origin))
            return
        joint_name, function = functions[column]
        ends = sorted(direction * math.radians(v) for v in limits[column])
        motor = Motor(int(column[1:]), MODEL, direction, function=function,
                      on_bus=int(column[1:]) not in ABSENT)
        joints.append(Joint(joint_name, "revolute", parent, child, origin, axis, ends[0],
                            ends[1], motor, effort=drive.stall_torque,
                            velocity=drive.no_load_speed, damping=drive.damping,
                            friction=drive.friction))
        boxes.setdefault(parent, []).append(_servo(f"{column}_servo", origin, axis))

    def frame(link: str, name: str, size: Vec3, pos: Vec3, mass: float,
              material: str = "frame", contact: Contact = "floor") -> None:
        boxes.setdefault(link, []).append(Box(f"{link}_{name}", size, pos, mass=mass,
                                              material=material, contact=contact))

    # the pelvis: both hip-yaw motors and the trunk's motor sit on it
    boxes["pelvis"] = []
    frame("pelvis", "frame", (a.pelvis_depth, a.hip_width + RX28_SIZE[0], a.trunk_height),
          (0.0, 0.0, a.trunk_height / 2), a.pelvis_mass)
    l1, l2, l3, l4 = (v * MM for v in (ARMSTRONG_LEG.l1, ARMSTRONG_LEG.l2, ARMSTRONG_LEG.l3,
                                       ARMSTRONG_LEG.l4))
    axes = _leg_axes()
    section = a.limb_section
    column_of = {name: column for column, (name, _) in functions.items()}
    sides: tuple[tuple[Side, float], ...] = (("left", a.hip_width / 2),
                                             ("right", -a.hip_width / 2))
    for side, y in sides:
        chain = [  # leg.py's joints in its order: (parent link, child link, origin)
            ("pelvis", f"{side}_hip_yaw_link", (0.0, y, 0.0)),
            (f"{side}_hip_yaw_link", f"{side}_hip_roll_link", (0.0, 0.0, -l1)),
            (f"{side}_hip_roll_link", f"{side}_thigh", (0.0, 0.0, 0.0)),
            (f"{side}_thigh", f"{side}_shank", (0.0, 0.0, -l2)),
            (f"{side}_shank", f"{side}_ankle_link", (0.0, 0.0, -l3)),
            (f"{side}_ankle_link", f"{side}_foot", (0.0, 0.0, 0.0)),
        ]
        for j, (parent, child, origin) in enumerate(chain):
            column = column_of[f"{side}_{JOINT_NAMES[j]}"]
            add(column, parent, child, origin, axes[j], _leg_direction(side, j, column))
        frame(f"{side}_thigh", "frame", (section, section, l2), (0.0, 0.0, -l2 / 2),
              a.thigh_mass)
        frame(f"{side}_shank", "frame", (section, section, l3), (0.0, 0.0, -l3 / 2),
              a.shank_mass)
        frame(f"{side}_foot", "sole", (a.foot_length, a.foot_width, a.foot_thickness),
              (a.foot_forward, 0.0, -l4 + a.foot_thickness / 2), a.foot_mass, "sole", "all")
        add(None, f"{side}_foot", f"{side}_sole", (0.0, 0.0, -l4))   # the IK's target point

    # the upper body: the trunk joint, the chest with the shoulders and the neck; which motor
    # is which joint is Table 4.1's, which way it turns Table 2.2's (_UPPER_BODY_AXES)
    def upper(name: str, parent: str, child: str, origin: Vec3) -> None:
        column = column_of[name]
        add(column, parent, child, origin, _UPPER_BODY_AXES[column])

    upper("trunk", "pelvis", "chest", (0.0, 0.0, a.trunk_height))
    # as wide as the shoulder motors' inner faces (their depth lies along y)
    frame("chest", "frame", (a.chest_depth, a.shoulder_width - RX28_SIZE[2], a.neck_height),
          (0.0, 0.0, a.neck_height / 2), a.chest_mass)
    for side, sign in (("left", 1.0), ("right", -1.0)):
        shoulder, arm, forearm = (f"{side}_shoulder_link", f"{side}_upper_arm",
                                  f"{side}_forearm")
        upper(f"{side}_shoulder_pitch", "chest", shoulder,
              (0.0, sign * a.shoulder_width / 2, a.shoulder_height))
        # the roll motor beside the pitch motor, one servo's depth further out (a guess)
        upper(f"{side}_shoulder_roll", shoulder, arm, (0.0, sign * RX28_SIZE[2], 0.0))
        frame(arm, "frame", (section, section, a.upper_arm), (0.0, 0.0, -a.upper_arm / 2),
              a.upper_arm_mass)
        upper(f"{side}_elbow", arm, forearm, (0.0, 0.0, -a.upper_arm))
        frame(forearm, "frame", (section, section, a.forearm), (0.0, 0.0, -a.forearm / 2),
              a.forearm_mass)
    upper("neck", "chest", "neck_link", (0.0, 0.0, a.neck_height))
    upper("camera", "neck_link", "head", (0.0, 0.0, a.camera_height))
    frame("head", "camera", (a.head_size,) * 3, (0.0, 0.0, a.head_size / 2), a.head_mass,
          "camera")

    links = tuple(Link(name, tuple(parts)) for name, parts in boxes.items())
    return Description("armstrong", "pelvis", links, tuple(joints), drive, MATERIALS, _HEADER,
                       assumptions=a)


@dataclass(frozen=True)
class HornMap:
    """How one joint turns its motor's horn: ``horn = offset + sign x joint angle`` (rad),
    ``offset`` the motor's ``init`` as a horn angle (0 at the RX-28's centre tick, what the
    firmware counts), ``sign`` its ``direction`` (the description's: motor angle = direction
    x joint angle) times its controller's ``flip`` (the configuration's: horn = init + flip x
    motor angle). The emulated robot's worlds turn their joints by it (:mod:`.physics`), and
    the ``<ros2_control>`` block states it (:mod:`.ros2_control`)."""

    joint: str
    column: str
    id: int
    offset: float
    direction: int
    flip: int

    @property
    def sign(self) -> int:
        return self.direction * self.flip


def horn_maps(description: Description, config: RobotConfig) -> dict[str, HornMap]:
    """Each joint whose motor is on the bus, by joint name, in the motion files' column
    order: how its horn follows it, from ``description``'s directions and ``config``'s
    ``init`` and flips."""
    rx28 = model(MODEL)
    position = rx28.register("goal_position")
    controllers = {c.motor.id: c.motor for c in config.controllers}
    maps = {}
    for joint, motor in description.motors:
        if not description.motor(joint).on_bus:
            continue
        if motor.id not in controllers:
            raise RobotValueError(f"no controller for motor {motor.id} ({joint.name}) in "
                                  f"{config.path or 'the configuration'}")
        raw = controllers[motor.id]
        maps[joint.name] = HornMap(joint.name, motor.actuator, motor.id,
                                   float(units.to_si(rx28, position, raw.init)),
                                   motor.direction, -1 if raw.flipped else 1)
    return maps


# -- the generated files ----------------------------------------------------------------------

_HEADER = ("Generated by servolab.robots.armstrong.description from seed 001 (Tables 2.2, 4.1, "
           "4.2, 5.2, Appendix A), the RX-28's e-Manual and the stated assumptions; do not "
           "edit: change the description and generate it again.")


def urdf(description: Description) -> str:
    """The URDF (:func:`servolab.robots.description.urdf`): links with inertial, visual and
    (for boxes that touch anything) collision boxes; revolute joints with the motor's range,
    the RX-28's stall torque and no-load speed as limits and its back-EMF damping; a
    ``<transmission>`` per motor joint whose actuator is the motor column (``m14``) and whose
    ``mechanicalReduction`` is the motor's direction."""
    return generic_urdf(description)


#: the physics step (s): MuJoCo's default, 2 ms, and the step the emulated robot's
#: Simulation takes in the MuJoCo world (:mod:`.physics`): the firmware's law runs once a
#: step, 500 times a second; at 1 ms the run costs twice as much for no visible difference
#: in the gaits (the joints' fastest dynamics, armature against the compliance slope, has a
#: period of about 80 ms)
TIMESTEP = 0.002


def mjcf(description: Description, drive: Drives = "position") -> str:
    """The MJCF for MuJoCo (:func:`servolab.robots.description.mjcf`): angles in radians, a
    floor, the pelvis free above it on straight legs, and a ``stand`` keyframe: Table 4.2's
    pose with its soles on the floor.

    ``drive="position"``: a position actuator per motor joint named by its column whose
    control is the motor's angle (``gear`` = direction) within the motor's range and whose
    force is limited to the RX-28's stall torque, the back-EMF as the joints' damping.
    ``drive="firmware"``: no actuators and no damping — the world's firmware law gives the
    torque, back-EMF included — and a joint whose motor is not on the bus (m62) welded, as a
    joint nothing turns holds by its gears' friction on the real robot."""
    d = description
    welded = frozenset(j.name for j, _ in d.motors
                       if drive == "firmware" and not d.motor(j).on_bus)
    stand = Keyframe("stand", d.joint_positions(STAND_POSE), d.standing_height(STAND_POSE))
    return generic_mjcf(d, drive, floor=True, free_base=True,
                        base_height=d.standing_height({}), keyframes=(stand,), welded=welded,
                        timestep=TIMESTEP)


def stand_com_offset(description: Description) -> tuple[float, float]:
    """Where the whole robot's centre of mass sits ahead of and to the left of the pelvis
    frame (m) in Table 4.2's stand pose (the trunk leans 25 degrees forwards): what a
    walking-pattern generator that plans the centre of mass must add to place the pelvis.
    MuJoCo computes it from the MJCF's ``stand`` keyframe."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(mjcf(description))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("stand").id)
    mujoco.mj_forward(model, data)
    pelvis = model.body(description.root).id
    x, y, _ = (float(v) for v in data.subtree_com[pelvis] - data.xpos[pelvis])
    return x, y


def assumptions_table(assumptions: Assumptions | None = None) -> str:
    """Every assumption with its value, unit and source, as ``servolab robots show
    armstrong.assumptions`` prints it: the names ``servolab walk --assume NAME=VALUE``
    takes."""
    a = assumptions if assumptions is not None else Assumptions()
    rows = ["# Armstrong's description: what seed 001 does not give, and the values taken "
            "(SI units; servolab walk --world mujoco --assume NAME=VALUE changes one)"]
    for name, value, unit, source in a.table():
        rows.append(f"{name} = {value:g} {unit}  # {source}")
    return "\n".join(rows) + "\n"


#: What :func:`model_file` writes.
FORMATS = ("urdf", "mjcf")


def model_file(kind: str, assumptions: Assumptions | None = None) -> str:
    """The text of Armstrong's ``urdf`` or ``mjcf`` under ``assumptions``: what a command
    prints or saves (``python -c "from servolab.robots.armstrong.description import
    model_file; print(model_file('urdf'))" > armstrong.urdf``)."""
    if kind not in FORMATS:
        close = suggest(kind, FORMATS)
        raise RobotValueError(f"no model format {kind!r}: one of {', '.join(FORMATS)}"
                              + (f" (did you mean {close!r}?)" if close else ""))
    description = describe(assumptions)
    return urdf(description) if kind == "urdf" else mjcf(description)
