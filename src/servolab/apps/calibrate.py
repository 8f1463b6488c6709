"""``servolab calibrate`` (seed 000, Appendix C): checkerboard images in, a camera calibration
out.

It reads the images, calibrates the camera (and, with ``--floor``, the floor plane from one
image of a board lying on it) and writes the result in the YAML layout of ROS's camera_info
plus the floor extrinsics, for ``servolab measure`` and for navigation. The work is
:mod:`servolab.vision.calibration`'s; this module parses and reads the images.
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from .arguments import positive_float
from .registry import Command


def _board(text: str) -> tuple[int, int]:
    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not m:
        raise argparse.ArgumentTypeError(f"{text!r} is not COLSxROWS in squares, e.g. 10x7")
    return int(m.group(1)), int(m.group(2))


def _read(path: str) -> object:
    import cv2

    from ..errors import UsageError

    if not Path(path).is_file():
        raise UsageError(f"no image file {path!r}")
    image = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
    if image is None:
        raise UsageError(f"{path!r} cannot be read as an image")
    return image


def _add_calibrate(p: argparse.ArgumentParser) -> None:
    p.add_argument("images", nargs="+", metavar="IMAGE", help="checkerboard images")
    p.add_argument("--board", type=_board, required=True, metavar="COLSxROWS",
                   help="the board counted in squares, as MATLAB counts it, e.g. 10x7")
    p.add_argument("--square", type=positive_float, required=True, metavar="MM",
                   help="a square's side in millimetres")
    p.add_argument("--floor", metavar="IMAGE", help="one image of a board lying on the floor: "
                   "the floor plane, for measure and for navigation")
    p.add_argument("--floor-board", type=_board, metavar="COLSxROWS",
                   help="the floor board, if not the same as --board")
    p.add_argument("--floor-square", type=positive_float, metavar="MM",
                   help="the floor board's square, if not the same as --square")
    p.add_argument("--out", required=True, metavar="FILE", help="where to write the YAML")


def _calibrate(args: argparse.Namespace) -> int:
    from ..errors import UsageError
    from ..vision import calibration as cal

    out = Path(args.out)
    if out.is_dir() or not out.parent.is_dir():  # said before the work, not after it
        raise UsageError(f"cannot write --out {args.out!r}: "
                         + ("it is a folder" if out.is_dir() else
                            f"no folder {str(out.parent)!r}"))
    images = [_read(p) for p in args.images]
    # a board that is not found, too few usable images: CalibrationError, one line (exit 2)
    calib = cal.calibrate(images, args.board, args.square,  # type: ignore[arg-type]
                          names=[Path(p).name for p in args.images])
    floor = None
    if args.floor:
        floor = cal.floor_extrinsics(calib, _read(args.floor),  # type: ignore[arg-type]
                                     args.floor_board or args.board,
                                     args.floor_square or args.square,
                                     name=Path(args.floor).name)
    try:
        cal.save(calib, floor, args.out)
    except OSError as exc:  # no permission, a full disk: where the user asked to write
        raise UsageError(f"cannot write --out {args.out!r}: {exc.strerror or exc}") from None
    print(f"fx {calib.fx:.2f} fy {calib.fy:.2f} cx {calib.cx:.2f} cy {calib.cy:.2f} px; "
          f"RMS reprojection error {calib.rms:.3f} px over {len(calib.per_image_errors)} images")
    for name, error in zip(calib.image_names, calib.per_image_errors, strict=True):
        print(f"  {name}: {error:.3f} px")
    for warning in calib.warnings:
        print(f"warning: {warning}")
    print(f"wrote {args.out}" + (" (with the floor plane)" if floor is not None else ""))
    return 0


COMMAND = Command(
    name="calibrate", group="tools", help="calibrate a camera from checkerboard images",
    description="Calibrate a camera from images of a checkerboard (counted in squares, one "
    "side even and the other odd), optionally with the floor plane from one image of a board "
    "lying on it; writes a YAML file in ROS's camera_info layout.",
    examples=("servolab calibrate img/*.png --board 10x7 --square 25 --out camera.yaml",
              "servolab calibrate img/*.png --board 10x7 --square 25 --floor floor.png "
              "--out camera.yaml"),
    add_arguments=_add_calibrate, run=_calibrate)
