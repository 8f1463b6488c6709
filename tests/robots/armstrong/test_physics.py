"""Armstrong in the MuJoCo world: the same robot code on the same emulated bus, with gravity.

Facts checked against sources other than this code:

- a body at rest on the floor: the floor carries its weight (the model's masses x g) and the
  zero-moment point lies under its centre of mass (static equilibrium; Vukobratović &
  Borovac 2004);
- the joints stand where the controllers sent them, less the compliance slope's sag
  (e-Manual, RX-28 Compliance): read over the bus, and in MuJoCo's own joint angles through
  the description's directions (Table 4.2's signs);
- a robot whose servos let go falls (the RX-28 with Torque Enable 0 gives no torque; its
  gears' friction, an assumption, cannot hold bent knees);
- the recording is read back by an independent decoder (``mcap`` + ``mcap-ros2-support``).
"""

from __future__ import annotations

import json
import math
import subprocess
from pathlib import Path

import numpy as np
import pytest
from mcap_ros2.reader import read_ros2_messages

from servolab.robots.armstrong.control_node import Armstrong
from servolab.robots.armstrong.description import Assumptions
from servolab.robots.armstrong.poses import MOTORS, STAND_POSE
from servolab.robots.errors import RobotValueError
from tests.clirun import servolab
from tests.simproc import sim_process

from .configs import ping_once_config

LEGS = MOTORS[:12]
RX28_TICK_DEG = 300.0 / 1023


@pytest.fixture(scope="module")
def standing(tmp_path_factory: pytest.TempPathFactory) -> Armstrong:
    config = ping_once_config(tmp_path_factory.mktemp("config"))
    robot = Armstrong(world="mujoco", config=config)
    robot.stand()
    robot.context.spin_for(1.0)
    yield robot
    robot.close()


def test_it_stands_on_its_feet_with_its_weight_over_them(standing: Armstrong) -> None:
    physics = standing.physics
    assert physics is not None and not standing.fallen
    world = physics.world
    last = world.samples[-20:]                      # the last 0.2 s, at rest
    weight = float(world.model.body_subtreemass[1]) * 9.81
    assert weight == pytest.approx(physics.description.total_mass * 9.81)
    assert np.mean([sum(s.feet) for s in last]) == pytest.approx(weight, rel=0.02)
    assert all(f > 0.2 * weight for s in last for f in s.feet)   # both feet bear it
    zmp = np.array([s.zmp for s in last])
    com = np.array([s.com[:2] for s in last])
    np.testing.assert_allclose(zmp.mean(axis=0), com.mean(axis=0), atol=0.003)
    assert min(s.margin for s in last) > 0.02       # well inside the feet


def test_the_joints_stand_where_they_were_sent_less_the_slopes_sag(standing: Armstrong
                                                                   ) -> None:
    physics = standing.physics
    assert physics is not None
    world = physics.world
    present = standing.node.present                 # degrees, from /controller_mXX/state
    for joint, motor in physics.description.motors:
        if not motor.on_bus:
            continue
        sent = STAND_POSE[motor.column]
        # loaded leg joints sag by up to the slope's share of their load: at most 32 ticks
        assert present[motor.column] == pytest.approx(sent, abs=32 * RX28_TICK_DEG)
        # MuJoCo's joint angle, through the description's direction, is the motor's
        qpos = world.data.qpos[world.model.joint(joint.name).qposadr[0]]
        assert motor.direction * math.degrees(qpos) == pytest.approx(
            present[motor.column], abs=RX28_TICK_DEG)


def test_the_ground_truth_says_where_it_stands(standing: Armstrong) -> None:
    physics = standing.physics
    assert physics is not None
    truth = physics.world.ground_truth()
    assert truth["z"] == pytest.approx(
        physics.description.standing_height(STAND_POSE), abs=0.01)
    assert truth["fallen"] == 0.0
    assert abs(truth["roll"]) < 0.05 and abs(truth["pitch"]) < 0.1


def test_a_robot_whose_servos_let_go_falls(tmp_path: Path) -> None:
    with Armstrong(world="mujoco", config=ping_once_config(tmp_path)) as robot:
        robot.stand()                               # knees bent (Table 4.2)
        assert not robot.fallen
        robot.bus.broadcast_write("torque_enable", 0)   # every motor lets go
        assert robot.context.spin_until(lambda: robot.fallen, timeout=3.0)
        physics = robot.physics
        assert physics is not None and physics.world.fell_at is not None
        robot.context.spin_for(1.0)
        assert physics.world.ground_truth()["z"] < 0.2        # down on the floor (0.29 standing)
        assert robot.should_stop()


def test_worlds_and_assumptions_are_checked_before_anything_moves() -> None:
    with pytest.raises(RobotValueError, match="no world 'gazebo'"):
        Armstrong(world="gazebo")
    with pytest.raises(RobotValueError, match="worlds are for the emulated robot"):
        Armstrong(world="mujoco", port="/dev/ttyUSB0")
    with pytest.raises(RobotValueError, match="did you mean 'hip_width'"):
        Assumptions.with_values({"hip_widht": 0.1})


def _walk(tmp_path: Path, *args: str) -> subprocess.CompletedProcess[str]:
    """``servolab walk --world mujoco ARGS`` with the shipped configuration, as a user (and
    docs/plots.py) runs it: its start-up is part of the run (the robot stands on straight
    legs meanwhile), and the docs' numbers are this run's."""
    return servolab("walk", "--world", "mujoco", "--no-progress", "--out", str(tmp_path / "run"),
                    *args, timeout=120)


@pytest.mark.slow
def test_servolab_walk_in_mujoco_says_whether_and_when_the_seeds_gait_falls(
        tmp_path: Path) -> None:
    done = _walk(tmp_path, "--steps", "4")
    assert done.returncode == 0, done.stderr
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    physics = summary["physics"]
    # it falls, as docs/biped.md says (figures.json: docs/plots.py's run of this command)
    figures = json.loads((Path(__file__).resolve().parents[3] / "docs" / "img"
                          / "figures.json").read_text())["figures"]
    assert figures["biped.seed_fell_after_s"]["run"] == "servolab walk --world mujoco --steps 4"
    # (a fall's time is chaotic: another CPU's rounding may move it; test_docs holds the
    # docs to the exact figure on the machine that made them)
    assert physics["fell_after_gait_start_s"] == pytest.approx(
        figures["biped.seed_fell_after_s"]["value"], abs=0.5)
    assert summary["fell"] is True and summary["fell_at_s"] > physics["fell_after_gait_start_s"]
    assert 0 < physics["fell_after_gait_start_s"] < 4 * 17 / 4.5
    assert physics["tipping_from_s"] < summary["fell_at_s"]
    assert physics["tipped"] in ("forwards", "backwards", "to its left", "to its right")
    assert physics["fall_cause"].startswith(f"from {physics['tipping_from_s']:.2f} s")
    assert f"fell at {summary['fell_at_s']:.2f} s" in done.stdout
    assert summary["stopped"] and summary["rows_played"] < 4 * 17   # the gait ends there
    assert set(physics["joints"]) == {f"m{i}" for i in
                                      (11, 12, 13, 14, 15, 16, 21, 22, 23, 24, 25, 26,
                                       31, 32, 33, 41, 42, 43, 51, 61)}
    assert all(0 <= j["peak_load"] <= 1 for j in physics["joints"].values())
    assert Path(summary["physics_plot"]).stat().st_size > 10_000
    # the ground truth is in the bag, read by an independent decoder
    (mcap,) = Path(summary["bag"]).glob("*.mcap")
    heights = [m.ros_msg.pose.pose.position.z
               for m in read_ros2_messages(str(mcap), topics=["/ground_truth"])]
    assert len(heights) > 100 and heights[0] == pytest.approx(0.31, abs=0.01)
    forces = [m.ros_msg.wrench.force.z for m in read_ros2_messages(
        str(mcap), topics=["/ground_truth/left_foot/wrench"])]
    assert len(forces) == len(heights) and max(forces) > 5.0


@pytest.mark.parametrize(("args", "words"), [
    (["--video", "x.mp4"], "--video needs --world mujoco"),
    (["--world", "mujoco", "--assume", "hip_width"], "give NAME=NUMBER"),
    (["--world", "mujoco", "--assume", "hip_width=0.1", "--assume", "hip_width=0.12"],
     "--assume hip_width is given twice"),
    (["--world", "mujoco", "--video", "walk.gif"], "walk.gif: name it .mp4 or .avi"),
    (["--world", "mujoco", "--port", "/dev/ttyUSB0"], "worlds are for the emulated robot"),
    (["--gait", "zmp", "--file", "gait.csv"], "give one of them"),
])
def test_the_walk_refuses_bad_options_before_anything_runs(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str],
        words: str) -> None:
    from servolab.cli import main

    assert main(["walk", "--out", str(tmp_path / "run"), *args]) == 2
    assert words in capsys.readouterr().err
    assert not (tmp_path / "run").exists()          # refused before the run folder


@pytest.mark.slow
def test_the_docs_sweep_table_is_what_the_sweep_gives() -> None:
    """docs/biped.md's sweep (docs/img/biped_sweep.json, written by docs/plots.py) against a
    new walk of two of its cases; a case that makes no robot is refused, not walked."""
    from servolab.robots.armstrong.motions import load_motion
    from servolab.robots.armstrong.sweep import Case, cases, sweep

    committed = json.loads((Path(__file__).resolve().parents[3] / "docs" / "img"
                            / "biped_sweep.json").read_text())
    assert [r["label"] for r in committed] == [c.label for c in cases()]
    assert len(committed) == 27
    picked = [Case(1.0, 0.10, 1.0), Case(0.5, 0.12, 1.2)]
    # the shipped configuration, as docs/plots.py walks: the start-up's length is part of
    # the run (the robot stands on straight legs meanwhile)
    again = sweep(load_motion(None), [*picked, Case(1.0, 0.07, 1.2)], steps=4)
    for result in again[:2]:
        (before,) = [r for r in committed if r["label"] == result["label"]]
        assert result["fell"] == before["fell"]
        assert result["fell_after_gait_start_s"] == before["fell_after_gait_start_s"]
        assert result["tipped"] == before["tipped"]
    assert "foot_width" in again[2]["refused"] and "hip_width" in again[2]["refused"]


@pytest.mark.slow
def test_the_served_biped_hangs_in_its_harness_until_every_servo_has_torque() -> None:
    """``servolab sim --robot armstrong`` serves the biped with its servos as they power up,
    torque off (e-Manual, RX-28 Torque Enable: initial value 0). Left so, it creeps over its
    gears and falls within 18 s (the same world without the harness, below) — before a
    client that a student starts a minute later, or one slowed by a busy machine, sends
    its first goal. So it hangs where it stands, as a lab holds a biped on a gantry, until
    every servo's torque is on; then the harness lets go."""
    from servolab.dynamixel.emulator import build_emulator
    from servolab.robots.armstrong.hardware import load_config
    from servolab.robots.armstrong.physics import armstrong_world
    from servolab.robots.armstrong.plugin import ROBOTS
    from servolab.sim import Simulation

    served = ROBOTS[0].served(None)
    simulation, emulator, physics = served.place(build_emulator(served.spec))  # type: ignore[misc]
    simulation.advance(18.0)
    world = physics.world
    assert world.fell_at is None and world.released_at is None
    ids = [m.id for m in served.spec.motors]
    for motor_id in ids[:-1]:  # all but one: still held
        motor = emulator.motor(motor_id)
        motor.write(motor.model.register("torque_enable").address, b"\x01")
    simulation.advance(0.1)
    assert world.released_at is None
    motor = emulator.motor(ids[-1])
    motor.write(motor.model.register("torque_enable").address, b"\x01")
    simulation.advance(0.1)
    assert world.released_at is not None and 18.1 <= world.released_at <= 18.2

    # the same robot, the same 18 s, no harness: it falls
    loose = Simulation(simulation.physics_step)
    bus = loose.add_emulator(build_emulator(served.spec))
    unheld = armstrong_world(loose, bus, load_config()).world
    loose.advance(18.0)
    assert unheld.fell_at is not None


@pytest.mark.slow
@pytest.mark.realtime
@pytest.mark.usefixtures("busy_cpu")
def test_the_biped_in_mujoco_on_a_real_time_bus_with_the_cpu_busy(tmp_path: Path) -> None:
    """``servolab sim --pty --robot armstrong``: the 20 RX-28 at 57142 bps drive the MuJoCo
    biped in real time, every core busy with another process, and ``servolab walk --port``
    walks it as it would the real robot; the sim's summary says what the physics did."""
    from servolab.gait.motionfile import MotionFile, write_motion_file

    config = ping_once_config(tmp_path)
    # after the stand (2 s), three rows: the knees bent 10 degrees further and back
    stand = np.array([STAND_POSE[m] for m in MOTORS])
    bent = stand.copy()
    for knee in ("m14", "m24"):
        bent[MOTORS.index(knee)] += 10.0 * np.sign(STAND_POSE[knee])
    write_motion_file(tmp_path / "bend.csv", MotionFile(MOTORS, np.vstack([stand, bent,
                                                                            stand])))
    with sim_process("--robot", "armstrong", out_dir=tmp_path / "sim") as (pty, _):
        walked = servolab("walk", "--file", str(tmp_path / "bend.csv"), "--no-progress", "--config",
                          str(config), "--out", str(tmp_path / "walk"), "--port", pty, timeout=120)
    assert walked.returncode == 0, walked.stderr[-2000:]
    assert json.loads((tmp_path / "walk" / "summary.json").read_text())["rows_played"] == 3
    served = json.loads((tmp_path / "sim" / "summary.json").read_text())
    assert served["baudrate"] == 57142 and served["instructions_received"] > 500
    physics = served["physics"]
    # the stand and the knee bend went through the physics: the knees carried the robot's
    # weight, and it stood (a straight-legged robot with torque off stands on its gears'
    # friction until the walk's first goals come; then its servos hold it)
    joints = physics["joints"]
    assert joints["m14"]["peak_load"] > 0.05 and joints["m24"]["peak_load"] > 0.05
    assert served["fell"] is False
    # the harness let go when the walk turned the servos on, within the sim's time
    assert 0.0 < served["harness_released_at_s"] < served["served_s"]
    assert Path(served["physics_plot"]).stat().st_size > 10_000


@pytest.mark.slow
def test_servolabs_own_gait_walks_without_falling(tmp_path: Path) -> None:
    """``--gait zmp``: Kajita's preview control through the same IK, motion file, bus and
    20 RX-28 as the seed's gait; footsteps of Table 5.1's l_step (40 mm), not fallen, the
    torso at least 0.8 x l_step a step forward, the zero-moment point inside the feet
    throughout. Two steps here; the ten of issue 31 are docs/plots.py's run, which
    tests/test_docs.py makes again (biped.zmp_forward_m; >= 0.32 m checked below)."""
    done = _walk(tmp_path, "--gait", "zmp", "--steps", "2")
    assert done.returncode == 0, done.stderr
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["gait"] == "zmp" and summary["rows_played"] == summary["rows_asked"]
    assert summary["fell"] is False and summary["fell_at_s"] is None
    physics = summary["physics"]
    assert physics["torso_forward_m"] >= 2 * 0.8 * 0.040
    assert physics["zmp_margin_min_m"] > 0.0 and physics["zmp_on_edge_share"] == 0.0
    assert abs(physics["torso_turned_deg"]) < 10.0
    assert max(j["peak_load"] for j in physics["joints"].values()) < 1.0   # none saturated


def test_the_docs_say_what_the_sweeps_found() -> None:
    """docs/biped.md's sweep sentences, from docs/img/biped_sweep*.json (python
    docs/plots.py writes them: 54 walks, too long for the suite; two are walked again
    above)."""
    root = Path(__file__).resolve().parents[3]
    doc = " ".join((root / "docs" / "biped.md").read_text().split())
    seed = json.loads((root / "docs" / "img" / "biped_sweep.json").read_text())
    own = json.loads((root / "docs" / "img" / "biped_sweep_zmp.json").read_text())
    times = [r["fell_after_gait_start_s"] for r in seed]
    assert all(r["fell"] for r in seed) and "falls every time" in doc
    assert f"between {min(times):.1f} s and {max(times):.1f} s after its first row" in doc
    ways = [r["tipped"] for r in seed]
    counts = {way: ways.count(way) for way in set(ways)}
    assert counts == {"forwards": 16, "to its left": 9, "to its right": 2}
    assert "16 times forwards, 9 times to its left, twice to its right" in doc
    walked = [r for r in own if "refused" not in r]
    assert not any(r["fell"] for r in walked)
    assert f"walks every one it can be made for ({len(walked)})" in doc
    forward = [r["torso_forward_m"] for r in walked]
    assert f"{min(forward):.3f} m to {max(forward):.3f} m forward" in doc
    assert min(forward) >= 10 * 0.8 * 0.040
    # the ten steps of the stated robot: docs/img/figures.json, made again by test_docs
    figures = json.loads((root / "docs" / "img" / "figures.json").read_text())["figures"]
    assert figures["biped.zmp_forward_m"]["value"] >= 10 * 0.8 * 0.040
    assert figures["biped.zmp_forward_m"]["run"].endswith("--gait zmp --steps 10")
    refused = [r for r in own if "refused" in r]
    assert len(refused) == 27 - len(walked) and f"for the {len(refused)}" in doc
    assert all(r["case"]["hip_width"] == 0.12 and "max_joint_speed" in r["refused"]
               for r in refused)


@pytest.mark.slow
def test_a_walk_in_mujoco_stopped_by_sigterm_finishes_and_keeps_its_physics(
        tmp_path: Path) -> None:
    """SIGTERM while servolab's gait plays in MuJoCo: the robot finishes to double support,
    the exit status is 128 + 15, and nothing recorded is lost: the summary has the physics,
    the bag the ground truth up to the end."""
    import signal

    from tests.robots.test_stop_signals import servolab, stop, summary_of

    run = tmp_path / "run"
    with servolab(["walk", "--world", "mujoco", "--gait", "zmp", "--config",
                   str(ping_once_config(tmp_path)), "--no-progress", "--out", str(run)],
                  signal.SIGTERM) as walk:
        stop(walk, signal.SIGTERM, "playing 276 rows once")
    summary = summary_of(run, signal.SIGTERM)
    assert summary["ending"] == "stand" and summary["stopped"] is True
    physics = summary["physics"]  # type: ignore[index]
    assert summary["fell"] is False and physics["zmp_margin_min_m"] > 0
    (mcap,) = Path(str(summary["bag"])).glob("*.mcap")
    truth = [m.log_time_ns / 1e9 for m in read_ros2_messages(str(mcap),
                                                             topics=["/ground_truth"])]
    commands = [m.log_time_ns / 1e9 for m in read_ros2_messages(
        str(mcap), topics=["/controller_m14/command"])]
    # the finish's last command (the stand pose) is in the bag, and the truth after it
    assert commands and truth and truth[-1] >= commands[-1]


def test_the_zmp_gait_keeps_to_the_legs_configured_joint_speed(tmp_path: Path) -> None:
    """A configuration whose leg controllers move at 0.5 rad/s (joint_speed, or a
    joint_max_speed below it): the plan that needs 0.87 rad/s is refused before anything
    moves, naming max_joint_speed (the servos could not follow it)."""
    from servolab.gait.errors import GaitValueError
    from servolab.robots.armstrong.motions import zmp_motion

    slow = tmp_path / "slow.yaml"
    slow.write_text(ping_once_config(tmp_path).read_text().replace(
        "  joint_speed: 1.0\n  motor: {id: 14,", "  joint_speed: 1.0\n  joint_max_speed: 0.5\n"
        "  motor: {id: 14,"))
    assert "joint_max_speed: 0.5" in slow.read_text()
    with pytest.raises(GaitValueError, match=r"max_joint_speed 0\.5 rad/s"):
        zmp_motion(10, slow)


def test_sim_refuses_a_protocol_for_a_robot_that_brings_its_bus(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    from servolab.cli import main

    assert main(["sim", "--pty", "--robot", "armstrong", "--protocol", "2",
                 "--out", str(tmp_path)]) == 2
    assert "--robot armstrong brings its own bus" in capsys.readouterr().err
