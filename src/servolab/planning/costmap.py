"""Occupancy grids and costmaps, inflated exactly as ROS costmap_2d's inflation layer does it.

Costs are costmap_2d's unsigned chars: :data:`FREE_SPACE` 0, :data:`INSCRIBED_INFLATED_OBSTACLE`
253, :data:`LETHAL_OBSTACLE` 254, :data:`NO_INFORMATION` 255. The cost of a cell at ``d`` cells
from the nearest obstacle cell (centre to centre) is ``InflationLayer::computeCost``
(costmap_2d/include/costmap_2d/inflation_layer.h, ros-planning/navigation)::

    d == 0                          -> 254
    d * resolution <= inscribed     -> 253
    otherwise                       -> (unsigned char)(252 * exp(-cost_scaling_factor
                                                                 * (d * resolution - inscribed)))

the cast truncating towards zero. A cell gets that cost only if ``d`` is at most
``cellDistance(inflation_radius) = ceil(inflation_radius / resolution)`` cells
(``InflationLayer::enqueue``, costmap_2d/plugins/inflation_layer.cpp, and
``Costmap2D::cellDistance``): the cut-off is a whole number of cells, rounded up, not the radius
itself. The new cost is combined with the cell's old one as ``updateCosts`` does: the larger
wins, except that an unknown cell (255) takes the inflated cost only when it is at least
253 (or above 0 with ``inflate_unknown``). Only lethal cells are inflated; unknown ones are not.

ROS finds each cell's obstacle by a wavefront from the obstacle cells (each cell inheriting the
source of the neighbour that reached it first); here ``scipy.ndimage.distance_transform_edt``
finds the truly nearest obstacle cell, and the distance is ``hypot(dx, dy)`` of the cell offsets,
as ROS's ``cached_distances_``. The two agree except in rare shapes where ROS's wavefront
inherits a source that is not the nearest one (it then gives a cell a lower cost, never higher).

The robot's inscribed radius is ``calculateMinAndMaxDistances`` of costmap_2d/src/footprint.cpp:
the least distance from the robot's centre to the footprint's vertices and edges (segments). A
``robot_radius`` is a footprint too in costmap_2d: ``makeFootprintFromRadius`` makes a 16-gon of
that radius, which :func:`footprint_from_radius` repeats; Costmap2DROS pads the footprint by
``footprint_padding`` (:func:`pad_footprint`) before the layers see it.

A polygon footprint is checked against a costmap along its outline, as base_local_planner's
``CostmapModel::footprintCost`` (base_local_planner/src/costmap_model.cpp) lays it down: the
polygon placed at a pose (:func:`orient_footprint`, the rotation ``WorldModel::footprintCost``
and costmap_2d's ``transformFootprint`` apply), each vertex taken to its cell, and each edge
rasterised from cell to cell by Bresenham's algorithm (:func:`line_cells`, base_local_planner's
``LineIterator``, which visits the cells costmap_2d's ``raytraceLine`` / ``bresenham2D`` visit),
the closing edge from the last vertex back to the first included (:func:`outline_cells`). All
of it is vectorised over any leading axes (every sample and pose of a DWA window at once).

Arrays are indexed ``[row, column]`` = ``[y, x]``, as the image the grid comes from.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage  # type: ignore[import-untyped]

from servolab.planning.errors import PlanningValueError

FREE_SPACE = 0
INSCRIBED_INFLATED_OBSTACLE = 253
LETHAL_OBSTACLE = 254
NO_INFORMATION = 255

#: Points of the polygon costmap_2d's makeFootprintFromRadius makes of a robot_radius.
RADIUS_FOOTPRINT_POINTS = 16


def occupancy_from_image(gray: ArrayLike, threshold: float) -> NDArray[np.bool_]:
    """Occupied cells of a grey image: pixels darker than ``threshold`` (``gray < threshold``).

    One pixel is one cell; a colour image is refused (convert it to grey first)."""
    image = np.asarray(gray)
    if image.ndim != 2:
        raise PlanningValueError("occupancy_from_image: expected a 2-D grey image, not an array of "
                                 f"shape {image.shape}")
    if not math.isfinite(threshold):
        raise PlanningValueError(f"occupancy_from_image: threshold must be finite, not {threshold}")
    return np.asarray(image < threshold, dtype=bool)


def cell_distance(world_distance: float, resolution: float) -> int:
    """Costmap2D::cellDistance: a distance in metres as whole cells, rounded up."""
    return int(max(0.0, math.ceil(world_distance / resolution)))


def compute_cost(distance_cells: ArrayLike, resolution: float, inscribed_radius: float,
                 cost_scaling_factor: float) -> NDArray[np.uint8]:
    """InflationLayer::computeCost for each distance (in cells, as ROS passes it), vectorised.

    Does not apply the inflation radius' cut-off: :func:`inflate` does."""
    d = np.asarray(distance_cells, dtype=float)
    metres = d * resolution
    with np.errstate(over="ignore", under="ignore"):
        factor = np.exp(-1.0 * cost_scaling_factor * (metres - inscribed_radius))
    decayed = np.trunc((INSCRIBED_INFLATED_OBSTACLE - 1) * factor)  # (unsigned char) cast
    cost = np.where(d == 0, LETHAL_OBSTACLE,
                    np.where(metres <= inscribed_radius, INSCRIBED_INFLATED_OBSTACLE, decayed))
    return np.asarray(cost, dtype=np.uint8)


def inflate(occupied: ArrayLike, resolution: float, inflation_radius: float,
            cost_scaling_factor: float, inscribed_radius: float, *,
            unknown: ArrayLike | None = None, inflate_unknown: bool = False) -> NDArray[np.uint8]:
    """The costmap of an occupancy grid after costmap_2d's inflation layer (see the module).

    ``occupied`` (bool, ``[row, col]``) are lethal cells; ``unknown`` (bool, same shape, or
    None) are NO_INFORMATION cells, which keep 255 unless inflation gives them 253 or more
    (any positive cost with ``inflate_unknown``). ``resolution`` is metres per cell."""
    occ = np.asarray(occupied, dtype=bool)
    if occ.ndim != 2:
        raise PlanningValueError(f"inflate: expected a 2-D occupancy grid, not shape {occ.shape}")
    if not (math.isfinite(resolution) and resolution > 0):
        raise PlanningValueError(f"inflate: resolution must be > 0 m, not {resolution}")
    for name, value in (("inflation_radius", inflation_radius),
                        ("cost_scaling_factor", cost_scaling_factor),
                        ("inscribed_radius", inscribed_radius)):
        if not (math.isfinite(value) and value >= 0):
            raise PlanningValueError(f"inflate: {name} must be finite and >= 0, not {value}")
    master = np.zeros(occ.shape, dtype=np.uint8)
    if unknown is not None:
        unk = np.asarray(unknown, dtype=bool)
        if unk.shape != occ.shape:
            raise PlanningValueError(f"inflate: unknown has shape {unk.shape}, the grid "
                                     f"{occ.shape}")
        master[unk] = NO_INFORMATION
    master[occ] = LETHAL_OBSTACLE
    radius_cells = cell_distance(inflation_radius, resolution)
    if radius_cells == 0 or not occ.any() or occ.all():
        return master
    # index of the nearest obstacle cell for every cell (obstacle cells are 0 in the input)
    indices = ndimage.distance_transform_edt(~occ, return_distances=False, return_indices=True)
    rows, cols = np.indices(occ.shape)
    distance = np.hypot(np.abs(cols - indices[1]), np.abs(rows - indices[0]))
    within = distance <= radius_cells
    cost = compute_cost(distance, resolution, inscribed_radius, cost_scaling_factor)
    was_unknown = master == NO_INFORMATION
    takes = (cost > FREE_SPACE) if inflate_unknown else (cost >= INSCRIBED_INFLATED_OBSTACLE)
    combined = np.where(was_unknown & takes, cost, np.maximum(master, cost))
    return np.where(within, combined, master).astype(np.uint8)


def footprint_from_radius(radius: float) -> NDArray[np.float64]:
    """costmap_2d's makeFootprintFromRadius: 16 points on the circle, from angle 0, (16, 2)."""
    angles = np.arange(RADIUS_FOOTPRINT_POINTS) * 2 * math.pi / RADIUS_FOOTPRINT_POINTS
    return np.column_stack((np.cos(angles) * radius, np.sin(angles) * radius))


def pad_footprint(footprint: ArrayLike, padding: float) -> NDArray[np.float64]:
    """costmap_2d's padFootprint: each coordinate moved ``padding`` away from 0 (a zero
    coordinate stays)."""
    points = _polygon(footprint)
    return np.asarray(points + np.sign(points) * padding, dtype=np.float64)


def footprint_distances(footprint: ArrayLike) -> tuple[float, float]:
    """costmap_2d's calculateMinAndMaxDistances: (inscribed, circumscribed) radius, the least
    and greatest distance from the centre (0, 0) to the footprint's vertices and edges."""
    points = _polygon(footprint)
    start, end = points, np.roll(points, -1, axis=0)
    vertex = np.hypot(start[:, 0], start[:, 1])
    edge = end - start
    length_sq = np.einsum("ij,ij->i", edge, edge)
    with np.errstate(invalid="ignore", divide="ignore"):
        param = np.einsum("ij,ij->i", -start, edge) / length_sq
    param = np.where(np.isfinite(param), param, 0.0)  # a zero-length edge: its vertex
    nearest = start + np.clip(param, 0.0, 1.0)[:, None] * edge
    edge_dist = np.hypot(nearest[:, 0], nearest[:, 1])
    return (float(min(vertex.min(), edge_dist.min())),
            float(max(vertex.max(), edge_dist.max())))


def inscribed_radius(footprint: ArrayLike) -> float:
    """The footprint's inscribed radius as costmap_2d computes it (:func:`footprint_distances`)."""
    return footprint_distances(footprint)[0]


def check_footprint(footprint: ArrayLike) -> NDArray[np.float64]:
    """A footprint as a (K, 2) float array of at least three finite [x, y] points; ValueError
    otherwise."""
    return _polygon(footprint)


def orient_footprint(footprint: ArrayLike,
                     poses: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The footprint (K, 2), in the robot's frame, placed at each pose ``(..., 3)`` = (x, y,
    theta): the world vertices' ``(xs, ys)``, each ``(K, ...)``, ``x + (px cos(theta) - py
    sin(theta))`` and ``y + (px sin(theta) + py cos(theta))`` (``WorldModel::footprintCost``'s
    oriented footprint, costmap_2d's ``transformFootprint``, added up as they add them).

    The vertex axis comes first, and x and y apart: numpy's loops then run along the long
    pose axes (a trailing axis of K = 4 would make every operation ~4 element-long loops)."""
    points = _polygon(footprint)
    p = np.asarray(poses, dtype=np.float64)
    if p.ndim < 1 or p.shape[-1] != 3:
        raise PlanningValueError(f"poses must be (..., 3) = (x, y, theta), not shape {p.shape}")
    cos, sin = np.cos(p[..., 2]), np.sin(p[..., 2])
    px = points[:, 0].reshape((-1,) + (1,) * (p.ndim - 1))             # (K, 1, ...)
    py = points[:, 1].reshape(px.shape)
    xs = p[..., 0] + (px * cos - py * sin)
    ys = p[..., 1] + (px * sin + py * cos)
    return xs, ys


def line_cells(x0: ArrayLike, y0: ArrayLike, x1: ArrayLike,
               y1: ArrayLike) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The cells ``(xs, ys)`` of the lines from cell ``(x0, y0)`` to cell ``(x1, y1)`` (integer
    arrays of one broadcast shape ``S``), each ``S + (L,)``, as base_local_planner's
    ``LineIterator`` (base_local_planner/include/base_local_planner/line_iterator.h) visits them.

    Bresenham's algorithm: the axis with the larger change (x on a tie) steps every cell; the
    other steps when its numerator, starting at ``den // 2`` and growing by the smaller change a
    cell, reaches the larger change ``den``. In closed form, cell ``k`` (0 .. den, both ends
    included) is offset ``k`` along the major axis and ``(den // 2 + k * minor) // den`` along
    the other, each in the direction of the end (the direction counts as positive when the end
    equals the start, as ``x1 >= x0`` does). Every line has ``L = max(den) + 1`` entries: a
    shorter one repeats its end cell, which leaves a maximum or an any() over the cells as it
    is."""
    a0, b0, a1, b1 = np.broadcast_arrays(*(np.asarray(c, dtype=np.int64)
                                           for c in (x0, y0, x1, y1)))
    dx, dy = a1 - a0, b1 - b0
    adx, ady = np.abs(dx), np.abs(dy)
    sx, sy = np.where(dx >= 0, 1, -1), np.where(dy >= 0, 1, -1)
    x_major = adx >= ady
    den = np.where(x_major, adx, ady)
    num_add = np.where(x_major, ady, adx)
    length = int(den.max()) + 1 if den.size else 1
    k = np.minimum(np.arange(length), den[..., None])                   # S + (L,)
    minor = (den[..., None] // 2 + k * num_add[..., None]) // np.maximum(den, 1)[..., None]
    xs = a0[..., None] + sx[..., None] * np.where(x_major[..., None], k, minor)
    ys = b0[..., None] + sy[..., None] * np.where(x_major[..., None], minor, k)
    return xs, ys


def outline_cells(vertex_cells: ArrayLike) -> NDArray[np.int64]:
    """The outline of closed polygons given by their vertices' cells ``(..., K, 2)`` (column,
    row), ``(..., K * L, 2)``: each edge from vertex ``i`` to ``i + 1`` and the last back to the
    first rasterised by :func:`line_cells`, as ``CostmapModel::footprintCost`` calls
    ``lineCost`` on them (a cell may appear more than once)."""
    cells = np.asarray(vertex_cells, dtype=np.int64)
    if cells.ndim < 2 or cells.shape[-1] != 2 or cells.shape[-2] < 3:
        raise PlanningValueError("vertex cells must be (..., K, 2) with K >= 3, not shape "
                                 f"{cells.shape}")
    ends = np.roll(cells, -1, axis=-2)
    xs, ys = line_cells(cells[..., 0], cells[..., 1], ends[..., 0], ends[..., 1])
    lead = cells.shape[:-1]
    return np.stack((xs.reshape((*lead[:-1], -1)), ys.reshape((*lead[:-1], -1))), axis=-1)


def _polygon(footprint: ArrayLike) -> NDArray[np.float64]:
    points = np.asarray(footprint, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 2 or len(points) < 3:
        raise PlanningValueError("a footprint must be at least three [x, y] points, not an array "
                                 f"of shape {points.shape}")
    if not np.isfinite(points).all():
        raise PlanningValueError("a footprint's points must be finite")
    return points


#: navfn's cost of a free cell and weight of the costmap's value (navfn/navfn.h)
COST_NEUTRAL = 50.0
COST_FACTOR = 0.8


def traversal_costs(costmap: ArrayLike) -> NDArray[np.float64]:
    """Cell costs for the planner from a costmap's 0..254: ``1 + 0.8 c / 50``, ``inf`` for
    253 and above (navfn's weights without its truncation to a byte; see
    :mod:`servolab.robots.navigation.plan`)."""
    c = np.asarray(costmap, dtype=np.float64)
    costs = (COST_NEUTRAL + COST_FACTOR * c) / COST_NEUTRAL
    costs[c >= INSCRIBED_INFLATED_OBSTACLE] = np.inf
    return costs
