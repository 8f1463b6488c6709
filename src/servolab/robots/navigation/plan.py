"""``servolab plan``'s run: a path on a map image with D* Lite, written to a run folder.

**The map.** The image is read in grey (``cv2.imread(..., IMREAD_GRAYSCALE)``, any format
OpenCV reads); one pixel is one cell, and a pixel darker than ``threshold`` (default 128, the
middle of 0..255: ``gray < 128``) is occupied (:func:`~servolab.planning.costmap.
occupancy_from_image`). Coordinates are in cells, ``x`` = column and ``y`` = row, counted from
the image's top-left pixel (0, 0), as an image viewer shows them.

**Without inflation** every free cell costs 1 and an occupied one ``inf``: with the grid's move
costs (:mod:`servolab.planning.grid`: a step of 1 or sqrt(2) times the mean of the two cells'
costs, no diagonal cutting an occupied corner) a path's cost is its length in cells.

**With inflation** (the default) the occupied cells are inflated as costmap_2d's inflation
layer does it (:func:`~servolab.planning.costmap.inflate`) with the parameter file's
``inflation_radius``, ``cost_scaling_factor`` and the robot's inscribed radius (from
``robot_radius`` or ``footprint``, padded by ``footprint_padding``); the default file is
``costmap_params.yaml`` shipped here (seed 000's D.2). A cell is ``resolution`` metres square: the
``--resolution`` given, else the file's ``resolution``, else costmap_2d's default 0.05 m. The
costmap's 0..254 becomes a traversal cost per cell with the weights of ROS's navfn global
planner (without its truncation to an unsigned char), divided by its neutral cost so that
free space costs 1::

    cost(c) = (COST_NEUTRAL + COST_FACTOR * c) / COST_NEUTRAL = 1 + 0.8 * c / 50  for c <= 252
    cost(c) = inf                                                                for c >= 253

(navfn's ``COST_NEUTRAL`` 50 and ``COST_FACTOR`` 0.8: a cell at the top of the decay, 252, costs
5.032 times a free one; navfn, truncating, gives 5.02). 253 (the robot's centre within its
inscribed radius of an obstacle) and 254 (lethal) cannot be entered, as navfn treats them.
A path's cost is then in "free cells": its length in cells where the costmap is 0, more near
obstacles.

The start and goal must be inside the map and free (not dark; with inflation, not within the
robot's inscribed radius of a dark pixel either); anything else is a :class:`PlanError` naming
which end and where: bad input, ``servolab plan`` exits 2. A map with no way from one end to the
other is not bad input: :func:`plan` raises the planner's
:class:`~servolab.planning.errors.NoPath`, a failure at run time (exit 1).

**A map_server map** (``--map map.yaml``, :func:`load_map_problem`) is read as map_server reads
it (:mod:`servolab.vision.map_file`): its image, ``resolution`` and ``origin``. The start and
goal are then in metres in the map frame, each in the cell ``Costmap2D::worldToMap`` gives
(``col = int((x - origin_x) / resolution)``, likewise the row, counted from the map's bottom
row, as nav_msgs/OccupancyGrid counts them); the path is reported in those cells and as their
centres in metres. The cells become costs as costmap_2d's static layer makes them
(:func:`~servolab.planning.occupancy_grid.lethal_and_unknown`): 100 and above lethal, unknown
(-1) NO_INFORMATION (255), the rest free; then the inflation above, at the map's resolution
(costmap_2d's static layer gives the master costmap the map's resolution, so the parameter
file's ``resolution`` is not used), with the file's ``inflate_unknown``. Unknown is never free
and never entered: servolab's planner treats NO_INFORMATION as navfn does with
``allow_unknown: false`` (inf in :func:`~servolab.planning.costmap.traversal_costs`), also
without inflation; a start or goal in unknown space is refused as one in an obstacle is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import numpy.typing as npt

from ...planning.costmap import (
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    inflate,
    occupancy_from_image,
    traversal_costs,
)
from ...planning.dstar_lite import DStarLite
from ...planning.errors import NoPath
from ...vision.map_file import OccupancyMap, load_map
from ..errors import RobotValueError
from .params import DEFAULT_COSTMAP, DEFAULT_RESOLUTION, CostmapParams, load_costmap

if TYPE_CHECKING:
    from collections.abc import Callable

    from ...runs import RunFolder

#: costmap_params.yaml of this package: seed 000's D.2, ``servolab plan``'s default
DEFAULT_PARAMS = DEFAULT_COSTMAP
#: pixels darker than this are occupied
DEFAULT_THRESHOLD = 128.0


class PlanError(RobotValueError):
    """Input ``servolab plan`` cannot plan on (a map, an end, a resolution): one line."""


@dataclass
class PlanProblem:
    """A map read and checked, ready to plan on."""

    map_path: str
    occupied: npt.NDArray[np.bool_]
    costs: npt.NDArray[np.float64]
    start: tuple[int, int]  # (x, y) = (column, row)
    goal: tuple[int, int]
    inflation: bool
    threshold: float
    costmap: npt.NDArray[np.uint8] | None = None
    params: CostmapParams | None = None
    resolution: float | None = None
    ignored: tuple[str, ...] = field(default=())
    #: the map_server map (``--map map.yaml``): then ``occupied`` are its lethal cells, the
    #: cells are in the map frame (row 0 at the origin) and the ends were given in metres
    map: OccupancyMap | None = None
    unknown: npt.NDArray[np.bool_] | None = None
    start_m: tuple[float, float] | None = None
    goal_m: tuple[float, float] | None = None

    def describe(self, which: str) -> str:
        """An end as the command line gave it: ``(x, y)`` cells, or ``(x, y) m``."""
        metres = self.start_m if which == "start" else self.goal_m
        if self.map is not None and metres is not None:
            return f"{which} ({metres[0]:g}, {metres[1]:g}) m"
        x, y = self.start if which == "start" else self.goal
        return f"{which} ({x}, {y})"


def read_map(path: str | Path) -> npt.NDArray[np.uint8]:
    """The image at ``path`` in grey; PlanError naming it if missing or unreadable."""
    import cv2

    p = Path(path)
    if not p.exists():
        raise PlanError(f"map image {str(p)!r} does not exist")
    if p.is_dir():
        raise PlanError(f"map image {str(p)!r} is a folder, not an image")
    image = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
    if image is None or image.size == 0:
        raise PlanError(f"map image {str(p)!r} cannot be read as an image by OpenCV")
    return np.asarray(image, dtype=np.uint8)


def load_problem(map_path: str | Path, start: tuple[int, int], goal: tuple[int, int], *,
                 params: str | Path | None = None, inflation: bool = True,
                 resolution: float | None = None,
                 threshold: float = DEFAULT_THRESHOLD) -> PlanProblem:
    """Read the map (and the costmap parameters with inflation), build the cell costs and
    check both ends; PlanError (or the parameter file's NavParamsError) on bad input."""
    gray = read_map(map_path)
    occupied = occupancy_from_image(gray, threshold)
    height, width = occupied.shape
    costmap = None
    costmap_params = None
    cell_m = None
    ignored: tuple[str, ...] = ()
    if inflation:
        if resolution is not None and not (math.isfinite(resolution) and resolution > 0):
            raise PlanError(f"--resolution must be > 0 m, not {resolution}")
        costmap_params = load_costmap(params if params is not None else DEFAULT_PARAMS)
        ignored = costmap_params.ignored
        cell_m = resolution if resolution is not None else costmap_params.resolution
    costmap, costs = _costs(occupied, None, cell_m, costmap_params)
    for name, (x, y) in (("start", start), ("goal", goal)):
        if not (0 <= x < width and 0 <= y < height):
            raise PlanError(f"{name} ({x}, {y}) is outside the map {str(map_path)!r}, which "
                            f"is {width} x {height} cells (x 0..{width - 1}, y 0..{height - 1})")
        if occupied[y, x]:
            raise PlanError(f"{name} ({x}, {y}) is inside an obstacle (a pixel darker than "
                            f"{threshold:g} in {str(map_path)!r})")
        if not math.isfinite(costs[y, x]) and costmap_params is not None and cell_m:
            inscribed = costmap_params.inscribed_radius
            value = int(costmap[y, x]) if costmap is not None else INSCRIBED_INFLATED_OBSTACLE
            raise PlanError(f"{name} ({x}, {y}) is within the robot's inscribed radius "
                            f"({inscribed:.3f} m = {inscribed / cell_m:.1f} cells) of an "
                            f"obstacle (inflated cost {value}); move it or plan with "
                            "--no-inflation")
    return PlanProblem(str(map_path), occupied, costs, start, goal, inflation, threshold,
                       costmap, costmap_params, cell_m, ignored)


def _costs(occupied: npt.NDArray[np.bool_], unknown: npt.NDArray[np.bool_] | None,
           cell_m: float | None, params: CostmapParams | None,
           ) -> tuple[npt.NDArray[np.uint8] | None, npt.NDArray[np.float64]]:
    """``(costmap, cell costs)``: inflated with ``params`` (the costmap None without them),
    unknown cells NO_INFORMATION and so impassable either way (see the module)."""
    if params is None or cell_m is None:
        blocked = occupied if unknown is None else occupied | unknown
        return None, np.where(blocked, np.inf, 1.0)
    if params.inflation_enabled:
        costmap = inflate(occupied, cell_m, params.inflation_radius, params.cost_scaling_factor,
                          params.inscribed_radius, unknown=unknown,
                          inflate_unknown=params.inflate_unknown)
    else:  # the file switches the inflation layer off: obstacles (and unknown) alone
        costmap = np.where(occupied, np.uint8(LETHAL_OBSTACLE), np.uint8(0)).astype(np.uint8)
        if unknown is not None:
            costmap[unknown & ~occupied] = NO_INFORMATION
    return costmap, traversal_costs(costmap)


def load_map_problem(map_path: str | Path, start: tuple[float, float],
                     goal: tuple[float, float], *, params: str | Path | None = None,
                     inflation: bool = True) -> PlanProblem:
    """Read a map_server map.yaml (and the costmap parameters with inflation), build the cell
    costs and check both ends, given in metres in the map frame (see the module); the map
    file's MapFileError, the parameter file's NavParamsError or a PlanError on bad input."""
    omap = load_map(map_path)
    lethal, unknown = omap.lethal_and_unknown()
    rows, cols = omap.shape
    costmap_params = None
    ignored: tuple[str, ...] = ()
    if inflation:
        costmap_params = load_costmap(params if params is not None else DEFAULT_PARAMS)
        ignored = costmap_params.ignored
    costmap, costs = _costs(lethal, unknown, omap.resolution, costmap_params)
    cells = []
    x0, x1, y0, y1 = omap.extent
    for name, (x, y) in (("start", start), ("goal", goal)):
        where = f"{name} ({x:g}, {y:g}) m"
        cell = omap.cell_of(x, y)
        if cell is None:
            raise PlanError(f"{where} is outside the map {str(map_path)!r}, which covers x "
                            f"{x0:g}..{x1:g} m, y {y0:g}..{y1:g} m ({cols} x {rows} cells of "
                            f"{omap.resolution:g} m)")
        col, row = cell
        pixel = f"cell ({col}, {row}) from the origin, pixel ({col}, {rows - 1 - row}) of " \
                f"{omap.image!r}"
        if lethal[row, col]:
            raise PlanError(f"{where} is in an occupied cell ({pixel})")
        if unknown[row, col]:
            raise PlanError(f"{where} is in unknown space ({pixel}: neither free nor "
                            "occupied, which servolab never plans through)")
        if not math.isfinite(costs[row, col]) and costmap_params is not None:
            inscribed = costmap_params.inscribed_radius
            value = int(costmap[row, col]) if costmap is not None else LETHAL_OBSTACLE
            raise PlanError(f"{where} is within the robot's inscribed radius "
                            f"({inscribed:.3f} m) of an obstacle (inflated cost {value}, "
                            f"{pixel}); move it or plan with --no-inflation")
        cells.append(cell)
    return PlanProblem(str(map_path), lethal, costs, cells[0], cells[1], inflation,
                       math.nan, costmap, costmap_params, omap.resolution, ignored, omap,
                       unknown, (float(start[0]), float(start[1])),
                       (float(goal[0]), float(goal[1])))


def plan(problem: PlanProblem) -> tuple[float, npt.NDArray[np.int64]]:
    """D* Lite on the problem: (cost, path as (N, 2) ``(x, y)`` cells); :class:`NoPath`, in
    the terms of the command line (``x``, ``y``, the map, ``--no-inflation``), if none."""
    (sx, sy), (gx, gy) = problem.start, problem.goal
    planner = DStarLite(problem.costs, (sy, sx), (gy, gx))
    try:
        cells = planner.path()
    except NoPath:
        how = " (with inflation; try --no-inflation)" if problem.inflation else ""
        raise NoPath(f"no path from {problem.describe('start')} to "
                     f"{problem.describe('goal')} on {problem.map_path!r}{how}") from None
    return float(planner.cost()), cells[:, ::-1].copy()


def run_plan(run_folder: RunFolder, problem: PlanProblem,
             say: Callable[[str], None] = print, *,
             result: tuple[float, npt.NDArray[np.int64]] | None = None) -> dict[str, Any]:
    """Plan (unless ``result``, a :func:`plan` already made, is given), write ``plan.png``
    and ``summary.json`` into the run folder and return the summary. A run ended early (a
    stop signal, an error) still writes ``summary.json``, with what it had and what ended it
    (``"interrupted"``), and re-raises."""
    height, width = problem.occupied.shape
    summary: dict[str, Any] = {
        "map": problem.map_path, "map_size": [width, height], "threshold": problem.threshold,
        "start": list(problem.start), "goal": list(problem.goal), "inflation": problem.inflation,
    }
    if problem.map is not None:  # a map.yaml: the ends in metres, the cells they fall in
        m = problem.map
        summary.update({
            "threshold": None, "start": list(problem.start_m or ()),
            "goal": list(problem.goal_m or ()), "start_cell": list(problem.start),
            "goal_cell": list(problem.goal), "image": m.image, "resolution_m": m.resolution,
            "origin": list(m.origin), "negate": m.negate,
            "occupied_thresh": m.occupied_thresh, "free_thresh": m.free_thresh,
            "mode": m.mode, "unknown_cells": 0 if problem.unknown is None
            else int(np.count_nonzero(problem.unknown)),
            "cells_are": "[column, row] from the map's origin (row 0 is the image's last row)",
        })
    interrupted: BaseException | None = None
    try:
        _plan_into(run_folder, problem, summary, say, result)
    except BaseException as error:  # a stop signal or an error: the summary says which
        interrupted = error
    run_folder.write_summary(summary, interrupted=interrupted)
    if interrupted is not None:
        raise interrupted
    return summary


def _plan_into(run_folder: RunFolder, problem: PlanProblem, summary: dict[str, Any],
               say: Callable[[str], None],
               result: tuple[float, npt.NDArray[np.int64]] | None) -> None:
    """:func:`run_plan`'s work: the path's figures and the plot, added to ``summary``."""
    if problem.ignored:
        say(f"ignored keys of {problem.params.path if problem.params else 'the parameters'}: "
            + ", ".join(problem.ignored))
    cost, path = result if result is not None else plan(problem)
    steps = np.abs(np.diff(path, axis=0))
    diagonal = int(np.count_nonzero(steps.min(axis=1))) if len(path) > 1 else 0
    length_cells = float(diagonal * math.sqrt(2.0) + (len(path) - 1 - diagonal))
    summary.update({"cost": cost, "length_cells": length_cells, "cells": len(path),
                    "path": path.tolist()})
    if problem.map is not None:
        centres = [problem.map.centre_of(float(c), float(r)) for c, r in path]
        summary.update({"path_m": [list(xy) for xy in centres],
                        "length_m": length_cells * problem.map.resolution})
    if problem.inflation and problem.params is not None:
        p = problem.params
        summary.update({
            "params": p.path, "resolution_m": problem.resolution,
            "length_m": length_cells * (problem.resolution or DEFAULT_RESOLUTION),
            "inflation_enabled": p.inflation_enabled,
            "inflation_radius_m": p.inflation_radius,
            "cost_scaling_factor": p.cost_scaling_factor,
            "inscribed_radius_m": p.inscribed_radius,
            "cost_mapping": "1 + 0.8 * c / 50 for costmap c <= 252 (navfn), inf for c >= 253",
            "ignored": list(p.ignored), "notes": list(p.notes),
        })
    else:
        summary["cost_mapping"] = ("free 1, occupied inf (cost = length in cells)"
                                   if problem.map is None else
                                   "free 1, occupied and unknown inf (cost = length in cells)")
    summary["plot"] = str(plot_plan(problem, path, run_folder.file("plan.png")))
    metres = f" = {summary['length_m']:.2f} m" if problem.map is not None else ""
    say(f"path of {len(path)} cells, length {length_cells:.2f} cells{metres}, cost {cost:.2f} "
        f"({'with' if problem.inflation else 'without'} inflation); plot {summary['plot']}")


def plot_plan(problem: PlanProblem, path: npt.NDArray[np.int64], target: Path) -> Path:
    """The map (obstacles black, unknown grey), the inflation's shading, the path, start and
    goal; in cells from the image's top-left for an image, in metres in the map frame (y up)
    for a map.yaml."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    height, width = problem.occupied.shape
    figure, ax = plt.subplots(figsize=(7, 7 * height / max(width, 1) + 0.5))
    if problem.map is not None:
        res = problem.map.resolution
        x0, x1, y0, y1 = problem.map.extent
        extent: tuple[float, float, float, float] = (x0, x1, y0, y1)
        origin: Literal["upper", "lower"] = "lower"
        xy = np.column_stack([x0 + (path[:, 0] + 0.5) * res, y0 + (path[:, 1] + 0.5) * res])
        start, goal = problem.start_m or (0.0, 0.0), problem.goal_m or (0.0, 0.0)
        limits = ((x0, x1), (y0, y1))
        labels = ("x (m, map frame)", "y (m, map frame)")
    else:
        extent = (-0.5, width - 0.5, height - 0.5, -0.5)
        origin = "upper"
        xy = path.astype(float)
        start = (float(problem.start[0]), float(problem.start[1]))
        goal = (float(problem.goal[0]), float(problem.goal[1]))
        limits = ((-0.5, width - 0.5), (height - 0.5, -0.5))
        labels = ("x (column, cells)", "y (row, cells)")
    if problem.costmap is not None:
        shade = np.ma.masked_where((problem.costmap == 0) | problem.occupied
                                   | (problem.costmap == NO_INFORMATION),
                                   problem.costmap.astype(float))
        image = ax.imshow(shade, cmap="YlOrRd", vmin=0, vmax=254, extent=extent,
                          origin=origin, interpolation="nearest")
        figure.colorbar(image, ax=ax, shrink=0.7, label="inflated cost (0..254)")
    if problem.unknown is not None and problem.unknown.any():
        unknown = np.ma.masked_where(~problem.unknown, np.full(problem.unknown.shape, 0.35))
        ax.imshow(unknown, cmap="gray_r", vmin=0, vmax=1, extent=extent, origin=origin,
                  interpolation="nearest")
    walls = np.ma.masked_where(~problem.occupied, np.ones(problem.occupied.shape))
    ax.imshow(walls, cmap="gray_r", vmin=0, vmax=1, extent=extent, origin=origin,
              interpolation="nearest")
    ax.plot(xy[:, 0], xy[:, 1], "-", color="tab:blue", lw=2, label="path (D* Lite)")
    ax.plot(*start, "o", color="tab:green", ms=8, label="start")
    ax.plot(*goal, "*", color="tab:purple", ms=12, label="goal")
    ax.set_xlim(*limits[0])
    ax.set_ylim(*limits[1])
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    ax.set_title(f"{Path(problem.map_path).name}: "
                 f"{'inflated' if problem.inflation else 'no inflation'}")
    ax.legend(loc="best", fontsize=8)
    figure.savefig(target, dpi=110, bbox_inches="tight")
    plt.close(figure)
    return target
