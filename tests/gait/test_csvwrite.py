"""Motion files the seed's MATLAB ``csvwrite`` wrote: plain numbers, comma-separated, no header.

Seed 001 Appendix E writes its angles with ``csvwrite('csv_winkel.v2.lstep40.dat',
M_winkel)`` (line 89): no header line, the first row being the ``M_winkel`` placeholder of
zeros (line 76, printed with 22 zeros for 21 columns). The control node's reader (section
4.2.4.3) skips the first line whatever it holds, and takes each line's cells in the order of
its ``structmotoren`` (section 4.2.4.2, Appendix B lines 10-33): that is the seed's column
order, the one Table 4.3's header and Appendix E's ``M_wink`` (lines 33, 70 and 80-84) write.
Such a file is read in that order after a one-line warning, or refused on request.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from servolab.cli import main
from servolab.gait.motionfile import (
    SEED_COLUMNS,
    MotionFile,
    MotionFileError,
    MotionFileWarning,
    read_motion_file,
    write_motion_file,
)
from servolab.gait.walking import GaitParameters, generate_walk
from servolab.robots.armstrong.hardware import joint_limits, load_config

#: Seed 001 section 4.2.4.2, ``structmotoren``, field by field (lines 12-32), typed here from
#: the seed text, not from servolab.
STRUCTMOTOREN = ("m11", "m12", "m13", "m14", "m15", "m16", "m21", "m22", "m23", "m24", "m25",
                 "m26", "m31", "m32", "m33", "m41", "m42", "m43", "m51", "m61", "m62")
ORDER = ",".join(STRUCTMOTOREN)


def csvwrite(path: Path, rows: np.ndarray, newline: str = "\n") -> Path:
    """As MATLAB's csvwrite writes a matrix: each value with 5 significant digits (``%.5g``,
    so 0 as ``0``), comma-separated, no header."""
    text = "".join(",".join(f"{value:.5g}" for value in row) + newline for row in rows)
    path.write_bytes(text.encode())
    return path


def seed_file(tmp_path: Path, zeros: int | None = 21, newline: str = "\n") -> Path:
    """Appendix E's file: the placeholder row of ``zeros`` zeros (None: none), then the
    generated sequence."""
    rows = generate_walk().motors
    path = csvwrite(tmp_path / "csv_winkel.v2.lstep40.dat", rows, newline)
    if zeros is not None:
        path.write_bytes((",".join(["0"] * zeros) + newline).encode() + path.read_bytes())
    return path


def test_the_seeds_column_order() -> None:
    assert SEED_COLUMNS == STRUCTMOTOREN


@pytest.mark.parametrize(("zeros", "newline"), [(21, "\n"), (22, "\n"), (21, "\r\n")])
def test_a_csvwrite_file_is_read_in_the_seeds_order_after_a_warning(
        tmp_path: Path, zeros: int, newline: str) -> None:
    path = seed_file(tmp_path, zeros, newline)
    with pytest.warns(MotionFileWarning) as caught:
        motion = read_motion_file(path, limits=joint_limits(load_config()),
                                  required=STRUCTMOTOREN)
    assert len(caught) == 1
    message = str(caught[0].message)
    assert message == (
        f"{path}: no header (the first line is numbers, as MATLAB's csvwrite writes); "
        f"assumed the seed's column order {ORDER} (001 section 4.2.4.2); line 1, all zeros, is "
        "Appendix E's placeholder row and was skipped, as the seed's reader skips its first "
        "line")
    assert caught[0].filename == __file__  # the warning points at the caller
    assert motion.names == STRUCTMOTOREN
    expected = np.array([[float(f"{v:.5g}") for v in row] for row in generate_walk().motors])
    np.testing.assert_array_equal(motion.angles, expected)
    assert motion.poses == 17


def test_a_first_line_that_is_a_pose_is_kept(tmp_path: Path) -> None:
    """The seed's reader would drop it; here it is the first pose, and the warning says so."""
    path = seed_file(tmp_path, zeros=None)
    with pytest.warns(MotionFileWarning, match=r"; line 1 is read as the first pose$"):
        motion = read_motion_file(path)
    assert motion.poses == 17 and motion.names == STRUCTMOTOREN
    assert motion.column("m12")[0] == float(f"{generate_walk().motors[0, 1]:.5g}")


def test_refused_on_request_saying_so(tmp_path: Path) -> None:
    path = seed_file(tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(MotionFileError) as caught:
            read_motion_file(path, headerless="refuse")
    assert str(caught.value) == (
        f"{path}:1: no header: the first line is numbers (as MATLAB's csvwrite writes); add "
        f"the header line {ORDER} if that is the seed's column order (001 section 4.2.4.2)")
    assert (caught.value.path, caught.value.line) == (str(path), 1)


@pytest.mark.parametrize(("text", "line", "message"), [
    ("1,2,3\n4,5,6\n", 1, "no header: the first line is numbers, and 3 of them; a file without "
     f"a header is read only in the seed's column order (21 columns, {ORDER}; 001 section "
     "4.2.4.2)"),
    (",".join(["0"] * 21) + "\n", 2, "no poses after Appendix E's placeholder row of zeros"),
    (",".join(["0"] * 21) + "\n" + ",".join(["1"] * 20) + "\n", 2,
     "column m62: missing (the line has 20 cells, the header 21)"),
])
def test_a_headerless_file_of_another_shape_is_refused(tmp_path: Path, text: str, line: int,
                                                        message: str) -> None:
    path = tmp_path / "m.csv"
    path.write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(MotionFileError) as caught:
            read_motion_file(path)
    assert str(caught.value) == f"{path}:{line}: {message}"


def test_the_joints_limits_still_hold(tmp_path: Path) -> None:
    rows = generate_walk().motors.copy()
    rows[3, STRUCTMOTOREN.index("m14")] = -170.0
    path = csvwrite(tmp_path / "bad.dat", rows)
    with pytest.warns(MotionFileWarning), pytest.raises(
            MotionFileError, match=r"bad\.dat:4: column m14: -170 degrees is outside the "
            r"joint's limits"):
        read_motion_file(path, limits=joint_limits(load_config()), required=STRUCTMOTOREN)


def test_a_header_of_numbers_cannot_be_written() -> None:
    """Else a written file would read back as a headerless one."""
    with pytest.raises(ValueError, match=r"motor names are all numbers \(1, 2\)"):
        MotionFile(("1", "2"), np.zeros((1, 2)))
    MotionFile(("1", "m12"), np.zeros((1, 2)))  # one name that is not a number is a header


def test_a_written_file_has_its_header_and_reads_without_warning(tmp_path: Path) -> None:
    path = tmp_path / "gait.csv"
    write_motion_file(path, generate_walk().motion())
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert read_motion_file(path).names == STRUCTMOTOREN


def test_gait_check_reads_a_csvwrite_file_with_a_one_line_warning(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = seed_file(tmp_path)
    assert main(["gait", "check", str(path)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == (f"servolab gait check: warning: {path}: no header (the first line is "
                      f"numbers, as MATLAB's csvwrite writes); assumed the seed's column "
                      f"order {ORDER} (001 section 4.2.4.2); line 1, all zeros, is Appendix "
                      "E's placeholder row and was skipped, as the seed's reader skips its "
                      "first line")
    assert out[1].startswith(f"{path}: 17 rows x 21 motors, within the joints' limits; 3.78 s "
                             "a sequence at 4.5 rows a second")


def test_gait_check_refuses_a_file_whose_loop_jumps(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """What the seed's MATLAB writes for c_step 1 (the literal port of Appendix D and E in
    benchmarks/gait.py, which refuses nothing): 5 rows ending with the feet swapped, m12
    12.73 degrees from the first row where no two rows inside differ by more than 7.21."""
    from tests.gait.test_walking import _benchmark as _literal_port

    rows = np.asarray(_literal_port().loop_walk(GaitParameters(c_step=1)))
    path = csvwrite(tmp_path / "one_step.dat", rows)
    assert main(["gait", "check", str(path)]) == 2
    captured = capsys.readouterr()
    assert "no header" in captured.out
    assert captured.err == (f"servolab gait check: error: {path}: played in a loop, the wrap "
                            "from the last row back to the first turns m12 (left hip pitch) "
                            "12.73 degrees, more than any two rows inside it do (7.21)\n")
