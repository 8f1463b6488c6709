"""``servolab plan --map MAP --start X Y --goal X Y``: a path on a map (D* Lite).

The command only parses; :mod:`servolab.robots.navigation.plan` reads the map, inflates it and plans
(its docstring gives the threshold, the cell size and the cost mapping). ``MAP`` is a
map_server ``map.yaml`` (known by its ``.yaml`` or ``.yml`` ending; the ends are then metres in
the map frame, the yaml giving resolution, origin and thresholds) or a map image (the ends are
cells: x = column, y = row, from the image's top-left pixel, whole numbers).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from .arguments import add_out, finite_float, positive_float
from .registry import Command

#: what ``--map`` ends with when it is a map_server map.yaml rather than an image
MAP_YAML_SUFFIXES = (".yaml", ".yml")


def _add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--map", required=True, metavar="MAP",
                   help="a map_server map.yaml (its image, resolution and origin: start and "
                   "goal in metres in the map frame), or a map image (PNG, JPEG, ...: one "
                   "pixel is one cell, dark pixels are occupied, start and goal in cells)")
    p.add_argument("--start", required=True, type=finite_float, nargs=2, metavar=("X", "Y"),
                   help="start: metres in the map frame with a map.yaml; with an image the "
                   "cell x = column, y = row (from the top-left pixel)")
    p.add_argument("--goal", required=True, type=finite_float, nargs=2, metavar=("X", "Y"),
                   help="goal: metres with a map.yaml, a cell with an image")
    p.add_argument("--params", metavar="FILE", help="costmap_2d parameter file for the "
                   "inflation (default: seed 000's D.2; 'servolab robots show costmap_params' "
                   "prints it)")
    p.add_argument("--resolution", type=positive_float, metavar="M", help="metres a cell (pixel) "
                   "of a map image measures (default: the file's resolution, else costmap_2d's "
                   "0.05; a map.yaml gives its own)")
    p.add_argument("--no-inflation", action="store_true", help="no costmap inflation: free "
                   "cells cost 1, so a path's cost is its length in cells")
    p.add_argument("--threshold", type=finite_float, metavar="GRAY",
                   help="pixels of a map image darker than this (0..255) are occupied (default "
                   "128; a map.yaml gives occupied_thresh and free_thresh)")
    add_out(p)


def _run(args: argparse.Namespace) -> int:
    from ..errors import UsageError
    from ..robots.navigation.plan import load_map_problem, load_problem, plan, run_plan
    from ..runs import RunFolder

    if args.no_inflation and (args.params is not None or args.resolution is not None):
        raise UsageError("--params and --resolution set the inflation; they are not used with "
                         "--no-inflation")
    # Bad input (PlanError, a bad map or parameter file) is refused, and no path (NoPath)
    # fails, before the run folder is made: a refused plan leaves none.
    if Path(args.map).suffix.lower() in MAP_YAML_SUFFIXES:
        for option, value, why in (("--resolution", args.resolution, "its resolution"),
                                   ("--threshold", args.threshold,
                                    "occupied_thresh and free_thresh")):
            if value is not None:
                raise UsageError(f"{option} is for a map image; {args.map} gives {why}")
        problem = load_map_problem(args.map, tuple(args.start), tuple(args.goal),
                                   params=args.params, inflation=not args.no_inflation)
    else:
        threshold = 128.0 if args.threshold is None else args.threshold
        if not 0 < threshold <= 255:
            raise UsageError(f"--threshold {threshold:g} must be a gray level in (0, 255]: "
                             "pixels darker than it are occupied")
        problem = load_problem(args.map, _cell("--start", args.start),
                               _cell("--goal", args.goal), params=args.params,
                               inflation=not args.no_inflation, resolution=args.resolution,
                               threshold=threshold)
    result = plan(problem)
    with RunFolder.create("plan", args.out) as run:
        run_plan(run, problem, result=result)  # writes summary.json, also when interrupted
    print(f"run folder: {run.path}")
    return 0


def _cell(option: str, values: list[float]) -> tuple[int, int]:
    """A map image's cell: whole numbers (metres need a map.yaml)."""
    from ..errors import UsageError

    if not all(v.is_integer() for v in values):
        raise UsageError(f"{option} {values[0]:g} {values[1]:g}: on a map image the ends are "
                         "cells (whole numbers); metres need a map_server map.yaml")
    return int(values[0]), int(values[1])


COMMAND = Command(
    name="plan", group="robots", help="plan a path on a map (map.yaml or image) with D* Lite",
    description="Plan the cheapest 8-connected path between two points of a map_server "
    "map.yaml (metres in the map frame; occupied and unknown cells are not entered) or two "
    "cells of a map image (dark pixels occupied, x = column, y = row) with D* Lite, on costs "
    "inflated as ROS "
    "costmap_2d's inflation layer does it (seed 000's costmap parameters by default) or, with "
    "--no-inflation, on the bare grid where a path's cost is its length in cells. The run "
    "folder gets summary.json (the path, its cost) and plan.png.",
    examples=("servolab plan --map map.yaml --start -1.0 2.5 --goal 3.2 4.0",
              "servolab plan --map floor.png --start 10 10 --goal 180 120",
              "servolab plan --map floor.png --start 10 10 --goal 180 120 --no-inflation",
              "servolab plan --map floor.png --start 10 10 --goal 180 120 "
              "--params my_costmap.yaml --resolution 0.02 --out runs/plan-a"),
    add_arguments=_add_arguments, run=_run)
