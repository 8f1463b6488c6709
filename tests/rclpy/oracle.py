"""Run one snippet of rclpy code under the real rclpy and under servolab (imports rewritten),
for tests that compare what the two print."""

from __future__ import annotations

import subprocess
import sys
import textwrap

from tests.rclpy.programs import servolab_env, servolabify
from tests.rosoracle import free_domain_id, run_ros


def run_both(code: str, timeout: float = 60.0) -> tuple[str, str]:
    """(what the real rclpy printed, what servolab printed) for ``code`` (servolab on its
    in-process transport); either failing fails the test with its stderr."""
    code = textwrap.dedent(code)
    domain = free_domain_id()
    ros = run_ros(code, domain, timeout=timeout)
    assert ros.returncode == 0, f"the real rclpy failed:\n{ros.stderr[-3000:]}"
    ours = subprocess.run([sys.executable, "-c", servolabify(code)],
                          env=servolab_env("local", 0, 0, domain), capture_output=True,
                          text=True, timeout=timeout, check=False)
    assert ours.returncode == 0, f"servolab failed:\n{ours.stderr[-3000:]}"
    return ros.stdout, ours.stdout
