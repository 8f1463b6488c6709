"""The real ROS 2 Jazzy rclpy, as a test oracle: never a dependency of servolab.

ROS 2 Jazzy's rclpy and message packages install from the package index (``ros-jazzy-rclpy``,
``ros-jazzy-rmw-fastrtps-cpp``, ...) into a virtual environment of their own, which ``make
test`` creates as ``.venv-ros`` (``make ros-oracle``; ``SERVOLAB_ROS_VENV`` names another). Its
programs run with ``LD_LIBRARY_PATH=<venv>/lib`` and speak DDS through their default middleware,
Fast DDS (``rmw_fastrtps_cpp``).

Each test picks a ROS domain whose DDS ports are free (RTPS 2.2 section 9.6.1.1: domain ``d``
uses UDP ports from ``7400 + 250 d``), never domain 0, so that nothing meets a ROS 2 system
that happens to run on the machine, and discovery stays on loopback
(``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``).
"""

from __future__ import annotations

import os
import random
import socket
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

#: RTPS's well-known port mapping (RTPS 2.2, 9.6.1.1): PB + DG * domain, DG = 250.
PORT_BASE = 7400
DOMAIN_GAIN = 250
#: the ports a domain's first participants use on this machine: discovery (d0, d1 + 2 i) and
#: user traffic (d3 + 2 i) for participant indices i up to about 20.
PORTS_PER_DOMAIN = 60


def ros_venv() -> Path:
    return Path(os.environ.get("SERVOLAB_ROS_VENV", REPO / ".venv-ros"))


def ros_python() -> Path:
    """The oracle venv's Python; the test is skipped, saying why, where it is not installed
    (a platform with no ``ros-jazzy-rclpy`` wheel: ``make ros-oracle`` reports it)."""
    python = ros_venv() / "bin" / "python"
    if not python.exists() or not any(ros_venv().glob("lib/python3*/site-packages/rclpy")):
        pytest.skip(f"the real ROS 2 rclpy is not installed in {ros_venv()} "
                    f"(make ros-oracle; see its log for why: no wheel for this platform?)")
    return python


def _ports_free(domain: int) -> bool:
    base = PORT_BASE + DOMAIN_GAIN * domain
    sockets = []
    try:
        for port in range(base, base + PORTS_PER_DOMAIN):
            s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            sockets.append(s)
            s.bind(("127.0.0.1", port))
        return True
    except OSError:
        return False
    finally:
        for s in sockets:
            s.close()


def free_domain_id() -> int:
    """A ROS domain (1..101) none of whose first ports is taken on this machine now."""
    domains = list(range(1, 102))  # ROS 2 docs: above 101 ports fall in the ephemeral range
    random.shuffle(domains)
    for domain in domains:
        if _ports_free(domain):
            return domain
    raise RuntimeError("no ROS domain has free DDS ports on this machine")


def ros_env(domain_id: int, **extra: str) -> dict[str, str]:
    """The environment a real rclpy program runs in: its libraries, Fast DDS, the domain,
    loopback discovery, and unbuffered output."""
    venv = ros_venv()
    env = {k: v for k, v in os.environ.items() if not k.startswith(("ROS_", "RMW_", "SERVOLAB_"))}
    env.update({
        "LD_LIBRARY_PATH": f"{venv / 'lib'}",
        "ROS_DOMAIN_ID": str(domain_id),
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
        "RMW_IMPLEMENTATION": "rmw_fastrtps_cpp",
        "PYTHONUNBUFFERED": "1",
        **extra,
    })
    return env


def run_ros(code: str, domain_id: int, *, timeout: float = 60.0,
            **extra: str) -> subprocess.CompletedProcess[str]:
    """Run ``code`` under the real rclpy to its end; its output as text."""
    return subprocess.run([str(ros_python()), "-c", code], env=ros_env(domain_id, **extra),
                          capture_output=True, text=True, timeout=timeout, check=False)


def servolab_on_ros_env(domain_id: int, **extra: str) -> dict[str, str]:
    """The environment a *servolab* program runs in with ``--transport ros2`` on the oracle's
    ROS 2, as ``source /opt/ros/jazzy/setup.bash`` would make it: ROS 2's Python packages on
    ``PYTHONPATH`` (before servolab's venv, as setup.bash puts them), and its libraries, with
    the folders the index's wheels keep theirs in (what the wheels' own
    ``ros_wheels_bootstrapper`` adds before it re-executes Python), on ``LD_LIBRARY_PATH``."""
    ros_python()  # skips, saying why, where the real rclpy is not installed
    venv = ros_venv()
    site = next(venv.glob("lib/python3*/site-packages"))
    libraries = [venv / "lib", *sorted(p for p in site.glob("ros_*.libs") if p.is_dir())]
    env = ros_env(domain_id, **extra)
    env.update({"PYTHONPATH": str(site), "SERVOLAB_TRANSPORT": "ros2",
                "LD_LIBRARY_PATH": os.pathsep.join(str(p) for p in libraries)})
    return env
