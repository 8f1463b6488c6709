"""Preview control of the zero-moment point on the cart-table model: the centre of mass (CoM)
that makes a biped's ZMP follow a planned reference.

Kajita, Kanehiro, Kaneko, Fujiwara, Harada, Yokoi and Hirukawa, "Biped walking pattern
generation by using preview control of zero-moment point", ICRA 2003, pp. 1620-1626. Why
this and not the seed's gait: a walker stays up while its ZMP stays inside the support
polygon, and the ZMP is set by the CoM's *acceleration* (the cart-table model below), so
the CoM must start moving *before* the ZMP has to move; a controller that sees the
reference ahead (the preview) can do that, a controller on the present error cannot.

The model, per horizontal axis, sampled every ``dt`` seconds: a cart of the robot's mass on
a massless table at the CoM's constant height ``z_c``, state ``x = (position, velocity,
acceleration)`` of the CoM, input the jerk ``u``::

    x[k+1] = A x[k] + B u[k],  A = [[1, dt, dt²/2], [0, 1, dt], [0, 0, 1]],
                               B = [dt³/6, dt²/2, dt]
    p[k]   = C x[k],           C = [1, 0, -z_c / g]     (the ZMP: p = x - z_c/g · ẍ)

The controller (the paper's, after Katayama et al. 1985) minimises ``sum(Qe e² + R u²)``
with ``e = p - p_ref``, on the state augmented by the integral of the ZMP error (``e``
summed), which removes a steady offset; the reference is known ``NL`` samples ahead::

    u[k] = -Gi · sum(e[0..k]) - Gx · x[k] - sum_{j=1..NL} Gd[j] · p_ref[k + j]

The gains come from the discrete algebraic Riccati equation of the augmented system, solved
by :func:`scipy.linalg.solve_discrete_are` (not iterated here). Units: SI (m, s, m/s²); the
paper's example (Fig. 6) used ``z_c = 0.814 m``, ``dt = 5 ms``, ``Qe = 1``, ``R = 1e-6`` and a
1.6 s preview: the defaults here but ``z_c``.

Pure: arrays in, arrays out. Every bad argument is a
:class:`~servolab.gait.errors.GaitValueError` naming it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.linalg import solve_discrete_are  # type: ignore[import-untyped]

from servolab.gait.errors import GaitValueError

FloatArray = npt.NDArray[np.float64]

#: Standard gravity (m/s²), the cart-table model's g.
GRAVITY = 9.80665
#: Kajita 2003's weights (its Fig. 6): the ZMP error's and the jerk's.
Q_ERROR = 1.0
R_JERK = 1e-6
#: Kajita 2003's preview window (s): the preview gain has faded by then.
PREVIEW_S = 1.6


def _positive(name: str, value: float, unit: str) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    if not (math.isfinite(number) and number > 0):
        raise GaitValueError(f"{name} must be a positive, finite number{unit}, got {value!r}")
    return number


def cart_table(dt: float, z_c: float, gravity: float = GRAVITY
               ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The cart-table model sampled every ``dt`` s with the CoM at ``z_c`` m: ``(A (3, 3),
    B (3, 1), C (1, 3))``, state (position, velocity, acceleration), input the jerk, output
    the ZMP (module docstring)."""
    dt = _positive("dt", dt, " s")
    z_c = _positive("z_c", z_c, " m")
    gravity = _positive("gravity", gravity, " m/s²")
    a = np.array([[1.0, dt, dt * dt / 2], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
    b = np.array([[dt**3 / 6], [dt * dt / 2], [dt]])
    c = np.array([[1.0, 0.0, -z_c / gravity]])
    return a, b, c


@dataclass(frozen=True, eq=False)
class PreviewController:
    """Kajita 2003's preview controller for one cart-table model; make one with
    :meth:`design`. Every axis uses the same gains (the model is the same along x and y).

    ``a``, ``b``, ``c``: the model; ``gi`` the integral gain, ``gx`` ``(3,)`` the state
    feedback, ``gd`` ``(NL,)`` the preview gains for ``p_ref[k + 1] .. p_ref[k + NL]``;
    ``riccati`` ``(4, 4)`` the DARE's solution of the augmented system (``augmented_a``,
    ``augmented_b``, ``q``, ``r``); ``closed_loop`` ``(4, 4)`` the augmented closed loop,
    whose eigenvalues lie inside the unit circle when the design is stable.
    """

    dt: float
    z_c: float
    a: FloatArray
    b: FloatArray
    c: FloatArray
    augmented_a: FloatArray
    augmented_b: FloatArray
    q: FloatArray
    r: float
    riccati: FloatArray
    gi: float
    gx: FloatArray
    gd: FloatArray
    closed_loop: FloatArray

    @classmethod
    def design(cls, dt: float, z_c: float, preview_s: float = PREVIEW_S, *,
               q_error: float = Q_ERROR, r_jerk: float = R_JERK,
               gravity: float = GRAVITY) -> PreviewController:
        """The gains for a model sampled every ``dt`` s with the CoM at ``z_c`` m, seeing the
        reference ``preview_s`` s ahead, weights ``q_error`` (ZMP error) and ``r_jerk``."""
        a, b, c = cart_table(dt, z_c, gravity)
        preview_s = _positive("preview_s", preview_s, " s")
        q_error = _positive("q_error", q_error, "")
        r_jerk = _positive("r_jerk", r_jerk, "")
        steps = round(preview_s / dt)
        if steps < 1:
            raise GaitValueError(f"preview_s {preview_s:g} s is shorter than one sample "
                                 f"(dt {dt:g} s)")
        # the augmented state (e[k], Δx[k]) of Katayama et al.: the ZMP error and the state's
        # increment; its first row integrates the error
        aa = np.zeros((4, 4))
        aa[0, 0] = 1.0
        aa[0, 1:] = (c @ a)[0]
        aa[1:, 1:] = a
        bb = np.vstack([c @ b, b])
        q = np.zeros((4, 4))
        q[0, 0] = q_error
        p = np.asarray(solve_discrete_are(aa, bb, q, np.array([[r_jerk]])), dtype=np.float64)
        gain_scale = 1.0 / (r_jerk + float((bb.T @ p @ bb)[0, 0]))
        k = gain_scale * (bb.T @ p @ aa)[0]
        closed = aa - bb @ k[None, :]
        # preview gains: Gd[1] = -Gi, Gd[j] = (R + B'PB)^-1 B' X[j-1], X[j] = Ac' X[j-1],
        # X[1] = -Ac' P I (I = the error's unit vector)
        gd = np.empty(steps)
        gd[0] = -k[0]
        x = -closed.T @ p[:, 0]
        for j in range(1, steps):
            gd[j] = gain_scale * float(bb[:, 0] @ x)
            x = closed.T @ x
        return cls(dt=float(dt), z_c=float(z_c), a=a, b=b, c=c, augmented_a=aa,
                   augmented_b=bb, q=q, r=r_jerk, riccati=p, gi=float(k[0]), gx=k[1:].copy(),
                   gd=gd, closed_loop=closed)

    @property
    def preview_steps(self) -> int:
        """NL: how many samples ahead the controller looks."""
        return int(self.gd.shape[0])

    def track(self, zmp_ref: npt.ArrayLike, initial: npt.ArrayLike | None = None
              ) -> tuple[FloatArray, FloatArray]:
        """The CoM's states that make the model's ZMP follow ``zmp_ref`` ``(N,)`` or ``(N,
        axes)`` (m, one sample every ``dt``): ``(states (N, 3[, axes]), zmp (N[, axes]))``,
        ``states[k] = (position, velocity, acceleration)`` and ``zmp`` the model's ``C x``.

        ``initial``: the CoM's starting position per axis, at rest (default ``zmp_ref[0]``:
        a robot standing still has its ZMP under its CoM). Past the end the reference is
        taken to stay at its last value, where the robot stands still.
        """
        ref = np.asarray(zmp_ref, dtype=np.float64)
        single = ref.ndim == 1
        ref2 = ref[:, None] if single else ref
        if ref2.ndim != 2 or ref2.shape[0] == 0 or ref2.shape[1] == 0:
            raise GaitValueError(f"zmp_ref must have shape (N,) or (N, axes), got {ref.shape}")
        if not np.isfinite(ref2).all():
            raise GaitValueError("zmp_ref must be finite")
        start = ref2[0] if initial is None else np.broadcast_to(
            np.asarray(initial, dtype=np.float64), ref2.shape[1:])
        if not np.isfinite(start).all():
            raise GaitValueError(f"initial must be finite, got {initial!r}")
        # about the start: a constant reference at the start is then kept exactly (a preview
        # cut off after NL samples makes sum(Gd) only nearly -Gx[0], which moves a CoM far
        # from the origin by a little), and where the origin lies does not matter
        ref2 = ref2 - start
        n, steps = ref2.shape[0], self.preview_steps
        padded = np.concatenate([ref2, np.repeat(ref2[-1:], steps, axis=0)])
        # f[k] = sum_j Gd[j] p_ref[k + j], j = 1..NL, for every k at once
        windows = np.lib.stride_tricks.sliding_window_view(padded[1:], steps, axis=0)[:n]
        preview = windows @ self.gd
        # the controlled model, every axis at once: state (x[k], s[k-1]) with s the summed
        # ZMP error, inputs (p_ref[k], f[k]) (_closed_loop_system)
        system_a, system_b = self._closed_loop_system()
        inputs = np.stack([ref2, preview], axis=1)           # (N, 2 inputs, axes)
        drive = np.einsum("ij,kja->kia", system_b, inputs)   # (N, 4, axes)
        state = np.zeros((4, ref2.shape[1]))
        states = np.empty((n, 3, ref2.shape[1]))
        for k in range(n):
            states[k] = state[:3]
            state = system_a @ state + drive[k]
        states[:, 0] += start
        zmp = np.einsum("j,kja->ka", self.c[0], states)
        if single:
            return states[:, :, 0], zmp[:, 0]
        return states, zmp

    def _closed_loop_system(self) -> tuple[FloatArray, FloatArray]:
        """The controlled model as one linear system ``z[k+1] = A z[k] + B w[k]``: state
        ``z = (x[k], s[k-1])`` with ``s`` the summed ZMP error, inputs ``w = (p_ref[k],
        f[k])`` (``f`` the preview sum). From ``s[k] = s[k-1] + C x[k] - p_ref[k]`` and the
        control law of the module docstring."""
        a, b, c = self.a, self.b, self.c
        feedback = self.gi * c + self.gx[None, :]
        system_a = np.zeros((4, 4))
        system_a[:3, :3] = a - b @ feedback
        system_a[:3, 3] = -self.gi * b[:, 0]
        system_a[3, :3] = c[0]
        system_a[3, 3] = 1.0
        system_b = np.zeros((4, 2))
        system_b[:3, 0] = self.gi * b[:, 0]
        system_b[:3, 1] = -b[:, 0]
        system_b[3, 0] = -1.0
        return system_a, system_b


def com_from_zmp(zmp_ref: npt.ArrayLike, dt: float, z_c: float, preview_s: float = PREVIEW_S,
                 *, initial: npt.ArrayLike | None = None, q_error: float = Q_ERROR,
                 r_jerk: float = R_JERK, gravity: float = GRAVITY
                 ) -> tuple[FloatArray, FloatArray]:
    """The CoM trajectory for a ZMP reference ``zmp_ref`` ``(N, 2)`` (m, x and y, one sample
    every ``dt`` s) with the CoM at height ``z_c`` m: ``(com (N, 2), zmp (N, 2))``, ``zmp``
    being the cart-table model's ZMP of that CoM (what the reference is tracked as).

    ``initial``: where the CoM starts, at rest (default ``zmp_ref[0]``). See
    :meth:`PreviewController.design` for the rest."""
    controller = PreviewController.design(dt, z_c, preview_s, q_error=q_error, r_jerk=r_jerk,
                                          gravity=gravity)
    states, zmp = controller.track(zmp_ref, initial)
    return states[:, 0], zmp
