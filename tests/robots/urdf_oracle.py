"""The oracle for URDF forward kinematics, shared by the state publishers' and the
descriptions' tests: the URDF as ``urdf-parser-py`` (ROS's reader) reads it, with rotations as
the URDF specification's matrices (wiki.ros.org/urdf/XML/joint: ``rpy`` "the rotation around
fixed axis: first roll around x, then pitch around y and finally yaw around z", Rz Ry Rx;
``<axis>`` in the joint (child) frame) and ``scipy.linalg.expm`` of the axis' skew matrix —
not servolab's scipy ``Rotation`` calls."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from scipy.linalg import expm
from scipy.spatial.transform import Rotation


def _rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def spec_rpy(rpy: Any) -> np.ndarray:
    """Roll about x, then pitch about y, then yaw about z, all about the fixed axes."""
    roll, pitch, yaw = (float(v) for v in rpy)
    return _rz(yaw) @ _ry(pitch) @ _rx(roll)


def axis_turn(axis: Any, q: float) -> np.ndarray:
    k = np.asarray(axis, dtype=float)
    k = k / np.linalg.norm(k)
    skew = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.asarray(expm(skew * q))


def homogeneous(rotation: np.ndarray, translation: Any) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = rotation
    t[:3, 3] = translation
    return t


def urdf_fk(robot: Any, tip: str, q: Mapping[str, float]) -> np.ndarray:
    """root -> ``tip`` as a 4x4 matrix, joint by joint of urdf-parser-py's chain."""
    t = np.eye(4)
    for name in robot.get_chain(robot.get_root(), tip, links=False):
        joint = robot.joint_map[name]
        origin = joint.origin
        t = t @ homogeneous(spec_rpy(origin.rpy if origin else (0, 0, 0)),
                            origin.xyz if origin else (0, 0, 0))
        if joint.type in ("revolute", "continuous"):
            t = t @ homogeneous(axis_turn(joint.axis, q.get(name, 0.0)), (0, 0, 0))
        elif joint.type == "prismatic":
            t = t @ homogeneous(np.eye(3), np.asarray(joint.axis) * q.get(name, 0.0))
    return t


def tf_chain(transforms: list[Any], root: str, tip: str) -> np.ndarray:
    """root -> ``tip`` composed from TransformStamped messages (each parent -> child)."""
    by_child = {t.child_frame_id: t for t in transforms}
    t = np.eye(4)
    frame = tip
    while frame != root:
        if frame not in by_child:
            raise AssertionError(f"no transform reaches {frame!r} from {root!r}")
        step = by_child[frame]
        r, p = step.transform.rotation, step.transform.translation
        t = homogeneous(Rotation.from_quat([r.x, r.y, r.z, r.w]).as_matrix(),
                        (p.x, p.y, p.z)) @ t
        frame = step.header.frame_id
    return t
