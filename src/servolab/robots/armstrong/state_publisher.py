"""Armstrong shows itself to a 3D viewer, as ROS's ``robot_state_publisher`` does.

Foxglove's 3D panel (and rviz2's RobotModel) draws a robot from ``/robot_description`` and
moves it with ``/tf``. :class:`ArmstrongStatePublisher` publishes, beside the joint
controllers of :mod:`servolab.robots.controllers`:

- ``/robot_description`` (``std_msgs/msg/String``): the URDF, once, latched
  (TRANSIENT_LOCAL, depth 1: :data:`~servolab.middleware.qos.qos_profile_latched`);
- ``/joint_states`` (``sensor_msgs/msg/JointState``): every movable URDF joint's position in
  radians, from what the joint controllers report on ``/<controller>/state``
  (``dynamixel_msgs/msg/JointState``'s ``current_pos``), one message a sweep of the manager
  (when every running controller has reported once since the last one; a controller that
  reports twice first, because another fell silent, publishes what is known; before the
  first message, :data:`STARTUP_REPORTS` reports). A joint whose
  motor has no running controller (Armstrong's camera, motor 62, absent) stays at 0, its URDF
  zero. A controller's angle is its motor's, 0 at ``init``; the joint's is the motor's over the
  transmission's ``mechanicalReduction`` (SimpleTransmission: actuator = reduction x joint),
  which Armstrong's URDF sets to the motor's direction (:mod:`.description`);
- ``/tf`` (``tf2_msgs/msg/TFMessage``): one transform a movable joint, parent link to child
  link, with the same stamp as the ``/joint_states`` it comes from;
- ``/tf_static`` (latched): the fixed joints' transforms, once.

The joint transform is the URDF's (wiki.ros.org/urdf/XML/joint; kdl_parser builds the same
KDL segment, which robot_state_publisher evaluates): the child frame is the joint's
``<origin>`` (``xyz``, then ``rpy``: roll about x, pitch about y, yaw about z, about the
*fixed* axes) followed by the joint's motion about or along ``<axis>``, which is given in the
joint (child) frame: ``T(q) = T(xyz) R(rpy) R(axis, q)`` for a revolute or continuous joint,
``T(xyz) R(rpy) T(axis q)`` for a prismatic one. The kinematics are pure functions
(:func:`rpy_quaternions`, :func:`joint_transforms`: arrays in, arrays out) on
``scipy.spatial.transform.Rotation``; quaternions are (x, y, z, w), as
``geometry_msgs/msg/Quaternion`` orders them.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation  # type: ignore[import-untyped]

from ...middleware.node import Node
from ...middleware.qos import qos_profile_latched
from ..errors import RobotValueError
from .control_node import controller_of

if TYPE_CHECKING:
    from ...middleware.context import Context
    from ..controllers.config import RobotConfig
    from .description import Assumptions

STRING = "std_msgs/msg/String"
JOINT_STATES = "sensor_msgs/msg/JointState"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
CONTROLLER_STATE = "dynamixel_msgs/msg/JointState"
#: The URDF joint types that move (robot_state_publisher publishes these on /tf); floating
#: and planar joints have no single position and are left out, as it leaves them out.
MOVABLE = ("revolute", "continuous", "prismatic")
#: tf2_ros' TransformBroadcaster's queue depth (rclcpp's default for it)
TF_DEPTH = 100
#: Before the first joint states, how many reports of one controller make them go out
#: without the others (a controller silent from the start; after that, two do)
STARTUP_REPORTS = 3


# -- the kinematics: pure ---------------------------------------------------------------------

def rpy_quaternions(rpy: ArrayLike) -> np.ndarray:
    """URDF ``rpy`` angles (..., 3) as quaternions (..., 4), (x, y, z, w): roll about x, then
    pitch about y, then yaw about z, about the fixed axes (``R = Rz(yaw) Ry(pitch)
    Rx(roll)``), which is scipy's extrinsic ``"xyz"``."""
    angles = np.asarray(rpy, dtype=np.float64)
    if angles.shape[-1:] != (3,):
        raise RobotValueError(f"rpy must have 3 angles in its last axis, not shape "
                              f"{angles.shape}")
    flat = Rotation.from_euler("xyz", angles.reshape(-1, 3)).as_quat()
    return np.asarray(flat.reshape((*angles.shape[:-1], 4)))


def _unit(axis: ArrayLike) -> np.ndarray:
    v = np.asarray(axis, dtype=np.float64)
    if v.shape[-1:] != (3,):
        raise RobotValueError(f"an axis must have 3 components, not shape {v.shape}")
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    if np.any(norm == 0) or not np.all(np.isfinite(norm)):
        raise RobotValueError("a joint axis must be a finite, non-zero vector")
    return np.asarray(v / norm)


def joint_transforms(xyz: ArrayLike, rpy: ArrayLike, axis: ArrayLike, q: ArrayLike,
                     prismatic: ArrayLike | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The child frames of n joints in their parents' frames at positions ``q`` (n,): their
    translations (n, 3) and rotations (n, 4, quaternions x y z w). ``xyz``, ``rpy`` (n, 3)
    are the joints' ``<origin>``, ``axis`` (n, 3) their ``<axis>`` (normalised here), and
    ``prismatic`` (n,) says which slide along it (default: none; all turn about it). A fixed
    joint is a revolute one at q = 0."""
    origin = np.atleast_2d(np.asarray(xyz, dtype=np.float64))
    angles = np.atleast_2d(np.asarray(rpy, dtype=np.float64))
    axes = _unit(np.atleast_2d(np.asarray(axis, dtype=np.float64)))
    positions = np.atleast_1d(np.asarray(q, dtype=np.float64))
    n = len(positions)
    if origin.shape != (n, 3) or angles.shape != (n, 3) or axes.shape != (n, 3):
        raise RobotValueError(f"{n} joint positions need xyz, rpy and axis of shape ({n}, 3), "
                              f"not {origin.shape}, {angles.shape}, {axes.shape}")
    slides = (np.zeros(n, dtype=bool) if prismatic is None
              else np.atleast_1d(np.asarray(prismatic, dtype=bool)))
    if slides.shape != (n,):
        raise RobotValueError(f"prismatic must have {n} flags, not shape {slides.shape}")
    if n == 0:
        return np.zeros((0, 3)), np.zeros((0, 4))
    placed = Rotation.from_euler("xyz", angles)
    turns = np.where(slides, 0.0, positions)
    moved = placed * Rotation.from_rotvec(axes * turns[:, None])
    slide = np.where(slides, positions, 0.0)
    translation = origin + placed.apply(axes * slide[:, None])
    return translation, np.asarray(moved.as_quat())


# -- the URDF, as far as the transforms need it ------------------------------------------------

def _floats(text: str | None, default: tuple[float, float, float], what: str) -> np.ndarray:
    if text is None:
        return np.array(default, dtype=np.float64)
    try:
        values = [float(v) for v in text.split()]
    except ValueError:
        values = []
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise RobotValueError(f"URDF {what}: {text!r} is not three numbers")
    return np.array(values, dtype=np.float64)


@dataclass(frozen=True)
class UrdfJoints:
    """A URDF's joints as arrays (in the file's order), and its transmissions."""

    robot: str
    names: tuple[str, ...]
    kinds: tuple[str, ...]
    parents: tuple[str, ...]
    children: tuple[str, ...]
    xyz: np.ndarray        # (n, 3) m
    rpy: np.ndarray        # (n, 3) rad
    axis: np.ndarray       # (n, 3) unit vectors, (1, 0, 0) where the URDF gives none
    #: actuator name -> (joint name, mechanicalReduction): actuator = reduction x joint
    transmissions: Mapping[str, tuple[str, float]]

    @classmethod
    def parse(cls, text: str) -> UrdfJoints:
        try:
            root = ET.fromstring(text)
        except ET.ParseError as error:
            raise RobotValueError(f"the robot description is not XML: {error}") from None
        if root.tag != "robot":
            raise RobotValueError(f"the robot description's root is <{root.tag}>, not <robot>")
        rows: list[tuple[str, str, str, str, np.ndarray, np.ndarray, np.ndarray]] = []
        for joint in root.findall("joint"):
            name, kind = joint.get("name", ""), joint.get("type", "")
            parent, child = joint.find("parent"), joint.find("child")
            if not name or parent is None or child is None:
                raise RobotValueError(f"URDF joint {name!r}: needs a name, <parent> and <child>")
            origin = joint.find("origin")
            axis = joint.find("axis")
            rows.append((name, kind, parent.get("link", ""), child.get("link", ""),
                         _floats(None if origin is None else origin.get("xyz"), (0, 0, 0),
                                 f"joint {name} origin xyz"),
                         _floats(None if origin is None else origin.get("rpy"), (0, 0, 0),
                                 f"joint {name} origin rpy"),
                         # the URDF's default axis is (1, 0, 0)
                         _unit(_floats(None if axis is None else axis.get("xyz"), (1, 0, 0),
                                       f"joint {name} axis"))))
        transmissions: dict[str, tuple[str, float]] = {}
        for transmission in root.findall("transmission"):
            joint_el, actuator = transmission.find("joint"), transmission.find("actuator")
            if joint_el is None or actuator is None:
                continue
            reduction_el = actuator.find("mechanicalReduction")
            text_value = (reduction_el.text or "1").strip() if reduction_el is not None else "1"
            try:
                reduction = float(text_value)
            except ValueError:
                reduction = math.nan
            if not (math.isfinite(reduction) and reduction != 0):
                raise RobotValueError(f"URDF transmission {transmission.get('name')!r}: "
                                      f"mechanicalReduction {text_value!r} is not a non-zero "
                                      "number")
            transmissions[actuator.get("name", "")] = (joint_el.get("name", ""), reduction)
        n = len(rows)
        return cls(root.get("name", ""), tuple(r[0] for r in rows), tuple(r[1] for r in rows),
                   tuple(r[2] for r in rows), tuple(r[3] for r in rows),
                   np.array([r[4] for r in rows]).reshape(n, 3),
                   np.array([r[5] for r in rows]).reshape(n, 3),
                   np.array([r[6] for r in rows]).reshape(n, 3), transmissions)

    def indices(self, kinds: Iterable[str]) -> list[int]:
        wanted = set(kinds)
        return [i for i, k in enumerate(self.kinds) if k in wanted]

    def transforms(self, rows: list[int], q: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """:func:`joint_transforms` of the joints at ``rows`` at positions ``q``."""
        return joint_transforms(self.xyz[rows], self.rpy[rows], self.axis[rows], q,
                                [self.kinds[i] == "prismatic" for i in rows])


# -- the node ----------------------------------------------------------------------------------

@dataclass(frozen=True)
class StatePublisherConfig:
    """What :class:`ArmstrongStatePublisher` publishes and listens to.

    ``urdf``: the robot description (its joints, and its transmissions, whose actuators name
    the motors); ``controllers``: the joint controllers that run, whose ``/<name>/state`` it
    hears; the controller of actuator ``m14`` is ``controller_m14`` (``controller_prefix``
    + the actuator's name, the seed's naming). ``frame_prefix`` goes before every link's name
    in the transforms (robot_state_publisher's parameter of that name)."""

    urdf: str
    controllers: tuple[str, ...] = ()
    controller_prefix: str = "controller_"
    frame_prefix: str = ""

    @classmethod
    def armstrong(cls, controllers: Iterable[str] = (),
                  assumptions: Assumptions | None = None,
                  config: RobotConfig | None = None) -> StatePublisherConfig:
        """Armstrong's URDF (:func:`.description.urdf` under ``assumptions``, with the motors
        of ``config``), listening to ``controllers``."""
        from .description import describe, urdf

        prefix = controller_of("")
        return cls(urdf(describe(assumptions, config)), tuple(controllers), prefix)


class ArmstrongStatePublisher(Node):
    """See the module docstring. ``published`` counts the ``/joint_states`` (and ``/tf``)
    messages sent; :attr:`topics` maps each topic it publishes to its type."""

    def __init__(self, context: Context, config: StatePublisherConfig, *,
                 name: str = "robot_state_publisher", namespace: str = "/") -> None:
        joints = UrdfJoints.parse(config.urdf)   # checked before the node is in the graph
        movable = joints.indices(MOVABLE)
        names = tuple(joints.names[i] for i in movable)
        slot = {n: k for k, n in enumerate(names)}
        slots: dict[str, tuple[int, float]] = {}
        for controller in config.controllers:
            actuator = controller.removeprefix(config.controller_prefix)
            if not controller.startswith(config.controller_prefix) or \
                    actuator not in joints.transmissions:
                raise RobotValueError(
                    f"controller {controller!r}: the robot description has no transmission "
                    f"whose actuator is {actuator!r} (actuators: "
                    f"{', '.join(sorted(joints.transmissions)) or 'none'})")
            joint, reduction = joints.transmissions[actuator]
            if joint not in slot:
                raise RobotValueError(f"controller {controller!r}: its joint {joint!r} is not "
                                      "a movable joint of the robot description")
            slots[controller] = (slot[joint], reduction)
        super().__init__(context, name, namespace)
        self.config = config
        self.joints = joints
        self._movable = movable
        self._fixed = joints.indices(("fixed",))
        #: the movable joints' names, in the URDF's order: /joint_states' ``name``
        self.joint_names = names
        #: controller -> (index into joint_names, the transmission's reduction)
        self._slots = slots
        #: rad (or m): each movable joint's position, 0 until its controller reports
        self.positions = np.zeros(len(self.joint_names))
        self.velocities = np.zeros(len(self.joint_names))
        self._heard: dict[str, int] = {}    # reports since the last publication
        self.published = 0
        self._description = self.create_publisher(STRING, "robot_description",
                                                  qos_profile_latched)
        self._joint_states = self.create_publisher(JOINT_STATES, "joint_states", 10)
        self._tf = self.create_publisher(TF_MESSAGE, "/tf", TF_DEPTH)
        self._tf_static = self.create_publisher(TF_MESSAGE, "/tf_static", qos_profile_latched)
        for controller in self._slots:
            self.create_subscription(CONTROLLER_STATE, f"/{controller}/state",
                                     lambda msg, c=controller: self._on_state(c, msg), 10)
        self._description.publish(self.message(STRING, data=config.urdf))
        self._tf_static.publish(self.message(TF_MESSAGE, transforms=self._transforms(
            self._fixed, np.zeros(len(self._fixed)), self.stamp())))

    @property
    def topics(self) -> dict[str, str]:
        """Each topic published (resolved) -> its type, e.g. for a recorder."""
        return {self.resolve("robot_description"): STRING,
                self.resolve("joint_states"): JOINT_STATES,
                "/tf": TF_MESSAGE, "/tf_static": TF_MESSAGE}

    def _on_state(self, controller: str, msg: Any) -> None:
        heard = self._heard.get(controller, 0)
        # a second report before the others: one fell silent, what is known goes out; before
        # the first publication it waits longer (a joint never heard would be drawn at 0,
        # which is not where a running joint is known to be)
        if heard >= (1 if self.published else STARTUP_REPORTS - 1):
            self.publish()
        index, reduction = self._slots[controller]
        self.positions[index] = float(msg.current_pos) / reduction
        self.velocities[index] = float(msg.velocity) / reduction
        self._heard[controller] = heard + 1
        if len(self._heard) == len(self._slots):
            self.publish()

    def publish(self) -> None:
        """``/joint_states`` and ``/tf`` of the positions now, stamped now."""
        self._heard.clear()
        stamp = self.stamp()
        self._joint_states.publish(self.message(
            JOINT_STATES, header={"stamp": stamp}, name=list(self.joint_names),
            position=self.positions.tolist(), velocity=self.velocities.tolist()))
        self._tf.publish(self.message(TF_MESSAGE, transforms=self._transforms(
            self._movable, self.positions, stamp)))
        self.published += 1

    def _transforms(self, rows: list[int], q: np.ndarray,
                    stamp: dict[str, int]) -> list[dict[str, Any]]:
        translations, rotations = self.joints.transforms(rows, q)
        prefix = self.config.frame_prefix
        out = []
        for i, t, r in zip(rows, translations.tolist(), rotations.tolist(), strict=True):
            out.append({
                "header": {"stamp": stamp, "frame_id": prefix + self.joints.parents[i]},
                "child_frame_id": prefix + self.joints.children[i],
                "transform": {"translation": dict(zip("xyz", t, strict=True)),
                              "rotation": dict(zip("xyzw", r, strict=True))}})
        return out
