"""Lets the tests import servolab from src/ while the package is not installed yet; the
fixtures every folder's tests share: one test at a time holds the wall clock (``realtime``),
every core kept busy by other processes (``busy_cpu``),
and a middleware context that is always closed (``ctx``)."""

from __future__ import annotations

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
# Nor may a developer's rmw_zenoh setup change what the tests' sessions do: a session config
# file, or a router check that waits for ever (servolab.middleware.zenoh_config). Tests that
# need them set them for the process they start.
os.environ.pop("ZENOH_SESSION_CONFIG_URI", None)
os.environ.pop("ZENOH_ROUTER_CONFIG_URI", None)
os.environ.pop("ZENOH_ROUTER_CHECK_ATTEMPTS", None)

import fcntl
import subprocess
import warnings
from collections.abc import Iterator
from typing import TYPE_CHECKING

import pytest

from tests.scheduling import RealTimeOnOneWorker, shared_folder, write_marked_ids

if TYPE_CHECKING:
    from servolab.clock import Clock
    from servolab.middleware.context import Context
    from servolab.middleware.messages import MessageTypes
    from servolab.middleware.transport import TransportOptions


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log: object) -> object | None:
    """``make test``'s ``--dist loadfile`` with every realtime test on one worker
    (tests/scheduling.py); any other ``--dist`` as pytest-xdist has it."""
    if config.getoption("dist") != "loadfile":
        return None
    return RealTimeOnOneWorker(config, log)


@pytest.hookimpl(trylast=True)  # after -m has deselected what this run leaves out
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    write_marked_ids(config, items)


@pytest.fixture(autouse=True)
def _one_real_time_test_at_a_time(request: pytest.FixtureRequest) -> Iterator[None]:
    """``make test`` runs two workers (pytest-xdist). A test marked ``realtime`` — one that
    holds the wall clock to a deadline, or keeps every core busy to see that others still
    meet theirs (``busy_cpu``) — takes a lock the other worker's such tests wait for, so that
    no two of them run at once; the rest of the suite runs beside them as on any busy PC."""
    if request.node.get_closest_marker("realtime") is None:
        yield
        return
    with (shared_folder(request.config) / "realtime.lock").open("a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


@pytest.fixture(autouse=True)
def _no_default_context_left_open(request: pytest.FixtureRequest) -> Iterator[None]:
    """rclpy's default context (``servolab.rclpy.init()``) is one per process, and a worker runs
    many test files: one left open fails the next test that calls ``init()`` ("already
    initialized"), whichever file it is in (seen in a clean-clone run, test_rclpy_shapes.py).
    Each test starts without one, and a test that leaves one open is named in a warning, which
    pytest's summary shows, then it is shut down."""
    from servolab.middleware import default_context

    if default_context.is_initialized():   # left by something that outlived its test
        warnings.warn(f"a default context was open before {request.node.nodeid}; shut down",
                      stacklevel=1)
        default_context.shutdown()
    yield
    if default_context.is_initialized():
        warnings.warn(f"{request.node.nodeid} left the default context open; shut down",
                      stacklevel=1)
        default_context.shutdown()


@pytest.fixture(scope="session")
def types() -> MessageTypes:
    """One set of message types for the session: loading them is the slow part of opening a
    context."""
    from servolab.middleware.messages import MessageTypes
    return MessageTypes()


@pytest.fixture
def ctx_transport() -> TransportOptions | None:
    """The transport ``ctx`` opens; None is the in-process one. A test module that wants
    another (DDS in a domain of its own) overrides this fixture."""
    return None


@pytest.fixture
def ctx_clock() -> Clock | None:
    """The clock ``ctx`` runs on; None is the wall clock. A test module that steps time
    itself overrides this fixture with a ``VirtualClock``."""
    return None


@pytest.fixture
def ctx(types: MessageTypes, ctx_transport: TransportOptions | None,
        ctx_clock: Clock | None) -> Iterator[Context]:
    """A middleware context for one test, closed after it whatever the test did (its nodes,
    their threads and the transport with it)."""
    from servolab.middleware.context import Context
    with Context.open(ctx_transport, types=types, clock=ctx_clock) as context:
        yield context


@pytest.fixture
def busy_cpu(request: pytest.FixtureRequest) -> Iterator[None]:
    """Every core kept busy by another process while the robot runs on its real-time bus, as
    on a lab PC that also runs a camera and a viewer: the stop must not depend on spare CPU.
    Only for a test marked ``realtime``: two such tests at once would each see twice the
    load they ask for."""
    assert request.node.get_closest_marker("realtime") is not None, (
        f"{request.node.nodeid} keeps every core busy: mark it pytest.mark.realtime")
    burners = [subprocess.Popen([sys.executable, "-c", "while True: pass"],
                                stdin=subprocess.DEVNULL)
               for _ in range(os.cpu_count() or 1)]
    try:
        yield
    finally:
        for burner in burners:
            burner.kill()
            burner.wait()
