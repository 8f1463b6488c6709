"""A synthetic camera: what a calibrated pinhole camera with OpenCV's lens distortion would see,
so that calibration and the navigation loop are tested against known truth (issue 18).

Why synthetic: the seed calibrated a real camera from 22 photographs (Appendix C), where the
true intrinsics are unknown and a test can only check that the numbers look plausible. Here
the camera is known exactly (``fx, fy, cx, cy`` and ``k1, k2, p1, p2, k3``, OpenCV's
``plumb_bob`` model), so a test can say "within 1 % of the truth".

Conventions are OpenCV's: a pose ``(rvec, tvec)`` maps a point of the object's frame (board or
floor, mm) into the camera frame (x right, y down, z along the optical axis). A checkerboard of
``cols x rows`` *squares* (as MATLAB and the seed's warning count it) has ``(cols-1) x (rows-1)``
inner corners; its frame has the origin at the first inner corner, x along the columns, y along
the rows and z into the board, so that the inner corner ``(i, j)`` is at ``(i*s, j*s, 0)``.
The squares are projected with ``cv2.projectPoints`` with their edges subdivided (distortion
bends straight edges) and filled at a supersampled resolution, then averaged down: the image is
anti-aliased, and a corner detector sees the corners where the model puts them.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np
import numpy.typing as npt

from .errors import VisionValueError

FloatArray = npt.NDArray[np.float64]
Image = npt.NDArray[np.uint8]

#: Grey levels of the rendered scenes: paper and floor are light, squares and obstacles dark.
WHITE = 235
BLACK = 20
FLOOR = 210
OBSTACLE = 30
ROBOT = 120


@dataclass(frozen=True)
class PinholeCamera:
    """A pinhole camera with OpenCV's distortion ``(k1, k2, p1, p2, k3)``; image in pixels."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int
    distortion: tuple[float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        for name in ("fx", "fy"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise VisionValueError(f"camera {name} must be a positive number of pixels, got "
                                       f"{value}")
        for name in ("width", "height"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value > 0):
                raise VisionValueError(f"camera {name} must be a positive number of pixels, got "
                                       f"{value}")
        if len(self.distortion) != 5 or not np.all(np.isfinite(self.distortion)):
            raise VisionValueError("camera distortion must be 5 finite numbers (k1, k2, p1, p2, "
                                   f"k3), got {self.distortion}")

    @property
    def camera_matrix(self) -> FloatArray:
        """The 3x3 intrinsic matrix K."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def distortion_coefficients(self) -> FloatArray:
        return np.asarray(self.distortion, dtype=np.float64)

    @property
    def image_size(self) -> tuple[int, int]:
        """``(width, height)``, the order OpenCV takes."""
        return (self.width, self.height)

    def project(self, points: npt.ArrayLike, rvec: npt.ArrayLike,
                tvec: npt.ArrayLike) -> FloatArray:
        """Pixels ``(N, 2)`` of object points ``(N, 3)`` (mm) seen at pose ``(rvec, tvec)``.

        Points behind the camera are refused: ``cv2.projectPoints`` would mirror them into the
        image instead.
        """
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        r = np.asarray(rvec, dtype=np.float64).reshape(3)
        t = np.asarray(tvec, dtype=np.float64).reshape(3)
        rotation, _ = cv2.Rodrigues(r)
        depth = pts @ np.asarray(rotation)[2] + t[2]
        if np.any(depth <= 1e-6):
            raise VisionValueError(f"{int(np.sum(depth <= 1e-6))} point(s) are behind the camera "
                                   f"at pose rvec={r.tolist()}, tvec={t.tolist()}")
        uv, _ = cv2.projectPoints(pts, r, t, self.camera_matrix, self.distortion_coefficients)
        return np.asarray(uv, dtype=np.float64).reshape(-1, 2)


def _validate_board(board: tuple[int, int], square_mm: float) -> tuple[int, int]:
    cols, rows = board
    if not (isinstance(cols, int | np.integer) and isinstance(rows, int | np.integer)
            and cols >= 2 and rows >= 2):
        raise VisionValueError("board must be (cols, rows) in squares, each at least 2, got "
                               f"{board}")
    if not (np.isfinite(square_mm) and square_mm > 0):
        raise VisionValueError(f"square size must be a positive number of mm, got {square_mm}")
    return int(cols), int(rows)


def board_corners(board: tuple[int, int], square_mm: float) -> FloatArray:
    """The inner corners ``(N, 3)`` in the board's frame, in the order ``findChessboardCorners``
    reports them for ``patternSize = (cols-1, rows-1)``: along a row first."""
    cols, rows = _validate_board(board, square_mm)
    jj, ii = np.mgrid[0:rows - 1, 0:cols - 1]
    return np.stack([ii.ravel() * square_mm, jj.ravel() * square_mm,
                     np.zeros(ii.size)], axis=1).astype(np.float64)


def board_outline(board: tuple[int, int], square_mm: float, margin: float = 1.0) -> FloatArray:
    """The four corners ``(4, 3)`` of the board's paper, ``margin`` squares around the squares."""
    cols, rows = _validate_board(board, square_mm)
    lo = (-1.0 - margin) * square_mm
    x_hi, y_hi = (cols - 1 + margin) * square_mm, (rows - 1 + margin) * square_mm
    return np.array([[lo, lo, 0.0], [x_hi, lo, 0.0], [x_hi, y_hi, 0.0], [lo, y_hi, 0.0]])


@dataclass
class _Canvas:
    """A supersampled drawing surface: polygons in image pixels, filled with sub-pixel
    precision, averaged down to the camera's resolution."""

    width: int
    height: int
    background: int
    supersample: int = 4
    data: Image = field(init=False)

    _SHIFT = 4  # fractional bits of the polygon coordinates given to cv2.fillPoly

    def __post_init__(self) -> None:
        if self.supersample < 1:
            raise VisionValueError(f"supersample must be at least 1, got {self.supersample}")
        s = self.supersample
        self.data = np.full((self.height * s, self.width * s), self.background, dtype=np.uint8)

    def fill(self, polygons: Sequence[FloatArray], value: int) -> None:
        """Fill polygons given in pixels of the final image (pixel centres at integers)."""
        s, scale = self.supersample, 1 << self._SHIFT
        pts = [np.round(((np.asarray(p).reshape(-1, 2) + 0.5) * s - 0.5) * scale)
               .astype(np.int32).reshape(-1, 1, 2) for p in polygons]
        if pts:
            cv2.fillPoly(self.data, pts, int(value), lineType=cv2.LINE_8, shift=self._SHIFT)

    def image(self, noise_std: float = 0.0, rng: np.random.Generator | None = None) -> Image:
        small = cv2.resize(self.data, (self.width, self.height), interpolation=cv2.INTER_AREA)
        out = np.asarray(small, dtype=np.float64)
        if noise_std > 0:
            gen = rng if rng is not None else np.random.default_rng()
            out = out + gen.normal(0.0, noise_std, out.shape)
        return np.clip(np.round(out), 0, 255).astype(np.uint8)


def render_checkerboard(camera: PinholeCamera, board: tuple[int, int], square_mm: float,
                        rvec: npt.ArrayLike, tvec: npt.ArrayLike, *,
                        noise_std: float = 0.0, rng: np.random.Generator | None = None,
                        background: int = 128, margin: float = 1.0, subdivisions: int = 8,
                        supersample: int = 4) -> Image:
    """A grayscale image ``(height, width)`` of a ``cols x rows``-square board at a pose.

    The board is printed on white paper ``margin`` squares wide around the squares (the quiet
    zone the corner detector needs) and lies on a ``background`` grey. The square at column
    ``i``, row ``j`` (counting from the square just before the first inner corner) is black
    when ``i + j`` is even. ``noise_std`` adds Gaussian noise in grey levels.
    """
    cols, rows = _validate_board(board, square_mm)
    if subdivisions < 1:
        raise VisionValueError(f"subdivisions must be at least 1, got {subdivisions}")
    n = subdivisions
    canvas = _Canvas(camera.width, camera.height, background, supersample)
    # The paper, its edges subdivided too.
    lo, hi_x, hi_y = -1.0 - margin, cols - 1 + margin, rows - 1 + margin
    k = 4 * n
    edge = np.linspace(0.0, 1.0, k, endpoint=False)
    paper = np.concatenate([
        np.stack([lo + (hi_x - lo) * edge, np.full(k, lo)], 1),
        np.stack([np.full(k, hi_x), lo + (hi_y - lo) * edge], 1),
        np.stack([hi_x - (hi_x - lo) * edge, np.full(k, hi_y)], 1),
        np.stack([np.full(k, lo), hi_y - (hi_y - lo) * edge], 1),
    ]) * square_mm
    paper_uv = camera.project(np.column_stack([paper, np.zeros(len(paper))]), rvec, tvec)
    canvas.fill([paper_uv], WHITE)
    # A fine grid over the squares, projected once; each square's outline is read off it.
    gx = (np.arange(cols * n + 1) / n - 1.0) * square_mm
    gy = (np.arange(rows * n + 1) / n - 1.0) * square_mm
    xx, yy = np.meshgrid(gx, gy)
    grid = np.stack([xx.ravel(), yy.ravel(), np.zeros(xx.size)], axis=1)
    uv = camera.project(grid, rvec, tvec).reshape(rows * n + 1, cols * n + 1, 2)
    squares: list[FloatArray] = []
    for j in range(rows):
        for i in range(cols):
            if (i + j) % 2:
                continue
            r0, c0 = j * n, i * n
            top = uv[r0, c0:c0 + n]
            right = uv[r0:r0 + n, c0 + n]
            bottom = uv[r0 + n, c0 + n:c0:-1]
            left = uv[r0 + n:r0:-1, c0]
            squares.append(np.concatenate([top, right, bottom, left]))
    canvas.fill(squares, BLACK)
    return canvas.image(noise_std, rng)


def pose_from(rotation_deg: npt.ArrayLike, center_mm: npt.ArrayLike, board: tuple[int, int],
              square_mm: float) -> tuple[FloatArray, FloatArray]:
    """``(rvec, tvec)`` putting the board's centre at ``center_mm`` in the camera frame, the
    board turned by the rotation vector ``rotation_deg`` (degrees) from facing the camera."""
    cols, rows = _validate_board(board, square_mm)
    rvec = np.deg2rad(np.asarray(rotation_deg, dtype=np.float64).reshape(3))
    rotation, _ = cv2.Rodrigues(rvec)
    centre = np.array([(cols / 2 - 1) * square_mm, (rows / 2 - 1) * square_mm, 0.0])
    tvec = np.asarray(center_mm, dtype=np.float64).reshape(3) - np.asarray(rotation) @ centre
    return rvec, tvec


def random_board_poses(camera: PinholeCamera, board: tuple[int, int], square_mm: float,
                       count: int, rng: np.random.Generator, *, max_tilt_deg: float = 40.0,
                       max_yaw_deg: float = 20.0, distance_mm: tuple[float, float] = (400, 900),
                       border_px: float = 10.0,
                       max_tries: int = 10000) -> list[tuple[FloatArray, FloatArray]]:
    """``count`` poses of the board that keep its paper wholly inside the image, tilted up to
    ``max_tilt_deg`` about a random axis in the board's plane and turned up to ``max_yaw_deg``
    in it: the spread of views a calibration needs (MATLAB's guide: tilted, near and far, at
    the image's edges)."""
    outline = board_outline(board, square_mm)
    poses: list[tuple[FloatArray, FloatArray]] = []
    for _ in range(max_tries):
        if len(poses) == count:
            break
        axis_angle = rng.uniform(0.0, 2 * np.pi)
        tilt = rng.uniform(0.3, 1.0) * max_tilt_deg
        yaw = rng.uniform(-max_yaw_deg, max_yaw_deg)
        tilt_vec = np.deg2rad(tilt) * np.array([np.cos(axis_angle), np.sin(axis_angle), 0.0])
        r_tilt, _ = cv2.Rodrigues(tilt_vec)
        r_yaw, _ = cv2.Rodrigues(np.array([0.0, 0.0, np.deg2rad(yaw)]))
        rvec_rad, _ = cv2.Rodrigues(np.asarray(r_tilt) @ np.asarray(r_yaw))
        z = rng.uniform(*distance_mm)
        x = rng.uniform(-0.35, 0.35) * z * camera.width / camera.fx
        y = rng.uniform(-0.35, 0.35) * z * camera.height / camera.fy
        rvec, tvec = pose_from(np.rad2deg(np.asarray(rvec_rad).ravel()), (x, y, z), board,
                               square_mm)
        try:
            uv = camera.project(outline, rvec, tvec)
        except VisionValueError:  # behind the camera
            continue
        inside = ((uv[:, 0] >= border_px) & (uv[:, 0] <= camera.width - 1 - border_px)
                  & (uv[:, 1] >= border_px) & (uv[:, 1] <= camera.height - 1 - border_px))
        if inside.all():
            poses.append((rvec, tvec))
    if len(poses) < count:
        raise VisionValueError(f"found only {len(poses)} of {count} board poses inside the image; "
                               "make the board smaller or the distances larger")
    return poses


# -- top-down scenes ---------------------------------------------------------------------------


@dataclass(frozen=True)
class Circle:
    """A round obstacle on the floor: centre ``(x, y)`` and radius, mm."""

    x: float
    y: float
    radius: float


@dataclass(frozen=True)
class RobotMarker:
    """The robot as the camera sees it: a grey disc with a light wedge pointing along its
    heading ``theta`` (radians, from the floor's x axis towards its y axis)."""

    x: float
    y: float
    theta: float
    radius: float = 100.0


@dataclass(frozen=True)
class FloorScene:
    """What lies on the floor plane ``z = 0``: dark polygons ``(N, 2)`` and circles (mm) on a
    light floor, and optionally the robot."""

    polygons: tuple[FloatArray, ...] = ()
    circles: tuple[Circle, ...] = ()
    robot: RobotMarker | None = None


def _circle_points(x: float, y: float, radius: float, n: int = 64) -> FloatArray:
    a = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    return np.stack([x + radius * np.cos(a), y + radius * np.sin(a)], axis=1)


def _densify(polygon: FloatArray, step_mm: float) -> FloatArray:
    """Points along the polygon's edges every ``step_mm`` at most (distortion bends them)."""
    out: list[FloatArray] = []
    closed = np.vstack([polygon, polygon[:1]])
    for a, b in itertools.pairwise(closed):
        k = max(1, int(np.ceil(np.hypot(*(b - a)) / step_mm)))
        t = np.arange(k)[:, None] / k
        out.append(a + (b - a) * t)
    return np.vstack(out)


def render_floor(camera: PinholeCamera, rvec: npt.ArrayLike, tvec: npt.ArrayLike,
                 scene: FloorScene, *, noise_std: float = 0.0,
                 rng: np.random.Generator | None = None, supersample: int = 2) -> Image:
    """A grayscale image of the floor ``scene`` seen by the overhead camera at floor pose
    ``(rvec, tvec)`` (floor frame to camera frame, as :func:`render_checkerboard` takes)."""
    canvas = _Canvas(camera.width, camera.height, FLOOR, supersample)

    def to_image(xy: FloatArray) -> FloatArray:
        dense = _densify(np.asarray(xy, dtype=np.float64).reshape(-1, 2), 20.0)
        return camera.project(np.column_stack([dense, np.zeros(len(dense))]), rvec, tvec)

    shapes = [to_image(p) for p in scene.polygons]
    shapes += [to_image(_circle_points(c.x, c.y, c.radius)) for c in scene.circles]
    canvas.fill(shapes, OBSTACLE)
    if scene.robot is not None:
        r = scene.robot
        canvas.fill([to_image(_circle_points(r.x, r.y, r.radius))], ROBOT)
        heading = np.array([np.cos(r.theta), np.sin(r.theta)])
        side = np.array([-heading[1], heading[0]])
        centre = np.array([r.x, r.y])
        wedge = np.array([centre + 0.8 * r.radius * heading,
                          centre - 0.4 * r.radius * heading + 0.4 * r.radius * side,
                          centre - 0.4 * r.radius * heading - 0.4 * r.radius * side])
        canvas.fill([to_image(wedge)], WHITE)
    return canvas.image(noise_std, rng)
