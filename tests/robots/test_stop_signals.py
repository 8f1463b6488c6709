"""Every robot command stops the same way, whichever signal ends it (issue 26).

Each command runs as a user runs it: a real process, on motors served by ``servolab sim --pty``
at the robot's own baud rate in real time, every core kept busy by other processes (but for
the biped: see its test), or (navigate, which is simulated only) on its emulated floor; stopped
mid-run by SIGTERM, SIGHUP, or SIGINT sent to a job that was started with SIGINT ignored (as a
shell starts a background job: Python then installs no Ctrl-C handler of its own).
Afterwards:

- the exit status is 128 + the signal (143, 129, 130), as a shell reports a process a signal
  ended;
- the motors are as the robot's stop leaves them, read back over the pty by a new client after
  the command exited: a base's wheels at speed 0, the treadmill's at goal velocity 0 with
  torque off (Listing 1's motor_deinit, seed 002), Armstrong's joints in the stand pose with torque
  on (a biped that went limp would fall);
- the bag is readable by ``mcap``'s own reader (not ours), and ``summary.json`` says which
  signal ended the run.

The signals and the commands are tested pairwise, not as a full matrix: which signal came
makes no difference past one shared handler. ``servolab.cli.main`` wraps every command in
``servolab.harness.stop_signals_raise``, which installs one handler for SIGINT, SIGTERM and
SIGHUP alike through ``servolab.signals.on_stop_signals`` (SIGINT explicitly, so a background
job's ignored SIGINT is replaced too); the first signal raises ``StopSignal``, and what a
command does on stop (its robot's ``ON_STOP``, the bag, ``summary.json``) never looks at which
signal it was. The launch supervisor (``servolab.middleware.launch``) installs its own handler
through the same ``on_stop_signals``. What does depend on the signal, its name in the summary
and the last line and the exit status 128 + N, comes from the signal's number in that shared
path. So every signal is tested on the cheapest robot command (drive: SIGTERM, SIGHUP and
SIGINT to a background job), every other robot command is stopped by one signal, rotated so
that each signal stops one of them (walk, flyball, navigate), and the launches, whose
supervisor decides its own exit status, share the three signals between them the same way
(Armstrong's launch, the cheaper, two; the treadmill's launch the third). tests/test_signals.py
and tests/test_harness.py send each signal to the shared handler in-process.

The tests on a pty in real time with every core busy are marked ``realtime`` (one at a time
across the workers: tests/conftest.py), and so is the treadmill's launch, whose three
interpreters beside pytest keep both cores busy. Navigate and Armstrong's launch are one
process each, on the simulated floor or in process, holding no deadline: they run beside the
rest of the suite, as tests/robots/navigation/test_run.py's and
tests/robots/armstrong/test_launch.py's do, and never wait for another worker's real-time test.
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from mcap.reader import make_reader

from servolab.dynamixel.bus import Bus
from servolab.robots.armstrong.hardware import load_config
from servolab.robots.armstrong.poses import STAND_POSE
from tests.robots.armstrong.configs import ping_once_config
from tests.simproc import sim_process
from tests.waiting import wait_for_line, wait_until

pytestmark = pytest.mark.slow
#: on a pty at the robot's baud rate in real time, with every core busy (or, the treadmill's
#: launch, three interpreters beside pytest)
REALTIME = pytest.mark.realtime

#: Armstrong's leg motors (001 Table 2.2): the ones the stand pose moves
LEG_MOTORS = (*range(11, 17), *range(21, 27))
#: how each signal reaches the command (SIGINT: to a job started with SIGINT ignored)
SIGTERM = pytest.param(signal.SIGTERM, id="SIGTERM")
SIGHUP = pytest.param(signal.SIGHUP, id="SIGHUP")
SIGINT_TO_A_BACKGROUND_JOB = pytest.param(signal.SIGINT, id="SIGINT-to-a-background-job")
#: every signal: on the cheapest robot command (see the module's docstring)
SIGNALS = [SIGTERM, SIGHUP, SIGINT_TO_A_BACKGROUND_JOB]

#: run ``python -m servolab ARGS`` with SIGINT ignored, as ``cmd &`` in a shell does; SIG_IGN
#: survives exec, so the command starts with it
IGNORING_SIGINT = ("import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_IGN); "
                   "os.execv(sys.executable, [sys.executable, '-m', 'servolab', *sys.argv[1:]])")


@contextmanager
def servolab(args: list[str], sig: signal.Signals) -> Iterator[subprocess.Popen[str]]:
    """``servolab ARGS`` as a process (SIGINT ignored at its start when ``sig`` is SIGINT),
    always ended when the block ends."""
    argv = ([sys.executable, "-c", IGNORING_SIGINT, *args] if sig == signal.SIGINT
            else [sys.executable, "-m", "servolab", *args])
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            stdin=subprocess.DEVNULL,
                            env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        yield proc
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        if proc.stdout is not None:
            proc.stdout.close()


def stop(proc: subprocess.Popen[str], sig: signal.Signals, marker: str,
         timeout: float = 60.0, *, last_line: bool = True) -> list[str]:
    """Wait for ``marker`` in the command's output (it is mid-run), send ``sig``, and return
    everything it said to the end; its exit status must be 128 + the signal, and its last line
    says so (the launch's supervisor says it in its own words)."""
    lines = wait_for_line(proc, marker, timeout=timeout)
    proc.send_signal(sig)
    rest, _ = proc.communicate(timeout=60)
    said = [*lines, *rest.splitlines()]
    assert proc.returncode == 128 + sig, "\n".join(said)
    if last_line:
        assert f"stopped by {sig.name}" in said[-1], said[-1]
    return said


def summary_of(run: Path, sig: signal.Signals) -> dict[str, object]:
    summary = json.loads((run / "summary.json").read_text())
    assert summary["interrupted"] == sig.name
    return summary  # type: ignore[no-any-return]


def mcap_messages(bag: Path) -> dict[str, int]:
    """Messages per topic, as mcap's own reader counts them (the bag's one file)."""
    (file,) = bag.glob("*.mcap")
    counts: dict[str, int] = {}
    with file.open("rb") as stream:
        for _schema, channel, _message in make_reader(stream).iter_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
    return counts


@REALTIME
@pytest.mark.parametrize("sig", SIGNALS)
def test_drive_stops_the_wheels(tmp_path: Path, sig: signal.Signals, busy_cpu: None) -> None:
    """Seed 000's base on two EX-106+ at 1 Mbps (Protocol 1.0): a 5 m line, stopped after it
    has driven a second; moving_speed 0 is the EX-106+'s wheel-mode stop (e-Manual)."""
    run = tmp_path / "run"
    with sim_process("--motors", "ex106+:0-1", "--baud", "1000000",
                     out_dir=tmp_path / "sim") as (pty, _), \
            servolab(["drive", "line", "--distance", "5", "--speed", "0.1", "--port", pty,
                      "--no-progress", "--out", str(run)], sig) as drive:
        stop(drive, sig, "moving: 1 of 50 s")
        with Bus.open(pty, protocol=1, baudrate=1_000_000) as bus:
            assert {i: bus.read(i, "moving_speed", raw=True) for i in (0, 1)} == {0: 0, 1: 0}
            wait_until(lambda: all(bus.read(i, "present_speed", raw=True) == 0
                                   for i in (0, 1)), timeout=5.0)
    summary = summary_of(run, sig)
    assert summary["wheels_after_stop"] == {"0": 0, "1": 0}
    assert 0.05 < summary["measured"]["odometry_x_m"] < 4.9  # type: ignore[index]
    assert mcap_messages(run / "drive_bag")["/odom"] > 10


@REALTIME
@pytest.mark.parametrize("sig", [SIGINT_TO_A_BACKGROUND_JOB])
def test_walk_finishes_in_double_support(tmp_path: Path, sig: signal.Signals,
                                         busy_cpu: None) -> None:
    """Armstrong's 20 RX-28 at 57142 bps (seed 001), on a busy CPU: stopped while it plays,
    the joints go to the stand pose of Table 4.2 (both feet down) and every motor keeps its
    torque on, at rest on that pose (servolab.robots.armstrong.supervisor). A read that
    misses its deadline through the pty is counted and survived, as dynamixel_motor does."""
    run = tmp_path / "run"
    motors = [*range(11, 17), *range(21, 27), 31, 32, 33, 41, 42, 43, 51, 61]
    config = ping_once_config(tmp_path)
    with sim_process("--motors", "rx28:11-16,21-26,31-33,41-43,51,61", "--baud", "57142",
                     out_dir=tmp_path / "sim") as (pty, _), \
            servolab(["walk", "--steps", "100", "--port", pty, "--config", str(config),
                      "--no-progress", "--out", str(run)], sig) as walk:
        stop(walk, sig, "playing 17 rows")
        with Bus.open(pty, protocol=1, baudrate=57142) as bus:
            assert all(bus.read(i, "torque_enable", raw=True) == 1 for i in motors)
            wait_until(lambda: not any(bus.read(i, "moving", raw=True) for i in motors),
                       timeout=10.0)
            held = {i: bus.read(i, ["goal_position", "present_position"], raw=True)
                    for i in motors}
            stand = {}
            for c in load_config().controllers:
                if c.motor.id in motors and f"m{c.motor.id}" in STAND_POSE:
                    init = float(bus.to_si(c.motor.id, "goal_position", c.motor.init))
                    stand[c.motor.id] = int(bus.from_si(
                        c.motor.id, "goal_position",
                        init + math.radians(STAND_POSE[f"m{c.motor.id}"])))
    # at rest (a few ticks of compliance margin) on the stand pose's goals
    assert all(abs(g["present_position"] - g["goal_position"]) <= 3  # type: ignore[operator]
               for g in held.values()), held
    assert {i: held[i]["goal_position"] for i in stand} == pytest.approx(stand, abs=1), held
    summary = summary_of(run, sig)
    assert summary["rows_played"] < summary["rows_asked"]  # type: ignore[operator]
    assert summary["ending"] == "stand"
    assert mcap_messages(run / "walk_bag")["/controller_m14/command"] > 0


@pytest.fixture(scope="module")
def fly_frames(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """9 s of frames at 66 frames/s, the fly off-centre so that the wheels turn, as the
    thesis's raw Fly_Image.bin: drifting 1 px every 10 frames (each pose rendered once)."""
    from servolab.vision.fly_render import FlyPose, render_fly

    frames = tmp_path_factory.mktemp("fly") / "Fly_Image.bin"
    with frames.open("wb") as out:
        for k in range(60):
            out.write(render_fly(FlyPose(420.0 - k, 250.0, 0.4))[0].tobytes() * 10)
    return frames


@REALTIME
@pytest.mark.parametrize("sig", [SIGTERM])
def test_flyball_stops_the_treadmill(tmp_path: Path, sig: signal.Signals, busy_cpu: None,
                                     fly_frames: Path) -> None:
    """The treadmill's three XM430-W210 at 1 Mbps (Protocol 2.0), tracking a recording at
    the camera's 66 frames/s: stopped mid-recording, goal velocity 0 and torque off."""
    frames = fly_frames
    run = tmp_path / "run"
    with sim_process("--motors", "xm430-w210:100-102", "--baud", "1000000",
                     out_dir=tmp_path / "sim") as (pty, _), \
            servolab(["flyball", "--frames", str(frames), "--port", pty, "--no-progress",
                      "--out", str(run)], sig) as flyball:
        stop(flyball, sig, "tracked ")
        with Bus.open(pty, protocol=2, baudrate=1_000_000) as bus:
            for i in (100, 101, 102):
                assert bus.read(i, ["goal_velocity", "torque_enable"], raw=True) == {
                    "goal_velocity": 0, "torque_enable": 0}
    summary = summary_of(run, sig)
    assert 0 < summary["frames"] < 600  # type: ignore[operator]
    assert mcap_messages(run / "flyball_bag")["/fly/pose"] > 0


@pytest.mark.parametrize("sig", [SIGHUP])
def test_navigate_stops_the_wheels(tmp_path: Path, sig: signal.Signals) -> None:
    """The navigation runs on its simulated floor only (no --port): the wheels' commands are
    read back from the emulated motors into the summary."""
    run = tmp_path / "run"
    with servolab(["navigate", "--goal", "3.3", "2.3", "--no-progress", "--out", str(run)],
                  sig) as navigate:
        stop(navigate, sig, "m to go")
    summary = summary_of(run, sig)
    assert summary["status"] == "INTERRUPTED"
    assert summary["wheels_after_stop"] == {"0": 0, "1": 0}
    assert (run / "navigate.png").stat().st_size > 0
    assert mcap_messages(run / "navigate_bag")["/odom"] > 0


@pytest.mark.parametrize("sig", [SIGINT_TO_A_BACKGROUND_JOB, SIGHUP])
def test_launch_stops_its_nodes(tmp_path: Path, sig: signal.Signals) -> None:
    """Armstrong's launch file (the robot and the walker in one process) ends on the signal
    with every node stopped."""
    launch = Path(__file__).resolve().parents[2] / "configs" / "armstrong.launch.yaml"
    with servolab(["launch", str(launch)], sig) as proc:
        said = stop(proc, sig, "[launch] started walker", last_line=False)
    assert "[launch] stopped walker" in said and "[launch] stopped armstrong" in said


@REALTIME
def test_a_terminal_that_closes_stops_the_drive_and_keeps_its_summary(tmp_path: Path,
                                                                      busy_cpu: None) -> None:
    """What a closing terminal does: the command's terminal goes away (every write to it then
    fails with EIO) and it gets SIGHUP. The stop must not trip over its own last lines: the
    wheels stop, the summary is written, exit 129."""
    import pty
    import select

    run = tmp_path / "run"
    master, slave = pty.openpty()
    with sim_process("--motors", "ex106+:0-1", "--baud", "1000000",
                     out_dir=tmp_path / "sim") as (port, _):
        drive = subprocess.Popen(
            [sys.executable, "-m", "servolab", "drive", "line", "--distance", "5", "--speed",
             "0.1", "--port", port, "--no-progress", "--out", str(run)],
            stdin=slave, stdout=slave, stderr=slave, start_new_session=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1"})
        os.close(slave)
        try:
            seen = b""
            while b"moving: 1 of 50 s" not in seen:
                ready, _, _ = select.select([master], [], [], 60.0)
                assert ready, f"no progress line: {seen!r}"
                seen += os.read(master, 4096)
            os.close(master)  # the terminal window closes
            master = -1
            drive.send_signal(signal.SIGHUP)
            assert drive.wait(60) == 129
        finally:
            if master >= 0:
                os.close(master)
            if drive.poll() is None:
                drive.kill()
                drive.wait()
        with Bus.open(port, protocol=1, baudrate=1_000_000) as bus:
            assert {i: bus.read(i, "moving_speed", raw=True) for i in (0, 1)} == {0: 0, 1: 0}
    summary = summary_of(run, signal.SIGHUP)
    assert summary["wheels_after_stop"] == {"0": 0, "1": 0}
    assert mcap_messages(run / "drive_bag")["/odom"] > 10


def test_a_stop_before_the_run_starts_still_leaves_a_summary(tmp_path: Path) -> None:
    """SIGTERM while navigate still calibrates its camera (before any node runs): the run
    folder gets its summary.json all the same, saying what ended it and when."""
    run = tmp_path / "run"
    with servolab(["navigate", "--goal", "3.3", "2.3", "--no-progress", "--out", str(run)],
                  signal.SIGTERM) as navigate:
        stop(navigate, signal.SIGTERM, "calibrating the overhead camera")
    summary = summary_of(run, signal.SIGTERM)
    assert summary["stage"] == "setting up, before the run started"


@REALTIME
@pytest.mark.parametrize("sig", [SIGTERM])
def test_the_treadmill_launch_stops_its_wheels_and_says_so(tmp_path: Path,
                                                           sig: signal.Signals) -> None:
    """configs/flyball.launch.yaml, camera PC and robot as two processes over Zenoh, stopped
    while the fly runs: the supervisor stops its children as ROS 2 launch does (SIGINT first),
    the camera PC stops the treadmill's wheels and writes its summary, and the launch exits
    128 + the signal it got."""
    launch = Path(__file__).resolve().parents[2] / "configs" / "flyball.launch.yaml"
    out = tmp_path / "run"
    shipped = 'parameters: {duration: 30.0, seed: 0, out: "runs/flyball-launch"}'
    text = launch.read_text()
    assert shipped in text
    path = tmp_path / "flyball.launch.yaml"
    path.write_text(text.replace(shipped, f'parameters: {{duration: 60.0, seed: 0, '
                                          f'out: "{out}"}}'))
    with servolab(["launch", str(path)], sig) as proc:
        said = stop(proc, sig, "[robot]", timeout=60.0, last_line=False)
    summary = summary_of(out, signal.SIGINT)  # what its supervisor sent the camera PC
    assert summary["wheels_after_stop"] == {
        str(i): {"goal_velocity": 0, "torque_enable": 0} for i in (100, 101, 102)}
    assert any(f"[launch] {sig.name}: stopping everything" in line for line in said)
