"""Lets the tests import servolab from src/ while the package is not installed yet."""

import sys
from pathlib import Path

try:
    import servolab  # noqa: F401
except ImportError:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import os

# No test may reach a well-known port: without this, every Zenoh session a test opens would
# look for a ROS router at tcp/localhost:7447 (the default; see servolab.middleware
# .zenoh_transport), and find a developer's real one. Tests that need a router start their
# own on a free port and name it here themselves.
os.environ["SERVOLAB_ZENOH_ROUTER"] = ""

import fcntl
from collections.abc import Iterator

import pytest


@pytest.fixture(autouse=True)
def _one_real_time_test_at_a_time(request: pytest.FixtureRequest,
                                  tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """``make test`` runs two workers (pytest-xdist). A test marked ``realtime`` — one that
    holds the wall clock to a deadline, or keeps every core busy to see that others still
    meet theirs (``busy_cpu``) — takes a lock the other worker's such tests wait for, so that
    no two of them run at once; the rest of the suite runs beside them as on any busy PC."""
    if request.node.get_closest_marker("realtime") is None:
        yield
        return
    shared = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        shared = shared.parent          # every worker's base folder sits in one run folder
    with (shared / "realtime.lock").open("a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)
