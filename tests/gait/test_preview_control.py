"""Preview control of the ZMP on the cart-table model (servolab.gait.preview_control), after
Kajita et al., "Biped walking pattern generation by using preview control of zero-moment
point", ICRA 2003.

The oracles are not the module's own arithmetic: the model's discretisation is checked
against scipy's zero-order hold of the continuous triple integrator, the gains against the
Riccati equation itself and the closed loop's eigenvalues, and the CoM against its ZMP
recomputed here by finite differences (p = x - z_c/g * x''), on the paper's own setting
(z_c = 0.814 m, dt = 5 ms, Qe = 1, R = 1e-6, a 1.6 s preview; its Fig. 6).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import cont2discrete  # type: ignore[import-untyped]

from servolab.gait.errors import GaitValueError
from servolab.gait.preview_control import (
    GRAVITY,
    PreviewController,
    cart_table,
    com_from_zmp,
)

#: Kajita 2003's example (Fig. 6): its cart-table and weights.
Z_C = 0.814
DT = 0.005


@pytest.fixture(scope="module")
def kajita() -> PreviewController:
    return PreviewController.design(DT, Z_C, 1.6, q_error=1.0, r_jerk=1e-6)


def finite_difference_zmp(com: np.ndarray, dt: float, z_c: float) -> np.ndarray:
    """The cart-table ZMP of a sampled CoM, x - z_c/g * x'', x'' by central differences
    (the ends repeat their neighbours)."""
    acc = np.empty_like(com)
    acc[1:-1] = (com[2:] - 2 * com[1:-1] + com[:-2]) / dt**2
    acc[0], acc[-1] = acc[1], acc[-2]
    return com - z_c / GRAVITY * acc


def fig6_reference(dt: float) -> tuple[np.ndarray, np.ndarray]:
    """A ZMP staircase like Kajita's Fig. 6: standing (longer than the preview, so the CoM
    starts at rest), then a step every 0.8 s, 0.3 m forward and from side to side (0.1 m),
    then standing; ``(time, zmp (N, 2))``."""
    time = np.arange(round(10.0 / dt)) * dt
    k = np.clip(np.floor((time - 2.0) / 0.8).astype(int) + 1, 0, 8)
    x = 0.3 * k
    y = np.where((k > 0) & (k < 8), np.where(k % 2 == 1, 0.1, -0.1), 0.0)
    return time, np.column_stack([x, y])


def test_cart_table_is_the_exact_discretisation_of_the_triple_integrator() -> None:
    a, b, c = cart_table(DT, Z_C)
    continuous_a = np.diag([1.0, 1.0], k=1)
    continuous_b = np.array([[0.0], [0.0], [1.0]])
    output = np.array([[1.0, 0.0, -Z_C / GRAVITY]])
    ad, bd, cd, _, _ = cont2discrete((continuous_a, continuous_b, output, np.zeros((1, 1))),
                                     DT, method="zoh")
    assert a == pytest.approx(ad, abs=1e-15)
    assert b == pytest.approx(bd, abs=1e-15)
    assert c == pytest.approx(cd)


def test_the_gains_solve_the_riccati_equation_of_the_augmented_system(
        kajita: PreviewController) -> None:
    """The augmented system (the ZMP error's sum and the state's increment) built here from
    the model, and the DARE's residual A'PA - P - A'PB (R + B'PB)^-1 B'PA + Q at the
    solution the controller holds."""
    a, b, c = kajita.a, kajita.b, kajita.c
    aa = np.block([[np.eye(1), c @ a], [np.zeros((3, 1)), a]])
    bb = np.vstack([c @ b, b])
    q = np.diag([1.0, 0.0, 0.0, 0.0])
    r = 1e-6
    p = kajita.riccati
    assert kajita.augmented_a == pytest.approx(aa)
    assert kajita.augmented_b == pytest.approx(bb)
    gain = np.linalg.solve(r + bb.T @ p @ bb, bb.T @ p @ aa)
    residual = aa.T @ p @ aa - p - aa.T @ p @ bb @ gain + q
    assert np.abs(residual).max() < 1e-6 * np.abs(p).max()
    assert p == pytest.approx(p.T)
    assert np.all(np.linalg.eigvalsh((p + p.T) / 2) > -1e-9 * np.abs(p).max())
    # the gains are that state feedback: Gi on the error's sum, Gx on the state
    assert kajita.gi == pytest.approx(gain[0, 0])
    assert kajita.gx == pytest.approx(gain[0, 1:])


def test_the_closed_loop_is_stable(kajita: PreviewController) -> None:
    loop = kajita.augmented_a - kajita.augmented_b @ np.concatenate([[kajita.gi], kajita.gx])[
        None, :]
    assert kajita.closed_loop == pytest.approx(loop)
    assert np.abs(np.linalg.eigvals(loop)).max() < 1.0


def test_the_preview_gain_fades_within_the_window(kajita: PreviewController) -> None:
    """As the paper plots it: the preview gain Gd starts at -Gi and falls off toward 0
    within the 1.6 s window (the far future hardly matters, which is why 1.6 s is enough)."""
    gd = kajita.gd
    assert kajita.preview_steps == 320
    assert gd[0] == pytest.approx(-kajita.gi)
    assert np.abs(gd[-1]) < 0.01 * np.abs(gd).max()
    assert np.abs(gd[round(1.0 / DT):]).max() < 0.1 * np.abs(gd).max()


def test_fig6_the_com_tracks_the_zmp_staircase(kajita: PreviewController) -> None:
    """Fig. 6: the cart-table ZMP of the generated CoM follows the reference; away from its
    jumps (which no CoM can make the ZMP follow in an instant) within 3 mm, 1 mm rms. The
    CoM moves before the ZMP does (the preview), stays within the reference's range and
    ends at rest over its last point."""
    time, reference = fig6_reference(DT)
    states, zmp = kajita.track(reference)
    com = states[:, 0]
    recomputed = finite_difference_zmp(com, DT, Z_C)
    jumps = time[np.flatnonzero(np.any(np.diff(reference, axis=0) != 0, axis=1)) + 1]
    calm = np.min(np.abs(time[:, None] - jumps[None, :]), axis=1) > 0.15
    # the module's own ZMP is the model's: the same, but where the jerk changes fast (the
    # central difference sees (u[k] - u[k-1]) dt / 6 of it): at the jumps, and a little as
    # each jump enters the preview window 1.6 s ahead
    assert zmp[calm] == pytest.approx(recomputed[calm], abs=3e-4)
    assert zmp == pytest.approx(recomputed, abs=5e-3)
    error = np.abs(recomputed - reference)[calm]
    assert error.max() < 3e-3          # the ZMP's small dip before each step
    assert np.sqrt(np.mean(error**2)) < 1e-3
    first = np.flatnonzero(np.abs(com[:, 0]) > 1e-3)[0]
    assert 0.4 < time[first] < 2.0            # the CoM starts before the first step
    assert com[:, 0].min() > -0.02 and com[:, 0].max() < 2.4 + 0.02
    assert np.abs(com[:, 1]).max() < 0.1
    assert com[-1] == pytest.approx(reference[-1], abs=1e-3)   # at rest over the last ZMP
    assert states[-1, 1:] == pytest.approx(np.zeros((2, 2)), abs=1e-3)


def test_com_from_zmp_is_the_controller_run(kajita: PreviewController) -> None:
    _, reference = fig6_reference(DT)
    com, zmp = com_from_zmp(reference, DT, Z_C, 1.6, q_error=1.0, r_jerk=1e-6)
    states, expected = kajita.track(reference)
    assert com.shape == (reference.shape[0], 2)
    assert com == pytest.approx(states[:, 0])
    assert zmp == pytest.approx(expected)


def test_a_constant_reference_keeps_the_com_still() -> None:
    reference = np.tile([0.02, -0.01], (400, 1))
    com, zmp = com_from_zmp(reference, 0.005, 0.3)
    assert com == pytest.approx(reference, abs=1e-12)
    assert zmp == pytest.approx(reference, abs=1e-12)


def test_initial_is_where_the_com_starts_at_rest() -> None:
    """A CoM that starts off the reference comes over it (the integral action leaves no
    offset), and one axis alone may be given as (N,)."""
    reference = np.zeros(1200)
    states, zmp = PreviewController.design(0.005, 0.3).track(reference, initial=0.03)
    assert states.shape == (1200, 3) and zmp.shape == (1200,)
    assert states[0] == pytest.approx([0.03, 0.0, 0.0])
    assert abs(states[-1, 0]) < 1e-4


@pytest.mark.parametrize(("call", "name"), [
    (lambda: cart_table(0.0, 0.3), "dt"),
    (lambda: cart_table(0.005, -0.3), "z_c"),
    (lambda: PreviewController.design(0.005, 0.3, preview_s=0.0), "preview_s"),
    (lambda: PreviewController.design(0.005, 0.3, preview_s=0.001), "preview_s"),
    (lambda: PreviewController.design(0.005, 0.3, r_jerk=0.0), "r_jerk"),
    (lambda: PreviewController.design(0.005, 0.3, q_error=float("nan")), "q_error"),
    (lambda: com_from_zmp(np.full((10, 2), np.nan), 0.005, 0.3), "zmp_ref"),
    (lambda: com_from_zmp(np.zeros((10, 2, 2)), 0.005, 0.3), "zmp_ref"),
    (lambda: com_from_zmp(np.zeros((0, 2)), 0.005, 0.3), "zmp_ref"),
    (lambda: com_from_zmp(np.zeros((10, 2)), 0.005, 0.3, initial=[np.inf, 0]), "initial"),
])
def test_bad_arguments_are_refused_by_name(call: object, name: str) -> None:
    with pytest.raises(GaitValueError, match=name) as error:
        call()  # type: ignore[operator]
    assert "\n" not in str(error.value)
