"""The fly tracker's raw logs (seed 002, Appendix A): the bytes are the C++ nodes' bytes, a file
cut off or of another kind is refused with one line, and a crash-cut run is still readable.

"Listing 1" and "Listing 2" below are the seed's (/work/shared/seeds/002_255ad431af70731f.txt);
the line numbers are that file's.
"""

from __future__ import annotations

import re
import struct
from pathlib import Path

import numpy as np
import pytest

from servolab.errors import ServolabError
from servolab.robots.treadmill.logs import (
    ENCODER_RECORD,
    FLY_RECORD,
    FLY_RECORD_FIELDS,
    EncoderLogWriter,
    FlyLogError,
    FlyLogWarning,
    FlyLogWriter,
    read_encoder_log,
    read_fly_log,
)


def fly_values(frame: int, time: float = 1522290000.25) -> list[float]:
    """One plausible record: seq, two microsecond counts, a centroid off the target, the
    command, area and motor positions, ROS time."""
    return [float(frame), 4210.0, 33333.0, 331.5, 180.25, 0.125, 10.0, -8.0, -0.125,
            -1.5, 2.5, -3.5, 412.0, 1023.0, -2048.0, 77.0, time]


def test_field_order_and_record_sizes_are_the_listings() -> None:
    # Listing 1, line 1054: output_data[] = {seq_init, elapsed_secs, samplingtime_secs, _cx,
    # _cy, _theta, dxm, dym, dthm, omega_1..3, maxArea, dxl1..3_present_position, secs}.
    assert FLY_RECORD_FIELDS == (
        "frame", "loop_time_us", "sampling_time_us", "cx", "cy", "theta", "dxm", "dym",
        "dthm", "omega1", "omega2", "omega3", "contour_area", "position1", "position2",
        "position3", "time")
    assert FLY_RECORD.names == FLY_RECORD_FIELDS
    # Listing 1, line 597: OutFile_Data_size_byte = 17*sizeof(double).
    assert FLY_RECORD.itemsize == 17 * 8
    # Listing 2, line 1102: Output_size_byte = 3*sizeof(int64_t).
    assert ENCODER_RECORD.itemsize == 3 * 8


def test_one_fly_record_is_seventeen_little_endian_doubles(tmp_path: Path) -> None:
    # Listing 1, line 1059: OutFile_Data.write((char *)output_data, 17*sizeof(double)): raw
    # native doubles, no header; x86 is little-endian IEEE-754 float64.
    path = tmp_path / "fly.bin"
    values = fly_values(7)
    with FlyLogWriter(path) as log:
        log.write(values)
    assert path.read_bytes() == struct.pack("<17d", *values)


def test_one_encoder_record_is_three_little_endian_int64(tmp_path: Path) -> None:
    # Listing 2, lines 1106-1109: int64_t output_data[] = {usecs, left_encoder,
    # right_encoder}, written 3*sizeof(int64_t).
    path = tmp_path / "encoders.bin"
    with EncoderLogWriter(path) as log:
        log.write(1522290000250000, -12345, 2**40)
    assert path.read_bytes() == struct.pack("<3q", 1522290000250000, -12345, 2**40)


def test_fly_log_round_trip(tmp_path: Path) -> None:
    path = tmp_path / "fly.bin"
    records = [fly_values(n, 1522290000.0 + n / 30) for n in range(5)]
    with FlyLogWriter(path) as log:
        for values in records:
            log.write(values)
    read = read_fly_log(path)
    assert read.dtype == FLY_RECORD and read.shape == (5,)
    for n, values in enumerate(records):
        assert tuple(read[n].tolist()) == tuple(values)
    assert read["frame"].tolist() == [0.0, 1.0, 2.0, 3.0, 4.0]


def test_a_file_written_the_c_way_is_read(tmp_path: Path) -> None:
    # What Listing 1's ofstream leaves (line 1059) and Listing 2's (line 1109), byte for byte.
    fly = tmp_path / "Fly_Data_Mar_28.bin"
    fly.write_bytes(b"".join(struct.pack("<17d", *fly_values(n)) for n in (41, 42)))
    log = read_fly_log(fly)
    assert log["frame"].tolist() == [41.0, 42.0]
    assert log["cx"].tolist() == [331.5, 331.5]
    assert log["position2"].tolist() == [-2048.0, -2048.0]
    assert log["time"][1] == 1522290000.25

    encoders = tmp_path / "MobRob_Data.bin"
    encoders.write_bytes(struct.pack("<3q", 10, 1, -1) + struct.pack("<3q", 20, 2, -2))
    enc = read_encoder_log(encoders)
    assert enc.dtype == ENCODER_RECORD
    assert enc["time_us"].tolist() == [10, 20]
    assert enc["left"].tolist() == [1, 2]
    assert enc["right"].tolist() == [-1, -2]


def test_a_truncated_fly_log_is_one_line_with_the_count(tmp_path: Path) -> None:
    path = tmp_path / "fly.bin"
    path.write_bytes(b"".join(struct.pack("<17d", *fly_values(n)) for n in range(9))
                     + b"\0" * 10)
    with pytest.raises(FlyLogError) as caught:
        read_fly_log(path)
    message = str(caught.value)
    assert message == (f"{path}: 1234 bytes is 9 whole records of 136 bytes and 10 bytes more: "
                       "truncated or not a fly log")
    assert "\n" not in message
    assert caught.value.records == 9
    assert isinstance(caught.value, ServolabError) and isinstance(caught.value, ValueError)

    with pytest.warns(FlyLogWarning, match="kept the 9 whole records"):
        log = read_fly_log(path, partial=True)
    assert log["frame"].tolist() == [float(n) for n in range(9)]


def test_a_truncated_encoder_log(tmp_path: Path) -> None:
    encoders = tmp_path / "encoders.bin"
    encoders.write_bytes(struct.pack("<3q", 1, 2, 3) + b"\1\2\3")
    with pytest.raises(FlyLogError, match=r"27 bytes is 1 whole record of 24 bytes and 3 bytes "
                       "more: truncated or not an encoder log$"):
        read_encoder_log(encoders)
    with pytest.warns(FlyLogWarning):
        assert read_encoder_log(encoders, partial=True)["right"].tolist() == [3]


def test_empty_files_are_zero_records(tmp_path: Path) -> None:
    path = tmp_path / "empty.bin"
    path.write_bytes(b"")
    assert read_fly_log(path).shape == (0,)
    assert read_fly_log(path).dtype == FLY_RECORD
    assert read_encoder_log(path).shape == (0,)


def test_a_missing_file_is_one_line(tmp_path: Path) -> None:
    path = tmp_path / "nope.bin"
    for read in (read_fly_log, read_encoder_log):
        with pytest.raises(FlyLogError) as caught:
            read(path)
        assert str(caught.value) == f"{path}: no such file"


@pytest.mark.parametrize(("field", "value"), [("frame", float("nan")), ("time", float("inf")),
                                              ("frame", 2.5), ("frame", -1.0)])
def test_a_frame_or_time_the_tracker_never_writes_is_refused(tmp_path: Path, field: str,
                                                             value: float) -> None:
    # Listing 1, line 889: seq_init = h.seq (a uint32); line 1053: secs = ros::Time::now()
    # .toSec(). Both are always finite, and seq a whole number.
    records = [fly_values(n) for n in range(4)]
    records[2][FLY_RECORD_FIELDS.index(field)] = value
    path = tmp_path / "fly.bin"
    path.write_bytes(b"".join(struct.pack("<17d", *r) for r in records))
    pattern = rf"^{re.escape(str(path))}: record 2: {field} is "
    with pytest.raises(FlyLogError, match=pattern) as caught:
        read_fly_log(path)
    assert "\n" not in str(caught.value)


def test_nan_where_the_tracker_computes_is_kept(tmp_path: Path) -> None:
    # theta is atan2 of moments (Listing 1, line 939): the refusal is for frame and time only.
    values = fly_values(3)
    values[FLY_RECORD_FIELDS.index("theta")] = float("nan")
    path = tmp_path / "fly.bin"
    path.write_bytes(struct.pack("<17d", *values))
    assert np.isnan(read_fly_log(path)["theta"][0])


def test_a_big_endian_file_is_not_taken_for_a_fly_log(tmp_path: Path) -> None:
    path = tmp_path / "fly.bin"
    path.write_bytes(struct.pack(">17d", *fly_values(1)))
    with pytest.raises(FlyLogError, match=r"record 0: frame is .* not a fly log"):
        read_fly_log(path)


def test_writers_refuse_a_wrong_record_and_write_nothing(tmp_path: Path) -> None:
    path = tmp_path / "fly.bin"
    with FlyLogWriter(path) as log:
        with pytest.raises(FlyLogError, match=r"a fly record is 17 values .* got 16"):
            log.write(fly_values(0)[:16])
        with pytest.raises(FlyLogError, match="got 18"):
            log.write([*fly_values(0), 0.0])
        with pytest.raises(FlyLogError, match="record 0: time is nan"):
            log.write(fly_values(0, time=float("nan")))
    assert path.read_bytes() == b""

    encoders = tmp_path / "encoders.bin"
    with EncoderLogWriter(encoders) as enc:
        with pytest.raises(FlyLogError, match="three int64"):
            enc.write(1, 2.5, 3)  # type: ignore[arg-type]
        with pytest.raises(FlyLogError, match="three int64"):
            enc.write(2**63, 0, 0)
    assert encoders.read_bytes() == b""


def test_each_record_is_on_disk_before_close(tmp_path: Path) -> None:
    # A killed run keeps what it wrote: another reader sees every record while the writer is
    # still open (nothing left in the process's buffer).
    path = tmp_path / "fly.bin"
    log = FlyLogWriter(path)
    try:
        for n in range(3):
            log.write(fly_values(n))
            assert read_fly_log(path)["frame"].tolist() == [float(k) for k in range(n + 1)]
    finally:
        log.close()
    with pytest.raises(FlyLogError, match="after its writer was closed"):
        log.write(fly_values(3))


def test_append_continues_a_log_but_not_a_cut_one(tmp_path: Path) -> None:
    path = tmp_path / "encoders.bin"
    with EncoderLogWriter(path) as enc:
        enc.write(1, 0, 0)
    with EncoderLogWriter(path, append=True) as enc:
        enc.write(2, 0, 0)
    assert read_encoder_log(path)["time_us"].tolist() == [1, 2]
    with EncoderLogWriter(path) as enc:  # replaces, as the listing's ios::out does
        enc.write(3, 0, 0)
    assert read_encoder_log(path)["time_us"].tolist() == [3]

    path.write_bytes(path.read_bytes() + b"\0")
    with pytest.raises(FlyLogError, match="1 whole record of 24 bytes and 1 bytes more"):
        EncoderLogWriter(path, append=True)
    assert path.stat().st_size == 25
