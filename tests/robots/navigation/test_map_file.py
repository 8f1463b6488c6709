"""Maps as ROS map_server reads them and map_saver writes them (servolab.vision.map_file and
servolab.planning.occupancy_grid), against a hand-written map and map_server's own rules.

Sources, cited at each test: ros-planning/navigation (noetic-devel) map_server/src/
image_loader.cpp (pixels to cells), main.cpp (the yaml keys), map_saver.cpp (the files it
writes); costmap_2d/plugins/static_layer.cpp (cells to costs); the ROS wiki's map_server page
(the yaml format, "origin ... of the lower-left pixel", "many parts of the system ignore yaw").
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from servolab.errors import ConfigFileError
from servolab.planning.occupancy_grid import (
    lethal_and_unknown,
    occupancy_from_pixels,
    pixels_from_occupancy,
)
from servolab.vision.map_file import MapFileError, load_map, save_map

MAPS = Path(__file__).resolve().parents[2] / "data" / "maps"
FIXTURE = MAPS / "asymmetric.yaml"

#: asymmetric.pgm as map_server's grid: row 0 is the image's LAST row (image_loader.cpp:
#: "we invert the graphics-ordering of the pixels to produce a map with cell (0,0) in the
#: lower-left corner"), 100 occupied, 0 free, -1 unknown. Worked out by hand from the pixels.
EXPECTED = np.array([
    [100, 0, 0, 0, 0, 0, 0, 0],
    [100, 0, 0, 0, 0, 0, 0, -1],
    [100, 0, 100, 0, 0, 0, 100, -1],
    [100, 0, 100, 100, 0, -1, -1, -1],
    [100, 0, 0, 0, 0, -1, -1, -1],
    [100, 100, 100, 100, 100, 100, 100, 100],
], dtype=np.int8)


def test_the_hand_written_map_reads_as_map_server_reads_it() -> None:
    """image_loader.cpp: p = (255 - pixel) / 255, p > occupied_thresh -> 100, p < free_thresh
    -> 0, else -1 (trinary), rows flipped; main.cpp: the image relative to the yaml's folder.
    A reader without the flip, or with x and y swapped, gives another grid (or shape)."""
    m = load_map(FIXTURE)
    assert m.occupancy.dtype == np.int8 and m.occupancy.shape == (6, 8)
    assert np.array_equal(m.occupancy, EXPECTED)
    assert not np.array_equal(m.occupancy[::-1], EXPECTED)  # the fixture is not flip-symmetric
    assert (m.resolution, m.origin, m.negate, m.mode) == (0.1, (-1.5, 2.0, 0.0), False, "trinary")
    assert (m.occupied_thresh, m.free_thresh) == (0.65, 0.196)
    assert Path(m.image) == MAPS / "asymmetric.pgm" and m.path == str(FIXTURE)
    # ROS wiki: origin is the lower-left pixel's corner; Costmap2D::worldToMap for metres
    assert m.extent == pytest.approx((-1.5, -0.7, 2.0, 2.6))
    assert m.cell_of(-1.45, 2.05) == (0, 0) and m.cell_of(-0.75, 2.55) == (7, 5)
    assert m.cell_of(-1.51, 2.05) is None and m.cell_of(-1.45, 2.61) is None
    assert m.centre_of(2, 3) == pytest.approx((-1.25, 2.35))


def test_the_static_layer_makes_unknown_no_information_not_free() -> None:
    """static_layer.cpp interpretValue (trinary_costmap, lethal_cost_threshold 100,
    unknown_cost_value -1, unknown tracked): 100 lethal, -1 NO_INFORMATION, the rest free."""
    lethal, unknown = lethal_and_unknown(EXPECTED)
    assert np.array_equal(lethal, EXPECTED == 100)
    assert np.array_equal(unknown, EXPECTED == -1)
    # raw mode's bytes above 100 read unsigned are lethal too; 50 (scale mode) is free
    lethal, unknown = lethal_and_unknown(np.array([[50, -56, -1]], dtype=np.int8))
    assert lethal.tolist() == [[False, True, False]] and unknown.tolist() == [[False, False, True]]


def test_colour_negate_and_the_other_modes_follow_image_loader() -> None:
    """image_loader.cpp: the channels are averaged (alpha too in trinary mode, not in scale
    or raw); negate takes 255 - average; scale gives 1 + 98 (p - free) / (occ - free); raw
    keeps the average as the cell's byte."""
    # BGR (OpenCV's order; the average does not care): (0, 0, 255) averages 85 -> p 0.667
    colour = np.array([[[0, 0, 255], [255, 255, 0], [255, 255, 255]]], dtype=np.uint8)
    assert occupancy_from_pixels(colour).tolist() == [[100, -1, 0]]
    grey = np.array([[0, 128, 255]], dtype=np.uint8)
    assert occupancy_from_pixels(grey, negate=True).tolist() == [[0, -1, 100]]
    # scale: 128 -> p = 127/255 = 0.498, 1 + 98 * (0.498 - 0.196) / (0.65 - 0.196) = 66.2 -> 66
    assert occupancy_from_pixels(grey, mode="scale").tolist() == [[100, 66, 0]]
    assert occupancy_from_pixels(grey, mode="raw").tolist() == [[0, -128, -1]]
    # alpha: averaged in trinary ((0+0+0+255)/4 = 63.75 -> p 0.75), left out in scale, where
    # a transparent pixel between the thresholds is unknown
    bgra = np.array([[[0, 0, 0, 255], [128, 128, 128, 0]]], dtype=np.uint8)
    assert occupancy_from_pixels(bgra).tolist() == [[100, -1]]
    assert occupancy_from_pixels(bgra, mode="scale").tolist() == [[100, -1]]


def test_save_writes_exactly_what_map_saver_writes(tmp_path: Path) -> None:
    """map_saver.cpp: "P5\\n# CREATOR: map_saver.cpp %.3f m/pix\\n%d %d\\n255\\n", a cell
    0..25 as 254, 65 and above as 0, else 205, image row y = map row height - y - 1; the yaml
    "image: %s\\nresolution: %f\\norigin: [%f, %f, %f]\\nnegate: 0\\noccupied_thresh: 0.65\\n
    free_thresh: 0.196\\n\\n"."""
    yaml_path, pgm = save_map(tmp_path / "office", EXPECTED, 0.1, (-1.5, 2.0, 0.0))
    assert (yaml_path, pgm) == (tmp_path / "office.yaml", tmp_path / "office.pgm")
    assert yaml_path.read_text() == ("image: office.pgm\nresolution: 0.100000\n"
                                     "origin: [-1.500000, 2.000000, 0.000000]\nnegate: 0\n"
                                     "occupied_thresh: 0.65\nfree_thresh: 0.196\n\n")
    header = b"P5\n# CREATOR: map_saver.cpp 0.100 m/pix\n8 6\n255\n"
    data = pgm.read_bytes()
    assert data.startswith(header) and len(data) == len(header) + 48
    image = np.frombuffer(data[len(header):], np.uint8).reshape(6, 8)
    assert image[0].tolist() == [0] * 8  # the map's top row (row 5) comes first
    assert image[5].tolist() == [0] + [254] * 7  # and its row 0 last
    assert image[3].tolist() == [0, 254, 0, 254, 254, 254, 0, 205]
    # map_saver's thresholds (--free 25, --occ 65) on values other than -1, 0, 100
    values = np.array([[0, 25, 26, 64, 65, -1]], dtype=np.int8)
    assert pixels_from_occupancy(values).tolist() == [[254, 254, 205, 205, 0, 205]]


def test_save_then_load_round_trips_and_opencv_reads_the_pgm(tmp_path: Path) -> None:
    """What map_saver writes, map_server (and load_map) reads back as the same grid, origin
    and resolution; also the overhead camera's bool map (occupied where true)."""
    rng = np.random.default_rng(3)
    grid = rng.choice(np.array([-1, 0, 100], dtype=np.int8), size=(13, 21))
    save_map(tmp_path / "map", grid, 0.05, (-3.25, 1.75))
    back = load_map(tmp_path / "map.yaml")
    assert np.array_equal(back.occupancy, grid)
    assert (back.resolution, back.origin) == (0.05, (-3.25, 1.75, 0.0))
    assert cv2.imread(str(tmp_path / "map.pgm"), cv2.IMREAD_UNCHANGED).shape == (13, 21)
    camera = rng.random((7, 9)) < 0.3
    save_map(tmp_path / "camera", camera, 0.05, (0.0, 0.0))
    assert np.array_equal(load_map(tmp_path / "camera.yaml").occupancy,
                          np.where(camera, 100, 0).astype(np.int8))


def test_a_colour_png_is_averaged_and_a_16_bit_one_refused(tmp_path: Path) -> None:
    """image_loader.cpp averages a colour pixel's channels; it reads 8-bit images (SDL)."""
    colour = np.zeros((2, 3, 3), np.uint8)
    colour[0] = [0, 0, 255]  # averages 85: occupied; the bottom row (map row 0) black
    colour[1] = [255, 255, 255]
    cv2.imwrite(str(tmp_path / "colour.png"), colour)
    text = FIXTURE.read_text().replace("asymmetric.pgm", "colour.png")
    (tmp_path / "colour.yaml").write_text(text)
    assert load_map(tmp_path / "colour.yaml").occupancy.tolist() == [[0] * 3, [100] * 3]
    cv2.imwrite(str(tmp_path / "colour.png"), np.zeros((2, 3), np.uint16))
    with pytest.raises(MapFileError, match=r"colour\.yaml:\d+: key 'image': .* uint16 pixels"):
        load_map(tmp_path / "colour.yaml")


def _refused(tmp_path: Path, text: str) -> str:
    path = tmp_path / "map.yaml"
    path.write_text(text)
    (tmp_path / "asymmetric.pgm").write_bytes((MAPS / "asymmetric.pgm").read_bytes())
    with pytest.raises(MapFileError) as info:
        load_map(path)
    message = str(info.value)
    assert "\n" not in message and isinstance(info.value, ConfigFileError)
    assert message.startswith(f"{path}:")  # the yaml by its path (and an image by its own)
    return message.replace(str(tmp_path) + "/", "")


@pytest.mark.parametrize(("old", "new", "message"), [
    ("resolution: 0.1", "resolution: -0.1",
     "map.yaml:{}: key 'resolution': must be > 0, not -0.1"),
    ("resolution: 0.1", "resoluton: 0.1",
     "map.yaml:{}: unknown key 'resoluton' (did you mean 'resolution'?)"),
    ("negate: 0", "negate: 2", "map.yaml:{}: key 'negate': must be 0 or 1, not 2"),
    ("origin: [-1.5, 2.0, 0.0]", "origin: [-1.5, 2.0]",
     "map.yaml:{}: key 'origin': must be [x, y, yaw] (3 numbers), not 2"),
    ("origin: [-1.5, 2.0, 0.0]", "origin: [-1.5, 2.0, 0.5]",
     "map.yaml:{}: key 'origin': yaw 0.5 rad is not supported"),
    ("free_thresh: 0.196", "free_thresh: 0.7",
     "map.yaml:{}: key 'free_thresh': 0.7 must be below occupied_thresh 0.65"),
    ("free_thresh: 0.196", "free_thresh: 0.196\nmode: binary",
     "map.yaml:{}: key 'mode': must be one of trinary, scale, raw"),
    ("image: asymmetric.pgm", "image: missing.pgm",
     "map.yaml:{}: key 'image': the map's image 'missing.pgm' does not exist"),
])
def test_bad_map_files_are_one_line_at_their_key(tmp_path: Path, old: str, new: str,
                                                  message: str) -> None:
    """main.cpp refuses a map without each key (and an unknown mode); here each is one line
    naming the file, the line and the key, and a missing image names both files."""
    text = FIXTURE.read_text()
    assert old in text
    bad = text.replace(old, new)
    line = next(n for n, written in enumerate(bad.splitlines(), 1)
                if written == new.splitlines()[-1])
    assert _refused(tmp_path, bad).startswith(message.format(line))
