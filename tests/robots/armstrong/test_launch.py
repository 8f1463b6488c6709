"""configs/armstrong.launch.yaml: the robot side and the walking side as launch-file nodes, in
one process (the file as shipped) and in two processes over Zenoh (as on a robot and a PC;
seed 001's two launch files). The walker is required: the launch ends when it has walked."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

from tests.clirun import launched, servolab

ROOT = Path(__file__).resolve().parents[3]
LAUNCH = ROOT / "configs" / "armstrong.launch.yaml"
# a short walk: one step, a fast stand, 9 rows a second
SHORT = ("{steps: 2, rate: 4.5, stand_duration: 2.0}",
         "{steps: 1, rate: 9.0, stand_duration: 0.5}")


def _launch(path: Path) -> subprocess.CompletedProcess[str]:
    """The launch, to its end; on a timeout it is stopped with every process it started
    (tests/processes.py), and the test fails."""
    return servolab("launch", str(path), timeout=180)


@pytest.mark.slow
def test_the_shipped_launch_file_walks_in_one_process(tmp_path: Path) -> None:
    path = tmp_path / "armstrong.launch.yaml"
    text = LAUNCH.read_text()
    assert SHORT[0] in text
    path.write_text(text.replace(*SHORT))
    result = _launch(path)
    assert result.returncode == 0, result.stderr[-2000:]
    assert "walked: 17 rows" in result.stdout + result.stderr
    said = result.stdout + result.stderr
    assert "Unable to start controller controller_m62" in said
    # seed 001 Figure 3.1, as the launch's nodes say it
    assert ("pan_tilt_port: Found 20 motors - 20 RX-28 [11, 12, 13, 14, 15, 16, 21, 22, 23, 24, "
            "25, 26, 31, 32, 33, 41, 42, 43, 51, 61], initialization complete.") in said


@pytest.mark.slow
def test_robot_and_walker_in_two_processes_over_zenoh(tmp_path: Path) -> None:
    path = tmp_path / "armstrong.launch.yaml"
    text = (LAUNCH.read_text().replace(*SHORT).replace("transport: local", "transport: zenoh")
            .replace("    parameters: {port: \"\", config: \"\"}",
                     "    parameters: {port: \"\", config: \"\"}\n    process: robot")
            .replace("    required: true", "    required: true\n    process: pc"))
    path.write_text(text)
    result = _launch(path)
    out = result.stdout + result.stderr
    assert result.returncode == 0, out[-2000:]
    assert "walked: 17 rows" in out
    assert "no joint states heard" not in out  # the walker heard the robot across processes
    pids = set(re.findall(r"started (?:armstrong|walker) \(pid (\d+)\)", out))
    assert len(pids) == 2, out[-2000:]


@pytest.mark.slow
def test_move_a_joint_from_the_command_line() -> None:
    """docs/biped.md's walk-through: the robot side runs (configs/armstrong_robot.launch.yaml)
    and, from another process, `servolab topic pub /controller_m14/command ...` moves the
    knee; its /controller_m14/state, heard over Zenoh, comes to the commanded 0.5 rad.

    Before it, a foreign Zenoh peer floods that command topic with 10 000 payloads that are
    no Float64 (issue 45): the robot stays up, the good command after them moves the knee,
    and /diagnostics counts the foreign publisher's drops (WARN "servolab: malformed
    messages", under its GID). Fewer than 10 000 may be counted: the command subscription
    keeps the last 10 (KEEP_LAST), and Zenoh's ring drops the rest before they are read."""
    import time

    from servolab.listening import beyond_loopback, listening
    from servolab.middleware.context import Context
    from servolab.middleware.malformed import publisher_name
    from servolab.middleware.node import Node
    from servolab.middleware.rmw_zenoh import encode_attachment
    from servolab.middleware.transport import TransportOptions
    from tests.middleware.conftest import foreign_zenoh_peer
    from tests.waiting import wait_for_line

    cdr = b"\x00\x01\x00\x00"
    not_a_float64 = [cdr + b"\x00\x00", b"", b"\x07\x07\x00\x00" + bytes(8), cdr]
    gid = bytes(range(16, 32))
    with launched(ROOT / "configs" / "armstrong_robot.launch.yaml") as (robot, endpoint):
        wait_for_line(robot, "started armstrong (in process", timeout=60.0)
        with Context.open(TransportOptions("zenoh", connect=[endpoint])) as ctx:
            heard: list[float] = []
            dropped: dict[str, int] = {}
            probe = Node(ctx, "probe")
            probe.create_subscription(
                "dynamixel_msgs/msg/JointState", "/controller_m14/state",
                lambda msg: heard.append(msg.current_pos))
            probe.create_subscription(
                "diagnostic_msgs/msg/DiagnosticArray", "/diagnostics",
                lambda msg: dropped.update({v.key: int(v.value) for s in msg.status
                                            if s.name == "servolab: malformed messages"
                                            for v in s.values}))
            key = ctx.transport._key(  # type: ignore[attr-defined]
                "/controller_m14/command", "std_msgs/msg/Float64")
            foreign = foreign_zenoh_peer(endpoint)
            try:
                put = foreign.declare_publisher(key)
                for i in range(10_000):
                    put.put(not_a_float64[i % 4],
                            attachment=encode_attachment(i, time.time_ns(), gid))
            finally:
                foreign.close()
            pub = servolab("topic", "pub", "/controller_m14/command", "std_msgs/msg/Float64",
                           "{data: 0.5}", "--once", "--connect", endpoint, timeout=60)
            assert pub.returncode == 0, pub.stderr
            assert ctx.spin_until(lambda: bool(heard) and abs(heard[-1] - 0.5) < 0.006,
                                  timeout=30.0), heard[-3:]
            counted = f"/controller_m14/command from {publisher_name(gid)}"
            assert ctx.spin_until(lambda: dropped.get(counted, 0) > 0, timeout=30.0), dropped
        assert robot.poll() is None  # still running: nothing from outside stopped it
        assert beyond_loopback(listening(robot.pid)) == []  # and it listens on loopback only


def test_the_walker_ends_in_double_support_on_an_error_in_diagnostics() -> None:
    """The walking side alone, on a simulated clock: joint states for the legs, then, while
    it stands up, /diagnostics says motor 14 is OVERHEATING (level ERROR, as
    dynamixel_serial_proxy publishes it): the walker stops the gait, sends the joints to the
    stand pose, and ends with the alarm as its error."""
    from servolab.middleware.context import Context
    from servolab.middleware.node import Node
    from servolab.robots.armstrong.launch_nodes import Walker
    from servolab.robots.armstrong.poses import MOTORS, STAND_POSE
    from servolab.robots.errors import RobotError
    from servolab.sim.simulation import Simulation

    context = Context.open(clock=Simulation())
    try:
        walker = Walker(context, parameter_overrides={"steps": 1})
        probe = Node(context, "probe")
        states = {m: probe.create_publisher("dynamixel_msgs/msg/JointState",
                                            f"/controller_{m}/state", 10) for m in MOTORS}
        diagnostics = probe.create_publisher("diagnostic_msgs/msg/DiagnosticArray",
                                             "/diagnostics", 10)
        for m, pub in states.items():
            pub.publish(probe.message("dynamixel_msgs/msg/JointState", name=m,
                                      current_pos=0.0))
        context.spin_until(lambda: bool(walker.commanded), timeout=2.0)
        assert walker.commanded, "the walker never started standing"
        diagnostics.publish(probe.message("diagnostic_msgs/msg/DiagnosticArray", status=[
            {"level": 0, "name": "Robotis Dynamixel Motor 13 on port pan_tilt_port",
             "message": "OK"},
            {"level": 2, "name": "Robotis Dynamixel Motor 14 on port pan_tilt_port",
             "message": "OVERHEATING"}]))
        with pytest.raises(RobotError, match=r"motor 14: OVERHEATING.*stand pose"):
            context.spin_for(5.0)
        assert walker.alarms == ["motor 14: OVERHEATING"]
        assert walker.rows_played == 0
        assert walker.commanded == pytest.approx(STAND_POSE)
    finally:
        context.close()
