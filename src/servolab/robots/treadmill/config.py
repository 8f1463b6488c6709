"""The treadmill rig as a file: ball and wheels, camera, tracker, controller and the run's
warnings, read through the one loader (:mod:`servolab.configfile`) with command-line
overrides (``--set tracker.threshold=60``).

Why a file: a fly lab's rig is not the thesis's. Its ball, its camera's scale and angle, its
lighting (a dark fly on a lit ball) and its gains are what it tunes, and each of them was a
constant in Listing 1. The shipped ``treadmill.yaml`` is the thesis's rig, so that the
defaults reproduce Listing 1 number for number; a lab copies it.

Angles are degrees in the file. The controller's two (``controller.dead_band_deg`` and
``camera.angle_to_motors``) become radians as Listing 1 computes them, ``deg * 3.141592 /
180`` (its ``limit_th`` and ``thm``), so the default is the listing's to the last digit; the
rig's geometry uses pi. The two differ by 2e-7 of the value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ...configfile import (
    ConfigMapping,
    ConfigValue,
    load,
    nonnegative_float,
    overridden,
    positive_float,
    shipped,
)
from ...errors import ConfigFileError
from ...kinematics.aot import MAX_CONDITION, THESIS_J1M, AotGeometry, listing_matrix
from ...kinematics.errors import KinematicsValueError
from ...vision.errors import VisionValueError
from ...vision.fly_tracker import POLARITIES, PX_PER_MM, FlyTrackerConfig
from ..errors import RobotValueError
from .control import FlyControllerConfig

if TYPE_CHECKING:
    from collections.abc import Collection

#: Listing 3: the camera's frame_rate (frames/s)
FRAME_RATE = 66.0
#: Listing 1's pi (``limit_th = 3*3.141592/180``, ``thm = 20*3.141592/180``)
LISTING_PI = 3.141592
_SECTIONS = ("ball", "camera", "tracker", "controller", "fictrac", "run")
_BALL = ("radius", "wheel_radius", "tilt", "wheel_angles")
_CAMERA = ("width", "height", "frame_rate", "px_per_mm", "angle_to_motors")
_TRACKER = ("threshold", "polarity", "min_area", "max_area", "roi", "background_subtraction")
_CONTROLLER = ("target", "dead_band_px", "dead_band_deg", "gain", "rotation_scale", "matrix")
_RUN = ("lost_fly_share", "late_after")
_FICTRAC = ("cam_to_lab",)


class RigConfigError(ConfigFileError):
    """A rig file (or a ``--set``) that cannot be used."""


@dataclass(frozen=True)
class CameraConfig:
    """The camera as the treadmill uses it: its frame, rate and scale."""

    width: int = 640
    height: int = 376
    #: frames/s: what the camera delivers, the rate a frame's lateness is measured against
    frame_rate: float = FRAME_RATE
    px_per_mm: float = PX_PER_MM

    @property
    def size(self) -> tuple[int, int]:
        return (self.width, self.height)

    @property
    def period(self) -> float:
        return 1.0 / self.frame_rate


@dataclass(frozen=True)
class RigConfig:
    """Everything about a treadmill rig servolab uses (see the module docstring)."""

    geometry: AotGeometry = field(default_factory=AotGeometry)
    camera: CameraConfig = field(default_factory=CameraConfig)
    tracker: FlyTrackerConfig = field(default_factory=FlyTrackerConfig)
    controller: FlyControllerConfig = field(default_factory=FlyControllerConfig)
    #: warn when the fly is not found in more than this share of a run's frames
    lost_fly_share: float = 0.5
    #: frames: a frame handled more than this many frame periods after its capture is late
    late_after: float = 1.0
    #: FicTrac's ``c2a_r``: the rotation vector (rad) from the camera's frame to the lab's
    cam_to_lab: tuple[float, float, float] = (0.0, 0.0, 0.0)
    #: the file it was read from (and the overrides), for the run's summary
    source: str = ""

    @property
    def late_after_s(self) -> float:
        return self.late_after * self.camera.period


#: the thesis's rig, shipped with servolab
SHIPPED_RIG = shipped(__package__ or "servolab.robots.treadmill", "treadmill.yaml")


def load_rig(path: str | Path | None = None, overrides: Collection[str] = ()) -> RigConfig:
    """The rig of file ``path`` (default: the shipped thesis rig) with ``overrides``
    (``key.path=value``) put in; every value is checked, errors name the file and line or
    the override."""
    file = Path(path) if path is not None else SHIPPED_RIG
    top = overridden(load(file, what="rig file", error=RigConfigError), list(overrides),
                     error=RigConfigError)
    rig = parse(top)
    shown = str(file) + "".join(f" --set {o}" for o in overrides)
    return replace(rig, source=shown)


def _section(top: ConfigMapping, name: str, keys: tuple[str, ...]) -> ConfigMapping:
    section = top.require(name).as_mapping(f"key {name!r}")
    section.check_keys(keys, required=keys, what=name)
    return section


def _floats(value: ConfigValue, count: int) -> tuple[float, ...]:
    items = value.as_list()
    if len(items) != count:
        raise value.error(f"key {value.key!r}: must be {count} numbers, not {len(items)}")
    return tuple(item.as_float() for item in items)


def parse(top: ConfigValue) -> RigConfig:
    """A rig from a loaded (and overridden) file."""
    mapping = top.as_mapping("a rig file")
    mapping.check_keys(_SECTIONS, required=_SECTIONS)
    ball, camera_map = _section(mapping, "ball", _BALL), _section(mapping, "camera", _CAMERA)
    tracker_map = _section(mapping, "tracker", _TRACKER)
    controller_map = _section(mapping, "controller", _CONTROLLER)
    run = _section(mapping, "run", _RUN)

    angle_value = camera_map.require("angle_to_motors")
    angle = angle_value.as_float()
    if not -180.0 <= angle <= 180.0:
        raise angle_value.error(f"key 'camera.angle_to_motors': must be within -180..180 deg, "
                                f"not {angle:g}")
    tilt_value = ball.require("tilt")
    tilt = tilt_value.as_float()
    if not 0.0 < tilt < 90.0:
        raise tilt_value.error(f"key 'ball.tilt': must be between 0 and 90 deg, not {tilt:g}")
    try:
        geometry = AotGeometry(
            ball_radius=positive_float(ball.require("radius")),
            wheel_radius=positive_float(ball.require("wheel_radius")),
            tilt=math.radians(tilt),
            wheel_angles=tuple(math.radians(a) for a in _floats(  # type: ignore[arg-type]
                ball.require("wheel_angles"), 3)),
            camera_to_motor=math.radians(angle))
    except KinematicsValueError as exc:
        raise ball.require("wheel_angles").error(f"key 'ball.wheel_angles': {exc}") from None

    width, height = (camera_map.require(k).as_int() for k in ("width", "height"))
    for key, size in (("width", width), ("height", height)):
        if size <= 0:
            raise camera_map.require(key).error(f"key 'camera.{key}': must be > 0 px, "
                                                f"not {size}")
    camera = CameraConfig(width, height, positive_float(camera_map.require("frame_rate")),
                          positive_float(camera_map.require("px_per_mm")))

    tracker = _tracker(tracker_map, camera)
    controller = _controller(controller_map, camera, angle, geometry)
    fictrac = _section(mapping, "fictrac", _FICTRAC)
    cam_to_lab = _floats(fictrac.require("cam_to_lab"), 3)
    share_value = run.require("lost_fly_share")
    share = share_value.as_float()
    if not 0.0 <= share <= 1.0:
        raise share_value.error(f"key 'run.lost_fly_share': must be a share in [0, 1], not "
                                f"{share:g}")
    return RigConfig(geometry, camera, tracker, controller, share,
                     positive_float(run.require("late_after")),
                     (cam_to_lab[0], cam_to_lab[1], cam_to_lab[2]))


def _same_rig(a: AotGeometry, b: AotGeometry) -> bool:
    """The same ball and wheels, as far as J1M is concerned (not the camera's angle)."""
    return bool(np.allclose([a.ball_radius, a.wheel_radius, a.tilt, *a.wheel_angles],
                            [b.ball_radius, b.wheel_radius, b.tilt, *b.wheel_angles],
                            rtol=1e-9, atol=1e-12))


def _tracker(section: ConfigMapping, camera: CameraConfig) -> FlyTrackerConfig:
    polarity_value = section.require("polarity")
    polarity = polarity_value.as_str()
    if polarity not in POLARITIES:
        raise polarity_value.error(f"key 'tracker.polarity': must be one of "
                                   f"{', '.join(POLARITIES)}, not {polarity!r}")
    roi_value = section.require("roi")
    roi: tuple[int, int, int, int] | None = None
    if roi_value.plain() is not None:
        items = roi_value.as_list()
        if len(items) != 4:
            raise roi_value.error("key 'tracker.roi': must be [x, y, width, height] or null")
        x, y, w, h = (item.as_int() for item in items)
        if w <= 0 or h <= 0 or x < 0 or y < 0 or x + w > camera.width \
                or y + h > camera.height:
            raise roi_value.error(f"key 'tracker.roi': [{x}, {y}, {w}, {h}] must lie within "
                                  f"the {camera.width}x{camera.height} frame")
        roi = (x, y, w, h)
    threshold_value = section.require("threshold")
    threshold = threshold_value.as_float()
    if not 0.0 <= threshold < 255.0:
        raise threshold_value.error(f"key 'tracker.threshold': must be a grey level in "
                                    f"[0, 255), not {threshold:g}")
    min_area = nonnegative_float(section.require("min_area"))
    max_value = section.require("max_area")
    if max_value.plain() is not None and not max_value.as_float() > min_area:
        raise max_value.error(f"key 'tracker.max_area': must be above min_area "
                              f"{min_area:g} px² (or null), not {max_value.as_float():g}")
    try:
        return FlyTrackerConfig(
            threshold=threshold, min_area=min_area,
            roi=roi,
            background_subtraction=section.require("background_subtraction").as_bool(),
            max_area=None if max_value.plain() is None else max_value.as_float(),
            polarity=polarity)
    except VisionValueError as exc:
        raise section.error(f"tracker: {exc}") from None


def _controller(section: ConfigMapping, camera: CameraConfig, angle_deg: float,
                geometry: AotGeometry) -> FlyControllerConfig:
    matrix_value = section.require("matrix")
    if isinstance(matrix_value.plain(), str):
        how = matrix_value.as_str()
        if how not in ("listing1", "geometry"):
            raise matrix_value.error("key 'controller.matrix': must be listing1 (Listing 1's "
                                     "J1M), geometry (the same made for the ball section's "
                                     "rig) or three rows of three numbers")
        thesis = AotGeometry()
        if how == "listing1" and not _same_rig(geometry, thesis):
            raise matrix_value.error("key 'controller.matrix': listing1 is the thesis rig's "
                                     "J1M, and the ball section is another rig: write "
                                     "geometry (J1M made for it) or your own rows")
        matrix = (np.array(THESIS_J1M, dtype=np.float64) if how == "listing1"
                  else listing_matrix(geometry))
    else:
        rows = matrix_value.as_list()
        if len(rows) != 3:
            raise matrix_value.error("key 'controller.matrix': must be three rows of three "
                                     "numbers")
        matrix = np.array([_floats(row, 3) for row in rows], dtype=np.float64)
        if not np.linalg.cond(matrix) <= MAX_CONDITION:
            raise matrix_value.error("key 'controller.matrix': is singular (some motion of "
                                     "the fly would turn no wheel)")
    target_value = section.require("target")
    target = _floats(target_value, 3)
    if not (0 <= target[0] < camera.width and 0 <= target[1] < camera.height):
        raise target_value.error(f"key 'controller.target': ({target[0]:g}, {target[1]:g}) "
                                 f"px is outside the {camera.width}x{camera.height} frame")
    try:
        return FlyControllerConfig(
            target=(target[0], target[1], target[2]),
            dead_band_px=nonnegative_float(section.require("dead_band_px")),
            dead_band_rad=nonnegative_float(section.require("dead_band_deg")) * LISTING_PI / 180,
            gain=nonnegative_float(section.require("gain")),
            rotation_scale=nonnegative_float(section.require("rotation_scale")),
            camera_to_motor=angle_deg * LISTING_PI / 180,
            px_per_mm=camera.px_per_mm, matrix=matrix)
    except RobotValueError as exc:
        raise section.error(f"controller: {exc}") from None
