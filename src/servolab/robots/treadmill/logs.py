"""The fly tracker's two data logs (seed 002, Appendix A), readable and writable byte for byte.

The thesis's C++ nodes write headerless binary files, one fixed-size record per event, in the
PC's native byte order (x86: little-endian). Nothing in the file says what it holds, so the only
checks possible are the size (a whole number of records) and values the writer can never
produce; both are made here, so that a wrong or cut-off file is refused with one line instead
of turning into plausible garbage:

- the fly log (Listing 1, the end of ``imageCb``): 17 IEEE-754 float64 per camera frame,
  :data:`FLY_RECORD`, 136 bytes;
- the encoder log (Listing 2, the ``sensor_state`` callback): three int64 per message,
  :data:`ENCODER_RECORD`, 24 bytes.

The third, the raw frames (Listing 1's ``Fly_Image.bin``), is a recording like any video:
:mod:`servolab.vision.frame_source` reads it and :mod:`servolab.vision.frame_writer` writes it.

The writers flush every record, as the C++ ``ofstream`` effectively does not: a run that is
killed keeps everything written before the kill (at worst the record being written is cut
short, which the readers' ``partial=True`` then drops). They do not ``fsync``; a power cut can
still lose what the OS had not yet stored.
"""

from __future__ import annotations

import math
import operator
import struct
import warnings
from collections.abc import Sequence
from pathlib import Path
from types import TracebackType
from typing import BinaryIO, Self

import numpy as np
import numpy.typing as npt

from ..errors import RobotValueError

#: The fly log's 17 fields in the order Listing 1 writes them (``output_data[]``); each is a
#: float64 whatever the C++ variable's type was.
#:
#: - ``frame``: the image's ``header.seq`` (``seq_init``), a uint32 count of camera frames;
#: - ``loop_time_us``: ``elapsed_secs``, despite its name microseconds
#:   (``duration_cast<microseconds>``) from the frame's arrival (after ``cv_bridge``) to after
#:   the motors' positions were read back: the processing and motor I/O time;
#: - ``sampling_time_us``: ``samplingtime_secs``, microseconds between this frame's arrival
#:   and the previous one's ("LOOP TIME"; the first counts from the node's start);
#: - ``cx``, ``cy``: the largest contour's centroid, pixels in the image (origin top left);
#:   the target (320, 188) when that contour is 100 px² or smaller (no fly found);
#: - ``theta``: the contour's orientation from its second moments, radians (0 if no fly);
#: - ``dxm``, ``dym``: the centroid's offset from the target, pixels, turned by the camera's
#:   20° misalignment into the motors' axes;
#: - ``dthm``: the orientation error, ``-(theta - 0)``, radians;
#: - ``omega1``..``omega3``: the velocities commanded to the three ball motors, Dynamixel Goal
#:   Velocity units, before ``Motor_Assign`` truncates them to int (0 inside the tolerance);
#: - ``contour_area``: ``maxArea``, the largest contour's area, px² (0 if none);
#: - ``position1``..``position3``: the motors' Present Position register after the command,
#:   Dynamixel position units (an int32 written as a double);
#: - ``time``: ``ros::Time::now().toSec()`` when the record was written, seconds (ROS time).
FLY_RECORD_FIELDS: tuple[str, ...] = (
    "frame", "loop_time_us", "sampling_time_us", "cx", "cy", "theta", "dxm", "dym", "dthm",
    "omega1", "omega2", "omega3", "contour_area", "position1", "position2", "position3", "time",
)
FLY_RECORD = np.dtype([(name, "<f8") for name in FLY_RECORD_FIELDS])

#: Listing 2's record: ``usecs``, ROS time in microseconds (``(int64_t)(toSec()*1000000)``,
#: truncated), then the TurtleBot3 ``SensorState`` ``left_encoder`` and ``right_encoder``
#: (encoder ticks).
ENCODER_RECORD = np.dtype([("time_us", "<i8"), ("left", "<i8"), ("right", "<i8")])


_FLY_STRUCT = struct.Struct("<17d")
_ENCODER_STRUCT = struct.Struct("<3q")


class FlyLogError(RobotValueError):
    """A fly-tracker log that cannot be read or written as asked.

    ``str(error)`` is one line, ``"<path>: <what is wrong>"``. ``records`` is the number of
    whole records the file holds when the fault is a cut-off tail (so a caller can decide to
    retry with ``partial=True``), else ``None``.
    """

    def __init__(self, path: str | Path, message: str, records: int | None = None) -> None:
        self.path = str(path)
        self.message = message
        self.records = records
        super().__init__(f"{self.path}: {message}")


class FlyLogWarning(UserWarning):
    """A cut-off tail dropped by a reader called with ``partial=True``; the message says how
    many whole records were kept, so the loss is never silent."""


def _plural(count: int, noun: str) -> str:
    return f"{count} whole {noun}" + ("" if count == 1 else "s")


def _tail_message(size: int, whole: int, itemsize: int, noun: str, what: str) -> str:
    rest = size - whole * itemsize
    return (f"{size} bytes is {_plural(whole, noun)} of {itemsize} bytes and {rest} bytes "
            f"more: truncated or not {what}")


def _whole_records(path: Path, itemsize: int, noun: str, what: str, partial: bool) -> int:
    """How many records to read: the size decides, since the files have no header; a tail that
    is not a whole record is an error unless the caller accepts a crash-cut run."""
    try:
        size = path.stat().st_size
    except FileNotFoundError:
        raise FlyLogError(path, "no such file") from None
    except OSError as error:
        raise FlyLogError(path, f"cannot read: {error.strerror}") from None
    if path.is_dir():
        raise FlyLogError(path, f"is a folder, not {what}")
    whole, rest = divmod(size, itemsize)
    if rest:
        message = _tail_message(size, whole, itemsize, noun, what)
        if not partial:
            raise FlyLogError(path, message, records=whole)
        warnings.warn(f"{path}: {message}; kept the {_plural(whole, noun)}", FlyLogWarning,
                      stacklevel=3)
    return whole


def _read_records(path: Path, dtype: np.dtype[np.void], what: str,
                  partial: bool) -> npt.NDArray[np.void]:
    count = _whole_records(path, dtype.itemsize, "record", what, partial)
    if count == 0:
        return np.empty(0, dtype=dtype)
    try:
        return np.fromfile(path, dtype=dtype, count=count)
    except OSError as error:
        raise FlyLogError(path, f"cannot read: {error.strerror or error}") from None


def _check_fly_values(path: Path, index: int, frame: float, time: float, verdict: str) -> None:
    """Refuse what Listing 1 cannot have written: seq is a uint32, time the ROS clock."""
    for name, value in (("frame", frame), ("time", time)):
        if not math.isfinite(value):
            raise FlyLogError(path, f"record {index}: {name} is {value}; the tracker always "
                              f"writes a finite {name}: {verdict}")
    if not (frame.is_integer() and 0 <= frame < 2**32):
        raise FlyLogError(path, f"record {index}: frame is {frame}, not an image seq (a whole "
                          f"number from 0 to 2**32 - 1): {verdict}")


def read_fly_log(path: str | Path, *, partial: bool = False) -> npt.NDArray[np.void]:
    """The fly log's records as a structured array of :data:`FLY_RECORD` (``log["cx"]``...).

    ``partial=True`` reads a run cut off mid-record (the tracker killed): the whole records are
    returned and a :class:`FlyLogWarning` says how many. A record whose ``frame`` or ``time`` is
    not a finite number (or ``frame`` not a uint32) is refused, naming its index: the tracker
    never writes one, so the file is something else or read with the wrong layout.
    """
    path = Path(path)
    log = _read_records(path, FLY_RECORD, "a fly log", partial)
    frames = log["frame"]
    times = log["time"]
    bad = ~(np.isfinite(frames) & np.isfinite(times) & (frames >= 0) & (frames < 2**32)
            & (np.floor(frames) == frames))
    if bad.any():
        index = int(np.argmax(bad))
        _check_fly_values(path, index, float(frames[index]), float(times[index]),
                          "not a fly log")
    return log


def read_encoder_log(path: str | Path, *, partial: bool = False) -> npt.NDArray[np.void]:
    """The encoder log's records as a structured array of :data:`ENCODER_RECORD`
    (``time_us``, ``left``, ``right``); ``partial`` as for :func:`read_fly_log`."""
    return _read_records(Path(path), ENCODER_RECORD, "an encoder log", partial)


class _RecordWriter:
    """One open file, one record per call, flushed at once so a kill keeps it."""

    def __init__(self, path: str | Path, itemsize: int, noun: str, what: str,
                 append: bool) -> None:
        self.path = Path(path)
        if append and self.path.exists():
            # Appending after a cut-off tail would shift every later record by the tail's size.
            _whole_records(self.path, itemsize, noun, what, partial=False)
        try:
            self._file: BinaryIO | None = open(self.path, "ab" if append else "wb")  # noqa: SIM115
        except OSError as error:
            raise FlyLogError(self.path, f"cannot write: {error.strerror}") from None

    def _write(self, data: bytes) -> None:
        if self._file is None:
            raise FlyLogError(self.path, "written after its writer was closed")
        self._file.write(data)
        self._file.flush()

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None

    def __enter__(self) -> Self:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 traceback: TracebackType | None) -> None:
        self.close()


class FlyLogWriter(_RecordWriter):
    """Writes the fly log as Listing 1 does, one :data:`FLY_RECORD` per :meth:`write`.

    ``append=False`` replaces an existing file (as the listing's ``ios::out`` does);
    ``append=True`` continues one, after checking it ends on a whole record.
    """

    def __init__(self, path: str | Path, *, append: bool = False) -> None:
        super().__init__(path, FLY_RECORD.itemsize, "record", "a fly log", append)
        self._records = 0

    def write(self, values: Sequence[float]) -> None:
        """Append one record: the 17 values in :data:`FLY_RECORD_FIELDS`' order. A wrong count,
        or a ``frame``/``time`` the reader would refuse, is refused before anything is
        written, so the file stays readable."""
        if len(values) != len(FLY_RECORD_FIELDS):
            raise FlyLogError(self.path, f"a fly record is {len(FLY_RECORD_FIELDS)} values "
                              f"({', '.join(FLY_RECORD_FIELDS)}), got {len(values)}")
        floats = [float(value) for value in values]
        _check_fly_values(self.path, self._records, floats[0], floats[-1],
                          "not written")
        self._write(_FLY_STRUCT.pack(*floats))
        self._records += 1


class EncoderLogWriter(_RecordWriter):
    """Writes the encoder log as Listing 2 does, one :data:`ENCODER_RECORD` per :meth:`write`;
    ``append`` as for :class:`FlyLogWriter`."""

    def __init__(self, path: str | Path, *, append: bool = False) -> None:
        super().__init__(path, ENCODER_RECORD.itemsize, "record", "an encoder log", append)

    def write(self, time_us: int, left: int, right: int) -> None:
        """Append one record; the three must be integers that fit int64 (a float would be
        rounded silently, so it is refused)."""
        try:
            data = _ENCODER_STRUCT.pack(operator.index(time_us), operator.index(left),
                                        operator.index(right))
        except (TypeError, struct.error) as error:
            raise FlyLogError(self.path, f"an encoder record is three int64 (time_us, left, "
                              f"right): {error}") from None
        self._write(data)
