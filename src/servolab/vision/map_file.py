"""Maps as ROS map_server reads them and map_saver writes them: a ``map.yaml`` beside an image.

Why: a map a user already has (made by gmapping, drawn by hand, saved by ``rosrun map_server
map_saver``) should plan and drive here as it does in ROS, and a map the overhead camera built
should open in ROS. The pixel rules are :mod:`servolab.planning.occupancy_grid`'s; this module
reads and writes the files (here, in the vision layer, because the image is read with OpenCV
and the simulated scene, below the robots, reads maps too).

**map.yaml** (map_server/src/main.cpp ``loadMapFromYaml``; ROS wiki map_server):
``image`` (the image's path, relative to the yaml's folder unless absolute), ``resolution``
(m/cell), ``origin`` ``[x, y, yaw]`` (the pose of the image's lower-left pixel), ``negate``
(0 or 1), ``occupied_thresh``, ``free_thresh``, and optionally ``mode`` (``trinary``, the
default, ``scale`` or ``raw``). It is read through :mod:`servolab.configfile`, so a bad key or
value is one line, ``map.yaml:LINE: key 'resolution': ...``, a :class:`MapFileError`; a key
map_server does not know is refused (a typo would otherwise be a silent default). A non-zero
yaw is refused: the wiki says "many parts of the system currently ignore yaw", and costmap_2d's
static layer is one of them, so a rotated map would be planned on unrotated.

**The image** is read with ``cv2.imread(path, IMREAD_UNCHANGED)``: 8-bit grey, or colour whose
channels are averaged as map_server does. A missing or unreadable image is one line naming the
yaml (at its ``image:`` line) and the image.

**Limits** (:mod:`servolab.limits`): the map.yaml is a YAML file (``SERVOLAB_MAX_YAML_MB``,
1 MB); the image may have at most ``SERVOLAB_MAX_MAP_MB`` (32) MB and as many million pixels
(a 5657-pixel square: 283 m at 5 cm a cell), both checked before it is decoded: its size with
``os.stat``, its width and height from its header (a small PNG can hold a huge blank image).

**Writing** (map_server/src/map_saver.cpp): ``<name>.pgm``, binary P5 with map_saver's comment
``# CREATOR: map_saver.cpp 0.050 m/pix``, 0 occupied, 254 free, 205 unknown, and ``<name>.yaml``
with map_saver's exact text (``resolution: %f``, ``origin: [%f, %f, %f]``, ``negate: 0``,
``occupied_thresh: 0.65``, ``free_thresh: 0.196`` and a blank line). One departure: map_saver
writes ``image:`` as the path it was given (``-f maps/office`` writes ``image:
maps/office.pgm``, which map_server then looks for in ``maps/maps/``); here it is the image's
file name, beside the yaml, which is what map_server reads back.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from ..configfile import ConfigMapping, ConfigValue, positive_float
from ..configfile import load as load_config
from ..errors import ConfigFileError
from ..limits import InputLimits, too_big
from ..planning.errors import PlanningValueError
from ..planning.occupancy_grid import (
    MODES,
    SAVER_FREE_THRESH,
    SAVER_OCCUPIED_THRESH,
    cell_to_world,
    lethal_and_unknown,
    occupancy_from_pixels,
    pixels_from_occupancy,
    world_to_cell,
)
from .errors import VisionError

#: the keys of map.yaml map_server reads (all but ``mode`` required)
KEYS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode")
REQUIRED = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh")


class MapFileError(ConfigFileError, VisionError):
    """A map.yaml (or its image) that cannot be used: ``path:line: message``."""


@dataclass(frozen=True, eq=False)
class OccupancyMap:
    """A map as map_server publishes it: ``occupancy`` int8 ``[row, col]`` with row 0 at the
    origin's y (100 occupied, 0 free, -1 unknown; 1..99 in scale mode), ``resolution`` m per
    cell, ``origin`` ``(x, y, yaw)`` of cell (0, 0)'s outer corner, and the files it came
    from."""

    occupancy: npt.NDArray[np.int8]
    resolution: float
    origin: tuple[float, float, float]
    path: str = ""
    image: str = ""
    negate: bool = False
    occupied_thresh: float = SAVER_OCCUPIED_THRESH
    free_thresh: float = SAVER_FREE_THRESH
    mode: str = "trinary"

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)``."""
        rows, cols = self.occupancy.shape
        return rows, cols

    @property
    def xy(self) -> tuple[float, float]:
        """The origin's ``(x, y)``, m."""
        return self.origin[0], self.origin[1]

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """``(x0, x1, y0, y1)`` m: the floor the grid covers."""
        rows, cols = self.shape
        x0, y0 = self.xy
        return x0, x0 + cols * self.resolution, y0, y0 + rows * self.resolution

    def lethal_and_unknown(self) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.bool_]]:
        """costmap_2d's static layer's lethal and unknown cells
        (:func:`~servolab.planning.occupancy_grid.lethal_and_unknown`)."""
        return lethal_and_unknown(self.occupancy)

    def cell_of(self, x: float, y: float) -> tuple[int, int] | None:
        """The cell ``(col, row)`` holding ``(x, y)`` m, or None off the map."""
        return world_to_cell(x, y, self.xy, self.resolution, self.shape)

    def centre_of(self, col: float, row: float) -> tuple[float, float]:
        """The centre ``(x, y)`` m of cell ``(col, row)``."""
        return cell_to_world(col, row, self.xy, self.resolution)


def load_map(path: str | Path, *, limits: InputLimits | None = None) -> OccupancyMap:
    """Read a map.yaml and its image as map_server does (see the module); files over the
    limits (``limits``, default :meth:`InputLimits.current()
    <servolab.limits.InputLimits.current>`) are refused before they are read."""
    limits = InputLimits.current() if limits is None else limits
    top = load_config(path, what="map file (map.yaml)", error=MapFileError, limits=limits)
    if top.plain() is None:
        raise top.error("empty file: expected a map_server map.yaml")
    m = top.as_mapping("a map_server map.yaml")
    m.check_keys(KEYS, required=REQUIRED)
    resolution = positive_float(m.require("resolution"))
    origin_value = m.require("origin")
    items = origin_value.as_list()
    if len(items) != 3:
        raise origin_value.error(f"key 'origin': must be [x, y, yaw] (3 numbers), not "
                                 f"{len(items)}")
    x, y, yaw = (item.as_float() for item in items)
    if yaw != 0.0:
        raise origin_value.error(f"key 'origin': yaw {yaw:g} rad is not supported: map_server "
                                 "passes it on but costmap_2d's static layer ignores it (ROS "
                                 "wiki map_server), so the map would be used unrotated; "
                                 "rotate the image instead")
    negate = _negate(m.require("negate"))
    occupied_value, free_value = m.require("occupied_thresh"), m.require("free_thresh")
    occupied_thresh, free_thresh = _fraction(occupied_value), _fraction(free_value)
    if not free_thresh < occupied_thresh:
        raise free_value.error(f"key 'free_thresh': {free_thresh:g} must be below "
                               f"occupied_thresh {occupied_thresh:g}")
    mode = "trinary"
    if (mode_value := m.get("mode")) is not None:
        mode = mode_value.as_str()
        if mode not in MODES:
            raise mode_value.error(f"key 'mode': must be one of {', '.join(MODES)} (map_server"
                                   f"'s modes), not {mode!r}")
    image_path = _image_path(m, Path(path))
    pixels = _read_image(image_path, m.require("image"), limits)
    try:
        occupancy = occupancy_from_pixels(pixels, negate=negate, occupied_thresh=occupied_thresh,
                                          free_thresh=free_thresh, mode=mode)
    except PlanningValueError as error:
        raise m.require("image").error(f"key 'image': {image_path}: {error}") from None
    return OccupancyMap(occupancy, resolution, (x, y, 0.0), str(path), str(image_path), negate,
                        occupied_thresh, free_thresh, mode)


def _negate(value: ConfigValue) -> bool:
    """map_server reads ``negate`` as an int used as a bool; 0 and 1 (or false and true)."""
    plain = value.plain()
    if isinstance(plain, bool):
        return plain
    if isinstance(plain, int) and plain in (0, 1):
        return bool(plain)
    raise value.error(f"key 'negate': must be 0 or 1, not {value.describe()}")


def _fraction(value: ConfigValue) -> float:
    number = value.as_float()
    if not 0.0 <= number <= 1.0:
        raise value.error(f"key {value.key!r}: must be a probability in [0, 1], not {number:g}")
    return number


def _image_path(m: ConfigMapping, yaml_path: Path) -> Path:
    """``image:`` as map_server resolves it: absolute, or relative to the yaml's folder."""
    value = m.require("image")
    name = value.as_str(nonempty=True)
    given = Path(name)
    return given if given.is_absolute() else yaml_path.parent / given


def _read_image(image_path: Path, value: ConfigValue,
                limits: InputLimits) -> npt.NDArray[np.uint8]:
    """The image, as OpenCV reads it unchanged; errors at the yaml's ``image:`` line."""
    import cv2

    if not image_path.is_file():
        why = "is a folder" if image_path.is_dir() else "does not exist"
        raise value.error(f"key 'image': the map's image {str(image_path)!r} {why}")
    message = too_big(image_path, "map_mb", "map image", limits)
    if message is None and (size := _image_size(image_path)) is not None:
        width, height = size
        if width * height > limits.map_mb * 1e6:
            shown = f"{width} x {height} pixels" if width else "too many pixels for Pillow"
            message = (f"{shown}: over the limit of {limits.map_mb:g} million pixels for a "
                       f"map image (not decoded; {limits.variable('map_mb')} raises it)")
    if message is not None:
        raise value.error(f"key 'image': the map's image {str(image_path)!r}: {message}")
    image = cv2.imread(str(image_path), cv2.IMREAD_UNCHANGED)
    if image is None or image.size == 0:
        raise value.error(f"key 'image': the map's image {str(image_path)!r} cannot be read "
                          "as an image by OpenCV")
    if image.dtype != np.uint8:
        raise value.error(f"key 'image': the map's image {str(image_path)!r} has "
                          f"{image.dtype} pixels; map_server reads 8-bit images")
    return np.asarray(image, dtype=np.uint8)


def _image_size(path: Path) -> tuple[int, int] | None:
    """``(width, height)`` from the image's header, without decoding it (Pillow, which
    matplotlib brings, reads only the header here), or None if it cannot tell."""
    import warnings

    from PIL import Image

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            with Image.open(path) as image:
                width, height = image.size
    except Image.DecompressionBombError:  # over twice Pillow's own limit, 179 M pixels
        return 0, 2 * (Image.MAX_IMAGE_PIXELS or 0) + 1
    except Exception:  # not an image Pillow knows: OpenCV says what it makes of it
        return None
    return int(width), int(height)


def save_map(path_prefix: str | Path, occupancy: npt.ArrayLike, resolution: float,
             origin: Sequence[float]) -> tuple[Path, Path]:
    """Write ``<path_prefix>.pgm`` and ``<path_prefix>.yaml`` as map_saver does (see the
    module) and return their paths ``(yaml, pgm)``.

    ``occupancy`` is ``[row, col]`` with row 0 at the origin's y: int8 as nav_msgs has it
    (100 occupied, 0 free, -1 unknown), or bool (occupied where true, as the overhead
    camera's map). ``origin`` is ``(x, y)`` or ``(x, y, yaw)`` with yaw 0, m."""
    if not (isinstance(resolution, int | float) and math.isfinite(resolution)
            and resolution > 0):
        raise MapFileError(str(path_prefix), 0, "", f"resolution must be > 0 m, not "
                           f"{resolution!r}")
    values = [float(v) for v in origin]
    if len(values) == 2:
        values.append(0.0)
    if len(values) != 3 or not all(math.isfinite(v) for v in values) or values[2] != 0.0:
        raise MapFileError(str(path_prefix), 0, "", f"origin must be (x, y) or (x, y, 0) m, "
                           f"not {tuple(origin)!r} (a rotated map is not supported)")
    try:
        image = pixels_from_occupancy(occupancy)
    except PlanningValueError as error:
        raise MapFileError(str(path_prefix), 0, "", str(error)) from None
    prefix = Path(path_prefix)
    pgm = prefix.with_name(prefix.name + ".pgm")
    yaml_path = prefix.with_name(prefix.name + ".yaml")
    height, width = image.shape
    header = f"P5\n# CREATOR: map_saver.cpp {resolution:.3f} m/pix\n{width} {height}\n255\n"
    pgm.write_bytes(header.encode("ascii") + image.tobytes())
    x, y, yaw = values
    yaml_path.write_text(f"image: {pgm.name}\nresolution: {resolution:f}\n"
                         f"origin: [{x:f}, {y:f}, {yaw:f}]\nnegate: 0\n"
                         f"occupied_thresh: 0.65\nfree_thresh: 0.196\n\n", encoding="utf-8")
    return yaml_path, pgm
