"""Motion files (servolab.gait.motionfile): the seed's CSV of poses, read strictly.

Source: seed 001, Table 4.3 and Appendix B (string_to_double turns bad cells into 0). The
seed's reader ignores the header, takes the 21 cells in a fixed order and turns any cell it
cannot read into 0 degrees. These tests pin the opposite: columns are matched by name, and
every malformed file is refused with one line naming the file, the line and the column.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from servolab.errors import ConfigFileError, ServolabError
from servolab.gait.motionfile import (
    _NUMBER,
    MotionFile,
    MotionFileError,
    read_motion_file,
    write_motion_file,
)

#: The seed's 21 motors, in the order of Table 4.3.
MOTORS = ("m11", "m12", "m13", "m14", "m15", "m16",
          "m21", "m22", "m23", "m24", "m25", "m26",
          "m31", "m32", "m41", "m42", "m51", "m52", "m53", "m61", "m62")

#: The first rows of Table 4.3 (the columns the table elides written as 0).
TABLE_4_3 = [
    [0, -27.666, 0.61939, -42.992, 15.326, -0.61939, 0, -14.746] + [0] * 13,
    [0, -26.595, 6.7817, -40.935, 14.34, -6.7817, 0, -12.398] + [0] * 13,
    [0, -27.476, -2.9396, -42.628, 15.152, 2.9396, 0, -15.152] + [0] * 13,
]


def write(tmp_path: Path, text: str, name: str = "walk.csv") -> Path:
    path = tmp_path / name
    path.write_bytes(text.encode())
    return path


def csv_text(names: tuple[str, ...] | list[str], rows: list[list[str]]) -> str:
    return "\n".join([",".join(names), *(",".join(row) for row in rows)]) + "\n"


def table_rows() -> list[list[str]]:
    return [[f"{value:g}" for value in row] for row in TABLE_4_3]


# -- reading ---------------------------------------------------------------------------------


def test_reads_table_4_3(tmp_path: Path) -> None:
    path = write(tmp_path, csv_text(MOTORS, table_rows()))
    motion = read_motion_file(path, required=MOTORS)
    assert motion.names == MOTORS
    assert motion.angles.shape == (3, 21)
    assert motion.angles.dtype == np.float64
    np.testing.assert_array_equal(motion.angles, np.array(TABLE_4_3, dtype=float))
    assert motion.column("m14").tolist() == [-42.992, -40.935, -42.628]
    assert motion.poses == 3


def test_columns_in_another_order_map_by_name(tmp_path: Path) -> None:
    shuffled = list(reversed(MOTORS))
    rows = [[f"{row[MOTORS.index(name)]:g}" for name in shuffled] for row in TABLE_4_3]
    motion = read_motion_file(write(tmp_path, csv_text(shuffled, rows)), required=MOTORS)
    assert motion.names == MOTORS
    np.testing.assert_array_equal(motion.angles, np.array(TABLE_4_3, dtype=float))


def test_without_required_the_file_order_is_kept(tmp_path: Path) -> None:
    motion = read_motion_file(write(tmp_path, "b,a\n1,2\n"))
    assert motion.names == ("b", "a")
    assert motion.angles.tolist() == [[1.0, 2.0]]


def test_required_first_then_other_known_columns_in_file_order(tmp_path: Path) -> None:
    path = write(tmp_path, "c,b,a\n3,2,1\n")
    limits = {"a": (-10.0, 10.0), "b": (-10.0, 10.0), "c": (-10.0, 10.0)}
    motion = read_motion_file(path, limits=limits, required=["a"])
    assert motion.names == ("a", "c", "b")
    assert motion.angles.tolist() == [[1.0, 3.0, 2.0]]


def test_tolerated_spelling(tmp_path: Path) -> None:
    """Spaces and tabs around cells, a BOM, CRLF, quotes, exponents, trailing blank lines;
    limits are inclusive."""
    text = '\ufeff m11 ,  "m12"\r\n -1.5e1 ,\t+.5 \r\n"3",90\r\n\r\n  \r\n'
    motion = read_motion_file(write(tmp_path, text), limits={"m11": (-15, 3),
                                                             "m12": (-90, 90)})
    assert motion.names == ("m11", "m12")
    assert motion.angles.tolist() == [[-15.0, 0.5], [3.0, 90.0]]


# -- refusing --------------------------------------------------------------------------------

HEADER = "m11,m12,m13,m14\n"
LIMITS = {name: (-150.0, 150.0) for name in ("m11", "m12", "m13", "m14")}


@pytest.mark.parametrize(("text", "line", "column", "message"), [
    # the seed's string_to_double would have made each of these cells 0 degrees
    (HEADER + "0,1,2,3\n0,1,2,abc\n", 3, "m14", "column m14: 'abc' is not a number"),
    (HEADER + "0,1,2,3\n0,,2,3\n", 3, "m12", "column m12: empty cell, not a number"),
    (HEADER + "0,1,2,1_000\n", 2, "m14", "column m14: '1_000' is not a number"),
    (HEADER + "0,1,2,0x1f\n", 2, "m14", "column m14: '0x1f' is not a number"),
    (HEADER + "0,1,2,3.5.1\n", 2, "m14", "column m14: '3.5.1' is not a number"),
    (HEADER + "0,1,2,3deg\n", 2, "m14", "column m14: '3deg' is not a number"),
    (HEADER + "0,1,2,3\n0,1,2,٣\n", 3, "m14", "column m14: '٣' is not a number"),
    (HEADER + "0,1,nan,3\n", 2, "m13", "column m13: 'nan' is not a number"),
    (HEADER + "0,1,2,inf\n", 2, "m14", "column m14: 'inf' is not a number"),
    (HEADER + "0,-Infinity,2,3\n", 2, "m12", "column m12: '-Infinity' is not a number"),
    (HEADER + "0,1,2,1e999\n", 2, "m14", "column m14: '1e999' is not a finite number"),
    # limits, inclusive, in degrees
    (HEADER + "0,1,2,3\n0,1,150.5,3\n", 3, "m13",
     "column m13: 150.5 degrees is outside the joint's limits [-150, 150]"),
    (HEADER + "-151,1,2,3\n", 2, "m11",
     "column m11: -151 degrees is outside the joint's limits [-150, 150]"),
    # the shape of a row
    (HEADER + "0,1,2,3\n0,1,2\n", 3, "m14",
     "column m14: missing (the line has 3 cells, the header 4)"),
    (HEADER + "0\n", 2, "m12", "column m12: missing (the line has 1 cell, the header 4)"),
    (HEADER + "0,1,2,3,4\n", 2, "", "5 cells, but the header names 4 motors (extra cell '4')"),
    (HEADER + "0,1,2,3,\n", 2, "", "5 cells, but the header names 4 motors (extra cell '')"),
    (HEADER + "0,1,2,3\n\n0,1,2,3\n", 3, "", "blank line between poses (was a pose lost?)"),
    (HEADER + ",,,\n", 2, "m11", "column m11: empty cell, not a number"),
    # the header
    ("m11,m12,m13,m12\n0,1,2,3\n", 1, "m12",
     "column m12: appears twice in the header (columns 2 and 4)"),
    ("m11,m12,m13,m15\n0,1,2,3\n", 1, "m15", "column m15: unknown motor (did you mean"),
    ("m11,m12,m13,elbow\n0,1,2,3\n", 1, "elbow", "column elbow: unknown motor"),
    ("m11,m12,m13\n0,1,2\n", 1, "m14", "column m14: missing from the header"),
    ("m11,m12,m14\n0,1,2\n", 1, "m13", "column m13: missing from the header"),
    ("m11,,m13,m14\n0,1,2,3\n", 1, "", "column 2 of the header has no motor name"),
    ("m11\tm12\tm13\tm14\n0\t1\t2\t3\n", 1, "", "the header has no commas; motion files are "
     "comma-separated (not tab- or semicolon-separated)"),
    ("m11;m12;m13;m14\n0;1,5;2;3\n", 1, "", "the header has no commas"),
    # the file as a whole
    ("", 1, "", "empty; a motion file starts with a header of motor names"),
    ("\n  \n", 1, "", "empty; a motion file starts with a header of motor names"),
    (HEADER, 2, "", "no poses after the header"),
    (HEADER + '0,1,"2"x,3\n', 2, "", "not valid CSV"),
    (HEADER + '0,1,"2,3\n0,1,2,3\n', 2, "", "not valid CSV"),
])
def test_malformed_files_are_refused(tmp_path: Path, text: str, line: int, column: str,
                                     message: str) -> None:
    path = write(tmp_path, text)
    required = ["m11", "m12", "m13", "m14"]
    if "m15" in text or "elbow" in text:  # "unknown" needs a known set without m15
        required = ["m11", "m12", "m13"]
    limits = {name: LIMITS[name] for name in required}
    with pytest.raises(MotionFileError) as caught:
        read_motion_file(path, limits=limits, required=required)
    error = caught.value
    assert str(error).startswith(f"{path}:{line}: {message}")
    assert "\n" not in str(error)
    assert (error.path, error.line, error.key) == (str(path), line, column)
    assert isinstance(error, ConfigFileError | ServolabError | ValueError)


def test_unknown_column_is_refused_with_limits_alone(tmp_path: Path) -> None:
    path = write(tmp_path, "m11,m99\n0,0\n")
    with pytest.raises(MotionFileError, match=r"walk\.csv:1: column m99: unknown motor$"):
        read_motion_file(path, limits={"m11": (-1.0, 1.0)})


def test_first_problem_wins_and_nothing_is_returned(tmp_path: Path) -> None:
    path = write(tmp_path, "m11,m12\n0,1\nx,1\n0,y\n")
    with pytest.raises(MotionFileError, match=r":3: column m11: 'x' is not a number"):
        read_motion_file(path)


def test_unreadable_and_not_utf8(tmp_path: Path) -> None:
    with pytest.raises(MotionFileError, match=r"missing\.csv: cannot read motion file"):
        read_motion_file(tmp_path / "missing.csv")
    path = tmp_path / "walk.csv"
    path.write_bytes(b"m11\n0\n\xff\n")
    with pytest.raises(MotionFileError, match=r"walk\.csv:3: not UTF-8 text \(byte 0xff"):
        read_motion_file(path)


def test_programming_mistakes_are_value_errors(tmp_path: Path) -> None:
    path = write(tmp_path, "m11\n0\n")
    with pytest.raises(ValueError, match="lowest <= highest"):
        read_motion_file(path, limits={"m11": (1.0, -1.0)})
    with pytest.raises(ValueError, match="twice"):
        read_motion_file(path, required=["m11", "m11"])
    with pytest.raises(ValueError, match="not one string"):
        read_motion_file(path, required="m11")


# -- writing and the round trip --------------------------------------------------------------


def test_written_file_is_the_seed_format(tmp_path: Path) -> None:
    path = tmp_path / "walk.csv"
    write_motion_file(path, MotionFile(("m11", "m12"), np.array([[0.0, -27.666], [1e-05, 2]])))
    assert path.read_text() == "m11,m12\n0.0,-27.666\n1e-05,2.0\n"


names_strategy = st.lists(
    st.text(st.characters(codec="utf-8", exclude_categories=("Cs", "Cc", "Zs", "Zl", "Zp")),
            min_size=1, max_size=6)
    .filter(lambda name: name == name.strip() and not any(c in name for c in ',;"')),
    min_size=1, max_size=8, unique=True).filter(
    # names that are all numbers would be a pose, not a header (tests/gait/test_csvwrite.py)
    lambda names: not all(_NUMBER.fullmatch(name) for name in names))


@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(names=names_strategy, data=st.data())
def test_round_trip_is_exact(tmp_path: Path, names: list[str], data: st.DataObject) -> None:
    poses = data.draw(st.integers(1, 5))
    angles = data.draw(hnp.arrays(np.float64, (poses, len(names)),
                                  elements=st.floats(allow_nan=False, allow_infinity=False)))
    motion = MotionFile(tuple(names), angles)
    path = tmp_path / "round.csv"
    write_motion_file(path, motion)
    assert read_motion_file(path) == motion
    order = data.draw(st.permutations(names))
    again = read_motion_file(path, required=order)
    assert again.names == tuple(order)
    for name in names:
        assert again.column(name).tobytes() == motion.column(name).tobytes()


def test_negative_zero_and_extremes_survive(tmp_path: Path) -> None:
    angles = np.array([[-0.0, 5e-324, 1.7976931348623157e308, 0.1 + 0.2]])
    motion = MotionFile(("a", "b", "c", "d"), angles)
    write_motion_file(tmp_path / "x.csv", motion)
    back = read_motion_file(tmp_path / "x.csv")
    assert back == motion
    assert np.signbit(back.angles[0, 0])


def test_motion_is_a_checked_read_only_value() -> None:
    source = np.zeros((2, 2))
    motion = MotionFile(("a", "b"), source)
    source[0, 0] = 1.0
    assert motion.angles[0, 0] == 0.0
    with pytest.raises(ValueError):
        motion.angles[0, 0] = 1.0
    assert motion == MotionFile(("a", "b"), np.zeros((2, 2)))
    assert motion != MotionFile(("b", "a"), np.zeros((2, 2)))
    assert hash(motion) == hash(MotionFile(("a", "b"), np.zeros((2, 2))))
    with pytest.raises(KeyError, match="no motor 'c'"):
        motion.column("c")
    for names, angles in [((), np.zeros((1, 0))), (("a", "a"), np.zeros((1, 2))),
                          ((" a",), np.zeros((1, 1))), (("a",), np.zeros((0, 1))),
                          (("a",), np.zeros(1)), (("a",), np.array([[np.nan]])),
                          (("a", "b"), np.zeros((1, 3)))]:
        with pytest.raises(ValueError):
            MotionFile(names, angles)
