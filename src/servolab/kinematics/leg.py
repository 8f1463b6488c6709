"""The leg of the Armstrong biped (seed 001, chapter 5): forward kinematics through the
Denavit–Hartenberg chain of Table 5.2, closed-form inverse kinematics with the foot kept
parallel to the floor, and the map from leg joint angles to the leg's motor columns.

Coordinates (mm): x forward, y lateral (to the robot's left, so that x, y, z is
right-handed), z up. The origin is the DH base frame of Table 5.2: on the hip-yaw axis, L1
above the point where the hip-roll and hip-pitch axes cross. The point solved for is the sole,
L4 below the ankle-roll axis. With the gait's foot height ``z = -(d_leg - d_step) = -295`` the
hip-roll axis is therefore 295 - L1 - L4 = 185 mm above the ankle-roll axis, which is the leg
that reproduces Tables 4.2 and 4.3 (seeds/README.md, "Facts worked out").

Joint angles (radians), in the order of :data:`JOINT_NAMES`: hip yaw (about the vertical,
counter-clockwise seen from above), hip roll (positive swings the foot to +y), hip pitch
(positive swings the foot forward), knee (positive bends the shank backwards), ankle pitch and
ankle roll. The ankle angles are counted so that the foot stays flat when
``ankle_pitch = knee - hip_pitch`` and ``ankle_roll = hip_roll``, as the README writes them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

from servolab.kinematics.dh import DHLink, FloatArray, chain_transform
from servolab.kinematics.errors import KinematicsValueError

JOINT_NAMES = ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")
HIP_YAW, HIP_ROLL, HIP_PITCH, KNEE, ANKLE_PITCH, ANKLE_ROLL = range(6)

# DH joint variable q_i = sign_i * joint angle: the DH axes of Table 5.2 point so that q_3 > 0
# swings the foot backwards and q_5, q_6 must cancel q_3 + q_4 and q_2 for a flat foot.
_DH_SIGNS = np.array([1.0, 1.0, -1.0, 1.0, -1.0, -1.0])

Side = Literal["left", "right"]

# Motor columns m?1..m?6 in the order of Table 4.1 (m?1 hip yaw, m?2 hip pitch, m?3 hip roll,
# m?4 knee, m?5 ankle pitch, m?6 ankle roll) as indices into JOINT_NAMES ...
_MOTOR_JOINTS = (HIP_YAW, HIP_PITCH, HIP_ROLL, KNEE, ANKLE_PITCH, ANKLE_ROLL)
# ... and their signs as Table 4.2 prints them (seeds/README.md): the two legs' knee and
# ankle-pitch servos are mounted mirrored.
_MOTOR_SIGNS: dict[Side, FloatArray] = {
    "left": np.array([1.0, -1.0, 1.0, -1.0, 1.0, -1.0]),
    "right": np.array([1.0, -1.0, 1.0, 1.0, -1.0, -1.0]),
}


@dataclass(frozen=True)
class LegGeometry:
    """Link lengths (mm) of Table 5.2 / Appendix D: hip yaw to hip, thigh, shank, ankle to sole."""

    l1: float = 70.0
    l2: float = 100.0
    l3: float = 100.0
    l4: float = 40.0

    def __post_init__(self) -> None:
        for name in ("l1", "l2", "l3", "l4"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise KinematicsValueError(f"leg length {name} must be a positive number of mm, "
                                           f"got {value}")

    @property
    def length(self) -> float:
        """``d_leg`` of Appendix D: the straight leg from the DH base to the sole."""
        return self.l1 + self.l2 + self.l3 + self.l4

    @property
    def dh_links(self) -> tuple[DHLink, ...]:
        """Table 5.2 of seed 001: theta offsets, d, a and alpha of the six links."""
        quarter = np.pi / 2
        return (
            DHLink(quarter, -self.l1, 0.0, quarter),
            DHLink(-quarter, 0.0, 0.0, -quarter),
            DHLink(0.0, 0.0, self.l2, 0.0),
            DHLink(0.0, 0.0, self.l3, 0.0),
            DHLink(0.0, 0.0, 0.0, quarter),
            DHLink(0.0, 0.0, self.l4, 0.0),
        )


ARMSTRONG_LEG = LegGeometry()
"""The leg of Table 5.2 (L1 = 70, L2 = L3 = 100, L4 = 40 mm), the default everywhere."""


def leg_transform(joints: npt.ArrayLike, geometry: LegGeometry = ARMSTRONG_LEG) -> FloatArray:
    """``T_6^0`` of Table 5.2 for joint angles of shape ``(N, 6)`` (radians): ``(N, 4, 4)``."""
    q = np.asarray(joints, dtype=np.float64) * _DH_SIGNS
    return chain_transform(geometry.dh_links, q)


def foot_position(joints: npt.ArrayLike, geometry: LegGeometry = ARMSTRONG_LEG) -> FloatArray:
    """Forward kinematics: the sole's position (mm), shape ``(N, 3)`` (or ``(3,)``)."""
    transform = leg_transform(joints, geometry)
    return np.asarray(transform[..., :3, 3])


def _leg_frame(
    positions: npt.ArrayLike, geometry: LegGeometry, yaw: npt.ArrayLike
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Target rotated into the yawed leg frame: forward, lateral, the hip-to-ankle height
    (positive when the ankle is below the hip) and the hip-to-ankle distance."""
    p = np.atleast_2d(np.asarray(positions, dtype=np.float64))
    if p.ndim != 2 or p.shape[1] != 3:
        raise KinematicsValueError(f"foot positions must have shape (N, 3), got {p.shape}")
    psi = np.broadcast_to(np.asarray(yaw, dtype=np.float64), p.shape[:1])
    c, s = np.cos(psi), np.sin(psi)
    forward = c * p[:, 0] + s * p[:, 1]
    lateral = -s * p[:, 0] + c * p[:, 1]
    height = -(p[:, 2] + geometry.l1 + geometry.l4)
    distance = np.sqrt(forward**2 + lateral**2 + height**2)
    return forward, lateral, height, distance


def reachable(
    positions: npt.ArrayLike, geometry: LegGeometry = ARMSTRONG_LEG, yaw: npt.ArrayLike = 0.0
) -> npt.NDArray[np.bool_]:
    """Which targets the leg can reach with a flat foot: the ankle below the hip and no further
    from it than the stretched leg (and no nearer than ``|L2 - L3|``)."""
    _, _, height, distance = _leg_frame(positions, geometry, yaw)
    return _within_reach(height, distance, geometry)


def _within_reach(height: FloatArray, distance: FloatArray,
                  geometry: LegGeometry) -> npt.NDArray[np.bool_]:
    with np.errstate(invalid="ignore"):
        ok = (
            np.isfinite(distance)
            & (height > 0)
            & (distance <= geometry.l2 + geometry.l3)
            & (distance >= abs(geometry.l2 - geometry.l3))
        )
    return np.asarray(ok)


def unreachable_reason(position: npt.ArrayLike, geometry: LegGeometry = ARMSTRONG_LEG,
                       yaw: float = 0.0) -> str:
    """Why one target is out of reach, in words, for error messages."""
    _, _, height, distance = _leg_frame(position, geometry, yaw)
    if not np.isfinite(distance[0]):
        return "it is not a finite position"
    if height[0] <= 0:
        return f"the ankle would be {-height[0]:.6g} mm above the hip-roll axis"
    if distance[0] > geometry.l2 + geometry.l3:
        return (f"the hip-to-ankle distance {distance[0]:.6g} mm exceeds the stretched leg "
                f"({geometry.l2 + geometry.l3:.6g} mm)")
    return f"the hip-to-ankle distance {distance[0]:.6g} mm is shorter than |L2 - L3|"


def format_position(position: npt.ArrayLike) -> str:
    """``(x, y, z)`` with enough digits to find the sample again."""
    return "(" + ", ".join(f"{v:.6g}" for v in np.asarray(position, dtype=np.float64)) + ")"


def leg_inverse(
    positions: npt.ArrayLike, geometry: LegGeometry = ARMSTRONG_LEG, yaw: npt.ArrayLike = 0.0
) -> FloatArray:
    """Closed-form inverse kinematics with the foot parallel to the floor.

    ``positions`` ``(N, 3)`` (or ``(3,)``) of the sole in mm, ``yaw`` the foot's heading
    (radians, scalar or ``(N,)``; the gait uses 0). Returns joint angles ``(N, 6)`` in radians,
    ordered as :data:`JOINT_NAMES`, knee bent backwards. Because the yaw axis is vertical and
    the foot flat, the yaw only rotates the target; the roll then tilts the leg's plane through
    the ankle (``roll = atan(y / h)``), and in that plane hip pitch and knee follow from the
    triangle thigh–shank–(hip to ankle), see seeds/README.md.

    Raises ``ValueError`` naming the first unreachable target's index and position: a target
    is never clipped into reach, because the robot would then silently put its foot elsewhere.
    """
    single = np.asarray(positions).ndim == 1
    forward, lateral, height, distance = _leg_frame(positions, geometry, yaw)
    ok = _within_reach(height, distance, geometry)
    if not ok.all():
        index = int(np.argmin(ok))
        target = np.atleast_2d(np.asarray(positions, dtype=np.float64))[index]
        psi = float(np.broadcast_to(np.asarray(yaw, dtype=np.float64), ok.shape)[index])
        raise KinematicsValueError(f"foot position {index} {format_position(target)} mm is out of "
                                   f"reach: {unreachable_reason(target, geometry, psi)}")
    l2, l3 = geometry.l2, geometry.l3
    roll = np.arctan2(lateral, height)
    in_plane_height = np.hypot(lateral, height)
    # the clips only absorb rounding at the stretched leg: reach was checked above
    at_hip = np.arccos(np.clip((l2**2 + distance**2 - l3**2) / (2 * l2 * distance), -1.0, 1.0))
    inner_knee = np.arccos(np.clip((l2**2 + l3**2 - distance**2) / (2 * l2 * l3), -1.0, 1.0))
    hip_pitch = np.arctan2(forward, in_plane_height) + at_hip
    knee = np.pi - inner_knee
    heading = np.broadcast_to(np.asarray(yaw, dtype=np.float64), roll.shape)
    joints = np.stack([heading, roll, hip_pitch, knee, knee - hip_pitch, roll], axis=-1)
    return joints[0] if single else joints


def leg_motor_angles(joints: npt.ArrayLike, side: Side) -> FloatArray:
    """Leg joint angles (radians, ``(N, 6)``) to the leg's motor columns m?1..m?6 in degrees.

    Signs as Table 4.2 of seed 001 prints them (seeds/README.md): left m12 = -hip pitch,
    m13 = +roll, m14 = -knee, m15 = +ankle pitch, m16 = -roll; right m22 = -hip pitch,
    m23 = +roll, m24 = +knee, m25 = -ankle pitch, m26 = -roll; hip yaw goes to m11 / m21
    unchanged (the gait keeps it 0).
    """
    if side not in _MOTOR_SIGNS:
        raise KinematicsValueError(f"side must be 'left' or 'right', got {side!r}")
    q = np.asarray(joints, dtype=np.float64)
    return np.asarray(np.degrees(q[..., list(_MOTOR_JOINTS)]) * _MOTOR_SIGNS[side])
