"""``servolab plan --map IMAGE --start X Y --goal X Y``: a path on a map image (D* Lite).

The command only parses; :mod:`servolab.robots.navigation.plan` reads the map, inflates it and plans
(its docstring gives the threshold, the cell size and the cost mapping). Coordinates are in
cells: x = column, y = row, from the image's top-left pixel.
"""

from __future__ import annotations

import argparse

from .arguments import add_out, finite_float, positive_float
from .registry import Command


def _add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--map", required=True, metavar="IMAGE",
                   help="map image (PNG, JPEG, ...): one pixel is one cell, dark pixels are "
                   "occupied")
    p.add_argument("--start", required=True, type=int, nargs=2, metavar=("X", "Y"),
                   help="start cell: x = column, y = row (from the top-left pixel)")
    p.add_argument("--goal", required=True, type=int, nargs=2, metavar=("X", "Y"),
                   help="goal cell: x = column, y = row")
    p.add_argument("--params", metavar="FILE", help="costmap_2d parameter file for the "
                   "inflation (default: seed 000's D.2; 'servolab robots show costmap_params' "
                   "prints it)")
    p.add_argument("--resolution", type=positive_float, metavar="M", help="metres a cell (pixel) "
                   "measures (default: the file's resolution, else costmap_2d's 0.05)")
    p.add_argument("--no-inflation", action="store_true", help="no costmap inflation: free "
                   "cells cost 1, so a path's cost is its length in cells")
    p.add_argument("--threshold", type=finite_float, default=128.0, metavar="GRAY",
                   help="pixels darker than this (0..255) are occupied (default 128)")
    add_out(p)


def _run(args: argparse.Namespace) -> int:
    from ..errors import UsageError
    from ..robots.navigation.plan import load_problem, plan, run_plan
    from ..runs import RunFolder

    if args.no_inflation and (args.params is not None or args.resolution is not None):
        raise UsageError("--params and --resolution set the inflation; they are not used with "
                         "--no-inflation")
    if not 0 < args.threshold <= 255:
        raise UsageError(f"--threshold {args.threshold:g} must be a gray level in (0, 255]: "
                         "pixels darker than it are occupied")
    # Bad input (PlanError, a bad parameter file) is refused, and no path (NoPath) fails,
    # before the run folder is made: a refused plan leaves none.
    problem = load_problem(args.map, tuple(args.start), tuple(args.goal),
                           params=args.params, inflation=not args.no_inflation,
                           resolution=args.resolution, threshold=args.threshold)
    result = plan(problem)
    with RunFolder.create("plan", args.out) as run:
        run_plan(run, problem, result=result)  # writes summary.json, also when interrupted
    print(f"run folder: {run.path}")
    return 0


COMMAND = Command(
    name="plan", group="robots", help="plan a path on a map image with D* Lite",
    description="Plan the cheapest 8-connected path between two cells of a map image (dark "
    "pixels occupied, x = column, y = row) with D* Lite, on costs inflated as ROS "
    "costmap_2d's inflation layer does it (seed 000's costmap parameters by default) or, with "
    "--no-inflation, on the bare grid where a path's cost is its length in cells. The run "
    "folder gets summary.json (the path, its cost) and plan.png.",
    examples=("servolab plan --map floor.png --start 10 10 --goal 180 120",
              "servolab plan --map floor.png --start 10 10 --goal 180 120 --no-inflation",
              "servolab plan --map floor.png --start 10 10 --goal 180 120 "
              "--params my_costmap.yaml --resolution 0.02 --out runs/plan-a"),
    add_arguments=_add_arguments, run=_run)
