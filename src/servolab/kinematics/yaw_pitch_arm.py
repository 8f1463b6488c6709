"""Closed-form inverse kinematics of a yaw-and-three-pitch-joints arm (the OpenMANIPULATOR-X's
layout), from its link parameters: the check of the numeric solver of :mod:`.chain`.

The arm: joint 1 turns about the base's vertical axis; joints 2, 3 and 4 turn about parallel
horizontal axes, so that the shoulder (joint 2), elbow (joint 3), wrist (joint 4) and tool all
stay in the vertical plane through the yaw axis. Each link is a vector in that plane, offsets
included (the OpenMANIPULATOR-X's upper arm goes 0.128 m up and 0.024 m forward, so its elbow
is not straight above its shoulder). :meth:`YawPitchArm.from_chain` reads the parameters off a
:class:`~servolab.kinematics.chain.Chain` at zero, which took them from the URDF's joint
origins: no number of a particular arm is written here.

A position and the tool's pitch (the angle of the tool's x axis below the horizontal, measured
toward the target's side of the yaw axis, as :meth:`Chain.pitch` does) are four equations in
four angles. They have up to four solutions: the arm facing the target or turned half a turn
and reaching back over (``yaw``), each with the elbow bent one way or the other (``elbow``).
:meth:`YawPitchArm.solve` returns those within the joint limits.

In the arm's plane a point is (u, w): u out from the yaw axis toward where the arm faces, w up.
A pitch joint turning by φ (about the plane's normal, the URDF's +y at zero) turns a link
vector (a, b) to (a cos φ + b sin φ, -a sin φ + b cos φ): positive φ tips it down.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from servolab.kinematics.dh import FloatArray
from servolab.kinematics.errors import KinematicsValueError

if TYPE_CHECKING:
    from servolab.kinematics.chain import Chain

Vec2 = tuple[float, float]
_TOLERANCE = 1e-9


def _turned(vector: Vec2, angle: float) -> Vec2:
    """``vector`` (u, w) turned by a pitch joint's ``angle``."""
    c, s = math.cos(angle), math.sin(angle)
    return vector[0] * c + vector[1] * s, -vector[0] * s + vector[1] * c


def _direction(vector: Vec2) -> float:
    """The pitch angle that turns the u axis (1, 0) onto ``vector``'s direction."""
    return math.atan2(-vector[1], vector[0])


def _into(angle: float, lower: float, upper: float) -> float | None:
    """``angle`` plus the whole turns that bring it within [lower, upper], else None."""
    turns = math.ceil((lower - angle) / (2.0 * math.pi) - 1e-12)
    shifted = angle + turns * 2.0 * math.pi
    return shifted if shifted <= upper + 1e-12 else None


def _wrapped(angle: float) -> float:
    return math.atan2(math.sin(angle), math.cos(angle))


@dataclass(frozen=True)
class YawPitchArm:
    """An arm's link parameters, in metres, as the module describes: ``yaw_axis`` the (x, y)
    of joint 1's axis in the base frame; ``shoulder`` joint 2's (u, w) (out from the yaw axis,
    height above the base frame); ``upper_arm``, ``forearm`` and ``hand`` the vectors (u, w)
    joint 2 -> 3 -> 4 -> tool with every joint at zero; ``signs`` +1 for a joint that turns
    about +z (joint 1) or the plane's +y (joints 2-4) at zero, -1 for the opposite axis;
    ``lower`` and ``upper`` the joint limits (rad)."""

    yaw_axis: Vec2
    shoulder: Vec2
    upper_arm: Vec2
    forearm: Vec2
    hand: Vec2
    signs: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0)
    lower: tuple[float, float, float, float] = (-math.inf,) * 4
    upper: tuple[float, float, float, float] = (math.inf,) * 4

    @classmethod
    def from_chain(cls, chain: Chain) -> YawPitchArm:
        """The parameters of ``chain`` (its joints' axes and the tool at zero), or a
        :class:`KinematicsValueError` saying which assumption of the layout it breaks."""
        if chain.n != 4 or chain.kinds != ("hinge",) * 4:
            raise KinematicsValueError(f"{chain.base} -> {chain.tip} is not four revolute joints "
                                       f"({', '.join(chain.kinds)}): no yaw-and-pitch arm")
        zero = np.zeros(4)
        anchors, axes = chain.axes(zero)
        tool = chain.forward(zero)
        if abs(abs(axes[0, 2]) - 1.0) > _TOLERANCE:
            raise KinematicsValueError(f"{chain.joint_names[0]} does not turn about the base's "
                                       f"vertical: axis {np.round(axes[0], 6).tolist()}")
        for name, axis in zip(chain.joint_names[1:], axes[1:], strict=True):
            if abs(abs(axis[1]) - 1.0) > _TOLERANCE:
                raise KinematicsValueError(f"{name} does not turn about the base's y axis at "
                                           f"zero: axis {np.round(axis, 6).tolist()}")
        points = np.vstack((anchors[1:], tool[:3, 3]))
        if np.any(np.abs(points[:, 1] - anchors[0, 1]) > _TOLERANCE):
            raise KinematicsValueError(f"{chain.base} -> {chain.tip} leaves the plane of its yaw "
                                       "axis at zero (a sideways offset): no closed form here")
        if not np.allclose(tool[:3, :3], np.eye(3), atol=_TOLERANCE):
            raise KinematicsValueError(f"the tool {chain.tip} is turned against the base at "
                                       "zero: its x axis must point along the base's x")

        def plane(vector: FloatArray) -> Vec2:
            return float(vector[0]), float(vector[2])

        axis_xy = (float(anchors[0, 0]), float(anchors[0, 1]))
        shoulder = (float(anchors[1, 0]) - axis_xy[0], float(anchors[1, 2]))
        signs = np.sign([axes[0, 2], axes[1, 1], axes[2, 1], axes[3, 1]])
        return cls(axis_xy, shoulder, plane(anchors[2] - anchors[1]),
                   plane(anchors[3] - anchors[2]), plane(tool[:3, 3] - anchors[3]),
                   _four(signs), _four(chain.lower), _four(chain.upper))

    def forward(self, q: npt.ArrayLike) -> tuple[FloatArray, float]:
        """The tool's position (base frame, m) and pitch (rad, in (-pi, pi]) at ``q``."""
        angles = _angles(q)
        s1, s2, s3, s4 = self.signs
        yaw = s1 * angles[0]
        phi2 = s2 * angles[1]
        phi3 = phi2 + s3 * angles[2]
        phi4 = phi3 + s4 * angles[3]
        u, w = self.shoulder
        for vector, angle in ((self.upper_arm, phi2), (self.forearm, phi3), (self.hand, phi4)):
            du, dw = _turned(vector, angle)
            u, w = u + du, w + dw
        xyz = np.array([self.yaw_axis[0] + u * math.cos(yaw),
                        self.yaw_axis[1] + u * math.sin(yaw), w])
        return xyz, _wrapped(phi4 if u >= 0 else math.pi - phi4)

    def solve(self, target_xyz: npt.ArrayLike, pitch: float, *,
              within_limits: bool = True) -> FloatArray:
        """Every joint position (rows of a k x 4 array, k = 0 to 4) that puts the tool at
        ``target_xyz`` with ``pitch``: within the limits (shifted by whole turns where that
        brings an angle inside), or, with ``within_limits=False``, all, in (-pi, pi]."""
        xyz = np.asarray(target_xyz, dtype=np.float64)
        if xyz.shape != (3,) or not np.all(np.isfinite(xyz)):
            raise KinematicsValueError(f"target_xyz must be 3 finite numbers, got {target_xyz!r}")
        if not math.isfinite(pitch):
            raise KinematicsValueError(f"pitch must be finite, got {pitch!r}")
        dx, dy = xyz[0] - self.yaw_axis[0], xyz[1] - self.yaw_axis[1]
        azimuth, reach = math.atan2(dy, dx), math.hypot(dx, dy)
        found = []
        for yaw, u, phi4 in ((azimuth, reach, pitch), (azimuth + math.pi, -reach, math.pi - pitch)):
            for phi2, phi3 in self._elbows(u, float(xyz[2]), phi4):
                s1, s2, s3, s4 = self.signs
                q = [s1 * yaw, s2 * phi2, s3 * (phi3 - phi2), s4 * (phi4 - phi3)]
                q = [_wrapped(a) for a in q]
                if within_limits:
                    inside = [_into(a, lo, hi) for a, lo, hi in zip(q, self.lower, self.upper,
                                                                    strict=True)]
                    if any(a is None for a in inside):
                        continue
                    q = [float(a) for a in inside if a is not None]
                found.append(q)
        return np.array(found, dtype=np.float64).reshape(-1, 4)

    def _elbows(self, u: float, w: float, phi4: float) -> list[tuple[float, float]]:
        """The (φ2, φ3) that put the wrist where the tool at (u, w) with its hand at φ4 needs
        it: none, one (arm straight) or two (elbow either way)."""
        hand = _turned(self.hand, phi4)
        du = u - hand[0] - self.shoulder[0]
        dw = w - hand[1] - self.shoulder[1]
        # in (u, -w) the pitch turns are the usual counter-clockwise ones
        first, second = math.hypot(*self.upper_arm), math.hypot(*self.forearm)
        cos = (du * du + dw * dw - first * first - second * second) / (2.0 * first * second)
        if abs(cos) > 1.0 + 1e-12:
            return []
        bend = math.acos(max(-1.0, min(1.0, cos)))
        out = []
        for delta in ((bend, -bend) if bend > 1e-12 else (bend,)):
            alpha = math.atan2(-dw, du) - math.atan2(second * math.sin(delta),
                                                    first + second * math.cos(delta))
            out.append((alpha - _direction(self.upper_arm),
                        alpha + delta - _direction(self.forearm)))
        return out


def _four(values: FloatArray) -> tuple[float, float, float, float]:
    a, b, c, d = (float(v) for v in values)
    return a, b, c, d


def _angles(q: npt.ArrayLike) -> list[float]:
    angles = np.asarray(q, dtype=np.float64)
    if angles.shape != (4,) or not np.all(np.isfinite(angles)):
        raise KinematicsValueError(f"q must be 4 finite angles, got {q!r}")
    return [float(a) for a in angles]
