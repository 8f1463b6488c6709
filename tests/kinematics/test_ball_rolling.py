"""The treadmill ball as a rigid body rolling on its three omni-wheels (seed 002 section 3:
4-inch ball, 100 mm wheels at 0/120/240 deg, axles at 40 deg to the ball's axis; section 3.1:
"no slip exists between the omni-directional wheels and the sphere"), against eq. (3b)-(3d)
as :mod:`servolab.kinematics.aot` keeps them.

The no-slip constraints are rebuilt here from first principles (the contact points and the
rims' directions from the geometry's numbers, not from the module) and solved by least
squares, so the module's solve is checked by an independent computation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servolab.kinematics.aot import AotGeometry, AotGeometryError, AotKinematics
from servolab.kinematics.ball_rolling import (
    RollingBall,
    ball_angular_velocity,
    drive_directions,
    rolling_ball_velocity,
    rolling_matrix,
    surface_velocity,
)
from servolab.kinematics.dh import FloatArray

RIG = AotGeometry()
BALL = RollingBall(RIG)
PAPER = AotKinematics.from_geometry(RIG)

speeds = st.floats(-5.0, 5.0, allow_nan=False)


def first_principles(geometry: AotGeometry) -> tuple[FloatArray, FloatArray]:
    """Contact points and rim directions from the geometry's numbers alone: wheel k at
    azimuth a_k touches the ball ``tilt`` below its equator (z from the centre towards the
    wheels); its rim runs horizontally round the ball's axis, clockwise seen along +z."""
    rb, t = geometry.ball_radius, geometry.tilt
    points, rims = [], []
    for a in geometry.wheel_angles:
        p = rb * np.array([math.cos(t) * math.cos(a), math.cos(t) * math.sin(a), math.sin(t)])
        around = np.cross([0.0, 0.0, 1.0], p)     # counter-clockwise round +z
        points.append(p)
        rims.append(-around / np.linalg.norm(around))
    return np.array(points), np.array(rims)


def lstsq_omega(geometry: AotGeometry, wheels: FloatArray, slip: float = 0.0) -> FloatArray:
    """Solve (omega x p_k) . d_k = (1 - slip) rho w_k by least squares, the constraint
    written as a linear map of omega column by column (omega = e_x, e_y, e_z)."""
    points, rims = first_principles(geometry)
    basis = np.eye(3)
    a = np.array([[np.dot(np.cross(e, p), d) for e in basis] for p, d in zip(points, rims,
                                                                             strict=True)])
    rhs = (1.0 - slip) * geometry.wheel_radius * np.asarray(wheels, dtype=float)
    omega, *_ = np.linalg.lstsq(a, rhs, rcond=None)
    return np.asarray(omega, dtype=np.float64)


# -- the constraint ---------------------------------------------------------------------------

@settings(max_examples=100, deadline=None)
@given(speeds, speeds, speeds)
def test_omega_is_the_least_squares_solution_of_the_no_slip_constraints(
        w1: float, w2: float, w3: float) -> None:
    wheels = np.array([w1, w2, w3])
    assert ball_angular_velocity(RIG, wheels) == pytest.approx(lstsq_omega(RIG, wheels),
                                                               abs=1e-12)


@pytest.mark.parametrize("geometry", [
    RIG,
    AotGeometry(ball_radius=0.1, wheel_radius=0.03, tilt=math.radians(25)),
    AotGeometry(wheel_angles=(0.3, 2.0, 4.5), tilt=math.radians(60)),   # not 120 deg apart
])
@pytest.mark.parametrize("slip", [0.0, 0.2])
def test_each_contact_moves_with_its_wheels_rim(geometry: AotGeometry, slip: float) -> None:
    # Direct check: the ball's surface at each contact, along that wheel's rim, moves at the
    # rim's speed rho w_k (less the stated slip); across the rim (the rollers' freedom) it
    # may move at any speed.
    wheels = np.array([1.5, -0.7, 0.4])
    omega = ball_angular_velocity(geometry, wheels, slip)
    points, rims = first_principles(geometry)
    along = [np.dot(np.cross(omega, p), d) for p, d in zip(points, rims, strict=True)]
    assert along == pytest.approx((1 - slip) * geometry.wheel_radius * wheels, abs=1e-12)
    assert drive_directions(geometry) == pytest.approx(rims, abs=1e-15)
    assert rolling_matrix(geometry) @ omega == pytest.approx(along, abs=1e-12)


def test_slip_scales_the_motion() -> None:
    wheels = np.array([0.3, 1.0, -2.0])
    assert rolling_ball_velocity(RIG, wheels, 0.25) == pytest.approx(
        0.75 * rolling_ball_velocity(RIG, wheels), abs=1e-15)


def test_surface_under_the_fly_is_omega_cross_the_top() -> None:
    # The fly stands on the top, -ball_radius z (z points down, towards the wheels).
    omega = np.array([0.4, -1.1, 0.7])
    v = np.cross(omega, [0.0, 0.0, -RIG.ball_radius])
    assert surface_velocity(RIG, omega) == pytest.approx([v[0], v[1], omega[2]], abs=1e-15)
    assert v[2] == 0.0


def test_vectorised_like_ball_velocity() -> None:
    w = np.array([[1.0, 0.0], [-0.5, 1.0], [-0.5, 1.0]])
    both = BALL.ball_velocity(w)
    assert both.shape == (3, 2)
    assert both[:, 0] == pytest.approx(BALL.ball_velocity(w[:, 0]))
    assert ball_angular_velocity(RIG, w).shape == (3, 2)


# -- pure spin and pure translation -----------------------------------------------------------

def test_equal_wheels_spin_the_ball_about_its_axis_only() -> None:
    # Three equal rim speeds: omega along z, the contacts' speed rb cos(tilt) |omega_z|.
    omega = ball_angular_velocity(RIG, [1.0, 1.0, 1.0])
    assert omega[:2] == pytest.approx([0.0, 0.0], abs=1e-15)
    assert abs(omega[2]) == pytest.approx(RIG.wheel_radius / (RIG.ball_radius
                                                              * math.cos(RIG.tilt)))
    assert BALL.ball_velocity([1.0, 1.0, 1.0])[:2] == pytest.approx([0.0, 0.0], abs=1e-15)


@pytest.mark.parametrize("direction", [0.0, 0.9, 2.5])
def test_a_translation_needs_the_wheels_summing_to_zero(direction: float) -> None:
    # The surface under the fly moving at (cos, sin) * 1 cm/s with no spin: omega horizontal,
    # and each wheel's rim speed rho w_k = sin(tilt) (y' cos a_k - x' sin a_k).
    vx, vy = 0.01 * math.cos(direction), 0.01 * math.sin(direction)
    a = np.asarray(RIG.wheel_angles)
    wheels = math.sin(RIG.tilt) * (vy * np.cos(a) - vx * np.sin(a)) / RIG.wheel_radius
    assert wheels.sum() == pytest.approx(0.0, abs=1e-15)
    assert BALL.ball_velocity(wheels) == pytest.approx([vx, vy, 0.0], abs=1e-15)
    assert ball_angular_velocity(RIG, wheels)[2] == pytest.approx(0.0, abs=1e-15)


# -- against eq. (3b) -------------------------------------------------------------------------

def test_signs_agree_with_eq_3b_wheel_by_wheel() -> None:
    # The rims' positive sense is eq. (3b)'s: each wheel alone moves x', y', theta' the same
    # way under both models, so Listing 1's signs still compensate on the rolling ball.
    rolling, paper = BALL.to_surface, PAPER.inverse
    big = np.abs(paper) > 1e-9
    assert np.array_equal(np.sign(rolling[big]), np.sign(paper[big]))
    assert np.abs(rolling[~big]).max() < 1e-12


def test_the_two_models_differ_by_one_scale_per_axis() -> None:
    # For wheels 120 deg apart both models map the wheels to the same directions of motion;
    # the rolling ball translates 1 / (1.5 sin(tilt)^3) = 2.51 times and turns
    # rho / (3 rb sin(tilt) cos(tilt)^2) = 0.87 times as fast as (3b) says.
    t, rho, rb = RIG.tilt, RIG.wheel_radius, RIG.ball_radius
    translate = 1 / (1.5 * math.sin(t) ** 3)
    turn = rho / (3 * rb * math.sin(t) * math.cos(t) ** 2)
    expected = np.diag([translate, translate, turn]) @ PAPER.inverse
    assert BALL.to_surface == pytest.approx(expected, abs=1e-12)
    assert (translate, turn) == pytest.approx((2.510, 0.870), abs=1e-3)


def test_eq_3b_turns_the_ball_2_9_times_too_much_for_its_translation() -> None:
    # aot.py's module docstring and tests/kinematics/test_aot.py
    # (test_eq_3c_is_the_rolling_constraint_only_at_orthogonal_contact_normals): at the rig's
    # 40 deg (section 3), 50.8 mm ball and 50 mm wheels, the rolling constraint needs the
    # wheels' rotation column of (3d) 2 / tan(40)^2 * 50.8 / 50 = 2.886 times larger against
    # the translation columns than (3c) makes it. Seen from the wheels' side, the same
    # factor: for the same wheel speeds, (3b)'s theta' over |(x', y')| is 2.886 times the
    # rolling ball's.
    spin, shift = np.ones(3), np.array([0.0, 1.0, -1.0])
    turn = BALL.ball_velocity(spin)[2] / PAPER.ball_velocity(spin)[2]
    move = (np.linalg.norm(BALL.ball_velocity(shift)[:2])
            / np.linalg.norm(PAPER.ball_velocity(shift)[:2]))
    assert move / turn == pytest.approx(2 / math.tan(RIG.tilt) ** 2 * 0.0508 / 0.05, rel=1e-12)
    assert move / turn == pytest.approx(2.886, abs=1e-3)


def test_at_orthogonal_contact_normals_eq_3b_is_rolling_up_to_one_scale() -> None:
    # tan(tilt) = sqrt(2) and r = ball radius: the one geometry where (3c) inverts the rolling
    # constraint (aot.py), here as one common factor on all three axes, sqrt(3/2).
    magic = AotGeometry(ball_radius=0.05, wheel_radius=0.05, tilt=math.atan(math.sqrt(2)))
    ratio = RollingBall(magic).to_surface / AotKinematics.from_geometry(magic).inverse
    nonzero = np.abs(AotKinematics.from_geometry(magic).inverse) > 1e-9
    assert ratio[nonzero] == pytest.approx(math.sqrt(1.5), rel=1e-12)


# -- bad input --------------------------------------------------------------------------------

@pytest.mark.parametrize(("name", "args"), [
    ("slip", ([1.0, 1.0, 1.0], 1.0)),
    ("slip", ([1.0, 1.0, 1.0], -0.1)),
    ("slip", ([1.0, 1.0, 1.0], math.nan)),
    ("slip", ([1.0, 1.0, 1.0], True)),
    ("slip", ([1.0, 1.0, 1.0], "0.1")),
    ("wheel_speeds", ([1.0, math.nan, 1.0], 0.0)),
    ("wheel_speeds", ([1.0, 2.0], 0.0)),
    ("wheel_speeds", (5.0, 0.0)),
    ("wheel_speeds", (["a", "b", "c"], 0.0)),
])
def test_bad_input_refused_in_one_line(name: str, args: tuple[object, object]) -> None:
    with pytest.raises(ValueError, match=rf"^{name} ") as info:
        ball_angular_velocity(RIG, *args)  # type: ignore[arg-type]
    assert "\n" not in str(info.value)


def test_bad_geometry_refused() -> None:
    with pytest.raises(ValueError, match=r"^geometry must be an AotGeometry"):
        RollingBall("rig")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"^omega must have 3 rows"):
        surface_velocity(RIG, [1.0, 2.0])


@pytest.mark.parametrize("kwargs", [
    {"tilt": 1e-12},                                   # contacts on the equator: rows vertical
    {"tilt": math.pi / 2 - 1e-12},                     # contacts at the pole: rows horizontal
    {"wheel_angles": (0.0, 1e-12, math.pi)},           # two wheels (almost) in one place
])
def test_wheels_that_cannot_fix_the_ball_are_refused(kwargs: dict[str, object]) -> None:
    geometry = AotGeometry(**kwargs)  # type: ignore[arg-type]
    with pytest.raises(AotGeometryError, match=r"^rolling constraint of AotGeometry\(") as info:
        RollingBall(geometry)
    assert "condition number" in str(info.value) and "\n" not in str(info.value)
