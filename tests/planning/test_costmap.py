"""Occupancy grids and costmap_2d's inflation.

Expected costs are computed by hand from ROS costmap_2d (ros-planning/navigation):
``InflationLayer::computeCost`` in costmap_2d/include/costmap_2d/inflation_layer.h
(254 at distance 0, 253 while ``distance * resolution <= inscribed_radius``, else
``(unsigned char)(252 * exp(-cost_scaling_factor * (distance * resolution - inscribed)))``),
the cut-off of ``InflationLayer::enqueue`` in costmap_2d/plugins/inflation_layer.cpp (a cell is
inflated while its distance in cells is at most ``cellDistance(inflation_radius)``, which
costmap_2d/src/costmap_2d.cpp rounds up: ``ceil(world_dist / resolution)``), the unknown-cell
rule of ``InflationLayer::updateCosts``, and ``calculateMinAndMaxDistances``,
``makeFootprintFromRadius`` and ``padFootprint`` in costmap_2d/src/footprint.cpp.

The footprint's outline is checked against two rasterisers that share no code with it:
OpenCV's 8-connected ``cv2.line`` / ``cv2.polylines`` (Bresenham too; it breaks a tie, a line
passing exactly between two cells, its own way, so it is the oracle only for lines without
one), and a line-by-line port of base_local_planner's ``LineIterator``
(base_local_planner/include/base_local_planner/line_iterator.h), ties included.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import cv2
import numpy as np
import pytest

from servolab.planning.costmap import (
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    cell_distance,
    compute_cost,
    footprint_distances,
    footprint_from_radius,
    inflate,
    inscribed_radius,
    line_cells,
    occupancy_from_image,
    orient_footprint,
    outline_cells,
    pad_footprint,
)

# resolution 0.05 m, inscribed 0.10 m, cost_scaling_factor 10, inflation_radius 0.22 m:
# ceil(0.22 / 0.05) = 5 cells. By hand, 252 * exp(-10 * (d * 0.05 - 0.10)) truncated:
#   d = 3      -> 252 * exp(-0.5)      = 152.85 -> 152
#   d = 4      -> 252 * exp(-1.0)      =  92.71 ->  92
#   d = 5      -> 252 * exp(-1.5)      =  56.23 ->  56  (0.25 m > 0.22 m, inside ceil's 5 cells)
#   d = √5     -> 252 * exp(-0.1180)   = 223.99 -> 223  (truncated, not rounded to 224)
#   d = √8     -> 252 * exp(-0.4142)   = 166.54 -> 166
#   d = √18    -> 252 * exp(-1.1213)   =  82.11 ->  82
#   d = √26, √32 > 5 cells             ->   0
#   d = 1, √2, 2 (0.10 m <= 0.10 m)    -> 253
HAND = np.array([
    [254, 253, 253, 152, 92, 56, 0],
    [253, 253, 223, 140, 87, 0, 0],
    [253, 223, 166, 112, 73, 0, 0],
    [152, 140, 112, 82, 56, 0, 0],
    [92, 87, 73, 56, 0, 0, 0],
    [56, 0, 0, 0, 0, 0, 0],
    [0, 0, 0, 0, 0, 0, 0],
], dtype=np.uint8)
ARGS = {"resolution": 0.05, "inflation_radius": 0.22, "cost_scaling_factor": 10.0,
        "inscribed_radius": 0.10}


def test_inflation_matches_costmap_2d_by_hand() -> None:
    occupied = np.zeros((7, 7), dtype=bool)
    occupied[0, 0] = True
    costs = inflate(occupied, **ARGS)
    assert costs.dtype == np.uint8
    np.testing.assert_array_equal(costs, HAND)
    # the other entries of HAND, by the same formula: (1, 3) is √10 cells, (1, 4) √17, ...
    for (r, c), value in np.ndenumerate(HAND):
        d = math.hypot(r, c)
        if 0 < d <= 5 and d * 0.05 > 0.10:
            assert value == int(252 * math.exp(-10.0 * (d * 0.05 - 0.10)))


def test_nearest_obstacle_wins_and_grid_is_not_symmetric_by_accident() -> None:
    occupied = np.zeros((3, 12), dtype=bool)
    occupied[1, 0] = occupied[1, 11] = True
    costs = inflate(occupied, **ARGS)
    row = costs[1]
    assert list(row) == [254, 253, 253, 152, 92, 56, 56, 92, 152, 253, 253, 254]
    assert costs[0, 0] == costs[2, 0] == 253


def test_compute_cost_and_cell_distance() -> None:
    assert cell_distance(0.22, 0.05) == 5
    assert cell_distance(0.20, 0.05) == 4
    assert cell_distance(0.0, 0.05) == 0
    assert list(compute_cost([0, 1, 2, 3, 4, 5], 0.05, 0.10, 10.0)) == [254, 253, 253, 152,
                                                                       92, 56]
    # no decay: every cell beyond the inscribed radius costs 252
    assert compute_cost([3.0], 0.05, 0.10, 0.0)[0] == 252


def test_zero_inflation_radius_leaves_obstacles_only() -> None:
    occupied = np.eye(4, dtype=bool)
    costs = inflate(occupied, 0.05, 0.0, 10.0, 0.1)
    np.testing.assert_array_equal(costs, np.where(occupied, LETHAL_OBSTACLE, 0))
    assert not inflate(np.zeros((3, 3), dtype=bool), **ARGS).any()


def test_unknown_cells_take_only_inscribed_costs_unless_inflate_unknown() -> None:
    occupied = np.zeros((1, 6), dtype=bool)
    occupied[0, 0] = True
    unknown = np.zeros_like(occupied)
    unknown[0, 1] = unknown[0, 3] = unknown[0, 5] = True
    costs = inflate(occupied, unknown=unknown, **ARGS)
    # d = 1: 253 >= INSCRIBED replaces 255; d = 3: 152 does not; d = 5: 56 does not
    assert list(costs[0]) == [254, INSCRIBED_INFLATED_OBSTACLE, 253, NO_INFORMATION, 92,
                              NO_INFORMATION]
    costs = inflate(occupied, unknown=unknown, inflate_unknown=True, **ARGS)
    assert list(costs[0]) == [254, 253, 253, 152, 92, 56]


def test_occupancy_from_image_dark_pixels() -> None:
    gray = np.array([[0, 127, 128, 255]], dtype=np.uint8)
    assert occupancy_from_image(gray, 128).tolist() == [[True, True, False, False]]
    with pytest.raises(ValueError, match="2-D"):
        occupancy_from_image(np.zeros((2, 2, 3)), 128)


def test_footprint_inscribed_radius_of_a_rectangle_and_a_triangle() -> None:
    rect = [[-0.2, -0.1], [0.2, -0.1], [0.2, 0.1], [-0.2, 0.1]]
    inscribed, circumscribed = footprint_distances(rect)
    assert inscribed == pytest.approx(0.1)
    assert circumscribed == pytest.approx(math.hypot(0.2, 0.1))
    # distances are to the edges as segments: every edge's line here passes nearer the centre
    # (y = 0.1 at 0.1, y = x through it) than its segment, whose nearest point is a vertex
    tri = [[0.1, 0.1], [0.5, 0.1], [0.5, 0.5]]
    assert footprint_distances(tri) == pytest.approx((math.hypot(0.1, 0.1),
                                                      math.hypot(0.5, 0.5)))
    padded = pad_footprint(rect, 0.01)
    np.testing.assert_allclose(padded, [[-0.21, -0.11], [0.21, -0.11], [0.21, 0.11],
                                        [-0.21, 0.11]])
    assert inscribed_radius(padded) == pytest.approx(0.11)


def test_robot_radius_is_a_16_gon() -> None:
    polygon = footprint_from_radius(0.2)
    assert polygon.shape == (16, 2)
    assert polygon[0] == pytest.approx([0.2, 0.0])
    assert inscribed_radius(polygon) == pytest.approx(0.2 * math.cos(math.pi / 16))
    assert footprint_distances(polygon)[1] == pytest.approx(0.2)
    with pytest.raises(ValueError, match="three"):
        inscribed_radius([[0, 1], [1, 0]])


def test_large_grid_is_fast() -> None:
    rng = np.random.default_rng(0)
    occupied = rng.random((1000, 1000)) < 0.01
    costs = inflate(occupied, 0.05, 0.40, 12.0, 0.2)
    assert (costs[occupied] == LETHAL_OBSTACLE).all()


def line_iterator(x0: int, y0: int, x1: int, y1: int) -> Iterator[tuple[int, int]]:
    """base_local_planner's LineIterator, statement for statement (line_iterator.h)."""
    deltax, deltay = abs(x1 - x0), abs(y1 - y0)
    xinc1 = xinc2 = 1 if x1 >= x0 else -1
    yinc1 = yinc2 = 1 if y1 >= y0 else -1
    if deltax >= deltay:
        xinc1, yinc2, den, num, numadd, numpixels = 0, 0, deltax, deltax // 2, deltay, deltax
    else:
        xinc2, yinc1, den, num, numadd, numpixels = 0, 0, deltay, deltay // 2, deltax, deltay
    x, y = x0, y0
    for _ in range(numpixels + 1):
        yield x, y
        num += numadd
        if num >= den:
            num -= den
            x += xinc1
            y += yinc1
        x += xinc2
        y += yinc2


def has_tie(x0: int, y0: int, x1: int, y1: int) -> bool:
    """A line passing exactly half-way between two cells somewhere (the minor offset
    ``k * minor / major`` is a whole number and a half): rasterisers may round either way."""
    major, minor = max(abs(x1 - x0), abs(y1 - y0)), min(abs(x1 - x0), abs(y1 - y0))
    return major > 0 and any((2 * k * minor) % (2 * major) == major for k in range(major + 1))


def cv2_cells(points: list[tuple[int, int]], closed: bool, shape: tuple[int, int] = (96, 96)
              ) -> set[tuple[int, int]]:
    image = np.zeros(shape, dtype=np.uint8)
    cv2.polylines(image, [np.array(points, dtype=np.int32)], closed, 1, 1, cv2.LINE_8)
    rows, cols = np.nonzero(image)
    return set(zip(cols.tolist(), rows.tolist(), strict=True))


def test_line_cells_are_line_iterators_bresenham_and_agree_with_opencv() -> None:
    rng = np.random.default_rng(7)
    ends = rng.integers(0, 40, (400, 4))
    ends[:20, 2:] = ends[:20, :2]                       # single cells
    ends[20:40, 3] = ends[20:40, 1]                     # horizontal and diagonal lines
    ends[40:60, 2] = ends[40:60, 0] + np.abs(ends[40:60, 3] - ends[40:60, 1])
    xs, ys = line_cells(ends[:, 0], ends[:, 1], ends[:, 2], ends[:, 3])  # all at once
    assert xs.shape == ys.shape == (400, int(np.abs(ends[:, 2:] - ends[:, :2]).max()) + 1)
    compared = 0
    for (x0, y0, x1, y1), row_x, row_y in zip(ends.tolist(), xs, ys, strict=True):
        ours = list(zip(row_x.tolist(), row_y.tolist(), strict=True))
        expected = list(line_iterator(x0, y0, x1, y1))
        # the same cells in the same order, then the end cell repeated to the common length
        assert ours[:len(expected)] == expected
        assert set(ours[len(expected):]) <= {(x1, y1)}
        if not has_tie(x0, y0, x1, y1):
            assert set(ours) == cv2_cells([(x0, y0), (x1, y1)], closed=False)
            compared += 1
    assert compared > 200


def test_outline_cells_of_a_turned_rectangle_match_cv2_polylines() -> None:
    """costmap_model.cpp's footprintCost: every edge, the last vertex back to the first too."""
    rectangle = np.array([[-0.25, -0.15], [0.25, -0.15], [0.25, 0.15], [-0.25, 0.15]])
    compared = 0
    for theta in np.linspace(0.0, 2 * math.pi, 37):
        xs, ys = orient_footprint(rectangle, (1.6, 1.5, theta))
        assert xs.shape == ys.shape == (4,)   # (K,) + the poses' shape
        np.testing.assert_allclose(np.hypot(xs - 1.6, ys - 1.5), math.hypot(0.25, 0.15))
        vertices = np.floor(np.column_stack((xs, ys)) / 0.05).astype(int)   # worldToMap
        pairs = list(zip(vertices.tolist(), np.roll(vertices, -1, axis=0).tolist(), strict=True))
        if any(has_tie(*a, *b) for a, b in pairs):
            continue
        cells = outline_cells(vertices)
        assert cells.shape[-1] == 2
        points = [(int(x), int(y)) for x, y in vertices]
        assert set(map(tuple, cells.tolist())) == cv2_cells(points, closed=True)
        compared += 1
    assert compared >= 10
    with pytest.raises(ValueError, match="K >= 3"):
        outline_cells([[0, 0], [1, 1]])
