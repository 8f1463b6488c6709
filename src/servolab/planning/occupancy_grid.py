"""Occupancy grids as ROS map_server reads and writes them, and as costmap_2d's static layer
turns them into costs: pure arrays, no files (:mod:`servolab.vision.map_file` reads and writes
the ``map.yaml`` and its image).

Why here: the same conversions serve ``servolab plan --map map.yaml``, the simulated scene that
takes its walls from a map, and the map the overhead camera builds, so they are written once,
each against the ROS source it repeats (ros-planning/navigation, noetic-devel):

- **Image to grid**, ``map_server/src/image_loader.cpp`` (``loadMapFromFile``): a pixel's
  channels are averaged (the alpha channel too in trinary mode, not in scale or raw mode);
  ``negate`` turns the average ``a`` into ``255 - a``; then ``p = (255 - a) / 255`` is the
  occupancy probability, ``p > occupied_thresh`` gives 100, ``p < free_thresh`` gives 0 and
  anything between -1 (unknown) in ``trinary`` mode, ``1 + 98 (p - free) / (occ - free)``
  (truncated) in ``scale`` mode unless the pixel is transparent; ``raw`` mode keeps ``a`` as
  the cell's byte. The image's row 0 is the *top* of the map: map row ``height - 1 - j`` is
  image row ``j`` ("we invert the graphics-ordering of the pixels to produce a map with cell
  (0,0) in the lower-left corner").
- **Grid to image**, ``map_server/src/map_saver.cpp``: a cell 0..``threshold_free`` (25) is
  written 254, one of ``threshold_occupied`` (65) or more 0, any other (unknown -1 included)
  205, rows flipped the same way. (The older map_saver wrote 254 for 0 and 0 for 100 only;
  for a grid of -1, 0 and 100 both write the same bytes.)
- **Grid to costmap**, ``costmap_2d/plugins/static_layer.cpp`` (``interpretValue``), with its
  defaults ``lethal_cost_threshold`` 100, ``unknown_cost_value`` -1 and ``trinary_costmap``
  true: the cell's byte read unsigned, 255 (-1) is NO_INFORMATION when unknown space is
  tracked, 100 and above LETHAL_OBSTACLE, anything else FREE_SPACE.
- **Metres to cells**, ``Costmap2D::worldToMap`` and ``mapToWorld``: cell ``(mx, my)`` holds
  ``x`` in ``[origin_x + mx * res, origin_x + (mx + 1) * res)``; its centre is at ``+ 0.5``.

Arrays are ``[row, col] = [y, x]`` with row 0 at the origin's ``y`` (the map frame, as
``nav_msgs/OccupancyGrid.data`` is laid out), unlike an image's.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import PlanningValueError

#: nav_msgs/OccupancyGrid's values: occupied, free, unknown
OCCUPIED = 100
FREE = 0
UNKNOWN = -1
#: map_server's modes (``mode:`` of map.yaml); trinary when the file does not say
MODES = ("trinary", "scale", "raw")
#: map_saver's thresholds (map.yaml's ``occupied_thresh``, ``free_thresh``; its --occ, --free)
SAVER_OCCUPIED_THRESH = 0.65
SAVER_FREE_THRESH = 0.196
SAVER_THRESHOLD_OCCUPIED = 65
SAVER_THRESHOLD_FREE = 25
#: the grey levels map_saver writes
SAVED_OCCUPIED = 0
SAVED_FREE = 254
SAVED_UNKNOWN = 205


def occupancy_from_pixels(pixels: ArrayLike, *, negate: bool = False,
                          occupied_thresh: float = SAVER_OCCUPIED_THRESH,
                          free_thresh: float = SAVER_FREE_THRESH,
                          mode: str = "trinary") -> NDArray[np.int8]:
    """The grid map_server makes of an 8-bit image: ``(H, W)`` grey or ``(H, W, C)`` with C
    channels (4: the last is alpha, as OpenCV and SDL both store it). See the module.

    One departure, stated: map_server reads the last byte of a 3-channel pixel as its alpha
    (a colour channel, which then makes a black-blue pixel unknown in scale mode); here only
    a fourth channel is alpha."""
    image = np.asarray(pixels)
    if image.dtype != np.uint8:
        raise PlanningValueError(f"a map image must be 8-bit, not {image.dtype}")
    if image.ndim == 2:
        image = image[:, :, None]
    if image.ndim != 3 or image.shape[2] not in (1, 2, 3, 4) or image.size == 0:
        raise PlanningValueError(f"a map image must be (H, W) or (H, W, 1..4), not shape "
                                 f"{np.asarray(pixels).shape}")
    if mode not in MODES:
        raise PlanningValueError(f"mode must be one of {', '.join(MODES)}, not {mode!r}")
    channels = image.shape[2]
    has_alpha = channels in (2, 4)
    averaged = channels if mode == "trinary" or not has_alpha else channels - 1
    # the sum is an int and the division a double, as image_loader.cpp computes them
    color_avg = image[:, :, :averaged].astype(np.int64).sum(axis=2) / float(averaged)
    alpha = image[:, :, -1] if has_alpha else np.full(image.shape[:2], 255, np.uint8)
    if negate:
        color_avg = 255 - color_avg
    if mode == "raw":
        # ``value = color_avg``: a double into an unsigned char, then the grid's signed byte
        grid = np.trunc(color_avg).astype(np.uint8).view(np.int8)
    else:
        occ = (255 - color_avg) / 255.0
        between = np.full(occ.shape, UNKNOWN, dtype=np.int8)
        if mode == "scale":
            with np.errstate(divide="ignore", invalid="ignore"):
                ratio = (occ - free_thresh) / (occupied_thresh - free_thresh)
                scaled = np.trunc(1 + 98 * ratio)
            between = np.where(alpha < 1, UNKNOWN, np.nan_to_num(scaled)).astype(np.int8)
        grid = np.where(occ > occupied_thresh, np.int8(OCCUPIED),
                        np.where(occ < free_thresh, np.int8(FREE), between)).astype(np.int8)
    return np.ascontiguousarray(grid[::-1])


def pixels_from_occupancy(occupancy: ArrayLike, *,
                          threshold_occupied: int = SAVER_THRESHOLD_OCCUPIED,
                          threshold_free: int = SAVER_THRESHOLD_FREE) -> NDArray[np.uint8]:
    """The image map_saver writes of a grid (``[row, col]``, row 0 at the origin): 254 for
    0..``threshold_free``, 0 from ``threshold_occupied``, 205 otherwise; image row 0 is the
    map's last row. A bool grid is occupied (100) where true, free (0) elsewhere."""
    grid = _grid(occupancy)
    values = grid.astype(np.int16)
    image = np.where((values >= 0) & (values <= threshold_free), SAVED_FREE,
                     np.where(values >= threshold_occupied, SAVED_OCCUPIED, SAVED_UNKNOWN))
    return np.ascontiguousarray(image[::-1].astype(np.uint8))


def lethal_and_unknown(occupancy: ArrayLike) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """costmap_2d's static layer on a grid: ``(lethal, unknown)`` masks (see the module).

    Unknown space is always tracked: a cell nobody has seen is not free (servolab's planner,
    like navfn with ``allow_unknown`` false, never enters it; :func:`~servolab.planning.
    costmap.traversal_costs` makes NO_INFORMATION impassable)."""
    grid = _grid(occupancy)
    byte = grid.view(np.uint8) if grid.dtype == np.int8 else grid.astype(np.uint8)
    unknown = byte == 255
    lethal = (byte >= OCCUPIED) & ~unknown
    return np.asarray(lethal, dtype=bool), np.asarray(unknown, dtype=bool)


def _grid(occupancy: ArrayLike) -> NDArray[np.int8]:
    """A grid as nav_msgs has it: int8; bool becomes 100 / 0."""
    grid = np.asarray(occupancy)
    if grid.ndim != 2 or grid.size == 0:
        raise PlanningValueError(f"an occupancy grid must be 2-D and not empty, not shape "
                                 f"{grid.shape}")
    if grid.dtype == np.bool_:
        return np.where(grid, np.int8(OCCUPIED), np.int8(FREE)).astype(np.int8)
    if not np.issubdtype(grid.dtype, np.integer):
        raise PlanningValueError(f"an occupancy grid must hold integers or bools, not "
                                 f"{grid.dtype}")
    if grid.min() < -128 or grid.max() > 127:
        raise PlanningValueError("an occupancy grid's values must fit a signed byte "
                                 f"(-1 unknown, 0..100), not {grid.min()}..{grid.max()}")
    return grid.astype(np.int8)


def world_to_cell(x: float, y: float, origin: tuple[float, float], resolution: float,
                  shape: tuple[int, int]) -> tuple[int, int] | None:
    """Costmap2D::worldToMap: the cell ``(col, row)`` holding the point ``(x, y)`` m, or None
    when the point is off the grid of ``shape = (rows, cols)``."""
    if not (math.isfinite(x) and math.isfinite(y)):
        return None
    if x < origin[0] or y < origin[1]:
        return None
    col = int((x - origin[0]) / resolution)
    row = int((y - origin[1]) / resolution)
    if col < shape[1] and row < shape[0]:
        return col, row
    return None


def cell_to_world(col: float, row: float, origin: tuple[float, float],
                  resolution: float) -> tuple[float, float]:
    """Costmap2D::mapToWorld: the centre ``(x, y)`` m of cell ``(col, row)``."""
    return (origin[0] + (col + 0.5) * resolution, origin[1] + (row + 0.5) * resolution)
