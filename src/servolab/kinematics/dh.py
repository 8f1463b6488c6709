"""Standard Denavit–Hartenberg transforms, vectorised over many joint configurations.

Seed 001 (section 5.2.2, Table 5.2) models each leg of the Armstrong biped as a chain of six
standard DH links. Its printed link matrices ``A_i^{i-1}`` carry typesetting slips (``A_2^1``
uses ``q_1``, ``A_5^4`` has a wrong third row, ``A_6^5`` a ``-cos`` in its second row); this
module uses the textbook convention they abbreviate,

    A_i = Rot_z(theta_i) · Trans_z(d_i) · Trans_x(a_i) · Rot_x(alpha_i),

so that the chain of Table 5.2 gives a straight leg of length L1 + L2 + L3 + L4 at zero angles.
Angles are radians, lengths in whatever unit the caller uses (the leg uses mm).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from servolab.kinematics.errors import KinematicsValueError

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class DHLink:
    """One row of a DH table: the joint variable is added to ``theta_offset`` (radians)."""

    theta_offset: float
    d: float
    a: float
    alpha: float


def dh_transform(theta: npt.ArrayLike, d: float, a: float, alpha: float) -> FloatArray:
    """The homogeneous transform of one standard DH link for every angle in ``theta``.

    ``theta`` of shape ``S`` gives transforms of shape ``S + (4, 4)``; doing this with array
    arithmetic rather than a loop is what lets a whole gait be solved at once.
    """
    th = np.asarray(theta, dtype=np.float64)
    ct, st = np.cos(th), np.sin(th)
    ca, sa = float(np.cos(alpha)), float(np.sin(alpha))
    out = np.zeros((*th.shape, 4, 4))
    out[..., 0, 0], out[..., 0, 1], out[..., 0, 2], out[..., 0, 3] = ct, -st * ca, st * sa, a * ct
    out[..., 1, 0], out[..., 1, 1], out[..., 1, 2], out[..., 1, 3] = st, ct * ca, -ct * sa, a * st
    out[..., 2, 1], out[..., 2, 2], out[..., 2, 3] = sa, ca, d
    out[..., 3, 3] = 1.0
    return out


def chain_transform(links: Sequence[DHLink], q: npt.ArrayLike) -> FloatArray:
    """The base-to-tip transform ``T_n^0 = A_1 · … · A_n`` for joint angles ``q``.

    ``q`` has shape ``(N, n)`` (or ``(n,)`` for one configuration), one column per link, and
    the result has shape ``(N, 4, 4)`` (or ``(4, 4)``).
    """
    angles = np.asarray(q, dtype=np.float64)
    single = angles.ndim == 1
    angles = np.atleast_2d(angles)
    if angles.ndim != 2 or angles.shape[1] != len(links):
        raise KinematicsValueError(f"joint angles must have shape (N, {len(links)}), got "
                                   f"{angles.shape}")
    total = np.broadcast_to(np.eye(4), (angles.shape[0], 4, 4)).copy()
    for column, link in enumerate(links):
        step = dh_transform(angles[:, column] + link.theta_offset, link.d, link.a, link.alpha)
        total = total @ step
    return total[0] if single else total
