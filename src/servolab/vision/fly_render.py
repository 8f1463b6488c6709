"""A synthetic dark-field frame of a fruit fly, so that the fly tracker (seed 002, Listing 1) is
tested against a known pose instead of the thesis's unlabelled video.

Why a drawn fly and not an ellipse: Listing 1 takes the moments of the thresholded blob, and a
real fly's blob is not symmetric front to back (a narrow head in front, wings folded back over
the abdomen, section 3.1's dark-field images), so its centroid is not its body centre. The
truth returned with each frame is therefore the moments of the region as drawn, computed on the
supersampled mask, which is well defined whatever the shape.

Defaults follow seed 002: 640 x 376 frames (section 3.2) at 38.4 px/mm (section 3.2's
calibration: "1mm per 38.4 pixels"), a bright fly scattering the side light onto a dark
background (dark-field, section 3.2). The fly's dimensions are textbook Drosophila
melanogaster: body about 2.5 mm long and 1 mm wide, wings about as long as the abdomen and
thorax together.

Geometry is drawn with ``cv2.fillPoly`` (sub-pixel, fixed-point ``shift``) on a canvas
``supersample`` times finer than the image, only around the fly, then averaged down with
``cv2.resize(INTER_AREA)``: edges are anti-aliased as a camera's would be. Output pixel ``i``
covers supersampled pixels ``s*i .. s*i + s - 1``, so its centre is at ``s*i + (s - 1)/2`` there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from .errors import VisionValueError

Image = npt.NDArray[np.uint8]
FloatArray = npt.NDArray[np.float64]

#: Seed 002, section 3.2: the camera's frame, width x height.
DEFAULT_SIZE = (640, 376)
#: Seed 002, section 3.2: "1mm per 38.4 pixels".
DEFAULT_PX_PER_MM = 38.4

_SHIFT = 8  # fractional bits of cv2.fillPoly's fixed-point vertices: 1/256 px
_VERTICES = 96  # per ellipse; the chord error at 96 vertices is < 0.06 % of the radius


@dataclass(frozen=True)
class FlyPose:
    """Where the fly is: its body centre in pixels and heading in radians, in image axes
    (x right, y down), 0 facing +x, pi/2 facing +y (down the screen)."""

    x: float
    y: float
    theta: float


@dataclass(frozen=True)
class FlyShape:
    """The fly's outline in mm, drawn in the fly's frame (u forward, v sideways).

    The body (thorax and abdomen) is one ellipse from the abdomen's tip to the neck, and the
    head a smaller ellipse in front of it, ``length_mm`` from the tip of the abdomen to the front
    of the head; the pose's position is the middle of that length. The wings are ellipses from
    the thorax, folded back over the abdomen and splayed a little to either side, drawn
    ``wing_brightness`` times as bright as the body (they are thin and scatter less light).
    """

    length_mm: float = 2.5
    width_mm: float = 1.0
    head_length_mm: float = 0.45
    head_width_mm: float = 0.65
    wing_length_mm: float = 1.7
    wing_width_mm: float = 0.6
    #: From the front of the head back to where the wings are hinged.
    wing_root_mm: float = 0.85
    #: Each wing's angle from the body axis, to its side.
    wing_spread_deg: float = 12.0
    #: Of the body's brightness above the background; a wing must still exceed the threshold.
    wing_brightness: float = 0.8

    def __post_init__(self) -> None:
        for name in ("length_mm", "width_mm", "head_length_mm", "head_width_mm",
                     "wing_length_mm", "wing_width_mm"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise VisionValueError(f"{name} must be a positive length, got {value}")
        if not self.head_length_mm < self.length_mm:
            raise VisionValueError(f"head_length_mm must be shorter than length_mm, got "
                                   f"{self.head_length_mm}")
        if not (math.isfinite(self.wing_root_mm) and 0 <= self.wing_root_mm <= self.length_mm):
            raise VisionValueError(f"wing_root_mm must be within the body, got {self.wing_root_mm}")
        if not (math.isfinite(self.wing_spread_deg) and 0 <= self.wing_spread_deg < 90):
            raise VisionValueError("wing_spread_deg must be in [0, 90), got "
                                   f"{self.wing_spread_deg}")
        if not (math.isfinite(self.wing_brightness) and 0 < self.wing_brightness <= 1):
            raise VisionValueError(f"wing_brightness must be in (0, 1], got {self.wing_brightness}")


@dataclass(frozen=True)
class FlyTruth:
    """The drawn fly's region (everything not background) in output pixels: centroid, axis
    angle in ``(-pi/2, pi/2]`` (the image-moment angle, so modulo pi) and area in px²."""

    cx: float
    cy: float
    theta: float
    area: float


def _ellipse(cu: float, cv: float, a: float, b: float, rot: float) -> FloatArray:
    """Vertices ``(u, v)`` of an ellipse centred at ``(cu, cv)`` with semi-axes ``a`` (along
    ``rot``) and ``b``."""
    t = np.linspace(0.0, 2 * np.pi, _VERTICES, endpoint=False)
    c, s = math.cos(rot), math.sin(rot)
    x, y = a * np.cos(t), b * np.sin(t)
    return np.stack([cu + c * x - s * y, cv + s * x + c * y], axis=1)


def fly_outline(pose: FlyPose, shape: FlyShape = FlyShape(),
                px_per_mm: float = DEFAULT_PX_PER_MM) -> tuple[list[FloatArray], FloatArray]:
    """The fly's polygons in image pixels: the two wings, and the body and head stacked; apart
    because the wings are drawn dimmer and underneath."""
    half = shape.length_mm / 2
    body_front = half - shape.head_length_mm * 0.8  # the head overlaps the thorax a little
    body = _ellipse((body_front - half) / 2, 0.0, (body_front + half) / 2, shape.width_mm / 2, 0.0)
    head = _ellipse(half - shape.head_length_mm / 2, 0.0, shape.head_length_mm / 2,
                    shape.head_width_mm / 2, 0.0)
    root = half - shape.wing_root_mm
    spread = math.radians(shape.wing_spread_deg)
    wings = []
    for side in (-1.0, 1.0):
        direction = math.pi + side * spread  # backwards, splayed to one side
        centre_u = root + shape.wing_length_mm / 2 * math.cos(direction)
        centre_v = shape.wing_length_mm / 2 * math.sin(direction)
        wings.append(_ellipse(centre_u, centre_v, shape.wing_length_mm / 2,
                              shape.wing_width_mm / 2, direction))
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    rotation = np.array([[c, -s], [s, c]]) * px_per_mm

    def to_image(uv: FloatArray) -> FloatArray:
        return np.asarray(uv @ rotation.T + np.array([pose.x, pose.y]), dtype=np.float64)

    return [to_image(w) for w in wings], np.stack([to_image(body), to_image(head)])


def render_fly(pose: FlyPose | None, *, size: tuple[int, int] = DEFAULT_SIZE,
               px_per_mm: float = DEFAULT_PX_PER_MM, shape: FlyShape = FlyShape(),
               background: int = 12, brightness: int = 210, noise_std: float = 0.0,
               rng: np.random.Generator | None = None,
               supersample: int = 4) -> tuple[Image, FlyTruth | None]:
    """A mono8 ``size = (width, height)`` dark-field frame of a fly at ``pose``, and the truth.

    ``pose=None`` gives an empty frame (background and noise only); so does a fly wholly outside
    the frame, and then the truth is ``None``. A fly partly outside is cut at the border and
    its truth is of the visible part. Gaussian noise of ``noise_std`` grey levels comes from
    ``rng`` (a fixed seed when ``None``, so every frame is reproducible).
    """
    width, height = size
    if width <= 0 or height <= 0:
        raise VisionValueError(f"size must be positive (width, height), got {size}")
    if not (math.isfinite(px_per_mm) and px_per_mm > 0):
        raise VisionValueError(f"px_per_mm must be positive, got {px_per_mm}")
    if not (0 <= background <= 255 and 0 <= brightness <= 255):
        raise VisionValueError(f"background and brightness must be grey levels, got "
                               f"{background}, {brightness}")
    if not (math.isfinite(noise_std) and noise_std >= 0):
        raise VisionValueError(f"noise_std must be >= 0, got {noise_std}")
    if supersample < 1:
        raise VisionValueError(f"supersample must be >= 1, got {supersample}")
    level = np.full((height, width), float(background))
    truth: FlyTruth | None = None
    if pose is not None:
        level, truth = _draw(level, pose, shape, px_per_mm, float(brightness - background),
                             supersample)
    if noise_std > 0:
        gen = rng if rng is not None else np.random.default_rng(0)
        level = level + gen.normal(0.0, noise_std, level.shape)
    return np.clip(np.rint(level), 0, 255).astype(np.uint8), truth


def _draw(level: FloatArray, pose: FlyPose, shape: FlyShape, px_per_mm: float,
          contrast: float, s: int) -> tuple[FloatArray, FlyTruth | None]:
    """Add the fly to ``level`` (a float image); drawn only in the fly's bounding box."""
    height, width = level.shape
    wings, body = fly_outline(pose, shape, px_per_mm)
    points = np.concatenate([*wings, *body])
    x0 = max(0, math.floor(points[:, 0].min()) - 2)
    y0 = max(0, math.floor(points[:, 1].min()) - 2)
    x1 = min(width, math.ceil(points[:, 0].max()) + 3)
    y1 = min(height, math.ceil(points[:, 1].max()) + 3)
    if x1 <= x0 or y1 <= y0:
        return level, None
    origin = np.array([x0, y0], dtype=np.float64)

    def fixed(poly: FloatArray) -> npt.NDArray[np.int32]:
        canvas_xy = (poly - origin) * s + (s - 1) / 2  # output pixel centres -> canvas
        return np.asarray(np.rint(canvas_xy * (1 << _SHIFT)), dtype=np.int32)

    canvas = np.zeros(((y1 - y0) * s, (x1 - x0) * s), dtype=np.float32)
    wing_level = float(shape.wing_brightness)
    cv2.fillPoly(canvas, [fixed(w) for w in wings], (wing_level,), cv2.LINE_8, _SHIFT)
    cv2.fillPoly(canvas, [fixed(b) for b in body], (1.0,), cv2.LINE_8, _SHIFT)
    mask = np.asarray(canvas > 0, dtype=np.uint8)
    m = cv2.moments(mask, True)
    if m["m00"] == 0:
        return level, None
    cx, cy = m["m10"] / m["m00"], m["m01"] / m["m00"]
    theta = 0.5 * math.atan2(2 * m["mu11"], m["mu20"] - m["mu02"])
    if theta <= -math.pi / 2:
        theta += math.pi
    truth = FlyTruth(x0 + (cx - (s - 1) / 2) / s, y0 + (cy - (s - 1) / 2) / s, theta,
                     m["m00"] / (s * s))
    coverage = cv2.resize(canvas, (x1 - x0, y1 - y0), interpolation=cv2.INTER_AREA)
    out = level.copy()
    out[y0:y1, x0:x1] += contrast * np.asarray(coverage, dtype=np.float64)
    return out, truth
