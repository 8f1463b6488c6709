"""Real time, real processes: ``servolab teleop`` between two ``servolab sim --pty`` at 1 Mbps (the
leader moved by its scripted hand, the follower on its table in MuJoCo), every core busy,
stopped by SIGTERM: the follower holds where it is, torque on, read back through its pty."""

from __future__ import annotations

import json
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from servolab.dynamixel.bus import Bus
from servolab.robots.open_manipulator_x import NAME as ARM
from tests.simproc import sim_process

IDS = [11, 12, 13, 14, 15]


def _line(proc: subprocess.Popen[str], starts: str, timeout: float) -> str:
    assert proc.stdout is not None
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        ready, _, _ = select.select([proc.stdout], [], [], deadline - time.monotonic())
        if not ready:
            break
        line = proc.stdout.readline()
        if not line:
            break
        if line.startswith(starts):
            return line
    raise AssertionError(f"servolab teleop said no line starting {starts!r} in {timeout} s")


@pytest.mark.slow
@pytest.mark.realtime
@pytest.mark.usefixtures("busy_cpu")
def test_on_two_ptys_sigterm_leaves_the_follower_holding(tmp_path: Path) -> None:
    with sim_process("--robot", f"{ARM}_leader", out_dir=tmp_path / "leader") as (leader, _), \
            sim_process("--robot", ARM, out_dir=tmp_path / "follower") as (follower, _):
        out = tmp_path / "run"
        proc = subprocess.Popen(
            [sys.executable, "-m", "servolab", "teleop", "--leader", leader, "--follower",
             follower, "--seconds", "60", "--out", str(out)],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL,
            text=True)
        try:
            _line(proc, "the follower has reached the leader", 30.0)
            # two seconds into the episode: the hand moves the leader
            _line(proc, "episode 1 of 1: 2 of 60 s", 30.0)
            proc.send_signal(signal.SIGTERM)
            assert proc.wait(timeout=20) == 128 + signal.SIGTERM
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        summary = json.loads((out / "summary.json").read_text())
        assert summary["interrupted"] == "SIGTERM"
        loop = summary["loop"]
        assert loop["commands_lost"] == 0 and loop["commands_checked"] > 50
        assert loop["achieved_hz"] > 50             # a busy machine, the ptys' wake-ups
        assert loop["tracking_error_arm_rad"]["p99"] < 0.15
        assert [e["complete"] for e in summary["episodes"]] == [False]
        held = [summary["held"][j] for j in ("joint1", "joint2", "joint3", "joint4")]
        with Bus.open(follower, protocol=2, baudrate=1_000_000) as bus:
            assert [int(bus.read(i, "torque_enable")) for i in IDS] == [1] * 5
            first = bus.sync_read("present_position", IDS[:4])
            time.sleep(0.5)
            then = bus.sync_read("present_position", IDS[:4])
        assert [then[i] for i in IDS[:4]] == pytest.approx([first[i] for i in IDS[:4]],
                                                           abs=0.01)
        assert [then[i] for i in IDS[:4]] == pytest.approx(held, abs=0.03)
