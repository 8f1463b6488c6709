"""Seed 002's controller, as Listing 1 computes it per frame: the fly's error to the image
centre, the dead band, the treadmill's three wheel speeds and the mobile robot's ``cmd_vel``.

Pure: a sighting in, a :class:`FlyCommand` out; the node that owns the bus and the topics
(:mod:`.flyball`) sends it. Listing 1, in order:

- the error ``dx = cx - 320``, ``dy = cy - 188``, ``dth = -(theta - 0)`` (eq. 4a-4c; a fly
  that was not found sits at the target, so the error is zero);
- turned into the motors' frame by ``thm`` = 20°: ``dxm = cos dx - sin dy``,
  ``dym = sin dx + cos dy``, ``dthm = dth``;
- outside the dead band (``|(dx, dy)| > 50`` px or ``|dth| > 3°``) the wheel speeds are
  ``omega_i = (J1M[i] . (dxm, dym, dthm * SF)) * K`` with K = 100, SF = 60, in the XM
  motors' goal_velocity units (0.229 rpm), truncated to whole units by ``(int)`` when sent;
  inside it, zero;
- the robot's ``linear.x = |(dx, dy)| * 38.4098 * 0.01 / (sampling time in ms)`` outside the
  distance band, ``angular.z = dthm / (sampling time in ms) * 57`` outside the angle band.

The robot's formula is the listing's as written, units and all: it is always forward (a
distance), and a turtlebot base clamps it to its limits. Its turn has the sign of ``dthm``,
the heading error: a fly turning clockwise in the image (theta growing, y down) turns the
robot clockwise (``angular.z`` < 0, ROS's counter-clockwise positive). servolab keeps the
wheel speeds within the motors' ``velocity_limit`` (the motor would refuse a larger goal),
which the listing left to chance, by scaling all three alike so that the ball still turns
the way the error asks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from ...kinematics.aot import THESIS_J1M, camera_to_motor
from ...vision.fly_tracker import PX_PER_MM, FlySighting
from ..errors import RobotValueError

FloatArray = npt.NDArray[np.float64]


def _thesis_matrix() -> FloatArray:
    return np.array(THESIS_J1M, dtype=np.float64)


@dataclass(frozen=True)
class FlyControllerConfig:
    """Listing 1's constants. ``matrix`` is J⁻¹M (the listing's, which eq. 3d gives from the
    rig's geometry in millimetres; see :mod:`servolab.kinematics.aot`)."""

    target: tuple[float, float, float] = (320.0, 188.0, 0.0)
    dead_band_px: float = 50.0
    dead_band_rad: float = 3 * 3.141592 / 180  # the listing's truncated pi
    gain: float = 100.0                 #: K
    rotation_scale: float = 60.0        #: SF
    camera_to_motor: float = 20 * 3.141592 / 180
    px_per_mm: float = PX_PER_MM
    matrix: FloatArray = field(default_factory=_thesis_matrix)
    #: the largest |goal_velocity| sent, in the motors' units (their velocity_limit)
    max_wheel_speed: float = 330.0

    def __post_init__(self) -> None:
        m = np.asarray(self.matrix, dtype=np.float64)
        if m.shape != (3, 3) or not np.all(np.isfinite(m)):
            raise RobotValueError(f"FlyControllerConfig: matrix must be 3x3 finite numbers, got "
                                  f"shape {m.shape}")
        object.__setattr__(self, "matrix", m)
        for name in ("dead_band_px", "dead_band_rad", "gain", "rotation_scale", "px_per_mm",
                     "max_wheel_speed"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise RobotValueError(f"FlyControllerConfig: {name} must be a number >= 0, not "
                                      f"{value!r}")
        if not all(math.isfinite(v) for v in (*self.target, self.camera_to_motor)):
            raise RobotValueError("FlyControllerConfig: target and camera_to_motor must be finite")


@dataclass(frozen=True)
class FlyCommand:
    """One frame's control: the errors (camera and motor frames), the wheel speeds (motor
    units, before truncation), the robot's Twist, and whether the fly was outside the band."""

    dx: float
    dy: float
    dth: float
    dxm: float
    dym: float
    dthm: float
    wheel_speeds: tuple[float, float, float]
    linear: float
    angular: float
    compensating: bool


def fly_command(sighting: FlySighting, sampling_time_us: float,
                config: FlyControllerConfig = FlyControllerConfig()) -> FlyCommand:
    """Listing 1's control for one frame (see the module docstring). ``sampling_time_us`` is
    the time since the previous frame, microseconds, as the listing measures it; the robot's
    speeds are 0 for a first frame (no sampling time yet)."""
    tx, ty, tth = config.target
    dx, dy = sighting.cx - tx, sighting.cy - ty
    dth = -(sighting.theta - tth)
    xm, ym = camera_to_motor(dx, dy, config.camera_to_motor)
    dxm, dym, dthm = float(xm), float(ym), dth
    distance = math.hypot(dx, dy)
    outside_r = distance > config.dead_band_px
    outside_th = abs(dth) > config.dead_band_rad
    if outside_r or outside_th:
        u = np.array([dxm, dym, dthm * config.rotation_scale])
        w = config.matrix @ u * config.gain
        largest = float(np.max(np.abs(w)))
        if largest > config.max_wheel_speed:  # all three scaled alike: the same direction
            w = w * (config.max_wheel_speed / largest)
        speeds = (float(w[0]), float(w[1]), float(w[2]))
    else:
        speeds = (0.0, 0.0, 0.0)
    ms = sampling_time_us * 0.001
    linear = distance * config.px_per_mm * 0.01 / ms if outside_r and ms > 0 else 0.0
    angular = dthm / ms * 57 if outside_th and ms > 0 else 0.0
    return FlyCommand(dx, dy, dth, dxm, dym, dthm, speeds, linear, angular,
                      outside_r or outside_th)
