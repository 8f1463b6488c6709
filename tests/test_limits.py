"""Nothing from outside stops or confuses servolab: every loader of a user's file refuses one
over its size limit before reading it, in one line naming the limit and how to raise it, and
no error line quotes more than 80 characters of a value (servolab.limits).

The big files are sparse (``truncate``): nothing is written, and a loader that read one
would take seconds and gigabytes, so the timing bound below only catches a loader that
reads before it checks."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from servolab.configfile import load
from servolab.errors import ConfigFileError, ServolabError, ServolabValueError
from servolab.gait.motionfile import MotionFileError, read_motion_file
from servolab.limits import InputLimits, clip, quoted, read_limited, too_big
from servolab.middleware.errors import LaunchError, ParameterError
from servolab.middleware.launch_file import load_launch
from servolab.middleware.parameters import ParameterOverrides
from servolab.robots.description import read_urdf
from servolab.robots.errors import RobotValueError
from servolab.robots.robot_folder import urdf_text
from servolab.vision.map_file import MapFileError, load_map

#: Small limits, so that a file "over the limit" is a few bytes.
TINY = InputLimits(motion_mb=0.001, motion_rows=5, yaml_mb=0.001, map_mb=0.001, urdf_mb=0.001)


def sparse(path: Path, size: int) -> Path:
    with open(path, "wb") as file:
        file.truncate(size)
    return path


def one_line(error: BaseException, *, longest: int = 200) -> str:
    """The error's text, one line of at most ``longest`` characters besides the paths of the
    test's temporary folder (which pytest makes long)."""
    text = str(error)
    folder = str(Path(getattr(error, "path", "") or "").parent)
    besides = text.replace(folder, "") if len(folder) > 1 else text
    assert "\n" not in text and len(besides) < longest, text
    return text


# -- the helpers --------------------------------------------------------------------------------

def test_clip_and_quoted_cut_long_values_with_an_ellipsis() -> None:
    assert clip("short") == "short"
    assert clip("x" * 100) == "x" * 79 + "…" and len(clip("x" * 100)) == 80
    assert quoted("x" * 100_000) == "'" + "x" * 77 + "…'"
    assert quoted([1] * 1000).endswith("…") and len(quoted([1] * 1000)) == 80
    assert quoted("m11") == "'m11'"


def test_the_limits_are_raised_through_the_environment() -> None:
    assert InputLimits.current({}) == InputLimits()
    raised = InputLimits.current({"SERVOLAB_MAX_MOTION_MB": "512", "SERVOLAB_MAX_YAML_MB": "inf"})
    assert raised.motion_mb == 512 and raised.yaml_mb == float("inf")
    for bad in ("0", "-1", "nan", "lots"):
        with pytest.raises(ServolabValueError, match=r"SERVOLAB_MAX_URDF_MB=.*must be a "
                                                     "number > 0"):
            InputLimits.current({"SERVOLAB_MAX_URDF_MB": bad})


def test_a_file_is_sized_before_it_is_read_and_a_device_read_no_further(tmp_path: Path) -> None:
    big = sparse(tmp_path / "big.bin", 2_000)
    message = too_big(big, "yaml_mb", "YAML file", TINY)
    assert message == ("0.0 MB: over the limit of 0.001 MB for a YAML file (not read; "
                       "SERVOLAB_MAX_YAML_MB raises it)")
    assert too_big(tmp_path / "missing", "yaml_mb", "YAML file", TINY) is None
    with pytest.raises(ValueError, match="over the limit"):
        read_limited(big, "yaml_mb", "YAML file", ValueError, TINY)
    # stat says 0 bytes for /dev/zero: it is read no further than the limit
    with pytest.raises(ValueError, match=r"more than 0.001 MB, the limit for a YAML file"):
        read_limited("/dev/zero", "yaml_mb", "YAML file", ValueError, TINY)


# -- motion files -------------------------------------------------------------------------------

def test_a_motion_file_of_a_million_rows_is_refused_in_one_line_before_loading(
        tmp_path: Path) -> None:
    """The finding: 10**6 rows (240 MB) loaded in 37 s at 3 GB. Refused by its size alone."""
    path = sparse(tmp_path / "walk.csv", 240_000_000)
    started = time.perf_counter()
    with pytest.raises(MotionFileError) as info:
        read_motion_file(path)
    assert time.perf_counter() - started < 1.0
    assert one_line(info.value) == (f"{path}: 240.0 MB: over the limit of 64 MB for a motion "
                                    "file (not read; SERVOLAB_MAX_MOTION_MB raises it)")


def test_a_motion_file_of_too_many_rows_is_refused_before_parsing(tmp_path: Path) -> None:
    path = tmp_path / "walk.csv"
    path.write_bytes(b"m11\n" + b"0\n" * 100_001)  # 200 kB: under the size limit
    with pytest.raises(MotionFileError) as info:
        read_motion_file(path)
    assert one_line(info.value).startswith(f"{path}: 100001 rows: over the limit of 100000 "
                                           "rows for a motion file (not parsed; "
                                           "SERVOLAB_MAX_MOTION_ROWS raises it)")
    assert "6.2 h at the seed's 4.5 rows a second" in str(info.value)
    path.write_bytes(b"m11\r" + b"0\r" * 6)  # old Mac line ends count too
    with pytest.raises(MotionFileError, match="6 rows: over the limit of 5 rows"):
        read_motion_file(path, input_limits=TINY)
    path.write_bytes(b"m11\n" + b"0\n" * 5)
    assert read_motion_file(path, input_limits=InputLimits(motion_rows=5)).poses == 5


@pytest.mark.parametrize(("row", "says"), [
    ("1,{big}", "column m12: '" + "x" * 77 + "…' is not a number"),
    ("1,2,{big}", "3 cells, but the header names 2 motors (extra cell '" + "x" * 38),
])
def test_a_100_kb_cell_is_cut_in_the_error_line(tmp_path: Path, row: str, says: str) -> None:
    path = tmp_path / "walk.csv"
    path.write_text("m11,m12\n" + row.format(big="x" * 100_000) + "\n")
    with pytest.raises(MotionFileError) as info:
        read_motion_file(path)
    assert says in one_line(info.value)


def test_a_100_kb_motor_name_is_cut_too(tmp_path: Path) -> None:
    path = tmp_path / "walk.csv"
    path.write_text("m11," + "m" * 100_000 + "\n1,2\n")
    with pytest.raises(MotionFileError) as info:
        read_motion_file(path, required=["m11"])
    assert "unknown motor" in one_line(info.value)


# -- YAML: launch files, parameter files ---------------------------------------------------------

def test_every_yaml_file_is_sized_before_it_is_read(tmp_path: Path) -> None:
    path = sparse(tmp_path / "config.yaml", 2_000_000)
    with pytest.raises(ConfigFileError) as info:
        load(path, what="robot base")
    assert one_line(info.value) == (f"{path}: 2.0 MB: over the limit of 1 MB for a robot base "
                                    "(not read; SERVOLAB_MAX_YAML_MB raises it)")
    with pytest.raises(LaunchError, match="over the limit of 1 MB for a launch file"):
        load_launch(sparse(tmp_path / "robot.launch.yaml", 2_000_000))
    with pytest.raises(ParameterError, match="over the limit of 1 MB for a parameter file"):
        ParameterOverrides.from_file(sparse(tmp_path / "params.yaml", 2_000_000))


def test_a_launch_file_naming_a_huge_parameter_file_is_refused(tmp_path: Path) -> None:
    sparse(tmp_path / "params.yaml", 5_000_000)
    path = tmp_path / "robot.launch.yaml"
    path.write_text("parameters: params.yaml\nnodes: [{name: a, node: m:C}]\n")
    with pytest.raises(LaunchError) as info:
        load_launch(path)
    assert one_line(info.value).startswith(f"{path}:1: key 'parameters': ")
    assert "5.0 MB: over the limit of 1 MB for a parameter file" in str(info.value)


SECRET = "root:$6$SECRETSALT$SECRETHASHSECRETHASH:19000:0:99999:7:::"


@pytest.mark.parametrize("content", [
    SECRET + "\ndaemon:*:19000:0:99999:7:::\n",             # /etc/shadow: YAML reads it as text
    "[" + SECRET + "\n",                                     # not valid YAML
    "SECRET: [1, 2\n",                                       # an unclosed list
    "'SECRET\n",                                             # an unclosed quote
    "SECRET: '\\q'\n",                                       # not valid YAML, the escape quoted
    "!SECRET!tag x\n",                                       # an undefined tag handle
    "SECRET\t: 1\n",                                         # a tab
    "SECRET: !!int SECRETVALUE\n",                           # a tag that does not fit
    "- " + SECRET + "\n",                                    # YAML, a list
    "MemTotal: SECRET kB\nMemFree: 1 kB\n",                  # /proc/meminfo: YAML, a mapping
])
def test_a_file_that_is_not_a_parameter_file_is_refused_without_its_content(
        tmp_path: Path, content: str) -> None:
    """A launch file may name any file as its parameters: ``/etc/shadow`` was echoed."""
    (tmp_path / "shadow").write_text(content)
    path = tmp_path / "robot.launch.yaml"
    path.write_text("nodes:\n  - {name: a, node: m:C, parameters: shadow}\n")
    with pytest.raises(LaunchError) as info:
        load_launch(path)
    message = one_line(info.value)
    assert "not a parameter file" in message and str(tmp_path / "shadow") in message
    shown = message.replace(str(tmp_path), "")
    assert "SECRET" not in shown and "root" not in shown and "Mem" not in shown


def test_a_yaml_error_says_line_and_column(tmp_path: Path) -> None:
    path = tmp_path / "params.yaml"
    path.write_text("talker:\n  ros__parameters:\n    rate: [1, 2\n")
    with pytest.raises(ParameterError) as info:
        ParameterOverrides.from_file(path)
    assert one_line(info.value).startswith(f"{path}:4: not valid YAML (")
    assert "at column 1: not a parameter file" in str(info.value)
    path.write_bytes(b"talker: \xff\n")
    with pytest.raises(ParameterError, match=r"params.yaml:1: not UTF-8 text: not a parameter "
                                             "file$"):
        ParameterOverrides.from_file(path)


@pytest.mark.parametrize("text", [
    "nodes:\n  - {name: a, node: m:C, parameters: {rate: [1, BIG]}}\n",  # not a parameter value
    "nodes:\n  - {name: a, node: m:C, parameters: {BIG: [1, a]}}\n",    # a parameter name
    "nodes:\n  - {name: a, node: m:C, BIG: 1}\n",                      # an unknown key
    "transport: BIG\nnodes: [{name: a, node: m:C}]\n",                 # a transport
    "nodes:\n  - {name: BIG, node: m:C}\n",                            # a node name
    "nodes:\n  - {name: a, node: BIG}\n",                              # a class path
    "nodes:\n  - {name: a, exec: '$(BIG)'}\n",                         # a substitution
    "nodes:\n  - {name: a, node: m:C, parameters: BIG}\n",             # a parameter file
    "BIG: 1\nnodes: [{name: a, node: m:C}]\n",                         # a top-level key
    "nodes: [{name: a, node: m:C}]\nnodes: 2\n",                       # a duplicate key
    "nodes: !!int BIG\n",                                              # a tag that does not fit
    "nodes: 1" + "0" * 5000 + "\n",                                    # a long number
])
def test_launch_errors_quote_at_most_80_characters_of_a_value(tmp_path: Path, text: str) -> None:
    path = tmp_path / "robot.launch.yaml"
    path.write_text(text.replace("BIG", "x" * 100_000))
    started = time.perf_counter()
    with pytest.raises(LaunchError) as info:
        load_launch(path)
    assert time.perf_counter() - started < 5.0
    message = one_line(info.value, longest=260).replace(str(tmp_path), "")
    assert "x" * 81 not in message and "0" * 81 not in message


# -- maps and URDFs ----------------------------------------------------------------------------

def test_a_map_image_over_the_limit_is_refused_before_it_is_decoded(tmp_path: Path) -> None:
    import cv2
    import numpy as np

    (tmp_path / "map.yaml").write_text("image: map.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n"
                                       "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    sparse(tmp_path / "map.pgm", 40_000_000)
    with pytest.raises(MapFileError) as info:
        load_map(tmp_path / "map.yaml")
    assert "40.0 MB: over the limit of 32 MB for a map image (not read; SERVOLAB_MAX_MAP_MB " \
           "raises it)" in one_line(info.value)
    # a small file of many pixels (a blank PNG compresses to almost nothing): by its header
    cv2.imwrite(str(tmp_path / "map.png"), np.full((100, 200), 254, np.uint8))
    (tmp_path / "map.yaml").write_text((tmp_path / "map.yaml").read_text().replace(".pgm",
                                                                                   ".png"))
    with pytest.raises(MapFileError, match=r"200 x 100 pixels: over the limit of 0.001 million "
                                           "pixels for a map image \\(not decoded"):
        load_map(tmp_path / "map.yaml", limits=InputLimits(map_mb=0.001))
    assert load_map(tmp_path / "map.yaml").shape == (100, 200)
    with pytest.raises(MapFileError, match="over the limit of 1e-05 MB for a map file"):
        load_map(tmp_path / "map.yaml", limits=InputLimits(yaml_mb=0.00001))  # the map.yaml


def test_a_urdf_over_the_limit_is_refused_before_it_is_read(tmp_path: Path) -> None:
    path = sparse(tmp_path / "arm.urdf", 20_000_000)
    with pytest.raises(RobotValueError) as info:
        urdf_text(path)
    assert one_line(info.value) == (f"{path}: 20.0 MB: over the limit of 16 MB for a URDF "
                                    "(not read; SERVOLAB_MAX_URDF_MB raises it)")
    with pytest.raises(RobotValueError, match="over the limit of 16 MB for a URDF"):
        urdf_text(sparse(tmp_path / "arm.urdf.xacro", 20_000_000))
    with pytest.raises(RobotValueError, match=r"<urdf>: 17.0 MB: over the limit of 16 MB for a "
                                              "URDF \\(not parsed"):
        read_urdf("<robot>" + " " * 17_000_000 + "</robot>")
    link = "l" * 100_000
    with pytest.raises(RobotValueError) as info:
        read_urdf(f'<robot name="r"><link name="{link}"/><link name="{link}"/></robot>')
    assert "is declared twice" in one_line(info.value)


def test_every_refusal_is_a_servolab_error() -> None:
    for cls in (MotionFileError, MapFileError, LaunchError, ParameterError, RobotValueError):
        assert issubclass(cls, ServolabError) and issubclass(cls, ValueError)
