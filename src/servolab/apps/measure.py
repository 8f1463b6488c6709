"""``servolab measure``: the distance on the floor between two image points (seed 000's
Figure C6), from a calibration written by ``servolab calibrate --floor``. A pixel off the
calibrated image is refused, naming it and the image's size: the lens was never fitted there."""

from __future__ import annotations

import argparse

from .arguments import finite_float
from .registry import Command


def _add_measure(p: argparse.ArgumentParser) -> None:
    p.add_argument("--calib", required=True, metavar="FILE",
                   help="a calibration written by servolab calibrate --floor")
    for name in ("U1", "V1", "U2", "V2"):
        p.add_argument(name.lower(), type=finite_float, metavar=name,
                       help="image point, pixels (on the calibrated image)" if name == "U1"
                       else None)


def _measure(args: argparse.Namespace) -> int:
    from ..errors import UsageError
    from ..vision import calibration as cal

    calib, floor = cal.load(args.calib)  # a bad file: CalibrationFileError, one line (exit 2)
    if floor is None:
        raise UsageError(f"--calib {args.calib} has no floor plane; calibrate with --floor "
                         "IMAGE")
    # a pixel off the calibrated image, or above the horizon: VisionValueError, one line
    # naming it (exit 2)
    distance = cal.measure(calib, floor, (args.u1, args.v1), (args.u2, args.v2))
    print(f"{distance:.2f} mm")
    return 0


COMMAND = Command(
    name="measure", group="tools", help="the floor distance between two image points (mm)",
    description="Turn two image points into floor points through a calibration written by "
    "servolab calibrate --floor, and print their distance in millimetres.",
    examples=("servolab measure --calib camera.yaml 120 340 480 352",),
    add_arguments=_add_measure, run=_measure)
