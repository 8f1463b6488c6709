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
"""

from __future__ import annotations

import math

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
    occupancy_from_image,
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
