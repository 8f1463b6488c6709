"""Seed 002's closed loop on the simulated fly, ball and robot (servolab flyball): the fly is
held near the centre while it walks, every frame is logged in the thesis's layout, the robot
drives, the motors end stopped with torque off, and the logs are analysed as chapter 3 does.
Read back with independent readers (struct for the binary logs, mcap-ros2-support for the bag).
"""

from __future__ import annotations

import struct
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap_ros2.reader import read_ros2_messages

from servolab.cli import main
from servolab.clock import VirtualClock
from servolab.dynamixel.bus import Bus
from servolab.middleware.context import Context
from servolab.robots.treadmill.camera_node import CameraNode
from servolab.robots.treadmill.node import TREADMILL_IDS, TreadmillNode
from servolab.robots.treadmill.run import run_flyball
from servolab.runs import RunFolder
from servolab.sim import Simulation
from servolab.vision.fly_render import FlyPose, render_fly
from tests.clirun import refusal

pytestmark = pytest.mark.slow
DURATION = 20.0
#: the module's run: seed 1's, whose 20 s run is the one issue 28's figures are about (see
#: test_the_robot_draws_the_spheres_path_with_each_clamp, which compares another clamp to it)
SEED = 1


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """``servolab flyball --duration 20 --seed 1`` (the default clamp, scaled), once for the
    tests of this module, which only read what it left."""
    folder = RunFolder.create("flyball", tmp_path_factory.mktemp("fly") / "run")
    summary = run_flyball(folder, duration=DURATION, seed=SEED, say=lambda _: None,
                          show_progress=False)
    summary["folder"] = folder.path
    return summary


def test_every_frame_is_logged_in_the_thesis_layout(run: dict[str, Any]) -> None:
    """Listing 1: 17 float64 per frame, no header, at 66 frames/s (Listing 3)."""
    data = Path(run["fly_data"]).read_bytes()
    assert len(data) == 136 * run["frames"]
    assert run["frames"] == pytest.approx(66 * DURATION, abs=2)
    first = struct.unpack_from("<17d", data, 0)
    last = struct.unpack_from("<17d", data, len(data) - 136)
    assert (first[0], last[0]) == (0.0, run["frames"] - 1.0)  # frame numbers
    assert last[16] - first[16] == pytest.approx(DURATION, abs=0.05)  # time
    assert last[2] == pytest.approx(1e6 / 66, rel=0.01)  # sampling time, µs
    encoders = Path(run["robot_encoders"]).read_bytes()
    assert len(encoders) % 24 == 0 and len(encoders) // 24 == run["encoder_records"] > 0


def test_the_fly_is_held_while_it_walks(run: dict[str, Any]) -> None:
    analysis = run["analysis"]
    assert analysis["frames_with_fly"] == analysis["frames"]  # never lost from view
    # it walked far further than it strayed: the ball carried it back
    assert run["fly_walked_m"] * 1000 > 5 * analysis["mean_distance_error_mm"]
    assert analysis["mean_distance_error_mm"] < 4.0
    assert analysis["sphere_path_length_m"] > 0.5 * run["fly_walked_m"]
    # the wheels answer about 110 ms after the frame that starts them (seed 002, ch. 3)
    assert analysis["response_delay_s"] == pytest.approx(0.11, abs=0.03)


def test_the_robot_is_driven_and_it_is_all_recorded(run: dict[str, Any]) -> None:
    (mcap,) = Path(run["bag"]).glob("*.mcap")
    topics = {m.channel.topic for m in read_ros2_messages(str(mcap))}
    assert topics == {"/cmd_vel", "/fly/pose", "/treadmill/joint_states", "/sensor_state", "/odom"}
    twists = [m.ros_msg for m in read_ros2_messages(str(mcap), topics=["/cmd_vel"])]
    assert any(t.linear.x > 0 for t in twists)
    assert run["analysis"]["robot_path_length_m"] > 0.05
    assert Path(run["plot"]).stat().st_size > 20_000


def test_analyze_reads_the_logs_again(run: dict[str, Any], capsys: pytest.CaptureFixture[str]
                                      ) -> None:
    assert main(["flyball", "analyze", str(run["folder"])]) == 0
    out = capsys.readouterr().out
    assert f"{run['analysis']['mean_distance_error_mm']:.3f} mm" in out
    assert (Path(run["folder"]) / "analysis.json").exists()


def test_a_truncated_log_is_named_with_its_count(run: dict[str, Any], tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    data = Path(run["fly_data"]).read_bytes()
    (tmp_path / "fly_data.bin").write_bytes(data[:136 * 10 + 7])
    (tmp_path / "robot_encoders.bin").write_bytes(Path(run["robot_encoders"]).read_bytes())
    status, line = refusal(["flyball", "analyze", str(tmp_path)], capsys)
    assert status == 2 and line.startswith("servolab flyball analyze: error: ")
    assert "10 whole records of 136 bytes and 7 bytes more" in line


def test_the_node_takes_image_raw_and_stops_the_wheels_when_destroyed() -> None:
    """Listing 1's image_converter: frames on /image_raw (a camera node here), each one
    SYNC_WRITE; its motor_deinit: goal velocity 0 and torque off once the node is gone."""
    sim = Simulation()
    bus = Bus.open("emu://xm430-w210:100-102", baudrate=1_000_000, simulation=sim)
    frames = [render_fly(FlyPose(420.0, 250.0, 0.4))[0] for _ in range(5)]

    def camera() -> np.ndarray | None:
        return frames.pop() if frames else None

    with Context.open(clock=VirtualClock()) as context:
        node = TreadmillNode(context, bus)
        reader = CameraNode(context, camera, frame_rate=66.0)
        context.spin_until(lambda: reader.finished, timeout=1.0)
        context.spin_for(0.05)
        assert node.frames == 5 and node.last is not None
        assert node.last[1].compensating  # the fly was off centre: the wheels were told
        assert set(bus.sync_read("goal_velocity", TREADMILL_IDS, raw=True).values()) != {0}
        timing = node.timing()
        assert timing["frames"] == 5 and timing["dropped_frames"] == 0
        assert timing["achieved_fps"] == pytest.approx(66.0)
    torque = bus.sync_read("torque_enable", TREADMILL_IDS)
    goal = bus.sync_read("goal_velocity", TREADMILL_IDS, raw=True)
    assert set(torque.values()) == {0} and set(goal.values()) == {0}


def test_recorded_frames_are_tracked_one_record_each(tmp_path: Path) -> None:
    """--frames DIR: a folder of images in name order, one record per frame; the tracker's
    centroid is the drawn fly's (within 0.5 px, the tracker's accuracy)."""
    import cv2

    from servolab.robots.treadmill.logs import read_fly_log

    frames = tmp_path / "frames"
    frames.mkdir()
    truths = []
    for k in range(12):
        image, truth = render_fly(FlyPose(300.0 + 8 * k, 200.0 - 3 * k, 0.1 * k),
                                  noise_std=3.0, rng=np.random.default_rng(k))
        assert truth is not None
        truths.append((truth.cx, truth.cy))
        cv2.imwrite(str(frames / f"frame{k}.png"), image)
    out = tmp_path / "run"
    assert main(["flyball", "--frames", str(frames), "--out", str(out), "--no-progress"]) == 0
    records = read_fly_log(out / "fly_data.bin")
    assert len(records) == 12
    got = np.column_stack([records["cx"], records["cy"]])
    assert np.max(np.hypot(*(got - np.array(truths)).T)) < 0.5


@pytest.mark.parametrize(("fps", "option", "time_base"), [
    (30.0, None, "the video's own: video CAP_PROP_POS_MSEC"),
    (30.0, "25", "given (--fps)"),
])
def test_a_video_plays_at_its_own_frame_rate(tmp_path: Path, fps: float, option: str | None,
                                             time_base: str) -> None:
    """Issue 28: a 30 fps video spanned 30 frames / 66 fps = 0.45 s instead of 1 s, and the
    controller divides by that time. Now the run's time base is the video's CAP_PROP_FPS
    (written by cv2.VideoWriter, read back by cv2.VideoCapture), or --fps; summary.json says
    which, and the log's time and sampling fields (Listing 1's layout) follow it."""
    import json

    import cv2

    from servolab.robots.treadmill.logs import read_fly_log

    video = tmp_path / "fly.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter.fourcc(*"MJPG"), fps, (640, 376),
                             isColor=False)
    assert writer.isOpened()
    frames = 30
    for k in range(frames):
        image, _ = render_fly(FlyPose(300.0 + 4 * k, 200.0, 0.05 * k))
        writer.write(image)
    writer.release()
    out = tmp_path / "run"
    extra = ["--fps", option] if option else []
    assert main(["flyball", "--frames", str(video), *extra, "--out", str(out),
                 "--no-progress"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    rate = float(option) if option else fps
    assert summary["frame_rate_hz"] == pytest.approx(rate)
    assert summary["time_base"] == time_base
    records = read_fly_log(out / "fly_data.bin")
    assert len(records) == frames
    assert records["time"][-1] - records["time"][0] == pytest.approx((frames - 1) / rate,
                                                                       rel=0.01)
    assert records["sampling_time_us"][-1] == pytest.approx(1e6 / rate, rel=0.01)


@pytest.mark.parametrize(("args", "message"), [
    (["--frames", "MISSING"], "MISSING: no such file or folder"),
    (["--fps", "30"], "give --frames too"),
    (["--port", "/dev/null"], "give --frames or --camera too"),
    (["--size", "640x376"], "the simulated camera's is the rig's"),
    (["--size", "640by376", "--frames", "/tmp"], "not a size WxH"),
    (["--frames", "/tmp", "--camera", "0"], "give one"),
    (["--duration", "-1"], "argument --duration"),
    (["--frames", "/tmp", "--duration", "5"], "a recording (--frames) runs as long as it is"),
])
def test_bad_input_is_one_line(tmp_path: Path, args: list[str], message: str,
                               capsys: pytest.CaptureFixture[str]) -> None:
    status, line = refusal(["flyball", *args, "--out", str(tmp_path / "run")], capsys)
    assert status == 2 and message in line
    assert not (tmp_path / "run").exists()


def test_a_video_that_cannot_be_opened_is_named(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    video = tmp_path / "broken.avi"
    video.write_bytes(b"not a video at all" * 100)
    status, line = refusal(["flyball", "--frames", str(video), "--out", str(tmp_path / "run")],
                           capsys)
    assert status == 2 and f"{video}: OpenCV cannot open this video" in line


def test_ctrl_c_stops_the_wheels_and_keeps_the_analysis(tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """Ctrl-C 40 frames in: the exception goes on up (the CLI exits 130), but the wheels are
    stopped first, and the logs are analysed into summary.json, marked interrupted."""
    import json

    from servolab.sim.fly_camera import SimulatedFlyCamera

    real = SimulatedFlyCamera.__call__

    def interrupting(self: SimulatedFlyCamera) -> np.ndarray:
        if self.frames == 40:
            raise KeyboardInterrupt
        return real(self)

    monkeypatch.setattr(SimulatedFlyCamera, "__call__", interrupting)
    folder = RunFolder.create("flyball", tmp_path / "run")
    with pytest.raises(KeyboardInterrupt):
        run_flyball(folder, duration=5.0, say=lambda _: None, show_progress=False)
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["interrupted"] == "SIGINT"  # a KeyboardInterrupt is Ctrl-C's
    assert summary["frames"] == 40 and summary["analysis"]["frames"] == 40


def test_analyze_a_treadmill_without_a_robot(run: dict[str, Any], tmp_path: Path) -> None:
    (tmp_path / "fly_data.bin").write_bytes(Path(run["fly_data"]).read_bytes())
    assert main(["flyball", "analyze", str(tmp_path)]) == 0


def _net_turning(path: np.ndarray) -> float:
    """The signed total turn (rad) of a path drawn with y up: counter-clockwise positive."""
    steps = np.diff(np.asarray(path, dtype=float), axis=0)
    steps = steps[np.hypot(steps[:, 0], steps[:, 1]) > 1e-9]
    heading = np.unwrap(np.arctan2(steps[:, 1], steps[:, 0]))
    return float(heading[-1] - heading[0])


def test_the_robot_draws_the_spheres_path_with_each_clamp(run: dict[str, Any],
                                                          tmp_path: Path) -> None:
    """Issue 28 on seed 002's Figure 21: with the Waffle as ROBOTIS sets it up (right motor
    in reverse Drive Mode), both encoders count up driving forward, and the robot's path has
    the sphere's shape (disparity <= 0.05 on seed 1's 20 s run; it was 0.76 with the right
    encoder counting backwards) and turns the sphere's way. Listing 4's per-wheel clamp
    (``--clamp per-wheel``) is reported beside it. The scaled clamp's run is the module's
    (seed 1, 20 s, the default clamp); the per-wheel run is the same but for its clamp."""
    from servolab.robots.treadmill.analysis import analyze
    from servolab.robots.treadmill.logs import read_encoder_log, read_fly_log

    runs = {}
    for clamp in ("scaled", "per-wheel"):
        if clamp == "scaled":
            summary = run
        else:
            folder = RunFolder.create("flyball", tmp_path / clamp)
            summary = run_flyball(folder, duration=DURATION, seed=SEED, say=lambda _: None,
                                  show_progress=False, wheel_clamp=clamp)
        assert summary["wheel_clamp"] == clamp
        fly = read_fly_log(summary["fly_data"])
        encoders = read_encoder_log(summary["robot_encoders"])
        result, series = analyze(fly, encoders)
        runs[clamp] = (result, series, encoders)
    result, series, encoders = runs["scaled"]
    assert result.path_disparity <= 0.05
    sphere, robot = _net_turning(series["sphere_path"]), _net_turning(series["robot_path"])
    assert sphere * robot > 0 and abs(sphere) > 0.5, (sphere, robot)
    # driving forward (the robot's command is always forward, Listing 1): both count up
    assert encoders["left"][-1] > encoders["left"][0]
    assert encoders["right"][-1] > encoders["right"][0]
    per_wheel = runs["per-wheel"][0]
    assert 0.0 <= per_wheel.path_disparity <= 1.0  # reported: the thesis's robot
    assert per_wheel.robot_path_length_m != pytest.approx(result.robot_path_length_m, rel=0.01)


def test_fictrac_output_reads_back_as_the_runs_own_figures(run: dict[str, Any]) -> None:
    """FicTrac's .dat (rjdmoore/fictrac doc/data_header.txt, 25 columns; Trackball.cpp's
    "%.14g" joined by ", ") read back with FicTrac's layout: one row per logged frame, its
    frame counter the log's camera frame number, its timestamp the frame's capture stamp
    (ms), and every column what the whole-run computation from fly_data.bin gives."""
    from servolab.robots.treadmill.fictrac import fictrac_rows, read_fictrac_dat
    from servolab.robots.treadmill.logs import read_fly_log

    dat = read_fictrac_dat(run["fictrac"])
    fly = read_fly_log(run["fly_data"])
    assert dat.shape == (len(fly), 25)
    assert np.array_equal(dat[:, 0], fly["frame"])  # column 1: the camera's frame number
    assert np.array_equal(dat[:, 22], np.arange(len(fly)))  # column 23: frames since start
    stamps = dat[:, 21] / 1000.0  # column 22: ms; the camera's 66 frames/s (a frame is
    # taken when the executor gets to its timer: up to a bus transaction late, under 1 ms)
    assert np.allclose(np.diff(stamps), 1 / 66.0, atol=1e-3)
    np.testing.assert_allclose(dat[:, 23][1:], np.diff(dat[:, 21]), atol=1e-6)  # column 24
    # the integrated position is the analysis's own sphere path (Figure 20, eq. 3b), in rad of
    # ball rotation: x rad * r = x m, FicTrac's y the path's -y (FicTrac's frame, see fictrac.py)
    from servolab.kinematics.aot import AotGeometry
    from servolab.robots.treadmill.analysis import fictive_path, sphere_motion

    path = fictive_path(sphere_motion(fly, AotGeometry())[2])
    radius = AotGeometry().wheel_radius
    np.testing.assert_allclose(dat[:, 14] * radius, path[:, 0], atol=1e-7)
    np.testing.assert_allclose(-dat[:, 15] * radius, path[:, 1], atol=1e-7)
    whole = fictrac_rows(fly)
    for column in (1, 2, 3, 8, 9, 10, 14, 15, 16, 18, 19, 20):
        np.testing.assert_allclose(dat[:, column], whole[:, column], rtol=1e-9, atol=1e-12,
                                   err_msg=f"column {column + 1}")
    assert np.ptp(dat[:, 14]) > 0 or np.ptp(dat[:, 15]) > 0  # the ball rolled


def test_dropped_and_late_frames_are_counted_exactly() -> None:
    """A source whose numbering skips 3 and 4 (frames lost before the node) and whose frame 6
    was stamped 5 ms before it could be read: 2 dropped (from the camera's numbers, which its
    node passes on), 1 late against late_after = 0.2 frame periods (3 ms), and the frames'
    numbers are the source's."""
    from dataclasses import replace
    from types import SimpleNamespace

    from servolab.robots.treadmill.config import RigConfig

    period = 1 / 66.0
    image = render_fly(FlyPose(330.0, 190.0, 0.1))[0]
    numbers = [0, 1, 2, 5, 6, 7, 8]
    frames = [SimpleNamespace(image=image, sequence=k,
                              stamp=i * period - (0.005 if k == 6 else 0.0))
              for i, k in enumerate(numbers)]
    source = SimpleNamespace(read=lambda: frames.pop(0) if frames else None)
    sim = Simulation()
    bus = Bus.open("emu://xm430-w210:100-102", baudrate=1_000_000, simulation=sim)
    with Context.open(clock=VirtualClock()) as context:
        reader = CameraNode(context, source, frame_rate=66.0)
        node = TreadmillNode(context, bus, rig=replace(RigConfig(), late_after=0.2),
                             camera=reader)
        context.spin_until(lambda: reader.finished, timeout=1.0)
        context.spin_for(0.05)
        timing = node.timing()
    assert node.sequences == numbers
    assert (timing["frames"], timing["dropped_frames"], timing["camera_frames"]) == (7, 2, 9)
    assert timing["late_frames"] == 1 and timing["latency_ms"]["max"] == pytest.approx(5.0)
    assert reader.skipped == 2


def test_a_wheel_read_that_fails_keeps_the_last_positions_then_ends_the_run() -> None:
    """Listing 1 logs "groupSyncRead getdata failed" and goes on; so does the node, for up to
    MAX_MISSED_READS frames in a row (the positions kept, the misses counted), then it stops
    the run rather than turn the ball blind."""
    from servolab.errors import ServolabError
    from servolab.robots.treadmill.node import MAX_MISSED_READS

    sim = Simulation()
    bus = Bus.open("emu://xm430-w210:100-102", baudrate=1_000_000, simulation=sim)
    frame = render_fly(FlyPose(420.0, 250.0, 0.4))[0]
    with Context.open(clock=VirtualClock()) as context:
        node = TreadmillNode(context, bus)
        CameraNode(context, lambda: frame, frame_rate=66.0)
        context.spin_until(lambda: node.frames >= 3, timeout=1.0)
        kept = node._last_present
        motor = bus.emulator.unplug(101)
        context.spin_until(lambda: node.missed_reads >= 2, timeout=1.0)
        assert node._last_present == kept and node.timing()["wheel_reads_missed"] >= 2
        bus.emulator.add(motor)  # back: reads work again
        missed = node.missed_reads
        context.spin_until(lambda: node._missed_in_a_row == 0, timeout=1.0)
        assert node.missed_reads == missed
        bus.emulator.unplug(101)
        with pytest.raises(ServolabError, match=rf"for {MAX_MISSED_READS + 1} frame\(s\) in a "
                           "row"):
            context.spin_for(1.0)
