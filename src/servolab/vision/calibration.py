"""Camera calibration and the image-to-floor mapping of seed 000, Appendix C, on OpenCV.

The seed calibrated its overhead camera with MATLAB from 22 checkerboard images (Figure C4
plots their reprojection errors), took the floor's extrinsics from one board lying on the floor
(MATLAB's ``extrinsics``) and turned image points into floor points with ``pointsToWorld`` to
measure a distance on the floor (Figure C6). This module does the same with OpenCV:

* :func:`calibrate`: ``findChessboardCorners`` + ``cornerSubPix`` + ``calibrateCamera``, with the
  per-image reprojection errors, warnings for images that spoil the fit and refusals for bad
  input (a symmetric board, a board not found, too few usable images);
* :func:`floor_extrinsics`: ``solvePnP`` on one board lying on the floor. The floor frame is the
  board's: origin at its first inner corner, x along its columns, y along its rows, mm;
* :func:`image_to_floor` / :func:`floor_to_image` / :func:`measure` (which refuses a pixel off
  the calibrated image, :func:`check_in_image`);
* :func:`save` / :func:`load`: ROS's ``camera_info`` YAML (what ``camera_calibration`` writes
  and ``camera_info_manager`` reads) plus a ``floor_extrinsics`` section.

Boards are counted in *squares*, as MATLAB and the seed's warning count them: ``(10, 7)`` is
10 squares along a row and 7 down a column, ``(9, 6)`` inner corners for OpenCV.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt
import yaml

from ..configfile import ConfigMapping, ConfigValue
from ..configfile import load as load_config
from ..errors import ConfigFileError
from .errors import VisionValueError
from .synthetic import board_corners

FloatArray = npt.NDArray[np.float64]

#: The seed's warning (Appendix C), quoted: why a board must have one even and one odd side.
SYMMETRIC_BOARD_REASON = (
    "The checkerboard must be asymmetric: one side should be even, and the other should be "
    "odd. Otherwise, the orientation of the board may be detected incorrectly."
)
#: Fewest usable views ``calibrate`` accepts: Zhang's method needs three views of a plane to
#: fix the five intrinsic parameters; fewer leave the focal lengths undetermined.
MIN_IMAGES = 3
#: Fewer usable views than this only warn: MATLAB's calibrator asks for 10 to 20.
RECOMMENDED_IMAGES = 10
#: An image whose reprojection error exceeds this multiple of the median spoils the fit...
SPOIL_FACTOR = 2.0
#: ... and this many pixels too. A ratio alone flags good views of a good calibration: with a
#: median of 0.054 px a view at 0.123 px is "twice the median" yet fits to an eighth of a
#: pixel, within what sub-pixel corner refinement (cornerSubPix) can be trusted to. Half a
#: pixel is several times that, and still well under one pixel: a view under it is never an
#: outlier, whatever the others do, and a view that does spoil the fit (another lens, a
#: board moved during the shot) misses by pixels.
SPOIL_FLOOR_PX = 0.5

_SUBPIX_CRITERIA = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 100, 1e-4)
_UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 100, 1e-12)


class CalibrationError(VisionValueError):
    """Calibration input that cannot be used: a symmetric board, a board not found, too few
    usable images, images of different sizes, a camera matrix or floor pose that is not one.
    ``str(error)`` is one line."""


class CalibrationFileError(ConfigFileError, CalibrationError):
    """A calibration YAML file that cannot be read: ``path:line: message``."""


@dataclass(frozen=True)
class CameraCalibration:
    """Intrinsics and distortion of a camera, and how well they fit the images they came from.

    ``per_image_errors`` are the RMS reprojection errors (pixels) of the images used, in the
    order of ``image_names`` (Figure C4); ``rms`` is over all their corners, the number
    ``cv2.calibrateCamera`` returns. A calibration read back by :func:`load` has neither
    (``rms`` is NaN). ``warnings`` are the one-line remarks :func:`calibrate` made.
    """

    camera_matrix: FloatArray
    distortion_coefficients: FloatArray
    image_size: tuple[int, int]
    per_image_errors: tuple[float, ...] = ()
    rms: float = math.nan
    image_names: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()
    camera_name: str = "camera"
    board_rvecs: tuple[FloatArray, ...] = field(default=(), repr=False)
    board_tvecs: tuple[FloatArray, ...] = field(default=(), repr=False)

    def __post_init__(self) -> None:
        k = np.asarray(self.camera_matrix, dtype=np.float64)
        d = np.asarray(self.distortion_coefficients, dtype=np.float64).ravel()
        if k.shape != (3, 3) or not np.all(np.isfinite(k)):
            raise CalibrationError(f"camera_matrix must be 3x3 finite numbers, got shape {k.shape}")
        if d.size not in (4, 5, 8, 12, 14) or not np.all(np.isfinite(d)):
            raise CalibrationError("distortion_coefficients must be 4, 5, 8, 12 or 14 finite "
                                   f"numbers (OpenCV's models), got {d.size}")
        k.setflags(write=False)
        d.setflags(write=False)
        object.__setattr__(self, "camera_matrix", k)
        object.__setattr__(self, "distortion_coefficients", d)

    @property
    def fx(self) -> float:
        return float(self.camera_matrix[0, 0])

    @property
    def fy(self) -> float:
        return float(self.camera_matrix[1, 1])

    @property
    def cx(self) -> float:
        return float(self.camera_matrix[0, 2])

    @property
    def cy(self) -> float:
        return float(self.camera_matrix[1, 2])


@dataclass(frozen=True)
class FloorExtrinsics:
    """The floor plane's pose in the camera frame: ``X_cam = rotation @ X_floor + translation``
    (mm), MATLAB's ``[R, t] = extrinsics(...)`` in OpenCV's (column-vector) convention."""

    rotation: FloatArray
    translation: FloatArray
    #: where the board lay in the robot's map, ``(x m, y m, yaw rad)`` (see :func:`in_map`),
    #: if the file says; the extrinsics themselves are in the board's frame
    board_at: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        if self.board_at is not None and (len(self.board_at) != 3 or not all(
                math.isfinite(v) for v in self.board_at)):
            raise CalibrationError(f"board_at must be 3 finite numbers (x m, y m, yaw rad), got "
                                   f"{self.board_at!r}")
        r = np.asarray(self.rotation, dtype=np.float64)
        t = np.asarray(self.translation, dtype=np.float64).reshape(-1)
        if r.shape != (3, 3) or not np.all(np.isfinite(r)):
            raise CalibrationError("rotation must be a 3x3 matrix of finite numbers, got "
                                   f"{r.shape}")
        if not np.allclose(r @ r.T, np.eye(3), atol=1e-6) or np.linalg.det(r) < 0:
            raise CalibrationError("rotation must be a proper rotation matrix "
                                   "(R Rᵀ = I, det R = 1)")
        if t.shape != (3,) or not np.all(np.isfinite(t)):
            raise CalibrationError("translation must be 3 finite numbers (mm), got shape "
                                   f"{t.shape}")
        r.setflags(write=False)
        t.setflags(write=False)
        object.__setattr__(self, "rotation", r)
        object.__setattr__(self, "translation", t)

    @property
    def rvec(self) -> FloatArray:
        """The rotation as a Rodrigues vector, as ``cv2.projectPoints`` takes it."""
        rvec, _ = cv2.Rodrigues(self.rotation)
        return np.asarray(rvec, dtype=np.float64).reshape(3)

    @property
    def camera_position(self) -> FloatArray:
        """The camera's centre in the floor frame (mm); its z is minus the height above the
        floor when the board's z points into the floor."""
        return np.asarray(-self.rotation.T @ self.translation, dtype=np.float64)


# -- the board -----------------------------------------------------------------------------


def check_board(board: tuple[int, int], square_mm: float) -> tuple[int, int]:
    """``(cols, rows)`` in squares if usable, else a :class:`CalibrationError` saying why."""
    try:
        cols, rows = (int(v) for v in board)
    except (TypeError, ValueError):
        raise CalibrationError(f"board must be COLSxROWS in squares, got {board!r}") from None
    if cols % 2 == rows % 2:
        kind = "even" if cols % 2 == 0 else "odd"
        raise CalibrationError(f"board {cols}x{rows} squares: both sides are {kind}. "
                               f"{SYMMETRIC_BOARD_REASON}")
    if cols < 4 or rows < 4:
        # OpenCV's detector needs more than 2 inner corners each way.
        raise CalibrationError(f"board {cols}x{rows} squares: needs at least 4 squares each way")
    if not (math.isfinite(square_mm) and square_mm > 0):
        raise CalibrationError(f"square size must be a positive number of mm, got {square_mm}")
    return cols, rows


def _gray(image: npt.ArrayLike, name: str) -> npt.NDArray[np.uint8]:
    img = np.asarray(image)
    if img.ndim == 3 and img.shape[2] in (3, 4):
        img = np.asarray(cv2.cvtColor(img.astype(np.uint8), cv2.COLOR_BGR2GRAY if img.shape[2] == 3
                                      else cv2.COLOR_BGRA2GRAY))
    if img.ndim != 2 or img.size == 0:
        raise CalibrationError(f"image {name}: must be a grayscale or BGR image, "
                               f"got shape {img.shape}")
    if img.dtype != np.uint8:
        raise CalibrationError(f"image {name}: must be 8-bit (uint8), got {img.dtype}")
    return np.ascontiguousarray(img)


def find_board(image: npt.ArrayLike, board: tuple[int, int], name: str = "image") -> FloatArray:
    """The inner corners ``(N, 2)`` (pixels, sub-pixel refined) of a ``cols x rows``-square
    board, in the order of :func:`servolab.vision.synthetic.board_corners` (the first corner
    next to the board's black outer-corner square, so that a board turned by 180° still gives
    the floor frame its own origin); a :class:`CalibrationError` naming the image if the board
    is not found."""
    cols, rows = board
    gray = _gray(image, name)
    pattern = (cols - 1, rows - 1)
    flags = cv2.CALIB_CB_ADAPTIVE_THRESH + cv2.CALIB_CB_NORMALIZE_IMAGE + cv2.CALIB_CB_FAST_CHECK
    found, corners = cv2.findChessboardCorners(gray, pattern, None, flags)
    if not found or corners is None:
        raise CalibrationError(f"{name}: checkerboard of {cols}x{rows} squares "
                               f"({pattern[0]}x{pattern[1]} inner corners) not found")
    pts = np.asarray(corners, dtype=np.float32).reshape(-1, 1, 2)
    # The search window must stay inside a square: a third of the closest corner spacing.
    grid = pts.reshape(rows - 1, cols - 1, 2)
    spacing = min(float(np.min(np.linalg.norm(np.diff(grid, axis=0), axis=2))),
                  float(np.min(np.linalg.norm(np.diff(grid, axis=1), axis=2))))
    half = int(np.clip(spacing / 3.0, 2, 11))
    refined = cv2.cornerSubPix(gray, pts, (half, half), (-1, -1), _SUBPIX_CRITERIA)
    out = np.asarray(refined, dtype=np.float64).reshape(-1, 2)
    # An even x odd board looks different turned by 180°: the square diagonally outside the
    # first inner corner is black (render_checkerboard's and MATLAB's detectCheckerboardPoints'
    # convention) and the one outside the last corner white. OpenCV 5.0 already orders them so,
    # but its documentation promises no orientation; a board read upside down would put the
    # floor's origin at the far corner, so the order is checked from the image itself.
    g = out.reshape(rows - 1, cols - 1, 2)
    first = g[0, 0] - (g[0, 1] - g[0, 0]) / 2 - (g[1, 0] - g[0, 0]) / 2
    last = g[-1, -1] - (g[-1, -2] - g[-1, -1]) / 2 - (g[-2, -1] - g[-1, -1]) / 2
    patch = max(3, int(spacing / 4))

    def grey(centre: FloatArray) -> float:
        sample = cv2.getRectSubPix(gray, (patch, patch), (float(centre[0]), float(centre[1])))
        return float(np.mean(sample))

    if grey(first) > grey(last):
        out = out[::-1].copy()
    return out


def _board_points(board: tuple[int, int], square_mm: float) -> npt.NDArray[np.float32]:
    return board_corners(board, square_mm).astype(np.float32)


# -- calibration ---------------------------------------------------------------------------


def spoiling_views(errors: Sequence[float], spoil_factor: float = SPOIL_FACTOR,
                   floor_px: float = SPOIL_FLOOR_PX) -> list[int]:
    """The indices of the views that spoil the fit: a reprojection error (px) over
    ``spoil_factor`` times the median of all *and* over ``floor_px``. The ratio finds the view
    unlike the others; the floor keeps a view that fits within a fraction of a pixel from being
    called bad only because the others fit even better (see :data:`SPOIL_FLOOR_PX`)."""
    if not errors:
        return []
    median = float(np.median(errors))
    limit = max(spoil_factor * median, floor_px)
    return [k for k, err in enumerate(errors) if err > limit]


def calibrate(images: Sequence[npt.ArrayLike], board: tuple[int, int], square_mm: float, *,
              names: Sequence[str] | None = None, min_images: int = MIN_IMAGES,
              spoil_factor: float = SPOIL_FACTOR, spoil_floor_px: float = SPOIL_FLOOR_PX,
              camera_name: str = "camera") -> CameraCalibration:
    """Intrinsics and distortion (``k1, k2, p1, p2, k3``) from images of a checkerboard of
    ``board = (cols, rows)`` squares of ``square_mm``.

    Images where the board is not found are skipped and named in ``warnings`` (MATLAB rejects
    them the same way); if fewer than ``min_images`` usable ones remain the calibration is
    refused, naming them. Images whose reprojection error exceeds ``spoil_factor`` times the
    median, and ``spoil_floor_px`` pixels, are kept but named in ``warnings``: remove them and
    calibrate again (:func:`spoiling_views`).
    """
    cols, rows = check_board(board, square_mm)
    labels = [str(n) for n in names] if names is not None else [
        f"image {i}" for i in range(len(images))]
    if len(labels) != len(images):
        raise CalibrationError(f"{len(labels)} names for {len(images)} images")
    if min_images < MIN_IMAGES:
        raise CalibrationError(f"min_images must be at least {MIN_IMAGES}, got {min_images}")
    warnings: list[str] = []
    corners: list[FloatArray] = []
    used: list[str] = []
    missing: list[str] = []
    size: tuple[int, int] | None = None
    first = ""
    for image, label in zip(images, labels, strict=True):
        gray = _gray(image, label)
        shape = (int(gray.shape[1]), int(gray.shape[0]))
        if size is None:
            size, first = shape, label
        elif shape != size:
            raise CalibrationError(f"{label}: {shape[0]}x{shape[1]} pixels, but {first} is "
                                   f"{size[0]}x{size[1]}; all images must come from one camera")
        try:
            corners.append(find_board(gray, (cols, rows), label))
            used.append(label)
        except CalibrationError as exc:
            missing.append(label)
            warnings.append(f"{exc}; skipped")
    if len(used) < min_images:
        why = f" (board not found in {', '.join(missing)})" if missing else ""
        raise CalibrationError(f"only {len(used)} usable image(s) of {len(labels)}{why}; "
                               f"calibration needs at least {min_images}")
    assert size is not None
    if len(used) < RECOMMENDED_IMAGES:
        warnings.append(f"only {len(used)} usable images; {RECOMMENDED_IMAGES} to 20 views at "
                        "varied tilts and distances give a reliable calibration")
    obj = _board_points((cols, rows), square_mm)
    object_points = [obj] * len(corners)
    image_points = [c.astype(np.float32).reshape(-1, 1, 2) for c in corners]
    rms, k, d, rvecs, tvecs = cv2.calibrateCamera(object_points, image_points, size, None, None)
    errors: list[float] = []
    for pts, rvec, tvec in zip(corners, rvecs, tvecs, strict=True):
        uv, _ = cv2.projectPoints(obj, rvec, tvec, k, d)
        diff = np.asarray(uv, dtype=np.float64).reshape(-1, 2) - pts
        errors.append(float(np.sqrt(np.mean(np.sum(diff**2, axis=1)))))
    median = float(np.median(errors))
    for bad in spoiling_views(errors, spoil_factor, spoil_floor_px):
        warnings.append(f"{used[bad]}: reprojection error {errors[bad]:.3f} px is more than "
                        f"{spoil_factor:g}x the median {median:.3f} px and "
                        f"{spoil_floor_px:g} px; it spoils the fit (remove it and calibrate "
                        "again)")
    return CameraCalibration(
        camera_matrix=np.asarray(k, dtype=np.float64),
        distortion_coefficients=np.asarray(d, dtype=np.float64).ravel(),
        image_size=size, per_image_errors=tuple(errors), rms=float(rms),
        image_names=tuple(used), warnings=tuple(warnings), camera_name=camera_name,
        board_rvecs=tuple(np.asarray(r, dtype=np.float64).reshape(3) for r in rvecs),
        board_tvecs=tuple(np.asarray(t, dtype=np.float64).reshape(3) for t in tvecs))


def floor_extrinsics(calib: CameraCalibration, image: npt.ArrayLike, board: tuple[int, int],
                     square_mm: float, *, name: str = "floor image") -> FloorExtrinsics:
    """The floor plane's pose from one image of a board lying on it (MATLAB's ``extrinsics``):
    the floor frame is the board's, origin at its first inner corner, mm."""
    cols, rows = check_board(board, square_mm)
    gray = _gray(image, name)
    if (gray.shape[1], gray.shape[0]) != tuple(calib.image_size):
        raise CalibrationError(f"{name}: {gray.shape[1]}x{gray.shape[0]} pixels, but the "
                               f"calibration is for {calib.image_size[0]}x{calib.image_size[1]}")
    corners = find_board(gray, (cols, rows), name)
    ok, rvec, tvec = cv2.solvePnP(_board_points((cols, rows), square_mm),
                                  corners.astype(np.float32), calib.camera_matrix,
                                  calib.distortion_coefficients, flags=cv2.SOLVEPNP_ITERATIVE)
    if not ok:
        raise CalibrationError(f"{name}: the board's pose could not be solved")
    rotation, _ = cv2.Rodrigues(rvec)
    return FloorExtrinsics(np.asarray(rotation, dtype=np.float64),
                           np.asarray(tvec, dtype=np.float64).reshape(3))


def in_map(extrinsics: FloorExtrinsics,
           board_at: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> FloorExtrinsics:
    """The floor extrinsics re-expressed in a map frame as ROS wants one: z up.

    A board's frame has its z into the board (OpenCV's and MATLAB's convention), so the floor
    frame :func:`floor_extrinsics` gives has its z pointing into the floor, and seen from
    above its y axis is the mirror of a map's. ``board_at`` ``(x, y, yaw)`` (mm, mm, rad) says
    where the board lay in the map: its first inner corner at ``(x, y)``, its x axis (along
    its first row) at ``yaw``, and its y axis therefore at ``yaw - 90°``. The default makes
    the map's x the board's x and the map's y the board's -y, with the origin at the first
    inner corner. The result maps map points (mm, z = 0) to the camera like the original
    maps board points: it is the same plane, a proper rotation (180° about x) away.
    """
    x0, y0, yaw = (float(v) for v in board_at)
    if not all(math.isfinite(v) for v in (x0, y0, yaw)):
        raise CalibrationError(f"board_at must be finite (x mm, y mm, yaw rad), got {board_at!r}")
    c, s = math.cos(yaw), math.sin(yaw)
    # the board's axes as columns, in map coordinates: x at yaw, y at yaw - 90°, z down
    axes = np.array([[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, -1.0]])
    rotation = extrinsics.rotation @ axes.T
    translation = extrinsics.translation - rotation @ np.array([x0, y0, 0.0])
    return FloorExtrinsics(rotation, translation)


# -- image <-> floor -----------------------------------------------------------------------


def _points2(points: npt.ArrayLike, what: str) -> tuple[FloatArray, bool]:
    arr = np.asarray(points, dtype=np.float64)
    single = arr.shape == (2,)
    arr = arr.reshape(1, 2) if single else arr
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise VisionValueError(f"{what} must be (2,) or (N, 2), got shape {np.shape(points)}")
    if not np.all(np.isfinite(arr)):
        raise VisionValueError(f"{what} must be finite numbers")
    return arr, single


def image_to_floor(calib: CameraCalibration, extrinsics: FloorExtrinsics,
                   uv: npt.ArrayLike) -> FloatArray:
    """Floor points ``(x, y)`` (mm) of image points ``(u, v)`` (pixels), ``(2,)`` or ``(N, 2)``:
    MATLAB's ``pointsToWorld``, with the lens distortion undone first.

    Each pixel is undistorted to a ray through the camera's centre, and the ray is cut with the
    floor plane z = 0. A pixel whose ray does not reach the floor in front of the camera (above
    the horizon) is refused, naming it.
    """
    pts, single = _points2(uv, "uv")
    normalised = cv2.undistortPoints(pts.reshape(-1, 1, 2), calib.camera_matrix,
                                     calib.distortion_coefficients,
                                     criteria=_UNDISTORT_CRITERIA)
    rays_cam = np.column_stack([np.asarray(normalised, dtype=np.float64).reshape(-1, 2),
                                np.ones(len(pts))])
    r, t = extrinsics.rotation, extrinsics.translation
    centre = -r.T @ t
    rays = rays_cam @ r  # each row is R^T ray
    dz = rays[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = -centre[2] / dz
    bad = ~np.isfinite(lam) | (lam <= 0)
    if np.any(bad):
        first = pts[int(np.argmax(bad))]
        raise VisionValueError(f"image point ({first[0]:g}, {first[1]:g}) does not look at the "
                               f"floor ({int(bad.sum())} point(s) at or above the horizon)")
    floor: FloatArray = np.asarray(centre[:2] + lam[:, None] * rays[:, :2], dtype=np.float64)
    return floor[0] if single else floor


def floor_to_image(calib: CameraCalibration, extrinsics: FloorExtrinsics,
                   xy: npt.ArrayLike) -> FloatArray:
    """Image points ``(u, v)`` (pixels, distorted as the camera sees them) of floor points
    ``(x, y)`` (mm), ``(2,)`` or ``(N, 2)``."""
    pts, single = _points2(xy, "xy")
    obj = np.column_stack([pts, np.zeros(len(pts))])
    depth = obj @ extrinsics.rotation[2] + extrinsics.translation[2]
    if np.any(depth <= 0):
        first = pts[int(np.argmax(depth <= 0))]
        raise VisionValueError(f"floor point ({first[0]:g}, {first[1]:g}) is behind the camera")
    uv, _ = cv2.projectPoints(obj, extrinsics.rvec, extrinsics.translation,
                              calib.camera_matrix, calib.distortion_coefficients)
    out = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    return out[0] if single else out


def check_in_image(calib: CameraCalibration, uv: npt.ArrayLike) -> FloatArray:
    """``uv`` ``(2,)`` or ``(N, 2)`` if every point lies on the calibrated image, else one line
    naming the first that does not and the image's size.

    Pixel centres are whole numbers (OpenCV's convention), so a ``W x H`` image covers
    ``-0.5 <= u <= W - 0.5`` and ``-0.5 <= v <= H - 0.5``. Outside it the lens model was never
    fitted (the distortion polynomial grows without bound there) and no camera could have
    seen the point: a floor distance from it would be a number about nothing."""
    pts, _ = _points2(uv, "uv")
    width, height = calib.image_size
    outside = ((pts[:, 0] < -0.5) | (pts[:, 0] > width - 0.5)
               | (pts[:, 1] < -0.5) | (pts[:, 1] > height - 0.5))
    if np.any(outside):
        u, v = pts[int(np.argmax(outside))]
        raise VisionValueError(f"image point ({u:g}, {v:g}) is outside the calibrated "
                               f"{width}x{height} image (u -0.5..{width - 0.5:g}, "
                               f"v -0.5..{height - 0.5:g} px)")
    return np.asarray(uv, dtype=np.float64)


def measure(calib: CameraCalibration, extrinsics: FloorExtrinsics, uv1: npt.ArrayLike,
            uv2: npt.ArrayLike) -> float:
    """The distance (mm) on the floor between two image points: Figure C6 of the seed. Points
    off the calibrated image are refused (:func:`check_in_image`)."""
    a_uv = check_in_image(calib, np.asarray(uv1, dtype=np.float64).reshape(2))
    b_uv = check_in_image(calib, np.asarray(uv2, dtype=np.float64).reshape(2))
    a = image_to_floor(calib, extrinsics, a_uv)
    b = image_to_floor(calib, extrinsics, b_uv)
    return float(np.hypot(*(b - a)))


# -- files ---------------------------------------------------------------------------------


def _matrix(values: npt.ArrayLike, rows: int, cols: int) -> dict[str, object]:
    data = [float(v) for v in np.asarray(values, dtype=np.float64).ravel()]
    return {"rows": rows, "cols": cols, "data": data}


def save(calib: CameraCalibration, extrinsics: FloorExtrinsics | None,
         path: str | Path) -> None:
    """Write ``calib`` (and the floor's extrinsics) as ROS's ``camera_info`` YAML.

    The layout is the one ROS's ``camera_calibration`` writes and ``camera_info_manager``
    reads; ``rectification_matrix`` is the identity and ``projection_matrix`` is ``[K | 0]``
    (a monocular camera). ``floor_extrinsics`` adds ``rotation_matrix`` and
    ``translation_vector`` (mm, floor frame to camera frame), which ROS's readers ignore, and
    ``board_at`` (m, m, rad) when the extrinsics know where the board lay in the map.
    """
    k = calib.camera_matrix
    projection = np.hstack([k, np.zeros((3, 1))])
    doc: dict[str, object] = {
        "image_width": int(calib.image_size[0]),
        "image_height": int(calib.image_size[1]),
        "camera_name": calib.camera_name,
        "camera_matrix": _matrix(k, 3, 3),
        "distortion_model": "plumb_bob",
        "distortion_coefficients": _matrix(calib.distortion_coefficients, 1,
                                           calib.distortion_coefficients.size),
        "rectification_matrix": _matrix(np.eye(3), 3, 3),
        "projection_matrix": _matrix(projection, 3, 4),
    }
    if extrinsics is not None:
        floor: dict[str, object] = {
            "rotation_matrix": _matrix(extrinsics.rotation, 3, 3),
            "translation_vector": _matrix(extrinsics.translation, 3, 1),
            "units": "mm",
        }
        if extrinsics.board_at is not None:
            floor["board_at"] = [float(v) for v in extrinsics.board_at]
        doc["floor_extrinsics"] = floor
    Path(path).write_text(yaml.safe_dump(doc, sort_keys=False, default_flow_style=None),
                          encoding="utf-8")


def _read_matrix(parent: ConfigMapping, name: str, shape: tuple[int, int] | None = None
                 ) -> FloatArray:
    node = parent.require(name).as_mapping()
    node.check_keys(("rows", "cols", "data"), required=("rows", "cols", "data"))
    rows = node.require("rows").as_int()
    cols = node.require("cols").as_int()
    items = node.require("data").as_list()
    data = [item.as_float() for item in items]
    if shape is not None and (rows, cols) != shape:
        raise node.error(f"key {node.key!r}: must be {shape[0]}x{shape[1]}, not {rows}x{cols}")
    if len(data) != rows * cols:
        raise items.error(f"key {items.key!r}: {rows}x{cols} needs {rows * cols} numbers, "
                          f"not {len(data)}")
    return np.asarray(data, dtype=np.float64).reshape(rows, cols)


def load(path: str | Path) -> tuple[CameraCalibration, FloorExtrinsics | None]:
    """Read what :func:`save` wrote (or a ROS ``camera_info`` YAML file, which has no floor
    extrinsics: ``None``). Errors are :class:`CalibrationFileError`, ``path:line: message``."""
    root: ConfigValue = load_config(path, what="calibration file", error=CalibrationFileError)
    doc = root.as_mapping()
    keys = ("image_width", "image_height", "camera_name", "camera_matrix", "distortion_model",
            "distortion_coefficients", "rectification_matrix", "projection_matrix",
            "floor_extrinsics")
    doc.check_keys(keys, required=("image_width", "image_height", "camera_matrix",
                                   "distortion_coefficients"))
    width = doc.require("image_width").as_int()
    height = doc.require("image_height").as_int()
    for name, value in (("image_width", width), ("image_height", height)):
        if value <= 0:
            raise doc.require(name).error(f"key {name!r}: must be positive, not {value}")
    model = doc.get("distortion_model")
    if model is not None and model.as_str() not in ("plumb_bob", "rational_polynomial"):
        raise model.error(f"key 'distortion_model': {model.as_str()!r} is not supported "
                          "(plumb_bob or rational_polynomial)")
    name_node = doc.get("camera_name")
    camera_name = name_node.as_str() if name_node is not None else "camera"
    k = _read_matrix(doc, "camera_matrix", (3, 3))
    d = _read_matrix(doc, "distortion_coefficients")
    if d.size not in (4, 5, 8, 12, 14):
        raise doc.require("distortion_coefficients").error(
            f"key 'distortion_coefficients': {d.size} numbers; OpenCV takes 4, 5, 8, 12 or 14")
    calib = CameraCalibration(k, d.ravel(), (width, height), camera_name=camera_name)
    extrinsics_node = doc.get("floor_extrinsics")
    if extrinsics_node is None:
        return calib, None
    ext = extrinsics_node.as_mapping()
    ext.check_keys(("rotation_matrix", "translation_vector", "units", "board_at"),
                   required=("rotation_matrix", "translation_vector"))
    units = ext.get("units")
    if units is not None and units.as_str() != "mm":
        raise units.error(f"key 'floor_extrinsics.units': must be mm, not {units.as_str()!r}")
    rotation = _read_matrix(ext, "rotation_matrix", (3, 3))
    translation = _read_matrix(ext, "translation_vector", (3, 1))
    board_at = None
    placed = ext.get("board_at")
    if placed is not None:
        items = placed.as_list()
        if len(items) != 3:
            raise placed.error("key 'floor_extrinsics.board_at': must be [x m, y m, yaw rad], "
                               f"not {len(items)} numbers")
        x, y, yaw = (item.as_float() for item in items)
        board_at = (x, y, yaw)
    try:
        extrinsics = FloorExtrinsics(rotation, translation.ravel(), board_at)
    except CalibrationError as exc:
        raise ext.error(f"key 'floor_extrinsics': {exc}") from None
    return calib, extrinsics
