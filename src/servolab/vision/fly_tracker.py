"""Where the fly is in a dark-field frame: the seed's blob tracker (seed 002, Appendix A,
Listing 1, ``imageCb``), kept number for number so that the servo loop built on it sees what the
thesis's loop saw.

Listing 1 thresholds the frame at 50 (``THRESH_BINARY``; the ``threshold_value = 125`` it
declares is never used), finds the external contours, keeps the largest by ``contourArea``, and
only if that area is above 100 px² takes the contour's moments: the centroid ``m10/m00,
m01/m00`` and the axis angle ``atan2(2 mu11', mu20' - mu02') / 2`` from the normalised central
moments. The angle is that of an axis, not a heading (a fly facing -x gives 0 like one facing
+x), in image axes (x right, y down), so a positive angle turns clockwise on the screen.

When nothing passes, Listing 1 leaves the sighting at the target (the image centre, section 3.2:
``(320, 188, 0)`` for its 640 x 376 frames), so the error it servoes on is zero and the stage
stops rather than jumping after a lost fly; :func:`track_fly` does the same and says so with
``present=False``.

Two additions, both off by default so the default is Listing 1: a region of interest (the seed's
camera did this in hardware with ``format7_roi``, section 5.2) and subtraction of a background
frame, so that a static reflection brighter than 50 does not become "the largest contour".

Two checks Listing 1 lacks, on by default because without them a frame with no fly in it is
"tracked": a largest contour above ``max_area`` is no fly (a blank white frame was a 239 625
px² fly, a lit ball a 102 140 px² one), and ``polarity`` says which way the fly differs from
its background. Listing 1's is ``"bright"``: a lit fly on a dark ball, ``THRESH_BINARY``.
``"dark"`` tracks a dark fly on a lit ball (``THRESH_BINARY_INV``: darker than ``threshold``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np
import numpy.typing as npt

from .errors import VisionValueError

Image = npt.NDArray[np.uint8]

#: px². A Drosophila, about 2.5 x 1 mm, is about 3 000 px² at the rig's 38.4 px/mm (seed 002,
#: Listing 3's px_per_mm), as the synthetic fly of :mod:`.fly_render` is; 20 000 leaves room
#: for a bigger fly or a closer camera and none for a lit ball or a blank frame.
DEFAULT_MAX_AREA = 20_000.0
POLARITIES = ("bright", "dark")

#: Listing 1's ``target_location``: the centre of its 640 x 376 frame, heading 0 (section 3.2).
DEFAULT_TARGET = (320.0, 188.0)
#: the thesis rig's image scale, px per mm of the ball's surface (seed 002 section 3.2: 38.4;
#: Listing 1 multiplies by 38.40983291722681)
PX_PER_MM = 38.40983291722681


@dataclass(frozen=True)
class FlyTrackerConfig:
    """The tracker's knobs; the defaults are Listing 1's."""

    #: Grey level the fly must exceed (``THRESH_BINARY``: strictly greater), Listing 1.
    threshold: float = 50.0
    #: px²; the largest contour is a fly only if its area is strictly greater, Listing 1.
    min_area: float = 100.0
    #: ``(x, y, width, height)`` in the image to search; ``None``: the whole image.
    roi: tuple[int, int, int, int] | None = None
    #: Subtract a background frame (saturating, ``cv2.subtract``) before the threshold.
    background_subtraction: bool = False
    #: px²; a largest contour above it is no fly (module docstring). ``None``: no bound.
    max_area: float | None = DEFAULT_MAX_AREA
    #: ``"bright"``: the fly is lighter than ``threshold`` (Listing 1); ``"dark"``: darker.
    polarity: str = "bright"

    def __post_init__(self) -> None:
        if not (math.isfinite(self.threshold) and 0.0 <= self.threshold < 255.0):
            raise VisionValueError("threshold must be a grey level in [0, 255), got "
                                   f"{self.threshold}")
        if not (math.isfinite(self.min_area) and self.min_area >= 0.0):
            raise VisionValueError(f"min_area must be a finite area >= 0 px², got {self.min_area}")
        if self.max_area is not None and not (math.isfinite(self.max_area)
                                              and self.max_area > self.min_area):
            raise VisionValueError(f"max_area must be a finite area above min_area "
                                   f"{self.min_area:g} px², got {self.max_area}")
        if self.polarity not in POLARITIES:
            raise VisionValueError(f"polarity must be 'bright' (a lit fly on a dark ball, "
                                   f"Listing 1) or 'dark', got {self.polarity!r}")
        if self.roi is not None:
            if len(self.roi) != 4 or not all(isinstance(v, int) for v in self.roi):
                raise VisionValueError("roi must be four integers (x, y, width, height), got "
                                       f"{self.roi}")
            if self.roi[2] <= 0 or self.roi[3] <= 0:
                raise VisionValueError(f"roi width and height must be > 0, got {self.roi}")


@dataclass(frozen=True)
class FlySighting:
    """What Listing 1 publishes for one frame, plus whether a fly was actually seen.

    ``cx, cy`` are full-image pixels and ``theta`` radians in ``(-pi/2, pi/2]``; when
    ``present`` is false they are the target's, as in Listing 1. ``area`` is the largest
    contour's area (0 if there is none), the ``maxArea`` Listing 1 compares with 100.
    """

    present: bool
    cx: float
    cy: float
    theta: float
    area: float
    #: the largest contour (full-image pixels), as Listing 1 draws it; None if there is none
    contour: npt.NDArray[np.int32] | None = field(default=None, compare=False, repr=False)


def _check_image(image: npt.NDArray[np.generic], name: str) -> None:
    if image.ndim != 2:
        raise VisionValueError(f"{name} must be a 2-D (mono8) image, got shape {image.shape}")
    if image.dtype != np.uint8:
        raise VisionValueError(f"{name} must be uint8 (mono8), got {image.dtype}")


def track_fly(image: Image, config: FlyTrackerConfig = FlyTrackerConfig(), *,
              target: tuple[float, float] = DEFAULT_TARGET,
              background: Image | None = None) -> FlySighting:
    """Find the fly in ``image`` as Listing 1's ``imageCb`` does.

    ``target`` is what an absent fly reports (Listing 1's ``target_location``), so that the
    error the caller servoes on is zero rather than a jump. ``background`` is used only with
    ``config.background_subtraction`` and must match ``image`` in shape and dtype.
    """
    image = np.asarray(image)
    _check_image(image, "image")
    height, width = image.shape
    work = image
    if config.background_subtraction:
        if background is None:
            raise VisionValueError("background_subtraction needs a background image, got None")
        background = np.asarray(background)
        if background.shape != image.shape or background.dtype != image.dtype:
            raise VisionValueError(f"background must be {image.dtype} of shape {image.shape}, got "
                                   f"{background.dtype} of shape {background.shape}")
        work = np.asarray(cv2.subtract(image, background), dtype=np.uint8)
    x0, y0 = 0, 0
    if config.roi is not None:
        x0, y0, w, h = config.roi
        if x0 < 0 or y0 < 0 or x0 + w > width or y0 + h > height:
            raise VisionValueError(f"roi {config.roi} is outside the {width} x {height} image")
        work = work[y0:y0 + h, x0:x0 + w]
    kind = cv2.THRESH_BINARY if config.polarity == "bright" else cv2.THRESH_BINARY_INV
    _, binary = cv2.threshold(work, config.threshold, 255.0, kind)
    contours, _ = cv2.findContours(binary, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    # Listing 1: strictly larger wins, so the first of equal areas is kept.
    best = -1
    max_area = 0.0
    for i, contour in enumerate(contours):
        area = float(cv2.contourArea(contour))
        if area > max_area:
            max_area = area
            best = i
    too_big = config.max_area is not None and max_area > config.max_area
    outline = None if best < 0 else np.asarray(contours[best] + np.array([x0, y0]),
                                                dtype=np.int32)
    if best < 0 or not max_area > config.min_area or too_big:
        return FlySighting(False, float(target[0]), float(target[1]), 0.0, max_area, outline)
    mu = cv2.moments(contours[best], False)
    cx = mu["m10"] / mu["m00"]
    cy = mu["m01"] / mu["m00"]
    mu20 = mu["m20"] / mu["m00"] - cx * cx
    mu02 = mu["m02"] / mu["m00"] - cy * cy
    mu11 = mu["m11"] / mu["m00"] - cx * cy
    theta = math.atan2(2.0 * mu11, mu20 - mu02) / 2.0
    if theta <= -math.pi / 2:  # atan2(-0.0, negative) = -pi; the same axis as +pi/2
        theta += math.pi
    # The moments are of the ROI's crop; shifting the centroid is exact (the angle is unchanged).
    return FlySighting(True, cx + x0, cy + y0, theta, max_area, outline)


#: BGR colours of the drawing: the fly's outline (Listing 1 picks a random one each frame;
#: a fixed one does not flicker), its centre (the listing's magenta), the dead band (red)
OUTLINE, CENTRE, DEAD_BAND, AXIS = (0, 255, 0), (255, 0, 255), (0, 0, 255), (255, 255, 0)


def draw_overlay(image: Image, sighting: FlySighting, *,
                 target: tuple[float, float] = DEFAULT_TARGET,
                 dead_band_px: float = 50.0) -> npt.NDArray[np.uint8]:
    """Listing 1's drawing of what the tracker saw (its ``imshow("a", drawing)``): the frame in
    colour, the largest contour, a 3 px circle at the fly's centre and the dead band's circle
    round the target; and, which the listing lacks, the body axis and "no fly" when none
    passed the area bounds. BGR, the image's size."""
    _check_image(np.asarray(image), "image")
    drawing = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
    if sighting.contour is not None and sighting.area > 0.0:
        cv2.drawContours(drawing, [sighting.contour], 0, OUTLINE, 2, cv2.LINE_8)
    centre = (round(sighting.cx), round(sighting.cy))
    cv2.circle(drawing, centre, 3, CENTRE, 1, cv2.LINE_8)
    if sighting.present:
        dx, dy = 25.0 * math.cos(sighting.theta), 25.0 * math.sin(sighting.theta)
        cv2.line(drawing, (round(sighting.cx - dx), round(sighting.cy - dy)),
                 (round(sighting.cx + dx), round(sighting.cy + dy)), AXIS, 1)
    else:
        cv2.putText(drawing, "no fly", (10, 30), cv2.FONT_HERSHEY_SIMPLEX, 0.8, DEAD_BAND, 2)
    cv2.circle(drawing, (round(target[0]), round(target[1])),
               round(dead_band_px), DEAD_BAND, 1, cv2.LINE_8)
    return np.asarray(drawing, dtype=np.uint8)
