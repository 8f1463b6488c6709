"""``servolab teleop`` from end to end on two emulated arms in virtual time: its run folder, a
bag that mcap's own readers decode (``mcap`` + ``mcap-ros2-support``, not servolab's) with the
documented topics and episode marks, camera images of the MuJoCo follower, and the stops: the
summary says what ended the run and where the follower was held."""

from __future__ import annotations

import json
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from servolab.cli import main
from servolab.harness import StopSignal
from servolab.robots.teleop.hand import Episodes
from servolab.robots.teleop.loop import LeaderLost, LoopOptions, TeleopLoop
from servolab.robots.teleop.run import run_teleop
from servolab.runs import RunFolder

from .conftest import FAST, request

JOINTS = ["joint1", "joint2", "joint3", "joint4", "gripper_left_joint"]


def decoded(bag: Path) -> dict[str, list[tuple[int, Any]]]:
    """Each topic's (log time ns, message), decoded by mcap-ros2-support."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    found: dict[str, list[tuple[int, Any]]] = defaultdict(list)
    (path,) = bag.glob("*.mcap")
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _schema, channel, message, msg in reader.iter_decoded_messages():
            found[channel.topic].append((message.log_time, msg))
    return found


@pytest.mark.slow
def test_two_episodes_are_recorded_with_images_and_decode_with_mcap(tmp_path: Path) -> None:
    options = LoopOptions(rate=FAST.rate, state_rate=50.0, camera_rate=5.0, engage_speed=5.0)
    summary = run_teleop(RunFolder.create("teleop", tmp_path),
                         request(episodes=Episodes(0.6, 2, 0.3), camera=True, options=options),
                         say=lambda _: None)
    written = json.loads((tmp_path / "summary.json").read_text())
    assert written["interrupted"] is None and summary["clock"] == "virtual"
    assert [(e["index"], e["complete"]) for e in summary["episodes"]] == [(0, True), (1, True)]
    loop = summary["loop"]
    assert loop["commands_lost"] == 0 and loop["commands_checked"] > 0
    assert set(summary["held"]) == set(JOINTS)
    assert (tmp_path / "teleop.png").stat().st_size > 0
    assert written["loop"]["cycles"] == loop["cycles"]

    topics = decoded(tmp_path / "teleop_bag")
    cycles = loop["cycles"]
    assert {t: len(m) for t, m in topics.items()} == {
        "/teleop/episode": 5, "/leader/joint_states": cycles,
        "/follower/joint_commands": cycles, "/follower/joint_states": loop["state_reads"],
        "/follower/camera/image/compressed": summary["bag"]["camera_frames"]}
    assert summary["bag"]["messages"] == sum(len(m) for m in topics.values())
    # the marks: none while engaging, then 0, none (the reset), 1, none
    marks = topics["/teleop/episode"]
    assert [m.data for _, m in marks] == [-1, 0, -1, 1, -1]
    for (start, _), (end, _), episode in zip(marks[1::2], marks[2::2], summary["episodes"],
                                             strict=True):
        assert (start / 1e9, end / 1e9) == pytest.approx((episode["start_s"],
                                                          episode["end_s"]), abs=1e-6)
        inside = [m for t, m in topics["/follower/joint_commands"] if start <= t < end]
        assert len(inside) == episode["cycles"]
    # every message's log time is its stamp; names and units as documented
    for topic in ("/leader/joint_states", "/follower/joint_commands",
                  "/follower/joint_states"):
        for t, msg in topics[topic][:50]:
            assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == t
            assert list(msg.name) == JOINTS
    state = topics["/follower/joint_states"][-1][1]
    assert len(state.position) == len(state.velocity) == len(state.effort) == 5
    assert abs(state.position[4]) < 0.02 and abs(state.effort[1]) > 0.01  # m; N m (gravity)
    # the action is the leader's reading, within the follower's limits
    for (_, leader), (_, command) in zip(topics["/leader/joint_states"][-20:],
                                         topics["/follower/joint_commands"][-20:], strict=True):
        assert list(command.position) == pytest.approx(list(leader.position))
    # images: JPEG of the MuJoCo follower, 320 x 240
    import cv2

    frames = topics["/follower/camera/image/compressed"]
    assert len(frames) >= 5 and frames[0][1].format == "jpeg"
    image = cv2.imdecode(np.frombuffer(bytes(frames[-1][1].data), np.uint8), cv2.IMREAD_COLOR)
    assert image.shape == (240, 320, 3) and image.std() > 10


def test_ctrl_c_ends_the_episode_incomplete_and_the_follower_holds(tmp_path: Path) -> None:
    def interrupt(loop: TeleopLoop) -> None:
        if loop.episode == 0 and loop.record.episodes[-1].cycles == 30:
            raise StopSignal(2)

    with pytest.raises(StopSignal):
        run_teleop(RunFolder.create("teleop", tmp_path), request(), say=lambda _: None,
                   on_cycle=interrupt)
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["interrupted"] == "SIGINT"
    assert [(e["cycles"], e["complete"]) for e in summary["episodes"]] == [(30, False)]
    assert set(summary["held"]) == set(JOINTS)
    marks = [m.data for _, m in decoded(tmp_path / "teleop_bag")["/teleop/episode"]]
    assert marks == [-1, 0, -1]


def test_a_silent_leader_ends_the_run_as_a_failure_with_the_follower_held(tmp_path: Path
                                                                           ) -> None:
    unplugged: list[int] = []

    def unplug(loop: TeleopLoop) -> None:
        emulator = loop.leader.bus.emulator
        if loop.episode == 0 and not unplugged:
            unplugged.extend(loop.leader.ids)
            for motor_id in unplugged:
                emulator.unplug(motor_id)

    with pytest.raises(LeaderLost):
        run_teleop(RunFolder.create("teleop", tmp_path), request(), say=lambda _: None,
                   on_cycle=unplug)
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["interrupted"].startswith("LeaderLost: the leader stopped answering")
    assert summary["loop"]["leader_failures"] >= 2 and "held" in summary


def test_the_command_runs_and_refuses_bad_input_before_a_run_folder(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "run"
    assert main(["teleop", "--seconds", "0.3", "--rate", "100", "--world", "emulated",
                 "--no-camera", "--out", str(out)]) == 0
    said = capsys.readouterr().out
    assert "1 episode recorded;" in said and "0 of " in said and "commands lost" in said
    summary = json.loads((out / "summary.json").read_text())
    assert summary["world"] == "emulated" and summary["camera"] is None
    assert (out / "teleop_bag" / "metadata.yaml").exists()

    refused = tmp_path / "refused"
    assert main(["teleop", "--leader", "emu://xm430-w350:11-15", "--out", str(refused)]) == 2
    assert capsys.readouterr().err.strip().endswith(
        "--leader emu://xm430-w350:11-15: emu:// alone is the arm emulated here (its own "
        "motors, from its URDF)")
    assert main(["teleop", "--robot", "seed000", "--out", str(refused)]) == 2
    assert "seed000 has no URDF" in capsys.readouterr().err
    assert not refused.exists()
