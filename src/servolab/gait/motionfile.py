"""Motion files: a sequence of poses, one row per pose, one column per motor, in degrees.

The format is the seed's (seed 001, section 4.2.4.1, Table 4.3): a CSV file whose first line
names the motors (``m11,m12,...,m62``) and whose every further line is one pose, the angle of
each motor in degrees. A gait generator (Matlab then, :mod:`servolab.gait` now) writes it and
the robot plays it row by row.

Why a strict reader: the seed's C++ reader (Appendix B) ignores the header, takes the cells in
a fixed order and passes each through ``string_to_double``, which returns 0 for anything it
cannot read. A typo, an empty cell or a column exported in another order becomes a joint
driven to 0 degrees, or to another joint's angle, on a walking robot. Here the header is
read, columns are matched by name (so any order works), and every cell must be a finite
decimal number inside its joint's limits; the first thing that is not so is a
:class:`MotionFileError` naming the file, the line (from 1) and the column, and nothing is
returned. The whole file is checked before a :class:`MotionFile` exists, so a caller never
holds half a motion.

What is accepted, precisely:

* cells are separated by commas only, read with :mod:`csv`; spaces and tabs around a cell
  are ignored. A cell may be quoted (``"m11"``) if the quote follows the comma or spaces and
  the comma follows the closing quote; other quoting is refused as not valid CSV. Tab- or
  semicolon-separated files are refused with a message saying so: with a semicolon the
  decimal separator may be a comma (``1,5``), and guessing the dialect is exactly the
  silent reinterpretation this module exists to prevent.
* a number is written in decimal, optionally with an exponent (``-27.666``, ``1e-05``,
  ``+3``, ``.5``); ``nan``, ``inf``, ``1_000``, hexadecimal and an empty cell are refused.
* the text is UTF-8 (a byte order mark, as spreadsheets write, is allowed); ``\\n`` or
  ``\\r\\n`` line ends; blank lines at the end of the file are ignored, a blank line between
  poses is refused (it may be a pose that was lost).
* at least one pose after the header.
* at most :class:`servolab.limits.InputLimits`' ``motion_mb`` (64 MB) and ``motion_rows``
  (100 000 poses: 6.2 h at the seed's 4.5 rows a second, 2.8 h at the ZMP walk's 10),
  checked before the file is parsed: the size with ``os.stat`` before a byte is read, the
  lines by counting line ends. ``SERVOLAB_MAX_MOTION_MB`` and ``SERVOLAB_MAX_MOTION_ROWS``
  raise them. An error quotes at most 80 characters of a cell (cut with "…").

A file without a header, as MATLAB's ``csvwrite`` writes one (Appendix E line 89: plain
numbers, comma-separated), is recognised by its first line being all numbers, and read in the
seed's column order :data:`SEED_COLUMNS` after a :class:`MotionFileWarning` (one line naming
the file and the order assumed); ``headerless="refuse"`` refuses it instead, saying the same.
That order is a fact of the seed, not a guess: it is the order of the control node's
``structmotoren`` and of the cells its reader takes from each line (001 section 4.2.4.2,
Appendix B lines 10-33 and 354-417), of Table 4.3's header, and of Appendix E's ``M_wink``
(m11..m26, then ``P_odd``/``P_par`` for m31..m62, line 70). Such a file must then have 21
cells in every line. A first line of zeros only (21 cells, or 22 as Appendix E line 76
prints it) is Appendix E's placeholder, which the seed's reader skipped as its header line:
it is skipped too (a pose of zeros would throw every joint to its calibration position), and
the warning says so. Any other first line is read as the first pose (the seed's reader would
have dropped it). Motor names that are all numbers are refused by :class:`MotionFile`, so a
header can never be taken for a pose.

:func:`write_motion_file` writes the same format with each angle as Python's shortest
round-tripping representation (``repr``), so ``read_motion_file(write_motion_file(m))``
gives back ``m`` bit for bit.

Pure: the functions read and write the file they are given and nothing else.
"""

from __future__ import annotations

import csv
import io
import math
import re
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import numpy.typing as npt

from ..configfile import suggest
from ..errors import ConfigFileError
from ..limits import ECHO_WIDTH, InputLimits, clip, quoted, read_limited
from .errors import GaitValueError, UnknownMotorError

__all__ = ["SEED_COLUMNS", "MotionFile", "MotionFileError", "MotionFileWarning",
           "read_motion_file", "write_motion_file"]

#: The seed's column order: 001 section 4.2.4.2 (``structmotoren``, the order in which the
#: control node's reader takes the cells of a line, Appendix B lines 354-417), Table 4.3's
#: header and Appendix E's ``M_wink`` (lines 33, 70, 80-84). What a file without a header
#: is read with.
SEED_COLUMNS = (
    "m11", "m12", "m13", "m14", "m15", "m16",
    "m21", "m22", "m23", "m24", "m25", "m26",
    "m31", "m32", "m33", "m41", "m42", "m43", "m51", "m61", "m62",
)

#: A decimal number as a motion file may write it (ASCII digits only, no ``_``): what Matlab,
#: spreadsheets and ``repr`` write, and nothing ``float()`` would accept beyond that.
_NUMBER = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")

#: Angles as read: float64, one row per pose.
Angles = npt.NDArray[np.float64]
#: The seed's playback rate (rows a second; :data:`servolab.gait.walking.PLAY_RATE`), to say
#: how long the row limit is.
_SEED_RATE = 4.5


class MotionFileError(ConfigFileError, GaitValueError):
    """A motion file that cannot be used.

    ``str(error)`` is one line, ``"<path>:<line>: column <name>: <problem>"`` (or
    ``"<path>:<line>: <problem>"`` when no column is meant); ``path``, ``line`` (from 1; 0 for
    the whole file, e.g. when it cannot be opened) and ``key`` (the column's motor name, or
    ``""``) are attributes, as for every :class:`~servolab.errors.ConfigFileError`.
    """


class MotionFileWarning(UserWarning):
    """A motion file that was read, but not as written: one without a header, read in the
    seed's column order. The message is one line naming the file."""


#: What a motor name may not hold: what a CSV header would split or quote on.
_NOT_IN_NAMES = ",;\t\r\n\""


@dataclass(frozen=True, eq=False)
class MotionFile:
    """A motion: ``angles[pose, column]`` in degrees, column ``j`` being motor ``names[j]``.

    Checked on construction, so that whatever exists can be written and read back: at least
    one motor and one pose, unique names without surrounding whitespace or line breaks, and
    finite angles. ``angles`` is stored as a read-only float64 copy (the motion is a value;
    a caller changing its array afterwards must not change it). Equality is exact: the same
    names in the same order and bit-identical angles.
    """

    names: tuple[str, ...]
    angles: Angles

    def __post_init__(self) -> None:
        names = tuple(self.names)
        for name in names:
            if not isinstance(name, str) or not name or name != name.strip() or any(
                    c in name for c in _NOT_IN_NAMES):
                raise GaitValueError(f"motor name {name!r}: must be non-empty text without "
                                     "surrounding whitespace, line breaks, quotes or separators "
                                     "(, ; tab)")
        if not names:
            raise GaitValueError("a motion needs at least one motor")
        if all(_NUMBER.fullmatch(name) for name in names):
            raise GaitValueError(f"motor names are all numbers ({', '.join(names)}): written "
                                 "as a header they would read as a pose")
        if len(set(names)) != len(names):
            twice = sorted({n for n in names if names.count(n) > 1})
            raise GaitValueError(f"motor names appear twice: {', '.join(twice)}")
        angles = np.array(self.angles, dtype=np.float64, order="C", copy=True)
        if angles.ndim != 2 or angles.shape[1] != len(names) or angles.shape[0] == 0:
            raise GaitValueError(f"angles must have shape (poses >= 1, {len(names)}), "
                                 f"not {angles.shape}")
        if not np.isfinite(angles).all():
            raise GaitValueError("angles must be finite")
        angles.flags.writeable = False
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "angles", angles)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, MotionFile):
            return NotImplemented
        return (self.names == other.names and self.angles.shape == other.angles.shape
                and self.angles.tobytes() == other.angles.tobytes())

    def __hash__(self) -> int:
        return hash((self.names, self.angles.shape, self.angles.tobytes()))

    @property
    def poses(self) -> int:
        """How many poses (rows) the motion has."""
        return int(self.angles.shape[0])

    def column(self, name: str) -> Angles:
        """The angles of motor ``name`` over the motion (an :class:`UnknownMotorError`, a KeyError
        too, names the motors)."""
        try:
            return self.angles[:, self.names.index(name)]
        except ValueError:
            raise UnknownMotorError(f"no motor {name!r} in this motion ({', '.join(self.names)})"
                                    ) from None


def read_motion_file(path: str | Path,
                     limits: Mapping[str, tuple[float, float]] | None = None,
                     required: Sequence[str] | None = None, *,
                     headerless: Literal["seed", "refuse"] = "seed",
                     input_limits: InputLimits | None = None) -> MotionFile:
    """Read and check a motion file.

    ``required``: the motors the file must have; the result's columns are in this order
    (followed by any other known column, in file order). ``limits``: each motor's
    ``(lowest, highest)`` angle in degrees, inclusive; an angle outside them is refused, and
    motors without limits are not checked. A column is unknown, and refused, when it is
    neither in ``required`` nor in ``limits``; with neither given, every column is accepted
    in file order. ``required`` or ``limits`` that do not make sense are a ValueError (a
    program's mistake, not the file's).

    ``headerless``: what to do with a file whose first line is numbers (MATLAB's ``csvwrite``
    writes no header): ``"seed"`` reads it in the seed's column order :data:`SEED_COLUMNS`
    and warns (:class:`MotionFileWarning`), ``"refuse"`` refuses it; see the module docstring.

    ``input_limits``: the largest file and the most poses taken (default
    :meth:`InputLimits.current() <servolab.limits.InputLimits.current>`); a file over them
    is refused before it is parsed.

    Raises :class:`MotionFileError` for the first problem in the file, top to bottom.
    """
    if headerless not in ("seed", "refuse"):
        raise GaitValueError(f"headerless must be 'seed' or 'refuse', not {headerless!r}")
    bounds = _check_limits(limits)
    wanted = _check_required(required)
    known = None if wanted is None and bounds is None else {*(wanted or ()), *(bounds or {})}
    source = str(path)

    def fail(line: int, column: str, message: str) -> MotionFileError:
        where = f"column {clip(column)}: " if column else ""
        return MotionFileError(source, line, column, where + message)

    size_limits = InputLimits.current() if input_limits is None else input_limits
    try:
        data = read_limited(path, "motion_mb", "motion file", lambda m: fail(0, "", m),
                            size_limits)
    except OSError as exc:
        raise fail(0, "", f"cannot read motion file ({exc.strerror or exc})") from None
    _check_rows(data, size_limits, fail)
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise fail(line, "", f"not UTF-8 text (byte 0x{data[exc.start]:02x}; is this a "
                   "motion file?)") from None

    rows = _rows(text, source)
    if not rows:
        raise fail(1, "", "empty; a motion file starts with a header of motor names "
                   "(m11,m12,...)")

    header_line, header_cells = rows[0]
    header = [cell.strip() for cell in header_cells]
    body = rows[1:]
    if all(_NUMBER.fullmatch(cell) for cell in header):
        header, body = _seed_columns(source, rows, headerless)
    if len(header) == 1 and ("\t" in header[0] or ";" in header[0]):
        raise fail(header_line, "", "the header has no commas; motion files are "
                   "comma-separated (not tab- or semicolon-separated)")
    first_at: dict[str, int] = {}
    for index, name in enumerate(header, start=1):
        if not name:
            raise fail(header_line, "", f"column {index} of the header has no motor name")
        if name in first_at:
            raise fail(header_line, name, f"appears twice in the header (columns "
                       f"{first_at[name]} and {index})")
        first_at[name] = index
        if known is not None and name not in known:
            close = suggest(name, known) if len(name) <= ECHO_WIDTH else None
            hint = f" (did you mean {close!r}?)" if close else ""
            raise fail(header_line, name, f"unknown motor{hint}")
    for name in wanted or ():
        if name not in first_at:
            raise fail(header_line, name, "missing from the header")

    values = np.empty((len(body), len(header)), dtype=np.float64)
    for pose, (line, cells) in enumerate(body):
        if not cells:
            raise fail(line, "", "blank line between poses (was a pose lost?)")
        if len(cells) < len(header):
            raise fail(line, header[len(cells)], f"missing (the line has {len(cells)} "
                       f"cell{'' if len(cells) == 1 else 's'}, the header {len(header)})")
        if len(cells) > len(header):
            raise fail(line, "", f"{len(cells)} cells, but the header names {len(header)} "
                       f"motors (extra cell {quoted(cells[len(header)].strip())})")
        for index, (name, cell) in enumerate(zip(header, cells, strict=True)):
            written = cell.strip()
            if not written:
                raise fail(line, name, "empty cell, not a number")
            angle = _number(written)
            if angle is None:
                raise fail(line, name, f"{quoted(written)} is not a number")
            if not math.isfinite(angle):
                raise fail(line, name, f"{quoted(written)} is not a finite number")
            if bounds is not None and name in bounds:
                low, high = bounds[name]
                if not low <= angle <= high:
                    raise fail(line, name, f"{clip(written)} degrees is outside the joint's "
                               f"limits [{low:g}, {high:g}]")
            values[pose, index] = angle
    if values.shape[0] == 0:
        raise fail(header_line + 1, "", "no poses after the header")

    order = list(wanted) if wanted is not None else []
    order += [name for name in header if name not in order]
    columns = [first_at[name] - 1 for name in order]
    return MotionFile(tuple(order), values[:, columns])


def write_motion_file(path: str | Path, motion: MotionFile) -> None:
    """Write ``motion`` as a motion file :func:`read_motion_file` reads back exactly.

    Each angle is written as ``repr(float)``, the shortest text that parses back to the same
    float64, so nothing is lost (``%.6g``, Matlab's default, loses up to 5e-7 degrees).
    Lines end in ``\\n``; the file is replaced.
    """
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(motion.names)
    for pose in motion.angles.tolist():
        writer.writerow([repr(float(angle)) for angle in pose])
    with open(path, "w", encoding="utf-8", newline="") as file:
        file.write(buffer.getvalue())


# -- helpers ---------------------------------------------------------------------------------


def _check_rows(data: bytes, limits: InputLimits,
                fail: Callable[[int, str, str], MotionFileError]) -> None:
    """Refuse, before parsing, a file of more poses than ``limits.motion_rows``: counted as
    its line ends (``\\n``, or ``\\r`` alone) less the header's, a blank line counting
    too."""
    ends = max(data.count(b"\n"), data.count(b"\r"))
    lines = ends + (0 if not data or data.endswith((b"\n", b"\r")) else 1)
    if lines - 1 > limits.motion_rows:
        hours = limits.motion_rows / _SEED_RATE / 3600
        raise fail(0, "", limits.over("motion_rows", lines - 1, "rows", "motion file",
                                         done="not parsed")
                   + f"; {limits.motion_rows:g} rows play {hours:.1f} h at the seed's "
                   f"{_SEED_RATE:g} rows a second")


def _seed_columns(source: str, rows: list[tuple[int, list[str]]],
                  headerless: str) -> tuple[list[str], list[tuple[int, list[str]]]]:
    """The header and poses of a file whose first line is numbers (module docstring): the
    seed's column order and every row, less Appendix E's placeholder row of zeros."""
    line, cells = rows[0]
    order = ",".join(SEED_COLUMNS)
    if headerless == "refuse":
        raise MotionFileError(source, line, "", "no header: the first line is numbers (as "
                              "MATLAB's csvwrite writes); add the header line "
                              f"{order} if that is the seed's column order (001 section "
                              "4.2.4.2)")
    placeholder = len(cells) in (len(SEED_COLUMNS), len(SEED_COLUMNS) + 1) and all(
        float(cell) == 0.0 for cell in cells)
    if not placeholder and len(cells) != len(SEED_COLUMNS):
        raise MotionFileError(source, line, "", f"no header: the first line is numbers, and "
                              f"{len(cells)} of them; a file without a header is read only in "
                              f"the seed's column order ({len(SEED_COLUMNS)} columns, {order}; "
                              "001 section 4.2.4.2)")
    body = rows[1:] if placeholder else rows
    if not body:
        raise MotionFileError(source, line + 1, "", "no poses after Appendix E's placeholder "
                              "row of zeros")
    first = (f"line {line}, all zeros, is Appendix E's placeholder row and was skipped, as "
             "the seed's reader skips its first line" if placeholder
             else f"line {line} is read as the first pose")
    warnings.warn(f"{source}: no header (the first line is numbers, as MATLAB's csvwrite "
                  f"writes); assumed the seed's column order {order} (001 section "
                  f"4.2.4.2); {first}", MotionFileWarning, stacklevel=3)
    return list(SEED_COLUMNS), body


def _rows(text: str, source: str) -> list[tuple[int, list[str]]]:
    """The CSV rows of ``text``, each with the line (from 1) it starts on. Blank lines (no
    text but spaces) before the first and after the last row are dropped; one between rows
    is kept, as an empty row, for the reader to refuse. ``,,`` is not blank: it is a row of
    empty cells."""
    reader = csv.reader(io.StringIO(text, newline=""), strict=True, skipinitialspace=True)
    rows: list[tuple[int, list[str]]] = []
    blank_at = 0
    while True:
        start = reader.line_num + 1
        try:
            cells = next(reader)
        except StopIteration:
            break
        except csv.Error as exc:
            raise MotionFileError(source, start, "", f"not valid CSV ({exc})") from None
        if len(cells) <= 1 and not "".join(cells).strip():
            blank_at = blank_at or start
            continue
        if blank_at and rows:
            rows.append((blank_at, []))
        blank_at = 0
        rows.append((start, cells))
    return rows


def _number(text: str) -> float | None:
    """The value of a decimal number as a motion file writes it, or None."""
    if _NUMBER.fullmatch(text) is None:
        return None
    return float(text)  # may be inf on overflow (1e999): the caller refuses it


def _check_limits(limits: Mapping[str, tuple[float, float]] | None
                  ) -> dict[str, tuple[float, float]] | None:
    if limits is None:
        return None
    checked: dict[str, tuple[float, float]] = {}
    for name, pair in limits.items():
        low, high = (float(value) for value in pair)
        if math.isnan(low) or math.isnan(high) or low > high:
            raise GaitValueError(f"limits of {name!r}: need lowest <= highest, not {pair!r}")
        checked[name] = (low, high)
    return checked


def _check_required(required: Sequence[str] | None) -> list[str] | None:
    if required is None:
        return None
    if isinstance(required, str):
        raise GaitValueError("required: a sequence of motor names, not one string")
    wanted = list(required)
    if len(set(wanted)) != len(wanted):
        raise GaitValueError(f"required names a motor twice: {wanted!r}")
    return wanted
