"""FicTrac-compatible output of the treadmill (servolab.robots.treadmill.fictrac): rows for a
known wheel motion against eq. 3b by hand, FicTrac's integration against numpy, the .dat
format against FicTrac's source, and bad files refused.

FicTrac references are to rjdmoore/fictrac at commit
1a528715527d10a30a315a6b7c7f5e9aecc41130 (2023-11-13, CMake version 2.1.2):
``doc/data_header.txt`` (25 columns; 24 and 25 since commit 7894ebb, 2019-12-06) and
``src/Trackball.cpp`` (``updatePath`` lines 877-997, ``logData`` lines 999-1026).
"""

from __future__ import annotations

import math
import re
from datetime import datetime
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from servolab.kinematics.aot import AotGeometry
from servolab.robots.treadmill.analysis import fictive_path, sphere_motion
from servolab.robots.treadmill.fictrac import (
    COLUMN_COUNT,
    COLUMNS,
    DEFAULT_CAM_TO_LAB,
    FicTracError,
    FicTracIntegrator,
    FicTracRow,
    FicTracWriter,
    fictrac_filename,
    fictrac_rows,
    format_line,
    multiarray_value,
    read_fictrac_dat,
    row_from_multiarray,
    socket_message,
)
from servolab.robots.treadmill.logs import FLY_RECORD

COMMIT = "1a528715527d10a30a315a6b7c7f5e9aecc41130"
TICK = 2 * math.pi / 4096  # rad per tick, the X series
# column indices (0-based) in FicTrac's order
CNT, DR_CAM, ERR, DR_LAB, R_CAM, R_LAB = 0, slice(1, 4), 4, slice(5, 8), slice(8, 11), \
    slice(11, 14)
POS, HEADING, DIRECTION, SPEED, INT = slice(14, 16), 16, 17, 18, slice(19, 21)
TS, SEQ, DTS, MIDNIGHT = 21, 22, 23, 24


def _fly_log(wheels: np.ndarray, dt: float = 1 / 66, t0: float = 1_700_000_000.0,
             frame0: int = 5000) -> np.ndarray:
    log = np.zeros(len(wheels), dtype=FLY_RECORD)
    log["frame"] = frame0 + np.arange(len(wheels))
    log["time"] = t0 + np.arange(len(wheels)) * dt
    for i in range(3):
        log[f"position{i + 1}"] = wheels[:, i]
    return log


def _random_wheels(n: int = 200, seed: int = 2) -> np.ndarray:
    steps = np.random.default_rng(seed).integers(-12, 13, size=(n, 3))
    steps[0] = 0
    return np.asarray(1000 + np.cumsum(steps, axis=0), dtype=np.float64)


def test_the_columns_are_fictracs_25() -> None:
    """data_header.txt (commit above) numbers its columns 1 to 25: lines 2-43."""
    assert COLUMN_COUNT == 25 == len(FicTracRow._fields)
    names = [name for name, _ in COLUMNS]
    assert names[0] == "frame_counter" and names[22] == "sequence_counter"
    assert names[23:] == ["delta_timestamp_ms", "ms_since_midnight"]


def test_one_wheel_at_constant_speed_against_eq_3b_by_hand() -> None:
    """Wheel 1 turns 4 ticks a frame (delta = 4 * 2 pi / 4096 = 0.0061359 rad), 2 and 3 stand.

    Eq. 3c's J, column 1 (wheel angle 0, R_1 = R (cos 40, 0, sin 40)): R_1z / R^2 * (R_1z, 0,
    -R_1x) = (sin^2 40, 0, -sin 40 cos 40) = (0.41317591, 0, -0.49240388), so eq. 3b gives
    the ball [w_y, w_x, w_z] = delta * that. Eq. 3b's M ([[0, 1/r, 0], [1/r, 0, 0], [0, 0,
    1]]) makes the surface x' = r w_x = 0, y' = r w_y, theta' = w_z, in the motors' frame; the
    camera is turned 20 deg with image axes (-1, -1, +1) (kinematics/aot.py, camera_to_motor
    and CAMERA_HANDEDNESS): x_c = -sin 20 y', y_c = -cos 20 y'. On the ball's top, (0, 0, -r)
    in the camera's frame (z down): dr_cam = (y_c, -x_c, r theta') / r = delta (-cos 20
    sin^2 40, sin 20 sin^2 40, -sin 40 cos 40) = delta (-0.38825835, 0.14131448,
    -0.49240388): r cancels.
    """
    n, delta = 12, 4 * TICK
    wheels = np.zeros((n, 3))
    wheels[:, 0] = 1000 + 4 * np.arange(n)
    integrator = FicTracIntegrator(midnight_s=0.0)
    rows = np.array([integrator.update(wheels[k], 100.0 + k / 66, 7 + k) for k in range(n)])

    dr_cam = delta * np.array([-0.38825835480968673, 0.14131448435589197,
                               -0.49240387650610395])
    np.testing.assert_array_equal(rows[0, 1:21], np.zeros(20))  # no previous frame
    assert not np.any(np.signbit(rows[0, 1:21]))  # and no "-0" in the file
    np.testing.assert_allclose(rows[1:, DR_CAM], np.tile(dr_cam, (n - 1, 1)), rtol=1e-12)
    assert np.all(rows[:, ERR] == 0.0)  # no template matching
    # the default lab frame is the camera's
    np.testing.assert_array_equal(rows[:, DR_LAB], rows[:, DR_CAM])
    k = np.arange(n)[:, None]
    # a constant axis: the orientation is k times the step
    np.testing.assert_allclose(rows[:, R_CAM], k * dr_cam, rtol=1e-9, atol=1e-15)
    lab = [(Rotation.from_matrix(DEFAULT_CAM_TO_LAB) * Rotation.from_rotvec(kk * dr_cam))
           .as_rotvec() for kk in range(n)]
    np.testing.assert_allclose(rows[:, R_LAB], lab, atol=1e-12)
    # velx = dr_lab[1] = 0.14131448 delta forward, vely = -dr_lab[0] = 0.38825835 delta to
    # the right: speed sin^2 40 delta, direction atan2(cos 20, sin 20) = 70 deg = 1.22173048
    np.testing.assert_allclose(rows[1:, SPEED], 0.41317591116653474 * delta, rtol=1e-12)
    np.testing.assert_allclose(rows[1:, DIRECTION], 1.2217304763960306, rtol=1e-12)
    np.testing.assert_allclose(rows[:, INT], k * delta * np.array(
        [0.14131448435589197, 0.38825835480968673]), rtol=1e-12, atol=1e-15)
    # heading -= dr_lab[2]: +0.49240388 delta each frame, wrapped into [0, 2 pi)
    expected_heading = np.mod(0.49240387650610395 * delta * np.arange(n), 2 * math.pi)
    np.testing.assert_allclose(rows[:, HEADING], expected_heading, rtol=1e-12)
    assert list(rows[:, CNT]) == list(range(7, 7 + n))
    assert list(rows[:, SEQ]) == list(range(n))
    np.testing.assert_allclose(rows[:, TS], (100.0 + np.arange(n) / 66) * 1000, rtol=1e-15)
    np.testing.assert_allclose(rows[1:, DTS], 1000 / 66, rtol=1e-9)
    assert rows[0, DTS] == 0.0


def _fictrac_position(rows: np.ndarray) -> np.ndarray:
    """updatePath's 4-sub-step integration, vectorised: sub-step i of a frame goes
    speed / 4 along the step's direction turned by the previous heading plus (2 i + 1) / 8 of
    the frame's (wrapped) heading change."""
    velx, vely = rows[:, DR_LAB][:, 1], -rows[:, DR_LAB][:, 0]
    heading = rows[:, HEADING]
    previous = np.concatenate([[0.0], heading[:-1]])
    change = np.mod(heading - previous + math.pi, 2 * math.pi) - math.pi
    alpha = np.arctan2(vely, velx)
    steps = np.zeros((len(rows), 2))
    for i in range(4):
        angle = alpha + previous + (2 * i + 1) / 8 * change
        steps += np.column_stack([np.cos(angle), np.sin(angle)]) * np.hypot(velx, vely)[:, None] / 4
    return np.cumsum(steps, axis=0)


def test_integration_against_numpy_cumulative_sums() -> None:
    geometry = AotGeometry()
    log = _fly_log(_random_wheels())
    rows = fictrac_rows(log, geometry, midnight_s=0.0)
    dr_lab = rows[:, DR_LAB]
    np.testing.assert_allclose(rows[:, INT], np.cumsum(np.column_stack(
        [dr_lab[:, 1], -dr_lab[:, 0]]), axis=0), atol=1e-12)
    heading = np.mod(-np.cumsum(dr_lab[:, 2]), 2 * math.pi)
    gap = np.mod(rows[:, HEADING] - heading + math.pi, 2 * math.pi) - math.pi
    np.testing.assert_allclose(gap, 0.0, atol=1e-12)
    assert np.all((rows[:, HEADING] >= 0) & (rows[:, HEADING] < 2 * math.pi))
    np.testing.assert_allclose(rows[:, POS], _fictrac_position(rows), atol=1e-12)
    # the orientation: every frame's rotation pre-multiplied, as FicTrac's R_roi
    total = Rotation.identity()
    expected = []
    for step in rows[:, DR_CAM]:
        total = Rotation.from_rotvec(step) * total
        expected.append(total.as_rotvec())
    np.testing.assert_allclose(rows[:, R_CAM], expected, atol=1e-10)
    # times the wheel radius (eq. 3b's r) the position is the analysis's fictive path in m,
    # which is drawn with image y up (FicTrac's y is image y: the fly's right): only its one
    # mid-step against FicTrac's four sub-steps differs (3e-8 m here, in 2.8 mm)
    _, _, motion = sphere_motion(log, geometry)
    np.testing.assert_allclose(rows[:, POS] * geometry.wheel_radius,
                               fictive_path(motion) * [1.0, -1.0], atol=1e-7)
    # a fly turning right (its image theta grows: clockwise seen from above) turns the
    # surface the other way (analysis.fictive_path); FicTrac's heading grows
    turned = FicTracIntegrator(midnight_s=0.0).advance([0.0, 0.0, -0.01], 0.0, 0)
    assert turned.heading == pytest.approx(0.01)


def test_update_frame_by_frame_gives_the_whole_runs_rows() -> None:
    """The incremental and the after-the-fact paths share one computation."""
    log = _fly_log(_random_wheels(60))
    whole = fictrac_rows(log, midnight_s=1_699_990_000.0)
    integrator = FicTracIntegrator(midnight_s=1_699_990_000.0)
    frames = np.array([integrator.update(log[[f"position{i}" for i in (1, 2, 3)]][k].tolist(),
                                         log["time"][k], int(log["frame"][k]))
                       for k in range(len(log))])
    # the direction of a step of (nearly) 0 is rounding noise: numpy sums the two paths'
    # eq. 3b products in another order
    moving = whole[:, SPEED] > 1e-12
    direction = np.where(moving, whole[:, DIRECTION], 0.0)
    np.testing.assert_allclose(np.where(moving, frames[:, DIRECTION], 0.0), direction,
                               rtol=1e-12)
    others = [j for j in range(COLUMN_COUNT) if j != DIRECTION]
    np.testing.assert_allclose(frames[:, others], whole[:, others], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(whole[:, MIDNIGHT], (log["time"] - 1_699_990_000.0) * 1000)


def test_a_wrap_of_the_position_register_is_not_a_turn() -> None:
    """The XM's present_position is a 32-bit count (as test_analysis.py); near 2**31 ticks a
    float64 wheel angle keeps ~1e-9 rad, so the rows agree to that."""
    wheels = _random_wheels(60)
    wheels[:, 1] = 1000 + 7 * np.arange(60)
    wrapped = wheels.copy()
    wrapped[:, 1] += 2**31 - wheels[30, 1]  # 2**31 - 1 -> -2**31 between frames 29 and 30
    wrapped[:, 1] = np.where(wrapped[:, 1] >= 2**31, wrapped[:, 1] - 2**32, wrapped[:, 1])
    assert wrapped[:, 1].min() < 0 < wrapped[:, 1].max()
    plain, odd = FicTracIntegrator(midnight_s=0.0), FicTracIntegrator(midnight_s=0.0)
    a = np.array([plain.update(w, k / 66, k) for k, w in enumerate(wheels)])
    b = np.array([odd.update(w, k / 66, k) for k, w in enumerate(wrapped)])
    rotation = [j for j in range(COLUMN_COUNT) if j != DIRECTION]
    np.testing.assert_allclose(b[:, rotation], a[:, rotation], atol=1e-7)


def test_reset_starts_a_new_sequence_and_keeps_the_mouse_sums() -> None:
    integrator = FicTracIntegrator(midnight_s=0.0)
    wheels = _random_wheels(10)
    for k in range(5):
        before = integrator.update(wheels[k], k / 66, k)
    integrator.reset()
    row = integrator.update(wheels[5], 5 / 66, 5)
    assert row.sequence_counter == 0 and row.frame_counter == 5
    assert row.forward_motion == pytest.approx(before.forward_motion + row.delta_rotation_lab_y)
    assert row.heading == pytest.approx(-row.delta_rotation_lab_z % (2 * math.pi))
    np.testing.assert_allclose([row.absolute_rotation_cam_x, row.absolute_rotation_cam_y,
                                row.absolute_rotation_cam_z],
                               [row.delta_rotation_cam_x, row.delta_rotation_cam_y,
                                row.delta_rotation_cam_z], atol=1e-15)


def test_the_orientation_keeps_turning_past_a_half_turn() -> None:
    """One wheel at 40 ticks a frame turns the ball 0.0394 rad a frame about one axis: past
    pi at frame 80, past 2 pi at 160. The rotation vectors stay those of the composed
    rotations (angle in [0, pi], as scipy gives them), where FicTrac's matrixToOmega would
    give 0 at exactly pi."""
    n = 200
    wheels = np.zeros((n, 3))
    wheels[:, 0] = 40 * np.arange(n)
    integrator = FicTracIntegrator(midnight_s=0.0)
    rows = np.array([integrator.update(wheels[k], k / 66, k) for k in range(n)])
    step = rows[1, DR_CAM]
    assert np.linalg.norm(step) == pytest.approx(40 * TICK * math.sin(math.radians(40)))
    cam = Rotation.from_rotvec(np.arange(n)[:, None] * step)
    np.testing.assert_allclose(rows[:, R_CAM], cam.as_rotvec(), atol=1e-9)
    tilted = FicTracIntegrator(midnight_s=0.0, cam_to_lab=[0.3, -0.2, 1.0])
    rows = np.array([tilted.update(wheels[k], k / 66, k) for k in range(n)])
    lab = Rotation.from_rotvec([0.3, -0.2, 1.0]) * cam
    got = Rotation.from_rotvec(rows[:, R_LAB])
    assert np.all((got.inv() * lab).magnitude() < 1e-9)  # the same rotations (pi: +-axis)
    assert np.all(np.linalg.norm(rows[:, R_CAM], axis=1) <= math.pi + 1e-12)


def test_cam_to_lab_takes_fictracs_rotation_vector_and_refuses_a_mirror() -> None:
    as_vector = FicTracIntegrator(cam_to_lab=[0.0, 0.0, math.pi])  # a fly facing image -x
    np.testing.assert_allclose(as_vector.cam_to_lab, np.diag([-1.0, -1.0, 1.0]), atol=1e-15)
    np.testing.assert_array_equal(FicTracIntegrator().cam_to_lab, DEFAULT_CAM_TO_LAB)
    with pytest.raises(FicTracError, match="not a rotation"):
        FicTracIntegrator(cam_to_lab=np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(FicTracError, match="shape"):
        FicTracIntegrator(cam_to_lab=np.eye(2))


def test_bad_frames_are_refused_in_one_line() -> None:
    integrator = FicTracIntegrator(midnight_s=0.0)
    with pytest.raises(FicTracError, match="3 finite tick counts"):
        integrator.update([1.0, 2.0], 0.0, 0)
    with pytest.raises(FicTracError, match=r"frame 1\.5 is not a whole number"):
        integrator.update([1.0, 2.0, 3.0], 0.0, 1.5)  # type: ignore[arg-type]
    with pytest.raises(FicTracError, match="unsigned int"):
        integrator.update([1.0, 2.0, 3.0], 0.0, -1)


# -- the file --------------------------------------------------------------------------------

def test_the_line_is_formatted_as_fictracs_logdata() -> None:
    """Trackball.cpp logData (lines 999-1026): ``ss.precision(14)`` on a default-format
    stream is C's %.14g, ``ss << cnt << ", "`` ... ``<< _data.ms << std::endl``; cnt and seq
    are ``unsigned int`` (include/Trackball.h, DATA)."""
    values = [0.0] * 25
    values[0], values[22] = 7, 3
    values[1], values[2], values[3] = 1 / 3, 1e-5, -0.5
    values[16] = 2 * math.pi
    values[21] = 1_700_000_000_123.4567
    line = format_line(FicTracRow(*values))
    assert line.endswith("\n") and "\r" not in line and not line.endswith(", \n")
    tokens = line[:-1].split(", ")
    assert len(tokens) == 25
    assert tokens[:4] == ["7", "0.33333333333333", "1e-05", "-0.5"]
    assert tokens[16] == "6.2831853071796" and tokens[21] == "1700000000123.5"
    assert tokens[22] == "3" and tokens[4] == "0"
    # the socket (and serial) output: "FT, " + the same line; scripts/socket_client.py reads
    # it with split(", "), toks[0] == "FT", int(toks[1]) the frame, int(toks[23]) the seq
    toks = socket_message(FicTracRow(*values))[:-1].split(", ")
    assert toks[0] == "FT" and int(toks[1]) == 7 and int(toks[23]) == 3 and len(toks) == 26


def test_file_name_is_fictracs() -> None:
    """Trackball.cpp line 399: ``_base_fn + "-" + exec_time + ".dat"``; include/timing.h
    execTime(): ``"%4d%02d%02d_%02d%02d%02d"`` of the local start time."""
    name = fictrac_filename("fictrac", datetime(2024, 1, 2, 3, 4, 5))
    assert name == "fictrac-20240102_030405.dat"
    assert re.fullmatch(r".+-\d{8}_\d{6}\.dat", name)


def test_writer_reader_round_trip_column_by_column(tmp_path: Path) -> None:
    rows = fictrac_rows(_fly_log(_random_wheels(80)), midnight_s=1_699_990_000.0)
    path = tmp_path / fictrac_filename("run", datetime(2024, 1, 2, 3, 4, 5))
    with FicTracWriter(path) as writer:
        writer.write_rows(rows)
        assert writer.rows == 80
    text = path.read_text()
    assert all(len(line.split(", ")) == COLUMN_COUNT for line in text.splitlines())
    back = read_fictrac_dat(path)
    assert back.shape == (80, COLUMN_COUNT)
    for j, (name, _) in enumerate(COLUMNS):
        if j in (CNT, SEQ):
            np.testing.assert_array_equal(back[:, j], rows[:, j], err_msg=name)
        else:  # 14 significant digits: within half a unit of the 14th
            np.testing.assert_allclose(back[:, j], rows[:, j], rtol=5e-14, atol=1e-300,
                                       err_msg=name)
    with pytest.raises(FicTracError, match="exists"):
        FicTracWriter(path)
    with FicTracWriter(path, overwrite=True) as writer, \
            pytest.raises(FicTracError, match="25 values, got 24"):
        writer.write(np.zeros(24))


def _write(path: Path, lines: list[str]) -> Path:
    path.write_text("".join(line + "\n" for line in lines))
    return path


def test_bad_files_are_refused_naming_file_and_line(tmp_path: Path) -> None:
    good = format_line(np.zeros(25))[:-1]
    old = ", ".join(["1"] * 23)  # FicTrac 2.02 and older
    with pytest.raises(FicTracError, match=r"old\.dat: line 2: 23 columns, a FicTrac \.dat "
                                           r"has 25 \(23 is FicTrac 2\.02 or older\)") as info:
        read_fictrac_dat(_write(tmp_path / "old.dat", [good, old]))
    assert info.value.line == 2 and "\n" not in str(info.value)
    with pytest.raises(FicTracError, match=r"sock\.dat: line 1: 26 columns"):
        read_fictrac_dat(_write(tmp_path / "sock.dat", ["FT, " + good]))
    word = good.split(", ")
    word[4] = "abc"
    with pytest.raises(FicTracError, match=r"line 1: column 5 \(delta_rotation_error\) is "
                                           r"'abc', not a number"):
        read_fictrac_dat(_write(tmp_path / "word.dat", [", ".join(word)]))
    half = good.split(", ")
    half[22] = "2.5"
    with pytest.raises(FicTracError, match=r"line 3: column 23 \(sequence_counter\) is 2\.5"):
        read_fictrac_dat(_write(tmp_path / "half.dat", [good, good, ", ".join(half)]))
    with pytest.raises(FicTracError, match="line 2: 1 columns"):
        read_fictrac_dat(_write(tmp_path / "blank.dat", [good, ""]))
    with pytest.raises(FicTracError, match="no such file"):
        read_fictrac_dat(tmp_path / "missing.dat")
    assert read_fictrac_dat(_write(tmp_path / "empty.dat", [])).shape == (0, 25)


# -- ROS -------------------------------------------------------------------------------------

def test_a_row_travels_as_a_float64_multiarray() -> None:
    from servolab.middleware.messages import MessageTypes

    types = MessageTypes()
    row = FicTracRow(*fictrac_rows(_fly_log(_random_wheels(3)), midnight_s=0.0)[-1])
    name = "std_msgs/msg/Float64MultiArray"
    message = types.from_value(name, multiarray_value(row))
    back = types.deserialize(types.serialize(message), name)
    assert row_from_multiarray(back) == row
    other = types.from_value(name, {"data": np.zeros(25)})
    with pytest.raises(FicTracError, match="not a FicTrac row"):
        row_from_multiarray(other)
