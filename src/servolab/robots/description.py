"""A robot's description: one model of links and joints from which its URDF (for viewers and
``/robot_description``) and its MJCF (for MuJoCo's physics) are written, and into which a
URDF is read.

Why one model: a URDF and an MJCF kept by hand drift apart, and then a viewer shows one robot
while the physics simulates another. A robot built in Python (Armstrong, :mod:`.armstrong.
description`) fills a :class:`Description` from its facts; a robot that is only data (a URDF
in a folder) is read with :meth:`Description.from_urdf`. Both are then written the same way.

What it holds: links with their inertials and simple shapes (boxes, cylinders, spheres;
meshes are kept for the URDF, not written into the MJCF), joints of every kind servolab's
worlds can drive — revolute, continuous, prismatic, fixed — with their limits and
``<mimic>``, and the Dynamixel motors that turn them (model, ID, direction, gear ratio).
Floating and planar joints are refused: no servo drives them.

Conventions are the URDF's (wiki.ros.org/urdf/XML): SI units, a joint's ``<origin>`` places
the child frame in the parent's (``xyz``, then ``rpy`` about the fixed axes), its ``<axis>``
is in the child frame, its position is radians (revolute, continuous) or metres (prismatic),
and a mimic joint's position is ``multiplier x leader + offset``. A motor turns its joint
through a transmission (ros_control's SimpleTransmission): horn angle = ``direction x
gear_ratio x`` joint position, so a rack-and-pinion gripper's prismatic joint (metres) driven
by a pinion of radius r has ``gear_ratio = 1 / r`` (radians of horn a metre).

The MJCF writer assumes neither a floating base nor a floor: :func:`mjcf` fixes the root link
to the world unless told ``free_base=True`` (then it stands at ``base_height``), and writes a
floor plane only when told ``floor=True``.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Collection, Iterable, Mapping
from dataclasses import KW_ONLY, dataclass, field, replace
from typing import Any, Literal

import numpy as np

from ..configfile import suggest
from ..limits import InputLimits, clip, quoted
from .errors import RobotValueError

Vec3 = tuple[float, float, float]
RGBA = tuple[float, float, float, float]
JointKind = Literal["revolute", "continuous", "prismatic", "fixed"]
#: The joint kinds a servo can drive (and a fixed joint): the URDF's other two, floating and
#: planar, have no single position.
JOINT_KINDS: tuple[JointKind, ...] = ("revolute", "continuous", "prismatic", "fixed")
#: The joints that move: robot_state_publisher puts these on /tf, the rest on /tf_static.
MOVABLE: tuple[JointKind, ...] = ("revolute", "continuous", "prismatic")
#: What a shape touches in the physics: nothing (seen only), the floor (a fall lands on it),
#: or everything (a sole, a gripper's finger).
Contact = Literal["none", "floor", "all"]
ZERO: Vec3 = (0.0, 0.0, 0.0)


# -- shapes -------------------------------------------------------------------------------------

def _rotation(rpy: Vec3) -> np.ndarray:
    """The URDF's ``rpy``: roll about x, pitch about y, yaw about z, about the fixed axes."""
    roll, pitch, yaw = rpy
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch),
                              math.sin(pitch), math.cos(yaw), math.sin(yaw))
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def _turned(tensor: np.ndarray, rpy: Vec3) -> np.ndarray:
    """An inertia tensor given in a frame turned by ``rpy``, in the unturned frame."""
    if rpy == ZERO:
        return tensor
    r = _rotation(rpy)
    return np.asarray(r @ tensor @ r.T)


@dataclass(frozen=True)
class _Shape:
    """What every shape has: a name, and (by keyword) its mass (kg; 0 where the link's
    ``<inertial>`` says it), material (a key of the description's materials), what it touches,
    its turn in the link frame (``rpy``) and whether it is seen (False: collision only)."""

    name: str
    _: KW_ONLY
    mass: float = 0.0
    material: str = ""
    contact: Contact = "none"
    rpy: Vec3 = ZERO
    visual: bool = True


@dataclass(frozen=True)
class Box(_Shape):
    """A uniform solid box in its link's frame: one piece of the link's shape and (if it has a
    mass) of its inertia."""

    size: Vec3          # full extents along x, y, z (m); the MJCF takes half of them
    pos: Vec3           # centre in the link frame (m)

    @property
    def inertia(self) -> np.ndarray:
        """The inertia tensor (kg m²) about the box's centre, in the link's axes."""
        x, y, z = self.size
        tensor = np.diag([y * y + z * z, x * x + z * z, x * x + y * y]) * self.mass / 12.0
        return _turned(tensor, self.rpy)


@dataclass(frozen=True)
class Cylinder(_Shape):
    """A uniform solid cylinder along its own z axis (as the URDF's and MJCF's are)."""

    radius: float
    length: float
    pos: Vec3

    @property
    def inertia(self) -> np.ndarray:
        r2, h2 = self.radius ** 2, self.length ** 2
        side = self.mass * (3 * r2 + h2) / 12.0
        return _turned(np.diag([side, side, self.mass * r2 / 2.0]), self.rpy)


@dataclass(frozen=True)
class Sphere(_Shape):
    """A uniform solid sphere."""

    radius: float
    pos: Vec3

    @property
    def inertia(self) -> np.ndarray:
        return np.eye(3) * 2.0 * self.mass * self.radius ** 2 / 5.0


@dataclass(frozen=True)
class Mesh(_Shape):
    """A mesh file (``package://...``): kept for the URDF and the viewers; the MJCF leaves it
    out (its inertia is the link's ``<inertial>``, its shape would need the file)."""

    filename: str
    pos: Vec3 = ZERO
    scale: Vec3 = (1.0, 1.0, 1.0)

    @property
    def inertia(self) -> np.ndarray:
        return np.zeros((3, 3))


Shape = Box | Cylinder | Sphere | Mesh


@dataclass(frozen=True)
class Inertial:
    """A link's mass, centre of mass (link frame) and inertia tensor about that centre."""

    mass: float
    com: Vec3
    inertia: tuple[tuple[float, float, float], ...]

    @property
    def six(self) -> tuple[float, float, float, float, float, float]:
        """``ixx iyy izz ixy ixz iyz``, the tensor's elements as the URDF and MJCF name them."""
        i = self.inertia
        return i[0][0], i[1][1], i[2][2], i[0][1], i[0][2], i[1][2]


NO_MASS = Inertial(0.0, ZERO, ((0.0,) * 3,) * 3)


@dataclass(frozen=True)
class Link:
    """A rigid body: its shapes, and its inertial — given (a URDF's ``<inertial>``) or, when
    not, made from the shapes' masses. A link with neither is a frame only (a sole, a tool
    centre point)."""

    name: str
    shapes: tuple[Shape, ...] = ()
    given_inertial: Inertial | None = None

    @property
    def boxes(self) -> tuple[Box, ...]:
        return tuple(s for s in self.shapes if isinstance(s, Box))

    @property
    def mass(self) -> float:
        return self.inertial.mass

    @property
    def inertial(self) -> Inertial:
        """The given one, else from the shapes: the centre of their masses, and their
        inertias moved to it (parallel-axis theorem)."""
        if self.given_inertial is not None:
            return self.given_inertial
        solid = [s for s in self.shapes if s.mass > 0]
        if not solid:
            return NO_MASS
        masses = np.array([s.mass for s in solid])
        centres = np.array([s.pos for s in solid])
        com = masses @ centres / masses.sum()
        tensor = np.zeros((3, 3))
        for shape, centre in zip(solid, centres, strict=True):
            d = centre - com
            tensor += shape.inertia + shape.mass * (d @ d * np.eye(3) - np.outer(d, d))
        return Inertial(float(masses.sum()), vec3(com), tuple(vec3(row) for row in tensor))


# -- joints and motors --------------------------------------------------------------------------

@dataclass(frozen=True)
class Mimic:
    """A joint that follows another (URDF ``<mimic>``, as robot_state_publisher and
    ros2_control read it): position = ``multiplier`` x the leader's + ``offset``."""

    joint: str
    multiplier: float = 1.0
    offset: float = 0.0


@dataclass(frozen=True)
class Motor:
    """The Dynamixel that turns a joint: its model (as servolab's model tables name it,
    ``XM430-W350``), its ID, and the transmission between its horn and the joint: horn angle
    (rad) = ``direction`` x ``gear_ratio`` x joint position (rad or m). ``name`` is the
    actuator's (the URDF transmission's, the MJCF actuator's): ``m<id>`` unless given."""

    id: int
    model: str = ""
    direction: int = 1
    gear_ratio: float = 1.0
    name: str = ""

    @property
    def actuator(self) -> str:
        return self.name or f"m{self.id}"

    @property
    def reduction(self) -> float:
        """SimpleTransmission's ``mechanicalReduction``: actuator = reduction x joint."""
        return self.direction * self.gear_ratio


@dataclass(frozen=True)
class Joint:
    """A joint from ``parent`` to ``child`` (see the module docstring for its conventions).
    ``lower``/``upper`` are None where the joint is unbounded (continuous, fixed);
    ``effort``/``velocity``/``damping``/``friction`` the URDF's ``<limit>`` and
    ``<dynamics>`` (None: not stated); ``armature`` the reflected rotor inertia (MJCF only)."""

    name: str
    kind: JointKind
    parent: str
    child: str
    origin: Vec3 = ZERO
    #: positive positions turn right-handed about it (slide along it); the URDF's default
    axis: Vec3 = (1.0, 0.0, 0.0)
    lower: float | None = None
    upper: float | None = None
    motor: Motor | None = None
    rpy: Vec3 = ZERO
    effort: float | None = None
    velocity: float | None = None
    damping: float | None = None
    friction: float | None = None
    armature: float | None = None
    mimic: Mimic | None = None

    @property
    def movable(self) -> bool:
        return self.kind in MOVABLE


@dataclass(frozen=True)
class Drive:
    """What every joint's servo gives the physics when they are all one model (written as the
    MJCF's defaults); a robot of mixed servos leaves it out and states them per joint."""

    stall_torque: float     # N m: the most a position actuator may push (forcerange)
    no_load_speed: float    # rad/s
    #: N m/rad: a position actuator's stiffness
    kp: float
    #: N m s/rad: a DC motor's back-EMF (stall torque / no-load speed)
    damping: float
    armature: float         # kg m²: rotor inertia x gear ratio²
    friction: float = 0.0   # N m: the gear train's dry friction, torque on or off


@dataclass(frozen=True)
class Keyframe:
    """A named pose for the MJCF: joint positions (rad or m, by joint name; mimic joints
    follow their leaders, the rest 0) and, with a free base, its height (m)."""

    name: str
    positions: Mapping[str, float]
    base_height: float = 0.0


@dataclass(frozen=True)
class Description:
    """A robot as one tree of links and joints from ``root``; ``materials`` name colours,
    ``drive`` is the shared servo drive (or None), ``comment`` heads the generated files."""

    name: str
    root: str
    links: tuple[Link, ...]
    joints: tuple[Joint, ...]
    drive: Drive | None = None
    materials: Mapping[str, RGBA] = field(default_factory=dict)
    comment: str = ""

    @classmethod
    def from_urdf(cls, text: str, source: str = "<urdf>") -> Description:
        """The description a URDF states (see :func:`read_urdf`)."""
        return read_urdf(text, source)

    def urdf(self) -> str:
        """This description as a URDF (:func:`urdf`)."""
        return urdf(self)

    def mjcf(self, drive: Drives = "position", **options: Any) -> str:
        """This description as an MJCF (:func:`mjcf`: ``floor``, ``free_base``, ...)."""
        return mjcf(self, drive, **options)

    def link(self, name: str) -> Link:
        for link in self.links:
            if link.name == name:
                return link
        raise RobotValueError(self._unknown("link", name, [k.name for k in self.links]))

    def joint(self, name: str) -> Joint:
        for joint in self.joints:
            if joint.name == name:
                return joint
        raise RobotValueError(self._unknown("joint", name, [j.name for j in self.joints]))

    def _unknown(self, what: str, name: str, known: list[str]) -> str:
        close = suggest(name, known)
        return f"{self.name} has no {what} {name!r}" + (f" (did you mean {close!r}?)"
                                                         if close else "")

    def children(self, link: str) -> tuple[Joint, ...]:
        return tuple(j for j in self.joints if j.parent == link)

    @property
    def motors(self) -> tuple[tuple[Joint, Motor], ...]:
        """The joints a motor turns, with their motors, in the joints' order."""
        return tuple((j, j.motor) for j in self.joints if j.motor is not None)

    @property
    def total_mass(self) -> float:
        return sum(link.mass for link in self.links)

    def with_motors(self, motors: Mapping[str, Motor]) -> Description:
        """This description with ``motors`` (joint name -> motor) on their joints, as a
        ``<ros2_control>`` block assigns them; an unknown or fixed joint is refused."""
        for name in motors:
            joint = self.joint(name)
            if not joint.movable or joint.mimic is not None:
                raise RobotValueError(f"{self.name}: joint {name!r} is {joint.kind}"
                                      f"{' (a mimic)' if joint.mimic else ''}: no motor turns it")
        return replace(self, joints=tuple(replace(j, motor=motors.get(j.name, j.motor))
                                          for j in self.joints))

    def mimicked(self, positions: Mapping[str, float]) -> dict[str, float]:
        """``positions`` (by joint name) with each mimic joint's position made from its
        leader's (``multiplier x leader + offset``)."""
        out = dict(positions)
        for joint in self.joints:
            if joint.mimic is not None:
                m = joint.mimic
                out[joint.name] = m.multiplier * out.get(m.joint, 0.0) + m.offset
        return out


def vec3(values: object) -> Vec3:
    x, y, z = (float(v) for v in np.asarray(values, dtype=np.float64))
    return x, y, z


# -- reading a URDF -----------------------------------------------------------------------------

class _Reader:
    """One URDF's text, read with errors that name the file and the element."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, where: str, what: str) -> RobotValueError:
        return RobotValueError(f"{self.source}: {where}: {what}")

    def floats(self, element: ET.Element | None, attribute: str, count: int,
               default: tuple[float, ...] | None, where: str) -> tuple[float, ...]:
        text = None if element is None else element.get(attribute)
        if text is None:
            if default is None:
                raise self.fail(where, f"needs {attribute}=")
            return default
        try:
            values = tuple(float(v) for v in text.split())
        except ValueError:
            values = ()
        if len(values) != count or not all(math.isfinite(v) for v in values):
            raise self.fail(where, f"{attribute}={quoted(text)} is not {count} finite number"
                                   f"{'s' if count > 1 else ''}")
        return values

    def number(self, element: ET.Element | None, attribute: str, where: str,
               default: float | None = None) -> float | None:
        if element is None or element.get(attribute) is None:
            return default
        return self.floats(element, attribute, 1, None, where)[0]

    def value(self, element: ET.Element, attribute: str, where: str, default: float) -> float:
        """A number attribute, ``default`` where it is not given."""
        return self.floats(element, attribute, 1, (default,), where)[0]

    def origin(self, parent: ET.Element, where: str) -> tuple[Vec3, Vec3]:
        origin = parent.find("origin")
        xyz = self.floats(origin, "xyz", 3, ZERO, f"{where} <origin>")
        rpy = self.floats(origin, "rpy", 3, ZERO, f"{where} <origin>")
        return vec3(xyz), vec3(rpy)

    def shape(self, element: ET.Element, link: str, index: int, contact: Contact,
              visual: bool) -> Shape:
        kind = element.tag
        name = element.get("name") or f"{link}_{kind}{index}"
        where = f"link {quoted(link)} <{kind}>"
        pos, rpy = self.origin(element, where)
        material_el = element.find("material")
        material = "" if material_el is None else material_el.get("name", "")
        geometry = element.find("geometry")
        if geometry is None or len(geometry) != 1:
            raise self.fail(where, "needs one shape in <geometry>")
        g = geometry[0]
        gw = f"{where} <{g.tag}>"
        seen = {"material": material, "contact": contact, "rpy": rpy, "visual": visual}
        if g.tag == "box":
            size = vec3(self.floats(g, "size", 3, None, gw))
            return Box(name, size, pos, **seen)  # type: ignore[arg-type]
        if g.tag == "cylinder":
            radius = self.positive(g, "radius", gw)
            length = self.positive(g, "length", gw)
            return Cylinder(name, radius, length, pos, **seen)  # type: ignore[arg-type]
        if g.tag == "sphere":
            return Sphere(name, self.positive(g, "radius", gw), pos,
                          **seen)  # type: ignore[arg-type]
        if g.tag == "mesh":
            filename = g.get("filename")
            if not filename:
                raise self.fail(gw, "needs filename=")
            scale = vec3(self.floats(g, "scale", 3, (1.0, 1.0, 1.0), gw))
            return Mesh(name, filename, pos, scale, **seen)  # type: ignore[arg-type]
        raise self.fail(where, f"<{g.tag}> is not a shape: one of box, cylinder, sphere, mesh")

    def positive(self, element: ET.Element, attribute: str, where: str) -> float:
        value = self.number(element, attribute, where)
        if value is None or value <= 0:
            raise self.fail(where, f"needs {attribute}= a positive number"
                            + ("" if value is None else f", not {value:g}"))
        return value

    def link(self, element: ET.Element) -> Link:
        name = element.get("name")
        if not name:
            raise self.fail("<link>", "needs a name=")
        where = f"link {quoted(name)}"
        inertial = None
        node = element.find("inertial")
        if node is not None:
            com, rpy = self.origin(node, f"{where} <inertial>")
            mass = self.number(node.find("mass"), "value", f"{where} <inertial> <mass>")
            if mass is None or mass < 0:
                raise self.fail(f"{where} <inertial> <mass>", "needs value= a number >= 0")
            i = node.find("inertia")
            ixx, iyy, izz, ixy, ixz, iyz = (
                0.0 if i is None else self.value(i, k, f"{where} <inertial> <inertia>", 0.0)
                for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz"))
            tensor = _turned(np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]), rpy)
            inertial = Inertial(mass, com, tuple(vec3(row) for row in tensor))
        shapes: list[Shape] = []
        visuals = element.findall("visual")
        for k, v in enumerate(visuals):
            shapes.append(self.shape(v, name, k, "none", True))
        for k, c in enumerate(element.findall("collision")):
            shape = self.shape(c, name, k, "all", False)
            # a collision that repeats a visual makes that visual solid, as the URDF writer
            # writes a touching shape twice
            twin = next((n for n, s in enumerate(shapes) if s.visual and s.contact == "none"
                         and replace(s, material="", contact="all", visual=False,
                                     name=shape.name) == shape), None)
            if twin is not None:
                shapes[twin] = replace(shapes[twin], contact="all")
            else:
                shapes.append(shape)
        return Link(name, tuple(shapes), inertial)

    def joint(self, element: ET.Element, links: Collection[str]) -> Joint:
        name = element.get("name")
        if not name:
            raise self.fail("<joint>", "needs a name=")
        where = f"joint {quoted(name)}"
        kind = element.get("type", "")
        if kind not in JOINT_KINDS:
            raise self.fail(where, f"type={quoted(kind)} is not one servolab's worlds can "
                                   f"drive: one of {', '.join(JOINT_KINDS)}")
        ends = []
        for tag in ("parent", "child"):
            node = element.find(tag)
            link = None if node is None else node.get("link")
            if not link:
                raise self.fail(where, f"needs <{tag} link=...>")
            if link not in links:
                close = suggest(link, list(links))
                raise self.fail(f"{where} <{tag}>", f"link={quoted(link)} is not a <link> of the "
                                f"robot" + (f" (did you mean {quoted(close)}?)" if close else ""))
            ends.append(link)
        origin, rpy = self.origin(element, where)
        axis = vec3(self.floats(element.find("axis"), "xyz", 3, (1.0, 0.0, 0.0),
                                f"{where} <axis>"))
        if kind != "fixed" and not any(axis):
            raise self.fail(f"{where} <axis>", "xyz='0 0 0' is not a direction")
        limit = element.find("limit")
        lw = f"{where} <limit>"
        lower: float | None = None
        upper: float | None = None
        if kind in ("revolute", "prismatic"):
            if limit is None:
                raise self.fail(where, f"a {kind} joint needs <limit lower= upper= effort= "
                                       "velocity=> (the URDF's rule)")
            lower = self.value(limit, "lower", lw, 0.0)    # the URDF's defaults: 0
            upper = self.value(limit, "upper", lw, 0.0)
            if lower > upper:
                raise self.fail(lw, f"lower={lower:g} is above upper={upper:g}")
        dynamics = element.find("dynamics")
        dw = f"{where} <dynamics>"
        mimic = None
        node = element.find("mimic")
        if node is not None:
            leader = node.get("joint")
            if not leader:
                raise self.fail(f"{where} <mimic>", "needs joint=")
            mimic = Mimic(leader, self.value(node, "multiplier", f"{where} <mimic>", 1.0),
                          self.value(node, "offset", f"{where} <mimic>", 0.0))
        return Joint(name, kind, ends[0], ends[1], origin,
                     axis if kind != "fixed" else (1.0, 0.0, 0.0), lower, upper, None, rpy,
                     self.number(limit, "effort", lw), self.number(limit, "velocity", lw),
                     self.number(dynamics, "damping", dw), self.number(dynamics, "friction", dw),
                     None, mimic)


def read_urdf(text: str, source: str = "<urdf>") -> Description:
    """The description a URDF's text states; ``source`` names it in errors (its file). Bad
    input is refused in one line naming the source and the element; ``<ros2_control>``,
    ``<transmission>`` and ``<gazebo>`` are left for the code that reads them. A text over
    the URDF limit (:mod:`servolab.limits`, ``SERVOLAB_MAX_URDF_MB``) is refused unparsed;
    errors quote at most 80 characters of a value."""
    reader = _Reader(source)
    limits = InputLimits.current()
    if len(text) > limits.bytes("urdf_mb"):  # characters: at least as many bytes
        raise RobotValueError(f"{source}: " + limits.over("urdf_mb", len(text), "MB", "URDF",
                                                          done="not parsed"))
    try:
        root = ET.fromstring(text)
    except ET.ParseError as error:
        raise RobotValueError(f"{source}: not XML: {error}") from None
    if root.tag != "robot":
        raise reader.fail(f"<{clip(root.tag)}>", "the root element must be <robot>")
    # only <link>, <joint> and <material> are read: <ros2_control>, <transmission> and
    # <gazebo> (and anything else) are other code's
    materials: dict[str, RGBA] = {}
    for node in root.iter("material"):
        color = node.find("color")
        name = node.get("name")
        if name and color is not None:
            r, g, b, a = reader.floats(color, "rgba", 4, None, f"material {quoted(name)} <color>")
            materials.setdefault(name, (r, g, b, a))
    links: list[Link] = []
    for element in root.findall("link"):
        link = reader.link(element)
        if any(k.name == link.name for k in links):
            raise reader.fail(f"link {quoted(link.name)}", "is declared twice")
        links.append(link)
    if not links:
        raise reader.fail("<robot>", "has no <link>")
    names = {k.name for k in links}
    joints: list[Joint] = []
    parent_of: dict[str, str] = {}
    for element in root.findall("joint"):
        joint = reader.joint(element, names)
        if any(j.name == joint.name for j in joints):
            raise reader.fail(f"joint {quoted(joint.name)}", "is declared twice")
        if joint.child in parent_of:
            raise reader.fail(f"joint {quoted(joint.name)} <child>",
                              f"link {quoted(joint.child)} already hangs from joint "
                              f"{quoted(parent_of[joint.child])}")
        parent_of[joint.child] = joint.name
        joints.append(joint)
    by_name = {j.name: j for j in joints}
    for joint in joints:
        if joint.mimic is not None:
            leader = by_name.get(joint.mimic.joint)
            if leader is None or not leader.movable or leader.mimic is not None \
                    or leader.name == joint.name:
                raise reader.fail(f"joint {quoted(joint.name)} <mimic>",
                                  f"joint={quoted(joint.mimic.joint)} is not a movable joint that "
                                  "is not itself a mimic")
    roots = [k.name for k in links if k.name not in parent_of]
    if len(roots) != 1:
        raise reader.fail("<robot>", "the links must form one tree: roots "
                          + (", ".join(repr(r) for r in roots) or "none (a loop)"))
    _check_tree(reader, roots[0], joints, names)
    return Description(root.get("name", ""), roots[0], tuple(links), tuple(joints),
                       materials=materials)


def _check_tree(reader: _Reader, root: str, joints: Iterable[Joint],
                links: Collection[str]) -> None:
    """Every link reached from ``root``: none left hanging in a loop of their own."""
    children: dict[str, list[str]] = {}
    for j in joints:
        children.setdefault(j.parent, []).append(j.child)
    seen, todo = {root}, [root]
    while todo:
        for child in children.get(todo.pop(), []):
            if child not in seen:
                seen.add(child)
                todo.append(child)
    lost = sorted(set(links) - seen)
    if lost:
        raise reader.fail(f"link {quoted(lost[0])}", "is not reached from the root link "
                          f"{quoted(root)} (its joints form a loop)")


# -- writing ------------------------------------------------------------------------------------

def _num(value: float) -> str:
    text = f"{value:.12g}"
    return "0" if text == "-0" else text


def _nums(values: tuple[float, ...] | list[float]) -> str:
    return " ".join(_num(v) for v in values)


def _xml(root: ET.Element) -> str:
    ET.indent(root, "  ")
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def _urdf_geometry(node: ET.Element, shape: Shape) -> None:
    geometry = ET.SubElement(node, "geometry")
    if isinstance(shape, Box):
        ET.SubElement(geometry, "box", size=_nums(shape.size))
    elif isinstance(shape, Cylinder):
        ET.SubElement(geometry, "cylinder", radius=_num(shape.radius),
                      length=_num(shape.length))
    elif isinstance(shape, Sphere):
        ET.SubElement(geometry, "sphere", radius=_num(shape.radius))
    else:
        attributes = {"filename": shape.filename}
        if shape.scale != (1.0, 1.0, 1.0):
            attributes["scale"] = _nums(shape.scale)
        ET.SubElement(geometry, "mesh", attributes)


def urdf(description: Description) -> str:
    """The URDF: materials; links with their inertial, visual and (for shapes that touch
    anything) collision shapes; joints with their limits, dynamics and mimic; and a
    ``<transmission>`` per motor (SimpleTransmission, ``mechanicalReduction`` = direction x
    gear ratio, actuator = the motor's name)."""
    d = description
    robot = ET.Element("robot", name=d.name)
    if d.comment:
        robot.append(ET.Comment(" " + d.comment + " "))
    for name, rgba in d.materials.items():
        material = ET.SubElement(robot, "material", name=name)
        ET.SubElement(material, "color", rgba=_nums(rgba))
    for link in d.links:
        element = ET.SubElement(robot, "link", name=link.name)
        inertial = link.inertial
        if inertial.mass > 0 or link.given_inertial is not None:
            node = ET.SubElement(element, "inertial")
            ET.SubElement(node, "origin", xyz=_nums(inertial.com), rpy="0 0 0")
            ET.SubElement(node, "mass", value=_num(inertial.mass))
            ET.SubElement(node, "inertia", dict(zip(("ixx", "iyy", "izz", "ixy", "ixz", "iyz"),
                                                    (_num(v) for v in inertial.six),
                                                    strict=True)))
        for shape in link.shapes:
            kinds = (("visual",) if shape.visual else ()) + \
                (("collision",) if shape.contact != "none" else ())
            for kind in kinds:
                node = ET.SubElement(element, kind, name=shape.name)
                ET.SubElement(node, "origin", xyz=_nums(shape.pos), rpy=_nums(shape.rpy))
                _urdf_geometry(node, shape)
                if kind == "visual" and shape.material:
                    ET.SubElement(node, "material", name=shape.material)
    for joint in d.joints:
        element = ET.SubElement(robot, "joint", name=joint.name, type=joint.kind)
        ET.SubElement(element, "parent", link=joint.parent)
        ET.SubElement(element, "child", link=joint.child)
        ET.SubElement(element, "origin", xyz=_nums(joint.origin), rpy=_nums(joint.rpy))
        if joint.kind == "fixed":
            continue
        ET.SubElement(element, "axis", xyz=_nums(joint.axis))
        # a revolute or prismatic joint must have a <limit> (its effort and velocity too); a
        # continuous one may, with effort and velocity only (wiki.ros.org/urdf/XML/joint)
        limit: dict[str, str] = {}
        if joint.kind != "continuous":
            limit["lower"] = _num(joint.lower if joint.lower is not None else 0.0)
            limit["upper"] = _num(joint.upper if joint.upper is not None else 0.0)
        if joint.kind != "continuous" or joint.effort is not None or joint.velocity is not None:
            limit["effort"] = _num(joint.effort or 0.0)
            limit["velocity"] = _num(joint.velocity or 0.0)
            ET.SubElement(element, "limit", limit)
        dynamics = {k: _num(v) for k, v in (("damping", joint.damping),
                                            ("friction", joint.friction)) if v is not None}
        if dynamics:
            ET.SubElement(element, "dynamics", dynamics)
        if joint.mimic is not None:
            ET.SubElement(element, "mimic", joint=joint.mimic.joint,
                          multiplier=_num(joint.mimic.multiplier),
                          offset=_num(joint.mimic.offset))
    for joint, motor in d.motors:
        transmission = ET.SubElement(robot, "transmission", name=f"{motor.actuator}_transmission")
        ET.SubElement(transmission, "type").text = "transmission_interface/SimpleTransmission"
        node = ET.SubElement(transmission, "joint", name=joint.name)
        ET.SubElement(node, "hardwareInterface").text = "hardware_interface/PositionJointInterface"
        actuator = ET.SubElement(transmission, "actuator", name=motor.actuator)
        ET.SubElement(actuator, "mechanicalReduction").text = _num(motor.reduction)
    return _xml(robot)


#: MJCF contact bits: a floor meets both kinds of touching shape, "all" shapes meet each
#: other too, and no other pair meets (rough shapes that overlap at their joints).
_CONTACT_BITS: dict[Contact, tuple[int, int]] = {"none": (0, 0), "floor": (2, 0), "all": (1, 1)}
_FLOOR_BITS = (1, 3)
#: The mass (kg) given to a moving link that has none (see _MjcfBodies.children)
SPECK_KG = 1e-6
#: MuJoCo's own default physics step (s)
TIMESTEP = 0.002

#: How the MJCF's servo joints are driven: by MuJoCo's position actuators (a model to look at
#: and play with on its own), or by nothing inside the model, the emulated servos' firmware
#: giving each joint its torque (:mod:`servolab.sim.mujoco_world`).
Drives = Literal["position", "firmware"]
#: The full-torque error of a position actuator when the description has no shared drive:
#: 32 ticks of a 1024-tick, 300-degree servo (the AX/RX default compliance slope).
_FULL_TORQUE_RAD = 32 * math.radians(300.0) / 1023


def _quat(rpy: Vec3) -> str:
    """MJCF's ``quat`` (w x y z) of a URDF ``rpy``."""
    from scipy.spatial.transform import Rotation  # type: ignore[import-untyped]

    x, y, z, w = Rotation.from_euler("xyz", rpy).as_quat()
    return _nums((float(w), float(x), float(y), float(z)))


def _placed(attributes: dict[str, str], rpy: Vec3) -> dict[str, str]:
    if rpy != ZERO:
        attributes["quat"] = _quat(rpy)
    return attributes


def _solid(link: Link) -> bool:
    """A link that is more than a frame in the MJCF: it has mass, or shapes MuJoCo draws
    (a mesh is the viewers' only)."""
    return link.inertial.mass > 0 or any(not isinstance(s, Mesh) for s in link.shapes)


def mjcf(description: Description, drive: Drives = "position", *, floor: bool = False,
         free_base: bool = False, base_height: float = 0.0,
         keyframes: Iterable[Keyframe] = (), welded: Collection[str] = (),
         timestep: float = TIMESTEP) -> str:
    """The MJCF for MuJoCo, in radians: the root link fixed to the world (or, with
    ``free_base``, free at ``base_height`` above the origin), a floor plane only if ``floor``,
    revolute joints as hinges with their range, continuous ones as hinges without, prismatic
    ones as slides, mimic joints tied to their leaders by a joint equality (``polycoef``
    offset, multiplier), ``welded`` joints (one nothing turns) left fixed, and a frame-only
    link on a fixed joint as a site. A link's mass is its inertial's; a link with shapes but
    no mass gets MuJoCo's (its shapes at water's density), a moving link with neither a speck
    (:data:`SPECK_KG`), as MuJoCo refuses a massless moving body.

    ``drive="position"``: a position actuator per motor joint named by its motor, whose control
    is the horn angle (``gear`` = direction x gear ratio) within the joint's range, its
    stiffness and force from the shared :class:`Drive` (else from the motor's model, full
    torque at 32 ticks of error). ``drive="firmware"``: no actuators and no damping — the
    world's firmware law gives the torque, back-EMF included."""
    if drive not in ("position", "firmware"):
        raise RobotValueError(f"no MJCF drive {drive!r}: one of position, firmware")
    d = description
    if free_base and d.root == "world":
        raise RobotValueError(f"{d.name}: its root link is 'world', which a URDF fixes the "
                              "robot to: it cannot have a free base")
    firmware = drive == "firmware"
    root = ET.Element("mujoco", model=d.name)
    if d.comment:
        root.append(ET.Comment(" " + d.comment + " "))
    ET.SubElement(root, "compiler", angle="radian", autolimits="true")
    # implicitfast: velocity-dependent forces (the joints' damping) integrated implicitly
    ET.SubElement(root, "option", timestep=_num(timestep), integrator="implicitfast")
    default = ET.SubElement(root, "default")
    if d.drive is not None:
        ET.SubElement(default, "joint", damping=_num(0.0 if firmware else d.drive.damping),
                      armature=_num(d.drive.armature), frictionloss=_num(d.drive.friction))
        if not firmware:
            ET.SubElement(default, "position", kp=_num(d.drive.kp),
                          forcerange=_nums((-d.drive.stall_torque, d.drive.stall_torque)))
    ET.SubElement(default, "site", size="0.005", rgba="1 0 0 1")
    asset = ET.SubElement(root, "asset")
    if floor:
        ET.SubElement(asset, "texture", name="grid", type="2d", builtin="checker",
                      width="512", height="512", rgb1="0.2 0.3 0.4", rgb2="0.3 0.4 0.5")
        ET.SubElement(asset, "material", name="floor", texture="grid", texrepeat="8 8",
                      reflectance="0.1")
    for name, rgba in d.materials.items():
        ET.SubElement(asset, "material", name=name, rgba=_nums(rgba))
    if not len(asset):
        root.remove(asset)
    world = ET.SubElement(root, "worldbody")
    ET.SubElement(world, "light", name="sun", pos="0 0 3", dir="0 0 -1", directional="true")
    if floor:
        ET.SubElement(world, "geom", name="floor", type="plane", size="0 0 0.05",
                      material="floor", contype=str(_FLOOR_BITS[0]),
                      conaffinity=str(_FLOOR_BITS[1]))
    order: list[str] = []
    writer = _MjcfBodies(d, firmware, frozenset(welded), order)
    base = d.link(d.root)
    if d.root == "world" and not free_base:
        writer.children(world, base)      # the URDF's "world" link is MuJoCo's world body
    else:
        body = ET.SubElement(world, "body", name=d.root,
                             pos=_nums((0.0, 0.0, base_height if free_base else 0.0)))
        if free_base:
            ET.SubElement(body, "freejoint", name="root")
        writer.body(body, base)
    equality = [(j, j.mimic) for j in d.joints if j.mimic is not None and j.name in order]
    if equality:
        node = ET.SubElement(root, "equality")
        for joint, mimic in equality:
            ET.SubElement(node, "joint", name=f"{joint.name}_mimic", joint1=joint.name,
                          joint2=mimic.joint,
                          polycoef=_nums((mimic.offset, mimic.multiplier, 0.0, 0.0, 0.0)))
    driven = [(j, m) for j, m in d.motors if j.name in order]
    if not firmware and driven:
        actuators = ET.SubElement(root, "actuator")
        for joint, motor in driven:
            attributes = {"name": motor.actuator, "joint": joint.name,
                          "gear": _num(motor.reduction)}
            if joint.lower is not None and joint.upper is not None and joint.kind != "continuous":
                lo, hi = sorted((motor.reduction * joint.lower, motor.reduction * joint.upper))
                attributes["ctrlrange"] = _nums((lo, hi))
            if d.drive is None and motor.model:
                from ..dynamixel.models import model

                stall = model(motor.model).stall_torque_nm
                attributes["kp"] = _num(stall / _FULL_TORQUE_RAD)
                attributes["forcerange"] = _nums((-stall, stall))
            ET.SubElement(actuators, "position", attributes)
    frames = list(keyframes)
    if frames:
        keyframe = ET.SubElement(root, "keyframe")
        for frame in frames:
            positions = d.mimicked(frame.positions)
            qpos = [0.0, 0.0, frame.base_height, 1.0, 0.0, 0.0, 0.0] if free_base else []
            key = {"name": frame.name,
                   "qpos": _nums(qpos + [positions.get(n, 0.0) for n in order])}
            if not firmware and driven:
                key["ctrl"] = _nums([m.reduction * positions.get(j.name, 0.0)
                                     for j, m in driven])
            ET.SubElement(keyframe, "key", key)
    return _xml(root)


@dataclass
class _MjcfBodies:
    """Writes the link tree as MJCF bodies, recording the order of the joints it writes (the
    qpos order)."""

    d: Description
    firmware: bool
    welded: frozenset[str]
    order: list[str]

    def body(self, body: ET.Element, link: Link) -> None:
        """``link``'s inertial and shapes into ``body``, then its children."""
        if link.inertial.mass > 0:
            inertial = link.inertial
            ET.SubElement(body, "inertial", pos=_nums(inertial.com), mass=_num(inertial.mass),
                          fullinertia=_nums(inertial.six))
        for shape in link.shapes:
            if isinstance(shape, Mesh):
                continue    # the file is the viewer's; the inertial stands for it
            contype, conaffinity = _CONTACT_BITS[shape.contact]
            attributes = {"name": shape.name}
            if isinstance(shape, Box):
                attributes.update(type="box", size=_nums(tuple(s / 2 for s in shape.size)))
            elif isinstance(shape, Cylinder):
                attributes.update(type="cylinder",
                                  size=_nums((shape.radius, shape.length / 2)))
            else:
                attributes.update(type="sphere", size=_num(shape.radius))
            attributes["pos"] = _nums(shape.pos)
            _placed(attributes, shape.rpy)
            if shape.material in self.d.materials:
                attributes["material"] = shape.material
            attributes.update(contype=str(contype), conaffinity=str(conaffinity),
                              group="0" if shape.contact != "none" else "1")
            ET.SubElement(body, "geom", attributes)
        self.children(body, link)

    def children(self, body: ET.Element, link: Link) -> None:
        """Each child: a frame-only link on a fixed joint becomes a site, anything else a
        body (with a hinge or a slide if its joint moves and is not welded)."""
        for joint in self.d.children(link.name):
            child = self.d.link(joint.child)
            if joint.kind == "fixed" and not _solid(child) and not self.d.children(child.name):
                ET.SubElement(body, "site", _placed({"name": child.name,
                                                     "pos": _nums(joint.origin)}, joint.rpy))
                continue
            element = ET.SubElement(body, "body", _placed({"name": child.name,
                                                           "pos": _nums(joint.origin)},
                                                          joint.rpy))
            moves = joint.movable and joint.name not in self.welded
            if moves:
                self._joint(element, joint)
            if moves and not _solid(child):
                # MuJoCo refuses a moving body without mass (a URDF link with no
                # <inertial>, a finger's frame): a speck of one, too small to matter
                ET.SubElement(element, "inertial", pos="0 0 0", mass=_num(SPECK_KG),
                              diaginertia=_nums((SPECK_KG * 1e-4,) * 3))
            self.body(element, child)

    def _joint(self, element: ET.Element, joint: Joint) -> None:
        attributes = {"name": joint.name,
                      "type": "slide" if joint.kind == "prismatic" else "hinge",
                      "axis": _nums(joint.axis)}
        if joint.kind != "continuous" and joint.lower is not None and joint.upper is not None:
            attributes["range"] = _nums((joint.lower, joint.upper))
        shared = self.d.drive
        # a joint's own dynamics where no shared drive states them (firmware: no damping,
        # the firmware's law gives the back-EMF)
        own = (("damping", None if self.firmware else joint.damping),
               ("frictionloss", joint.friction), ("armature", joint.armature))
        if shared is None:
            attributes.update({k: _num(v) for k, v in own if v is not None})
        ET.SubElement(element, "joint", attributes)
        self.order.append(joint.name)
