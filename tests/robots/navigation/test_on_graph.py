"""``servolab navigate --map``, a robot on the graph: what is checked before anything opens,
and how an outage of odometry is counted. The run itself, with three Waffles and a router
killed mid-run, is tests/robots/test_fleet_hosts.py."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from servolab.middleware.transport import TransportOptions
from servolab.robots.navigation.on_graph import OUTAGE_S, OdometryWatch, prepare
from servolab.robots.navigation.session import NavigationError
from servolab.vision.map_file import MapFileError, save_map
from tests.clirun import refusal

REPO = Path(__file__).resolve().parents[3]
FLOOR = REPO / "configs" / "fleet_floor.yaml"
ZENOH = TransportOptions("zenoh")


def test_the_shipped_fleet_floor_takes_a_start_and_a_goal() -> None:
    navigation = prepare(FLOOR, (0.3, 1.0, 0.0), (1.0, 1.0), ZENOH, namespace="/robot1")
    assert navigation.goal == (1.0, 1.0, 0.0)   # facing the way from the start
    assert navigation.topic("diff_drive_controller/cmd_vel") == \
        "/robot1/diff_drive_controller/cmd_vel"


@pytest.mark.parametrize(("start", "goal", "says"), [
    ((0.3, 1.0, 0.0), (3.5, 1.0), "the goal (3.5, 1) is off the map"),
    ((0.3, 1.0, 0.0), (1.5, 1.0), "the goal (1.5, 1) is on an occupied"),
    ((0.0, 0.0, 0.0), (1.0, 1.0), "the initial pose (0, 0) is on an occupied"),
    ((0.3, math.nan, 0.0), (1.0, 1.0), "must be finite"),
])
def test_a_start_or_goal_the_map_cannot_take_is_refused(
        start: tuple[float, float, float], goal: tuple[float, float], says: str) -> None:
    with pytest.raises(NavigationError, match=says.replace("(", r"\(").replace(")", r"\)")):
        prepare(FLOOR, start, goal, ZENOH)


def test_a_rotated_map_and_a_bad_topic_are_refused(tmp_path: Path) -> None:
    yaml_path, _ = save_map(tmp_path / "turned", np.zeros((10, 10), bool), 0.1, (0, 0, 0))
    yaml_path.write_text(yaml_path.read_text().replace("origin: [0.000000, 0.000000, "
                                                       "0.000000]", "origin: [0, 0, 0.5]"))
    with pytest.raises(MapFileError, match=r"turned.yaml:3: key 'origin': yaw 0.5 rad"):
        prepare(yaml_path, (0.5, 0.5, 0.0), (0.6, 0.6), ZENOH)
    with pytest.raises(NavigationError, match="--cmd-vel 'cmd vel'"):
        prepare(FLOOR, (0.3, 1.0, 0.0), (1.0, 1.0), ZENOH, cmd_vel="cmd vel")


def test_an_outage_is_a_silence_longer_than_the_pose_timeout_with_what_was_lost() -> None:
    watch = OdometryWatch()
    period = 0.02
    for k in range(100):                       # 2 s of odometry at 50 Hz
        watch.add(10.0 + k * period, 500.0 + k * period)
    for k in range(150, 200):                  # k 100..149 never arrived: 1 s silent
        watch.add(10.0 + k * period + 0.003, 500.0 + k * period)
    assert watch.period() == pytest.approx(period)
    (outage,) = watch.outages(since=10.0)
    assert outage.lost == 50
    assert outage.start_s == pytest.approx(99 * period)
    assert outage.seconds == pytest.approx(51 * period + 0.003)
    assert outage.seconds > OUTAGE_S
    # odometry that never comes back is an outage to the run's end
    (*_, last) = watch.outages(since=10.0, until=10.0 + 199 * period + 2.0)
    assert last.seconds == pytest.approx(2.0 - 0.003)
    assert last.lost == round(2.0 / period) - 1
    # a late message or two is no outage
    jittery = OdometryWatch()
    for k in range(50):
        jittery.add(k * period + (0.3 if k == 20 else 0.0), k * period)
    assert jittery.outages(since=0.0) == []


@pytest.mark.parametrize(("argv", "says"), [
    (["--initial-pose", "0", "0"], "--initial-pose: for a robot on the graph, with --map"),
    (["--connect", "tcp/127.0.0.1:7"], "--connect: for a robot on the graph, with --map"),
    (["--transport", "dds", "--domain-id", "3"],
     "--domain-id, --transport dds: for a robot on the graph, with --map"),
    (["--map", str(FLOOR)], "--map needs --initial-pose"),
    (["--map", str(FLOOR), "--initial-pose", "0.3", "1", "--scene", "x.yaml"],
     "--scene: for the simulated floor, not with --map"),
])
def test_the_two_kinds_of_run_refuse_each_others_options(
        argv: list[str], says: str, capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    status, line = refusal(["navigate", "--goal", "1", "1", "--out", str(tmp_path / "run"),
                            *argv], capsys)
    assert status == 2 and says in line, line
    assert not (tmp_path / "run").exists()
