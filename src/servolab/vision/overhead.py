"""What the overhead camera of seed 000 gives navigation: the floor's occupancy grid and the
robot's pose, from one grayscale frame.

Pure functions and precomputed tables: arrays in, arrays out, OpenCV for the image work. The
calibration (:mod:`servolab.vision.calibration`) speaks mm in the board's floor frame; this
module's API speaks **metres and radians** in that same frame, the units navigation plans in.
The scene's grey levels are those of :mod:`servolab.vision.synthetic`: a light floor, dark
obstacles, a mid-grey robot disc carrying a light wedge that points along its heading.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from ..planning.occupancy_grid import SAVER_FREE_THRESH, SAVER_OCCUPIED_THRESH
from .calibration import CameraCalibration, FloorExtrinsics, floor_to_image, image_to_floor
from .errors import VisionValueError

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

_MM = 1000.0  # mm per m: the calibration's unit per this module's

#: A cell whose fraction of dark sub-points is above this is occupied, below
#: :data:`FREE_FRACTION` free, and in between unknown: map_server's default
#: ``occupied_thresh`` and ``free_thresh`` (map_saver writes them; image_loader.cpp applies them
#: to a pixel's darkness), applied to the cell's share of dark samples, which is what the
#: camera's occupancy probability of the cell is. With the default 3 x 3 samples one dark
#: sample (1/9 = 0.11) is noise and leaves a cell free, two (0.22) make it unknown, six
#: (0.67) occupied. Why not any dark sample: image noise 20 on the robot's mid-grey disc (120,
#: 2.3 sigma above the threshold 75) or at an obstacle's blurred edge darkens single samples
#: at random, so the map flickered and the navigator repaired its plan for nothing.
OCCUPIED_FRACTION = SAVER_OCCUPIED_THRESH
FREE_FRACTION = SAVER_FREE_THRESH
_UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 100, 1e-12)


@dataclass(frozen=True)
class FloorGrid:
    """The map's cells on the floor: ``cols = round(width/resolution)`` along x,
    ``rows = round(depth/resolution)`` along y, cell ``(row, col)`` covering x in
    ``[origin_x + col*res, +res)``, y likewise. Arrays are ``[row, col] = [y, x]``."""

    width: float  # m along the floor's x
    depth: float  # m along y
    resolution: float  # m per cell
    origin: tuple[float, float] = (0.0, 0.0)  # floor point (m) of cell (0, 0)'s corner

    def __post_init__(self) -> None:
        for name in ("width", "depth", "resolution"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise VisionValueError(f"FloorGrid {name} must be a positive number of m, got "
                                       f"{value!r}")
        if len(self.origin) != 2 or not all(math.isfinite(v) for v in self.origin):
            raise VisionValueError(f"FloorGrid origin must be two finite numbers (m), "
                                   f"got {self.origin!r}")
        rows, cols = self.shape
        if rows < 1 or cols < 1:
            raise VisionValueError(f"FloorGrid resolution {self.resolution} m is coarser than the "
                                   f"floor ({self.width} x {self.depth} m): no whole cell")

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)``, the shape of :meth:`FloorSampler.occupancy`'s grid."""
        return (round(self.depth / self.resolution), round(self.width / self.resolution))


def _check_image(image: object, calib: CameraCalibration) -> npt.NDArray[np.uint8]:
    width, height = calib.image_size
    if not isinstance(image, np.ndarray) or image.ndim != 2 or image.dtype != np.uint8:
        shape = getattr(image, "shape", None)
        dtype = getattr(image, "dtype", type(image).__name__)
        raise VisionValueError(f"image must be a 2-D uint8 grayscale array, got shape {shape} "
                               f"of {dtype}")
    if image.shape != (height, width):
        raise VisionValueError(f"image is {image.shape[1]}x{image.shape[0]} pixels, but the "
                               f"calibration is for {width}x{height}")
    return image


def _seen(calib: CameraCalibration, extrinsics: FloorExtrinsics, xy_mm: FloatArray,
          uv: FloatArray) -> BoolArray:
    """Whether each floor point's projection ``uv`` really is where the camera sees it.

    Inside the image is not enough: the polynomial lens model folds back on itself far outside
    the field of view (for k1 < 0 it turns round), so a floor point the camera cannot see may
    project into the image; undoing the distortion at ``uv`` must lead back to the point.
    """
    width, height = calib.image_size
    ok = (uv[:, 0] >= 0) & (uv[:, 0] <= width - 1) & (uv[:, 1] >= 0) & (uv[:, 1] <= height - 1)
    idx = np.flatnonzero(ok)
    if idx.size == 0:
        return ok
    norm = cv2.undistortPoints(uv[idx].reshape(-1, 1, 2), calib.camera_matrix,
                               calib.distortion_coefficients, criteria=_UNDISTORT_CRITERIA)
    rays = np.column_stack([np.asarray(norm, dtype=np.float64).reshape(-1, 2),
                            np.ones(idx.size)]) @ extrinsics.rotation
    centre = -extrinsics.rotation.T @ extrinsics.translation
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = -centre[2] / rays[:, 2]
        back = centre[:2] + lam[:, None] * rays[:, :2]
        err = np.linalg.norm(back - xy_mm[idx], axis=1)
    ok[idx] = np.isfinite(lam) & (lam > 0) & (err < 1.0)
    return ok


class FloorSampler:
    """Built once per (calibration, extrinsics, grid): precomputes, with
    :func:`~servolab.vision.calibration.floor_to_image`, the image position of
    ``samples x samples`` sub-points in every cell (``cv2.remap`` maps), because the map is
    rebuilt from every camera frame and projecting through the lens model each time would cost
    more than reading the pixels."""

    def __init__(self, calib: CameraCalibration, extrinsics: FloorExtrinsics, grid: FloorGrid,
                 samples: int = 3) -> None:
        if not (isinstance(samples, int) and samples >= 1):
            raise VisionValueError(f"samples must be a positive whole number, got {samples!r}")
        self.calib, self.extrinsics, self.grid, self.samples = calib, extrinsics, grid, samples
        rows, cols = grid.shape
        step = grid.resolution / samples
        xs = grid.origin[0] + (np.arange(cols * samples) + 0.5) * step
        ys = grid.origin[1] + (np.arange(rows * samples) + 0.5) * step
        xx, yy = np.meshgrid(xs, ys)  # [row*samples + a, col*samples + b]
        xy_mm = np.column_stack([xx.ravel(), yy.ravel()]) * _MM
        depth = xy_mm @ extrinsics.rotation[2, :2] + extrinsics.translation[2]
        uv = np.full((len(xy_mm), 2), -1.0)
        front = depth > 0  # floor_to_image refuses points behind the camera
        if np.any(front):
            uv[front] = floor_to_image(calib, extrinsics, xy_mm[front])
        seen = front & _seen(calib, extrinsics, xy_mm, uv)
        uv[~seen] = -10.0  # outside the image: remap's constant border, and masked anyway
        shape = xx.shape
        map_u = uv[:, 0].reshape(shape).astype(np.float32)
        map_v = uv[:, 1].reshape(shape).astype(np.float32)
        self._map1, self._map2 = cv2.convertMaps(map_u, map_v, cv2.CV_16SC2)
        self._unseen = ~seen.reshape(shape)

    def dark_fraction(self, image: npt.NDArray[np.uint8],
                      threshold: float = 75.0) -> FloatArray:
        """Each cell's share ``[rows, cols]`` (0..1) of sub-points darker than ``threshold``:
        the evidence :meth:`occupancy` thresholds, for tools and tests to look at."""
        img = _check_image(image, self.calib)
        if not (math.isfinite(threshold) and 0 < threshold <= 255):
            raise VisionValueError(f"threshold must be a grey level in (0, 255], got {threshold}")
        grey = cv2.remap(img, self._map1, self._map2, cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        rows, cols = self.grid.shape
        s = self.samples
        dark = (np.asarray(grey) < threshold).reshape(rows, s, cols, s)
        return np.asarray(dark.mean(axis=(1, 3)), dtype=np.float64)

    def occupancy(self, image: npt.NDArray[np.uint8], threshold: float = 75.0, *,
                  previous: BoolArray | None = None) -> BoolArray:
        """Occupied cells ``[rows, cols]`` by map_server's two thresholds on the share of each
        cell's sub-points darker than ``threshold`` (:data:`OCCUPIED_FRACTION`,
        :data:`FREE_FRACTION`): above the first occupied, below the second free, in between
        unknown, which is not free (a planner must not drive where nobody looked), and
        neither is a cell with any sub-point outside the camera's view.

        ``previous``, the grid this gave for the frame before, keeps an unknown cell as it
        was: a cell changes only on clear evidence, so an obstacle's edge that splits a cell
        cannot flicker either (without it, an edge cell whose dark share sits at
        :data:`FREE_FRACTION` may still toggle from frame to frame). The price: a cell that
        an obstacle appearing later covers by less than :data:`OCCUPIED_FRACTION` stays free,
        which the costmap's inflation (tens of cm) dwarfs."""
        fraction = self.dark_fraction(image, threshold)
        occupied = fraction > OCCUPIED_FRACTION
        between = ~occupied & (fraction >= FREE_FRACTION)
        if previous is not None:
            known = np.asarray(previous, dtype=bool)
            if known.shape != fraction.shape:
                raise VisionValueError(f"previous occupancy has shape {known.shape}, the grid "
                                       f"{fraction.shape}")
            between &= known
        rows, cols = self.grid.shape
        s = self.samples
        unseen = self._unseen.reshape(rows, s, cols, s).any(axis=(1, 3))
        result: BoolArray = occupied | between | unseen
        return result


@dataclass(frozen=True)
class RobotSighting:
    """The robot seen from above: its pose on the floor and where its disc's centre is in the
    image (for drawing and for checking the camera against odometry)."""

    x: float  # m, floor frame
    y: float  # m
    yaw: float  # rad, from the floor's x axis towards its y axis, in (-pi, pi]
    u: float  # px, the disc's centre in the image
    v: float  # px


def _largest(mask: npt.NDArray[np.uint8]) -> tuple[npt.NDArray[np.uint8], int]:
    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    if count < 2:
        return np.zeros_like(mask), 0
    best = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    return (labels == best).astype(np.uint8), int(stats[best, cv2.CC_STAT_AREA])


def _polygon_centroid(poly: FloatArray) -> tuple[FloatArray, float]:
    """Centroid and (absolute) area of a simple polygon (shoelace formula)."""
    x, y = poly[:, 0], poly[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    area = float(np.sum(cross)) / 2.0
    if abs(area) < 1e-12:
        return np.mean(poly, axis=0), 0.0
    c = np.array([np.sum((x + xn) * cross), np.sum((y + yn) * cross)]) / (6.0 * area)
    return c, abs(area)


def find_robot(image: npt.NDArray[np.uint8], calib: CameraCalibration,
               extrinsics: FloorExtrinsics, *, low: float = 75.0, high: float = 170.0,
               min_area_px: float = 50.0) -> RobotSighting | None:
    """The robot's pose from one overhead frame, or ``None`` if no robot (or no readable
    heading wedge) is seen.

    The disc is the grey band ``low <= grey <= high``; obstacle edges blend from dark to light
    through the same band, so an opening removes those thin lines and the largest component
    left is the disc (refused below ``min_area_px``). The disc's convex hull fills the wedge
    (a hole in the band) even when the thin ring beyond the wedge's tip breaks up, and the
    hull's outline is mapped to the floor before taking its centroid, so that perspective and
    lens distortion do not pull the centre. The wedge (hull minus band) is long along the
    heading (second moments 3:1) but its centroid lies at the disc's centre, so its principal
    axis, on the floor, gives the heading line and its far tip (0.8 r ahead against 0.4 r
    behind) the sense.
    """
    img = _check_image(image, calib)
    if not (low <= high):
        raise VisionValueError(f"low ({low}) must not exceed high ({high})")
    band = ((img >= low) & (img <= high)).astype(np.uint8)
    kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (3, 3))
    opened = np.asarray(cv2.morphologyEx(band, cv2.MORPH_OPEN, kernel), dtype=np.uint8)
    disc, area = _largest(opened)
    if area < min_area_px:
        return None
    # Give the disc back the band pixels the opening shaved off its rim and its thin ring.
    disc = np.asarray(cv2.dilate(disc, kernel, iterations=2), dtype=np.uint8) & band
    contours, _ = cv2.findContours(disc, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    outline = max(contours, key=cv2.contourArea)
    hull = cv2.convexHull(outline)
    filled = np.zeros_like(band)
    cv2.drawContours(filled, [hull], -1, 1, thickness=cv2.FILLED)
    hull_uv = np.asarray(hull, dtype=np.float64).reshape(-1, 2)
    if len(hull_uv) < 3:
        return None
    centre, _ = _polygon_centroid(image_to_floor(calib, extrinsics, hull_uv))
    # The wedge: light pixels inside the disc, away from the rim where floor pixels between
    # the hull's vertices would join it.
    inner = np.asarray(cv2.erode(filled, kernel, iterations=1), dtype=np.uint8)
    wedge, wedge_area = _largest((inner & (1 - band)).astype(np.uint8))
    if wedge_area < 3:
        return None
    # Weigh each pixel by how much of it the wedge covers (the image is anti-aliased), read
    # from its grey between the disc's and the wedge's: sub-pixel moments, not a staircase.
    region = (np.asarray(cv2.dilate(wedge, kernel), dtype=np.uint8)
              & np.asarray(cv2.erode(filled, kernel, iterations=2), dtype=np.uint8))
    rows, cols = np.nonzero(region)
    disc_grey = float(np.median(img[disc.astype(bool)]))
    wedge_grey = float(np.percentile(img[wedge.astype(bool)], 90))
    if wedge_grey - disc_grey < 1.0:
        return None
    weight = np.clip((img[rows, cols].astype(np.float64) - disc_grey)
                     / (wedge_grey - disc_grey), 0.0, 1.0)
    pts = image_to_floor(calib, extrinsics, np.column_stack([cols, rows]).astype(np.float64))
    pts = pts - np.average(pts, axis=0, weights=weight)
    cov = (pts * weight[:, None]).T @ pts / float(np.sum(weight))
    _, vecs = np.linalg.eigh(cov)
    axis = vecs[:, 1]  # the largest eigenvalue's
    along = pts @ axis
    if -float(np.min(along)) > float(np.max(along)):
        axis = -axis
    u, v = floor_to_image(calib, extrinsics, centre)
    return RobotSighting(x=float(centre[0]) / _MM, y=float(centre[1]) / _MM,
                         yaw=float(math.atan2(axis[1], axis[0])), u=float(u), v=float(v))
