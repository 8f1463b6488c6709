"""configs/flyball.launch.yaml: the camera PC and the robot as two processes over Zenoh
(seed 002, Figure 2). The treadmill is required: it stops after its duration, analyses the
logs, and the launch ends; the robot's encoder log was heard across the processes."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from servolab.robots.treadmill.logs import read_encoder_log, read_fly_log

ROOT = Path(__file__).resolve().parents[3]
LAUNCH = ROOT / "configs" / "flyball.launch.yaml"


@pytest.mark.slow
def test_camera_pc_and_robot_in_two_processes(tmp_path: Path) -> None:
    out = tmp_path / "run"
    text = LAUNCH.read_text()
    shipped = 'parameters: {duration: 30.0, seed: 0, out: "runs/flyball-launch"}'
    assert shipped in text and "base: turtlebot3_waffle" in text  # a shipped base, by name
    path = tmp_path / "flyball.launch.yaml"
    path.write_text(text.replace(shipped, f'parameters: {{duration: 4.0, seed: 0, '
                                          f'out: "{out}"}}'))
    result = subprocess.run([sys.executable, "-m", "servolab", "launch", str(path)],
                            capture_output=True, text=True, timeout=180)
    said = result.stdout + result.stderr
    assert result.returncode == 0, said[-3000:]
    pids = set(re.findall(r"started (?:treadmill|robot) \(pid (\d+)\)", said))
    assert len(pids) == 2, said[-2000:]
    # the same outputs as the one-process run: both logs, the analysis, the figure
    summary = json.loads((out / "summary.json").read_text())
    fly = read_fly_log(out / "fly_data.bin")
    encoders = read_encoder_log(out / "robot_encoders.bin")
    # 4 s counted from the robot's first message: real time at 66 frames/s, about 264 frames
    assert len(fly) == summary["frames"] > 100
    assert len(encoders) == summary["encoder_records"] > 20  # the robot, over Zenoh
    analysis = summary["analysis"]
    for key in ("mean_distance_error_mm", "mean_angle_error_deg", "sphere_path_length_m"):
        assert analysis[key] >= 0.0, key  # a number, not NaN
    assert analysis["robot_path_length_m"] > 0.0  # the robot drove, on /cmd_vel over Zenoh
    assert (out / "flyball.png").stat().st_size > 20_000
