"""AOT kinematics: seed 002 section 3 (rig), 3.1 eq. (3b)-(3d), and Appendix A Listing 1
(``J1M``, ``K``, ``SF``, ``thm`` and the motor-velocity law)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servolab.kinematics.aot import (
    THESIS_J1M,
    AotGeometry,
    AotGeometryError,
    AotKinematics,
    camera_to_motor,
    contact_points,
    inverse_jacobian_m,
    jacobian,
    m_matrix,
)
from servolab.kinematics.dh import FloatArray

RIG = AotGeometry()
KIN = AotKinematics.from_geometry(RIG)

speeds = st.floats(-1.0, 1.0, allow_nan=False)


def up_to_column_scale(matrix: FloatArray) -> FloatArray:
    """Each column over its largest-magnitude entry: pixels vs metres and raw velocity vs
    rad/s change each column's scale, not the ratios within it."""
    pivots = matrix[np.argmax(np.abs(matrix), axis=0), np.arange(3)]
    return np.asarray(matrix / pivots, dtype=np.float64)


# -- geometry -----------------------------------------------------------------------------------

def test_default_geometry_is_the_rig() -> None:
    # Section 3: 4-inch ball, 100 mm wheels, 40 deg, wheels at 0/120/240 deg;
    # Listing 1: thm = 20 deg "compensation for camera axis".
    assert RIG.ball_radius == pytest.approx(2 * 0.0254)
    assert RIG.wheel_radius == pytest.approx(0.100 / 2)
    assert RIG.tilt == pytest.approx(math.radians(40))
    assert np.degrees(RIG.wheel_angles) == pytest.approx([0, 120, 240])
    assert RIG.camera_to_motor == pytest.approx(math.radians(20))


def test_contact_points_lie_on_the_ball_at_the_tilt() -> None:
    # Eq. (3c): R_k runs from the ball's centre to wheel k's contact point.
    r = contact_points(RIG)
    assert np.linalg.norm(r, axis=1) == pytest.approx([RIG.ball_radius] * 3)
    elevation = np.arcsin(r[:, 2] / RIG.ball_radius)
    assert elevation == pytest.approx([RIG.tilt] * 3)
    assert np.degrees(np.arctan2(r[:, 1], r[:, 0])) % 360 == pytest.approx([0, 120, 240])


@pytest.mark.parametrize(("name", "kwargs"), [
    ("ball_radius", {"ball_radius": 0.0}),
    ("ball_radius", {"ball_radius": math.nan}),
    ("wheel_radius", {"wheel_radius": -0.05}),
    ("wheel_radius", {"wheel_radius": math.inf}),
    ("tilt", {"tilt": 0.0}),
    ("tilt", {"tilt": math.pi / 2}),
    ("tilt", {"tilt": math.nan}),
    ("wheel_angles", {"wheel_angles": (0.0, 1.0, 1.0)}),
    ("wheel_angles", {"wheel_angles": (0.0, 2 * math.pi, 3.0)}),
    ("wheel_angles", {"wheel_angles": (0.0, math.nan, 3.0)}),
    ("wheel_angles", {"wheel_angles": (0.0, 3.0)}),
    ("camera_to_motor", {"camera_to_motor": math.inf}),
])
def test_bad_geometry_refused_naming_the_field(name: str, kwargs: dict[str, object]) -> None:
    with pytest.raises(ValueError, match=rf"^{name} ") as info:
        AotGeometry(**kwargs)  # type: ignore[arg-type]
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("kwargs", [
    {"tilt": 1e-12},                                   # R_1z -> 0: J's rows 1-2 vanish
    {"tilt": math.pi / 2 - 1e-12},                     # R_1x -> 0: J's row 3 vanishes
    {"wheel_angles": (0.0, 1e-12, math.pi)},           # two wheels (almost) in one place
])
def test_singular_geometry_refused_with_condition_number(kwargs: dict[str, object]) -> None:
    geometry = AotGeometry(**kwargs)  # type: ignore[arg-type]
    with pytest.raises(AotGeometryError, match=r"condition number [0-9.e+]+") as info:
        inverse_jacobian_m(geometry)
    message = str(info.value)
    assert "\n" not in message and "AotGeometry(" in message
    assert "inf" not in message.replace("infinite", "") and "nan" not in message
    with pytest.raises(AotGeometryError):
        AotKinematics.from_geometry(geometry)


def test_singular_matrix_refused() -> None:
    with pytest.raises(AotGeometryError, match="condition number"):
        AotKinematics.from_matrix(np.ones((3, 3)))
    with pytest.raises(ValueError, match="3x3"):
        AotKinematics.from_matrix(np.eye(2))
    with pytest.raises(ValueError, match="finite"):
        AotKinematics.from_matrix(np.diag([1.0, math.nan, 1.0]))


# -- eq. (3b)-(3d) ------------------------------------------------------------------------------

def test_jacobian_is_eq_3c() -> None:
    # Eq. (3c), written out for a_1 = 0, a_2 = 120 deg, a_3 = 240 deg.
    r1 = contact_points(RIG)[0]
    x, z = r1[0], r1[2]
    c120, s120 = math.cos(2 * math.pi / 3), math.sin(2 * math.pi / 3)
    expected = z / RIG.ball_radius**2 * np.array([
        [z, z * c120, z * c120],
        [0.0, -z * s120, z * s120],
        [-x, -x, -x]])
    assert jacobian(RIG) == pytest.approx(expected, abs=1e-15)


def test_m_matrix_is_eq_3b() -> None:
    # Eq. (3b)/(3d): M = [[0, 1/r, 0], [1/r, 0, 0], [0, 0, 1]].
    assert m_matrix(0.05) == pytest.approx(np.array([[0, 20, 0], [20, 0, 0], [0, 0, 1]]))
    with pytest.raises(ValueError, match=r"^r "):
        m_matrix(0.0)


def test_j_times_inverse_jacobian_m_is_m() -> None:
    # Eq. (3b) J w = M X' and (3d) J^-1 M X' = w together.
    assert jacobian(RIG) @ KIN.matrix == pytest.approx(m_matrix(RIG.wheel_radius), abs=1e-12)


@settings(max_examples=200)
@given(speeds, speeds, speeds)
def test_round_trip(dx: float, dy: float, dtheta: float) -> None:
    v = np.array([dx, dy, dtheta])
    assert KIN.ball_velocity(KIN.wheel_speeds(dx, dy, dtheta)) == pytest.approx(v, abs=1e-12)


def test_wheel_speeds_broadcast_and_refuse_nan() -> None:
    w = KIN.wheel_speeds([0.01, 0.0], [0.0, 0.02], 0.5)
    assert w.shape == (3, 2)
    assert w[:, 1] == pytest.approx(KIN.wheel_speeds(0.0, 0.02, 0.5))
    assert KIN.ball_velocity(w) == pytest.approx(np.array([[0.01, 0.0], [0.0, 0.02], [0.5, 0.5]]))
    with pytest.raises(ValueError, match=r"^dy "):
        KIN.wheel_speeds(0.0, math.nan, 0.0)
    with pytest.raises(ValueError, match="3 rows"):
        KIN.ball_velocity([1.0, 2.0])


def test_pure_rotation_turns_all_wheels_equally() -> None:
    # Listing 1: J1M[2] = J1M[5] = J1M[8] = -0.00856566, so dx = dy = 0 drives the three
    # motors alike; three equal wheel speeds spin the ball about its axis only.
    w = KIN.wheel_speeds(0.0, 0.0, 1.0)
    assert w == pytest.approx([w[0]] * 3, rel=1e-12)
    assert w[0] != 0
    assert KIN.ball_velocity([1.0, 1.0, 1.0])[:2] == pytest.approx([0.0, 0.0], abs=1e-15)
    assert THESIS_J1M[:, 2] == pytest.approx([THESIS_J1M[0, 2]] * 3)


def test_translations_leave_the_wheel_sum_zero() -> None:
    # With wheels at 0/120/240 deg, translation columns of J^-1 M sum to zero (cos and sin
    # of the three angles do), as Listing 1's do: 0 - 0.000353621 + 0.000353621 and
    # 0.000408326 - 2 * 0.000204163.
    assert KIN.matrix[:, :2].sum(axis=0) == pytest.approx([0.0, 0.0], abs=1e-12)
    assert THESIS_J1M[:, :2].sum(axis=0) == pytest.approx([0.0, 0.0], abs=1e-12)


# -- Listing 1's J1M ----------------------------------------------------------------------------

def test_thesis_j1m_is_the_listing() -> None:
    # Listing 1: double J1M[9] = {0.0, 0.000408326, -0.00856566, -0.000353621, -0.000204163,
    # -0.00856566, 0.000353621, -0.000204163, -0.00856566}; // J inverse * M
    assert THESIS_J1M.flatten().tolist() == [
        0.0, 0.000408326, -0.00856566, -0.000353621, -0.000204163, -0.00856566,
        0.000353621, -0.000204163, -0.00856566]
    with pytest.raises(ValueError):
        THESIS_J1M[0, 0] = 1.0


def test_listing_ratios_are_the_geometrys() -> None:
    # Ratios Listing 1's J1M shows, which the 0/120/240 deg wheels of section 3 imply.
    t = THESIS_J1M
    assert t[0, 0] == 0.0
    assert t[1, 1] / t[0, 1] == pytest.approx(-0.5, abs=1e-6)
    assert t[2, 1] == t[1, 1]
    assert t[2, 0] == -t[1, 0]
    assert t[1, 0] / t[0, 1] == pytest.approx(-math.cos(math.radians(30)), abs=1e-6)
    ours = KIN.matrix
    assert ours[0, 0] == pytest.approx(0.0, abs=1e-12)
    assert ours[1, 1] / ours[0, 1] == pytest.approx(t[1, 1] / t[0, 1], abs=1e-3)
    assert ours[2, 1] / ours[1, 1] == pytest.approx(1.0, abs=1e-3)
    assert ours[2, 0] / ours[1, 0] == pytest.approx(-1.0, abs=1e-3)
    assert ours[1, 0] / ours[0, 1] == pytest.approx(t[1, 0] / t[0, 1], abs=1e-3)
    assert up_to_column_scale(ours) == pytest.approx(up_to_column_scale(t), abs=1e-3)
    # Same signs too, column by column: the scale relating each column is positive.
    nonzero = t != 0
    assert np.array_equal(np.sign(ours[nonzero]), np.sign(t[nonzero]))


def test_listing_is_eq_3c_in_millimetres_without_prefactor() -> None:
    # Listing 1's six-digit constants are (3d) for section 3's rig in mm, r = 50 mm (wheel,
    # (3a)), R_1 = 50.8 mm (cos 40, 0, sin 40), with (3c)'s R_1z / |R|^2 taken as 1: so
    # J1M = (|R|^2 / R_1z) * J^-1 M = 79.0 mm * J^-1 M.
    mm = AotGeometry(ball_radius=50.8, wheel_radius=50.0)
    r1z = contact_points(mm)[0, 2]
    listing = inverse_jacobian_m(mm) * (r1z / mm.ball_radius**2)
    assert listing == pytest.approx(THESIS_J1M, rel=2e-6, abs=1e-12)
    assert mm.ball_radius**2 / r1z == pytest.approx(79.03, abs=0.01)


def test_rotation_to_translation_ratio_comes_from_the_geometry() -> None:
    # Listing 1: J1M[2] / J1M[1] = -0.00856566 / 0.000408326 = -20.98, in mm. By (3c) it is
    # -r R_1z / (2 R_1x) = -r tan(tilt) / 2: 50 mm * tan 40 / 2 = 20.98 mm, 0.02098 m in SI.
    listing_ratio = THESIS_J1M[0, 2] / THESIS_J1M[0, 1]
    assert listing_ratio == pytest.approx(-20.9775, abs=1e-3)
    ours = KIN.matrix[0, 2] / KIN.matrix[0, 1]
    assert ours == pytest.approx(-RIG.wheel_radius * math.tan(RIG.tilt) / 2, rel=1e-12)
    assert ours * 1000 == pytest.approx(listing_ratio, rel=1e-4)
    # The other reading of "40 deg to the axis" (contact point 40 deg from the axis) does not.
    other = AotKinematics.from_geometry(AotGeometry(tilt=math.radians(50))).matrix
    assert other[0, 2] / other[0, 1] * 1000 == pytest.approx(-29.79, abs=0.01)


def rolling_wheel_matrix(geometry: AotGeometry) -> FloatArray:
    """Rigid-body no-slip model for comparison: rho w_k = (R_k x s_k) . omega, s_k the
    horizontal rolling direction at wheel k, omega from X' with the ball's radius."""
    r = contact_points(geometry)
    a = np.asarray(geometry.wheel_angles)
    s = np.stack([-np.sin(a), np.cos(a), np.zeros(3)], axis=1)
    normals = np.cross(r, s)                       # rows: R_k x s_k
    rb = geometry.ball_radius
    # Surface at the fly (z towards the wheels, fly at -z): x' = -rb w_y, y' = rb w_x.
    x_to_omega = np.array([[0.0, 1 / rb, 0.0], [-1 / rb, 0.0, 0.0], [0.0, 0.0, 1.0]])
    return np.asarray(normals @ x_to_omega / geometry.wheel_radius, dtype=np.float64)


def test_eq_3c_is_the_rolling_constraint_only_at_orthogonal_contact_normals() -> None:
    # Robinson et al. 2005's construction as (3c) transcribes it sums each wheel's contribution
    # as if alone; it inverts the no-slip constraint only when the contact normals are
    # orthogonal, tan(tilt) = sqrt(2), with r = ball radius.
    magic = AotGeometry(ball_radius=0.05, wheel_radius=0.05, tilt=math.atan(math.sqrt(2)))
    assert up_to_column_scale(inverse_jacobian_m(magic)) == pytest.approx(
        up_to_column_scale(rolling_wheel_matrix(magic)), abs=1e-12)
    # At the rig's 40 deg the rotation column must be 2 / tan(40)^2 * 50.8 / 50 = 2.89 times
    # larger against the translation columns than (3c) makes it.
    paper = KIN.matrix[0, 2] / KIN.matrix[0, 1]
    rolling = rolling_wheel_matrix(RIG)
    factor = (rolling[0, 2] / rolling[0, 1]) / paper
    assert factor == pytest.approx(2 / math.tan(RIG.tilt) ** 2 * 0.0508 / 0.05, rel=1e-12)
    assert factor == pytest.approx(2.886, abs=1e-3)


# -- Listing 1's control law --------------------------------------------------------------------

def test_camera_to_motor_is_the_listings_rotation() -> None:
    # Listing 1: dxm = cos(thm) dx - sin(thm) dy; dym = sin(thm) dx + cos(thm) dy.
    thm = RIG.camera_to_motor
    dxm, dym = camera_to_motor(10.0, 0.0, thm)
    assert (float(dxm), float(dym)) == pytest.approx((10 * math.cos(thm), 10 * math.sin(thm)))
    dxm, dym = camera_to_motor(0.0, 10.0, thm)
    assert (float(dxm), float(dym)) == pytest.approx((-10 * math.sin(thm), 10 * math.cos(thm)))
    dxm, dym = camera_to_motor([3.0, -1.0], [4.0, 2.0], 1.1)
    assert np.hypot(dxm, dym) == pytest.approx(np.hypot([3.0, -1.0], [4.0, 2.0]))
    with pytest.raises(ValueError, match=r"^angle "):
        camera_to_motor(1.0, 1.0, math.nan)


def test_from_matrix_reproduces_the_listings_motor_command() -> None:
    # Listing 1: omega_k = (J1M[k,0] dxm + J1M[k,1] dym + J1M[k,2] dthm SF) K, K = 100,
    # SF = 60; a fly 120 px right, 40 px down, heading off by 0.2 rad.
    k, sf = 100.0, 60.0
    dxm, dym = camera_to_motor(120.0, 40.0, 20 * 3.141592 / 180)
    listing = [(THESIS_J1M[i, 0] * dxm + THESIS_J1M[i, 1] * dym
                + THESIS_J1M[i, 2] * 0.2 * sf) * k for i in range(3)]
    thesis = AotKinematics.from_matrix(THESIS_J1M)
    assert thesis.wheel_speeds(dxm, dym, 0.2 * sf) * k == pytest.approx(listing, rel=1e-12)
    assert thesis.ball_velocity(thesis.wheel_speeds(dxm, dym, 0.2)) == pytest.approx(
        [float(dxm), float(dym), 0.2])


def test_listing_matrix_is_the_listings_for_the_thesis_rig() -> None:
    """listing_matrix (the rig file's ``matrix: geometry``) gives Listing 1's J1M for
    section 3's rig (SI in, as the rig file says it), and scales with the ball for others."""
    from servolab.kinematics.aot import listing_matrix

    assert listing_matrix(AotGeometry()) == pytest.approx(THESIS_J1M, rel=2e-6, abs=1e-12)
    bigger = listing_matrix(AotGeometry(ball_radius=0.0762))
    assert not np.allclose(bigger, THESIS_J1M, rtol=1e-3)
