"""docs/layout.md's "Adding a robot", run as a student runs it: a robot folder on
SERVOLAB_ROBOT_PATH (a URDF with its <ros2_control> block and a controllers file) and a Python
package declaring the ``servolab.robots`` entry point, each listed, opened on emulated motors
and moved, and the folder robot served on a pty to the official ROBOTIS dynamixel-sdk.

Facts checked against ROBOTIS's e-Manual (docs/en/dxl/x/xm430-w350.md): model number 1020;
Torque Enable at 64 (1 byte), Goal Position at 116 and Present Position at 132 (4 bytes);
0.088 deg a tick, 4096 ticks a turn; servolab calls tick 2048 (the horn's centre) 0 rad, as the
community dynamixel_hardware does.
"""

from __future__ import annotations

import math
import os
import shlex
import subprocess
import sys
from pathlib import Path

import dynamixel_sdk
import pytest

import servolab.robots
from servolab.cli import main
from tests.clirun import one_line
from tests.clirun import servolab as servolab_command
from tests.robots.adding_a_robot import blocks, commands, examples, write_files
from tests.simproc import sim_process
from tests.viewclient import SDK_V1, WEBSOCKET_V1, NodeClient, node_client, started_client
from tests.waiting import wait_until

#: e-Manual, XM430-W350: model number and control table
XM430_W350 = 1020
TORQUE_ENABLE, GOAL_POSITION, PRESENT_POSITION = 64, 116, 132
TICKS_PER_TURN, CENTRE = 4096, 2048


def ticks(angle: float) -> int:
    return CENTRE + round(angle * TICKS_PER_TURN / (2 * math.pi))


@pytest.fixture
def robot_path(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The page's robot folder written to ``tmp_path``, which is the working directory, with
    SERVOLAB_ROBOT_PATH set as its first shell block says."""
    write_files(tmp_path, "robots/")
    monkeypatch.chdir(tmp_path)
    (export, *_) = commands(examples("bash")[0])
    name, _, value = export.removeprefix("export ").partition("=")
    assert name == "SERVOLAB_ROBOT_PATH" and value.startswith("$PWD/")
    monkeypatch.setenv(name, str(tmp_path / value.removeprefix("$PWD/")))
    return tmp_path


def test_the_page_shows_each_file_and_step() -> None:
    files = {b.file for b in blocks() if b.file}
    assert files == {"robots/pan_tilt/pan_tilt.urdf", "robots/pan_tilt/controllers.yaml",
                     "robots/pan_tilt/robot.yaml", "lab_robots/pyproject.toml",
                     "lab_robots/lab_robots/__init__.py", "lab_robots/lab_robots/pan_tilt.py"}
    assert len(examples("bash")) == 3 and len(examples("python")) == 2


@pytest.mark.slow
def test_the_folder_robot_is_listed_and_its_urdf_shown(robot_path: Path,
                                                       capsys: pytest.CaptureFixture[str]
                                                       ) -> None:
    _, listing, show = commands(examples("bash")[0])
    assert main(shlex.split(listing)[1:]) == 0
    out = capsys.readouterr().out
    assert "pan_tilt: a pan-tilt head of two XM430-W350" in out
    assert "2 x XM430-W350 (IDs 1-2), Protocol 2.0, 1000000 bps" in out
    assert f"from:    folder {robot_path / 'robots' / 'pan_tilt'}" in out
    assert "armstrong:" in out  # beside servolab's own
    assert main(shlex.split(show)[1:]) == 0
    assert capsys.readouterr().out == (robot_path / "robots/pan_tilt/pan_tilt.urdf").read_text()
    # another process finds it through the environment alone
    listed = servolab_command("robots")
    assert listed.returncode == 0, listed.stderr
    assert "pan_tilt: a pan-tilt head of two XM430-W350" in listed.stdout


def test_the_folder_robot_moves_both_joints_as_the_page_says(
        robot_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    block = examples("python")[0]
    exec(compile("\n" * block.line + block.source, block.where, "exec"), {})
    out = capsys.readouterr().out.splitlines()
    assert out == ["('pan', 'tilt')", "{'pan': 0.8, 'tilt': -0.4}"]
    with servolab.robots.load("pan_tilt") as head:
        head.move_to({"pan": 0.8, "tilt": -0.4})
        raw = {i: head.bus.read(i, "present_position", raw=True) for i in (1, 2)}
        assert abs(raw[1] - ticks(0.8)) <= 0.02 * TICKS_PER_TURN / (2 * math.pi)
        assert abs(raw[2] - ticks(-0.4)) <= 0.02 * TICKS_PER_TURN / (2 * math.pi)
        assert head.bus.read(1, "torque_enable") == 1


def test_a_goal_outside_the_urdf_limits_is_refused_before_anything_moves(
        robot_path: Path) -> None:
    from servolab.robots.errors import RobotValueError

    with servolab.robots.load("pan_tilt") as head:
        with pytest.raises(RobotValueError, match=r"^pan_tilt: joint tilt: goal 2 rad is outside "
                           r"its URDF limits \[-1\.5, 1\.5\]$") as caught:
            head.move_to({"pan": 0.5, "tilt": 2.0})
        one_line(caught, "pan_tilt", "tilt")
        assert head.bus.read(1, "torque_enable") == 0  # the pan was not sent either
        with pytest.raises(ValueError, match="no Dynamixel joint 'roll'; there are pan, tilt"):
            head.move_to({"roll": 0.1})


@pytest.mark.slow
def test_sim_serves_the_folder_robot_to_the_dynamixel_sdk(robot_path: Path) -> None:
    """The page's ``servolab sim --robot pan_tilt --pty`` at the head's own 1 Mbps, in real
    time, driven by the unmodified ROBOTIS SDK through its own PortHandler."""
    (line,) = commands(examples("bash")[1])
    argv = shlex.split(line)
    assert argv[:4] == ["servolab", "sim", "--robot", "pan_tilt"] and "--pty" in argv
    link = robot_path / "pan_tilt.pty"
    args = [a for a in argv[2:] if a != "--pty"]
    args[args.index("--link") + 1] = str(link)
    with sim_process(*args, out_dir=robot_path / "sim"):
        port = dynamixel_sdk.PortHandler(str(link))
        assert port.openPort() and port.setBaudRate(1_000_000)
        packets = dynamixel_sdk.PacketHandler(2.0)
        try:
            goals = {1: ticks(0.8), 2: ticks(-0.4)}
            for motor_id, goal in goals.items():
                model, comm, error = packets.ping(port, motor_id)
                assert (model, comm, error) == (XM430_W350, dynamixel_sdk.COMM_SUCCESS, 0)
                assert packets.write1ByteTxRx(port, motor_id, TORQUE_ENABLE, 1)[0] == 0
                assert packets.write4ByteTxRx(port, motor_id, GOAL_POSITION, goal)[0] == 0

            def present(motor_id: int) -> int:
                value, comm, _ = packets.read4ByteTxRx(port, motor_id, PRESENT_POSITION)
                return int(value) if comm == dynamixel_sdk.COMM_SUCCESS else -1

            assert wait_until(lambda: all(abs(present(i) - g) <= 20 for i, g in goals.items()),
                              timeout=15.0), {i: present(i) for i in goals}
        finally:
            port.closePort()


def test_the_live_view_example_serves_and_moves(robot_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    block = examples("python")[1]
    exec(compile("\n" * block.line + block.source, block.where, "exec"), {})
    (url,) = capsys.readouterr().out.splitlines()
    assert url.startswith("ws://127.0.0.1:") and int(url.rsplit(":", 1)[1]) > 0


@pytest.mark.slow
def test_a_package_declaring_the_entry_point_is_found_and_moves_both_joints(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The page's ``lab_robots`` package, built and installed (offline, into a folder of its
    own on the test's path, so the project's venv is left as it was) by pip."""
    write_files(tmp_path, "lab_robots/")
    install, listing = commands(examples("bash")[2])
    assert shlex.split(install) == ["pip", "install", "./lab_robots"]
    site = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                    "--no-index", "--no-build-isolation", "--target", str(site),
                    "./lab_robots"], cwd=tmp_path, check=True, timeout=300,
                   capture_output=True)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(site), *filter(None, [os.environ.get("PYTHONPATH")])])}
    argv = shlex.split(listing)
    assert argv[0] == "servolab"
    ran = servolab_command(*argv[1:], env=env)
    assert ran.returncode == 0, ran.stderr
    listed = ran.stdout
    assert "lab_pan_tilt: our lab's pan-tilt head, two XM430-W350" in listed
    assert "2 x XM430-W350 (IDs 1-2), Protocol 2.0, 1000000 bps" in listed
    assert "from:    entry point lab_pan_tilt = 'lab_robots.pan_tilt:PLUGIN'" in listed

    monkeypatch.syspath_prepend(str(site))
    (fragment,) = [b for b in blocks() if b.fragment and b.language == "python"]
    scope: dict[str, object] = {}
    exec(compile("\n" * fragment.line + fragment.source, fragment.where, "exec"), scope)
    head = scope["head"]
    try:
        assert type(head).__module__ == "lab_robots.pan_tilt"
        angles = head.angles  # type: ignore[attr-defined]
        assert wait_until(lambda: all(abs(a - g) < 0.02 for a, g in zip(angles(), (0.5, -0.2),
                                                                      strict=True)),
                          timeout=20.0), angles()
    finally:
        head.close()  # type: ignore[attr-defined]


def _latest_rotation(client: NodeClient, child: str) -> dict[str, float] | None:
    for message in reversed(client.messages("/tf")):
        for transform in message["transforms"]:
            if transform["child_frame_id"] == child:
                return dict(transform["transform"]["rotation"])
    return None


@pytest.mark.slow
@pytest.mark.parametrize("subprotocol", [WEBSOCKET_V1, SDK_V1])
def test_the_live_view_of_a_folder_robot_follows_its_joints(robot_path: Path,
                                                            subprotocol: str) -> None:
    """Foxglove's own client (tests/view_client) watches the folder robot opened with
    servolab.robots.load and moved from Python: /robot_description is the URDF, and /tf turns
    each joint's link by the angle its motor reports (URDF: pan about z, tilt about y; a
    rotation by a about a unit axis u is the quaternion (u sin a/2, cos a/2))."""
    node_client()  # skips, saying why, where Node or the npm packages are missing
    with servolab.robots.load("pan_tilt") as head:
        server = head.view()
        with started_client(server.url, subprotocol,
                            ["/robot_description", "/tf", "/joint_states"], count=1_000_000,
                            timeout=90) as client:
            client.wait_until(lambda c: c.messages("/robot_description"), "the description")
            assert client.messages("/robot_description")[0]["data"] == head.urdf
            for pan, tilt in ((0.8, -0.4), (-0.5, 0.3)):
                reached = head.move_to({"pan": pan, "tilt": tilt})
                expected = {"pan_link": {"x": 0.0, "y": 0.0, "z": math.sin(reached["pan"] / 2),
                                         "w": math.cos(reached["pan"] / 2)},
                            "tilt_link": {"x": 0.0, "y": math.sin(reached["tilt"] / 2),
                                          "z": 0.0, "w": math.cos(reached["tilt"] / 2)}}

                def follows(c: NodeClient, expected: dict[str, dict[str, float]] = expected
                            ) -> bool:
                    for child, quaternion in expected.items():
                        got = _latest_rotation(c, child)
                        if got is None or any(abs(got[k] - v) > 2e-3
                                              for k, v in quaternion.items()):
                            return False
                    return True

                client.wait_until(follows, f"/tf at pan {pan}, tilt {tilt}", timeout=20)
            (latest,) = client.messages("/joint_states")[-1:]
            assert latest["name"] == ["pan", "tilt"]


def test_a_goal_the_motor_would_refuse_is_refused_before_any_joint_moves(
        robot_path: Path) -> None:
    """A goal inside the URDF's limits that the motor itself refuses (an XM430 in position
    mode takes 0..4095, about ±π: e-Manual, XM430-W350, Goal Position(116) "Min Position
    Limit(52) ~ Max Position Limit(48)") is refused for every joint before the first is sent,
    and a goal that is not a number is one line naming its joint."""
    from servolab.robots.errors import RobotValueError

    urdf = robot_path / "robots/pan_tilt/pan_tilt.urdf"
    urdf.write_text(urdf.read_text().replace('lower="-1.5" upper="1.5"',
                                             'lower="-4" upper="4"'))
    with servolab.robots.load("pan_tilt") as head:
        with pytest.raises(RobotValueError, match=r"^pan_tilt: joint tilt: motor 2 "
                           r"\(XM430-W350\) goal_position: 3\.50?1? rad \(raw 4330\) is outside "
                           r"its position "
                           r"limits") as caught:
            head.move_to({"pan": 1.0, "tilt": 3.5})
        one_line(caught, "pan_tilt", "tilt")
        assert head.bus.read(1, "torque_enable") == 0  # the pan was not sent either
        for goal in ("x", None, float("nan"), True):
            with pytest.raises(RobotValueError, match=rf"^pan_tilt: joint pan: goal {goal!r} "
                               r"is not a number \(rad\)$"):
                head.move_to({"pan": goal})  # type: ignore[dict-item]
        assert head.bus.read(1, "torque_enable") == 0


def test_stopping_tries_every_motor_when_one_does_not_answer(robot_path: Path) -> None:
    """The head holds on stop: a motor that stopped answering (unplugged from the emulated
    bus) is named, and the other one is still held and its torque still turned off."""
    from servolab.robots.errors import RobotError

    with servolab.robots.load("pan_tilt") as head:
        head.move_to({"pan": 0.3, "tilt": 0.2})
        unplugged = head.bus.emulator.unplug(1)
        head.bus.write(2, "goal_position", -0.5)
        with pytest.raises(RobotError, match=r"^pan_tilt: motor 1: no answer") as caught:
            head.stop()
        one_line(caught, "motor 1")
        assert str(caught.value).count("motor 1") == 1   # named once, not once a layer
        assert "motor 2" not in str(caught.value)
        held = head.bus.read(2, "goal_position")
        assert abs(held - head.bus.read(2, "present_position")) < 0.01
        assert abs(held - -0.5) > 0.1    # held where it was, not sent on to its goal
        with pytest.raises(RobotError, match=r"^pan_tilt: motor 1: no answer"):
            head.torque(False)
        assert head.bus.read(2, "torque_enable") == 0
        head.bus.emulator.add(unplugged)  # plugged back, so that closing holds both
