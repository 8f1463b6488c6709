"""configs/armstrong.launch.yaml: the robot side and the walking side as launch-file nodes, in
one process (the file as shipped) and in two processes over Zenoh (as on a robot and a PC;
seed 001's two launch files). The walker is required: the launch ends when it has walked."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
LAUNCH = ROOT / "configs" / "armstrong.launch.yaml"
# a short walk: one step, a fast stand, 9 rows a second
SHORT = ("{steps: 2, rate: 4.5, stand_duration: 2.0}",
         "{steps: 1, rate: 9.0, stand_duration: 0.5}")


def _launch(path: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "servolab", "launch", str(path)],
                          capture_output=True, text=True, timeout=180)


@pytest.mark.slow
def test_the_shipped_launch_file_walks_in_one_process(tmp_path: Path) -> None:
    path = tmp_path / "armstrong.launch.yaml"
    text = LAUNCH.read_text()
    assert SHORT[0] in text
    path.write_text(text.replace(*SHORT))
    result = _launch(path)
    assert result.returncode == 0, result.stderr[-2000:]
    assert "walked: 17 rows" in result.stdout + result.stderr
    assert "Unable to start controller controller_m62" in result.stderr


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
