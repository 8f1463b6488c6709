"""Any robot shown to a 3D viewer, as ROS 2's ``robot_state_publisher`` shows it.

Foxglove's 3D panel (and rviz2's RobotModel) draws a robot from ``/robot_description`` and
moves it with ``/tf``. :class:`RobotStatePublisher` is given the robot's URDF and publishes:

- ``/robot_description`` (``std_msgs/msg/String``): the URDF, once, latched
  (TRANSIENT_LOCAL, depth 1: :data:`~servolab.middleware.qos.qos_profile_latched`);
- ``/tf_static`` (latched): the fixed joints' transforms, once;
- ``/tf`` (``tf2_msgs/msg/TFMessage``): one transform a movable joint, parent link to child
  link, each time the joints' positions come, with their stamp.

Where the positions come from: by default ``sensor_msgs/msg/JointState`` on ``/joint_states``,
from any robot (as robot_state_publisher: a message's joints and the mimic joints that follow
them, stamped as the message). With ``controllers=`` it hears instead the
``dynamixel_msgs/msg/JointState`` that dynamixel_motor's joint controllers publish on
``/<controller>/state`` and publishes ``/joint_states`` itself (see
:class:`ControllerStates`): what a robot run by servolab's controller manager needs.

A mimic joint (URDF ``<mimic joint= multiplier= offset=>``) is placed at ``multiplier x
leader + offset`` (wiki.ros.org/urdf/XML/joint; robot_state_publisher and ros2_control's
mimic joints do the same); it is never read from a message.

The joint transform is the URDF's (wiki.ros.org/urdf/XML/joint; kdl_parser builds the same
KDL segment, which robot_state_publisher evaluates): the child frame is the joint's
``<origin>`` (``xyz``, then ``rpy``: roll about x, pitch about y, yaw about z, about the
*fixed* axes) followed by the joint's motion about or along ``<axis>``, which is given in the
joint (child) frame: ``T(q) = T(xyz) R(rpy) R(axis, q)`` for a revolute or continuous joint,
``T(xyz) R(rpy) T(axis q)`` for a prismatic one. The kinematics are pure functions
(:func:`rpy_quaternions`, :func:`joint_transforms`, :func:`follow_mimics`: arrays in, arrays
out) on ``scipy.spatial.transform.Rotation``; quaternions are (x, y, z, w), as
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

from ..middleware.node import Node
from ..middleware.qos import qos_profile_latched
from .description import MOVABLE, Description
from .errors import RobotValueError

if TYPE_CHECKING:
    from ..middleware.context import Context

STRING = "std_msgs/msg/String"
JOINT_STATES = "sensor_msgs/msg/JointState"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
CONTROLLER_STATE = "dynamixel_msgs/msg/JointState"
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


def follow_mimics(q: ArrayLike, leader: ArrayLike, multiplier: ArrayLike,
                  offset: ArrayLike) -> np.ndarray:
    """Positions ``q`` (n,) with each mimic joint's made from its leader's: ``leader`` (n,)
    is the index of the joint each follows (-1: none, it keeps its own), and a follower's
    position is ``multiplier x q[leader] + offset`` (URDF ``<mimic>``)."""
    positions = np.array(q, dtype=np.float64)
    leaders = np.asarray(leader, dtype=np.intp)
    follows = leaders >= 0
    positions[follows] = (np.asarray(multiplier, dtype=np.float64)[follows]
                          * positions[leaders[follows]]
                          + np.asarray(offset, dtype=np.float64)[follows])
    return positions


# -- the URDF, as the transforms need it -------------------------------------------------------

@dataclass(frozen=True)
class UrdfJoints:
    """A URDF's joints as arrays (in the file's order), their mimics, and its
    transmissions."""

    robot: str
    names: tuple[str, ...]
    kinds: tuple[str, ...]
    parents: tuple[str, ...]
    children: tuple[str, ...]
    xyz: np.ndarray        # (n, 3) m
    rpy: np.ndarray        # (n, 3) rad
    axis: np.ndarray       # (n, 3) unit vectors, (1, 0, 0) where the URDF gives none
    #: (n,) the index of the joint each mimics (-1: none), its multiplier and offset
    leader: np.ndarray
    multiplier: np.ndarray
    offset: np.ndarray
    #: actuator name -> (joint name, mechanicalReduction): actuator = reduction x joint
    transmissions: Mapping[str, tuple[str, float]]

    @classmethod
    def parse(cls, text: str, source: str = "the robot description") -> UrdfJoints:
        d = Description.from_urdf(text, source)
        n = len(d.joints)
        index = {j.name: k for k, j in enumerate(d.joints)}
        mimics = [j.mimic for j in d.joints]
        return cls(d.name, tuple(j.name for j in d.joints), tuple(j.kind for j in d.joints),
                   tuple(j.parent for j in d.joints), tuple(j.child for j in d.joints),
                   np.array([j.origin for j in d.joints], dtype=np.float64).reshape(n, 3),
                   np.array([j.rpy for j in d.joints], dtype=np.float64).reshape(n, 3),
                   _unit(np.array([j.axis for j in d.joints],
                                  dtype=np.float64).reshape(n, 3)) if n else np.zeros((0, 3)),
                   np.array([-1 if m is None else index[m.joint] for m in mimics],
                            dtype=np.intp),
                   np.array([1.0 if m is None else m.multiplier for m in mimics]),
                   np.array([0.0 if m is None else m.offset for m in mimics]),
                   _transmissions(text, source))

    def indices(self, kinds: Iterable[str]) -> list[int]:
        wanted = set(kinds)
        return [i for i, k in enumerate(self.kinds) if k in wanted]

    def transforms(self, rows: list[int], q: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """:func:`joint_transforms` of the joints at ``rows`` at positions ``q``."""
        return joint_transforms(self.xyz[rows], self.rpy[rows], self.axis[rows], q,
                                [self.kinds[i] == "prismatic" for i in rows])


def _transmissions(text: str, source: str) -> dict[str, tuple[str, float]]:
    """actuator -> (joint, mechanicalReduction) of a URDF's SimpleTransmissions (the text is
    XML: the description's reader has read it)."""
    transmissions: dict[str, tuple[str, float]] = {}
    for transmission in ET.fromstring(text).findall("transmission"):
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
            raise RobotValueError(f"{source}: transmission {transmission.get('name')!r}: "
                                  f"mechanicalReduction {text_value!r} is not a non-zero "
                                  "number")
        transmissions[actuator.get("name", "")] = (joint_el.get("name", ""), reduction)
    return transmissions


# -- the node ----------------------------------------------------------------------------------

@dataclass(frozen=True)
class ControllerStates:
    """Positions from dynamixel_motor's joint controllers: ``controllers`` are the ones that
    run, whose ``/<name>/state`` is heard; the controller of actuator ``m14`` (a URDF
    transmission's actuator) is ``controller_m14`` (``prefix`` + the actuator's name). A
    controller's angle is its motor's, 0 at its ``init``; the joint's is the motor's over the
    transmission's ``mechanicalReduction`` (SimpleTransmission: actuator = reduction x joint).

    ``/joint_states`` goes out once a sweep of the manager: when every running controller has
    reported once since the last one; a controller that reports twice first, because another
    fell silent, publishes what is known; before the first message, :data:`STARTUP_REPORTS`
    reports. A joint whose motor has no running controller stays at 0, its URDF zero."""

    controllers: tuple[str, ...]
    prefix: str = "controller_"


class RobotStatePublisher(Node):
    """See the module docstring. ``published`` counts the ``/tf`` messages sent (and, with
    controllers, the ``/joint_states``); :attr:`topics` maps each topic it publishes to its
    type."""

    def __init__(self, context: Context, urdf: str, *, name: str = "robot_state_publisher",
                 namespace: str = "/", frame_prefix: str = "",
                 controllers: ControllerStates | None = None) -> None:
        joints = UrdfJoints.parse(urdf)   # checked before the node is in the graph
        movable = joints.indices(MOVABLE)
        names = tuple(joints.names[i] for i in movable)
        slots = _controller_slots(joints, names, controllers) if controllers else {}
        super().__init__(context, name, namespace)
        self.urdf = urdf
        self.joints = joints
        self.frame_prefix = frame_prefix
        self._movable = movable
        self._fixed = joints.indices(("fixed",))
        #: the movable joints' names, in the URDF's order (/joint_states' ``name`` with
        #: controllers)
        self.joint_names = names
        self._slot = {n: k for k, n in enumerate(names)}
        #: rad (or m): each movable joint's position, 0 until it is heard
        self.positions = np.zeros(len(names))
        self.velocities = np.zeros(len(names))
        self._controllers = controllers
        #: controller -> (index into joint_names, the transmission's reduction)
        self._slots = slots
        self._heard: dict[str, int] = {}    # reports since the last publication
        self.published = 0
        self._description = self.create_publisher(STRING, "robot_description",
                                                  qos_profile_latched)
        self._joint_states = (self.create_publisher(JOINT_STATES, "joint_states", 10)
                              if controllers else None)
        self._tf = self.create_publisher(TF_MESSAGE, "/tf", TF_DEPTH)
        self._tf_static = self.create_publisher(TF_MESSAGE, "/tf_static", qos_profile_latched)
        if controllers:
            for controller in self._slots:
                self.create_subscription(CONTROLLER_STATE, f"/{controller}/state",
                                         lambda msg, c=controller: self._on_state(c, msg), 10)
        else:
            self.create_subscription(JOINT_STATES, "joint_states", self._on_joint_states, 10)
        self._description.publish(self.message(STRING, data=urdf))
        self._tf_static.publish(self.message(TF_MESSAGE, transforms=self._transforms(
            self._fixed, np.zeros(len(self._fixed)), self.stamp())))

    @property
    def topics(self) -> dict[str, str]:
        """Each topic published (resolved) -> its type, e.g. for a recorder."""
        topics = {self.resolve("robot_description"): STRING}
        if self._joint_states is not None:
            topics[self.resolve("joint_states")] = JOINT_STATES
        return {**topics, "/tf": TF_MESSAGE, "/tf_static": TF_MESSAGE}

    def _mimicked(self, q: np.ndarray) -> np.ndarray:
        """The movable joints' positions with the mimic joints following their leaders."""
        full = np.zeros(len(self.joints.names))
        full[self._movable] = q
        full = follow_mimics(full, self.joints.leader, self.joints.multiplier,
                             self.joints.offset)
        return full[self._movable]

    # -- from /joint_states -------------------------------------------------------------------
    def _on_joint_states(self, msg: Any) -> None:
        """The message's joints (and the mimics that follow them) on /tf, as
        robot_state_publisher: a joint it does not know is passed over, a message whose
        positions do not match its names is dropped (and said so)."""
        names, positions = list(msg.name), list(msg.position)
        if len(names) != len(positions):
            self.get_logger().warning(f"/joint_states: {len(names)} names but "
                                      f"{len(positions)} positions: message dropped")
            return
        heard = set()
        for joint, position in zip(names, positions, strict=True):
            k = self._slot.get(joint)
            if k is not None and self.joints.leader[self._movable[k]] < 0:
                self.positions[k] = float(position)
                heard.add(k)
        follows = {k for k, i in enumerate(self._movable)
                   if self.joints.leader[i] >= 0
                   and self._slot.get(self.joints.names[int(self.joints.leader[i])]) in heard}
        rows = sorted(heard | follows)
        if not rows:
            return
        q = self._mimicked(self.positions)
        stamp = {"sec": int(msg.header.stamp.sec), "nanosec": int(msg.header.stamp.nanosec)}
        self._tf.publish(self.message(TF_MESSAGE, transforms=self._transforms(
            [self._movable[k] for k in rows], q[rows], stamp)))
        self.published += 1

    # -- from the joint controllers -----------------------------------------------------------
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
        """``/joint_states`` (with controllers) and ``/tf`` of the positions now, stamped
        now."""
        self._heard.clear()
        stamp = self.stamp()
        q = self._mimicked(self.positions)
        if self._joint_states is not None:
            self._joint_states.publish(self.message(
                JOINT_STATES, header={"stamp": stamp}, name=list(self.joint_names),
                position=q.tolist(), velocity=self.velocities.tolist()))
        self._tf.publish(self.message(TF_MESSAGE, transforms=self._transforms(
            self._movable, q, stamp)))
        self.published += 1

    def _transforms(self, rows: list[int], q: np.ndarray,
                    stamp: dict[str, int]) -> list[dict[str, Any]]:
        translations, rotations = self.joints.transforms(rows, q)
        prefix = self.frame_prefix
        out = []
        for i, t, r in zip(rows, translations.tolist(), rotations.tolist(), strict=True):
            out.append({
                "header": {"stamp": stamp, "frame_id": prefix + self.joints.parents[i]},
                "child_frame_id": prefix + self.joints.children[i],
                "transform": {"translation": dict(zip("xyz", t, strict=True)),
                              "rotation": dict(zip("xyzw", r, strict=True))}})
        return out


def _controller_slots(joints: UrdfJoints, names: tuple[str, ...],
                      controllers: ControllerStates) -> dict[str, tuple[int, float]]:
    """controller -> (index into the movable joints, the transmission's reduction)."""
    slot = {n: k for k, n in enumerate(names)}
    slots: dict[str, tuple[int, float]] = {}
    for controller in controllers.controllers:
        actuator = controller.removeprefix(controllers.prefix)
        if not controller.startswith(controllers.prefix) or \
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
    return slots
