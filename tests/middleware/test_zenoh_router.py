"""Coexisting with ROS (issue 15): a servolab session never takes the ROS router's port, meets
a router where rmw_zenoh's sessions look for one, and meets its peers with or without it.

A real ``rmw_zenohd`` listens on ``tcp/*:7447``; these tests stand a Zenoh session in router
mode (the ``eclipse-zenoh`` package, as ``zenohd`` is) in for it, on a loopback port chosen free
at run time, and point servolab at it with ``$SERVOLAB_ZENOH_ROUTER``: no test takes 7447.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
import zenoh

from servolab.middleware.context import Context
from servolab.middleware.errors import TransportError
from servolab.middleware.transport import TransportOptions
from servolab.middleware.zenoh_transport import (
    DEFAULT_LISTEN,
    DEFAULT_ROUTER,
    ROUTER_ENV,
    session_endpoints,
)
from tests.clirun import SERVOLAB, servolab
from tests.middleware.conftest import free_port
from tests.processes import started
from tests.waiting import wait_for, wait_for_graph_at

STRING = "std_msgs/msg/String"


def listening_ports(pid: int) -> set[tuple[str, int]]:
    """The TCP (address, port) pairs process ``pid`` listens on, as the kernel has them."""
    inodes = set()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        try:
            target = os.readlink(fd)
        except OSError:
            continue  # closed while we looked
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    found = set()
    for table in ("tcp", "tcp6"):
        for line in Path(f"/proc/{pid}/net/{table}").read_text().splitlines()[1:]:
            fields = line.split()
            if fields[3] == "0A" and fields[9] in inodes:  # 0A: LISTEN
                address, port = fields[1].split(":")
                found.add((address, int(port, 16)))
    return found


def loopback(address: str) -> bool:
    """``/proc/net/tcp``'s hex address is 127.x.x.x (little-endian) or ``::1``."""
    if len(address) == 8:
        return address.endswith("7F")
    return address == "0" * 24 + "01000000"


@contextmanager
def router(port: int) -> Iterator[zenoh.Session]:
    """A Zenoh router, as ``rmw_zenohd`` is one, on ``tcp/127.0.0.1:port``."""
    config = zenoh.Config()
    config.insert_json5("mode", '"router"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("listen/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
    config.insert_json5("connect/endpoints", "[]")
    session = zenoh.open(config)  # fails if anything holds the port
    try:
        yield session
    finally:
        session.close()


@pytest.fixture
def router_port(monkeypatch: pytest.MonkeyPatch) -> int:
    """A free port where the tests' router will be; servolab sessions look for it there."""
    port = free_port()
    monkeypatch.setenv(ROUTER_ENV, f"tcp/127.0.0.1:{port}")
    return port


def test_default_endpoints_are_rmw_zenohs(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(ROUTER_ENV, raising=False)
    assert session_endpoints(TransportOptions("zenoh")) == (["tcp/127.0.0.1:0"],
                                                            ["tcp/localhost:7447"])
    assert (DEFAULT_LISTEN, DEFAULT_ROUTER) == ("tcp/127.0.0.1:0", "tcp/localhost:7447")
    # --connect replaces the router, --listen the ephemeral port
    assert session_endpoints(TransportOptions("zenoh", connect=["tcp/10.0.0.2:7447"])) == (
        ["tcp/127.0.0.1:0"], ["tcp/10.0.0.2:7447"])
    assert session_endpoints(TransportOptions("zenoh", listen=["tcp/0.0.0.0:9000"])) == (
        ["tcp/0.0.0.0:9000"], ["tcp/localhost:7447"])
    monkeypatch.setenv(ROUTER_ENV, "")
    assert session_endpoints(TransportOptions("zenoh")) == (["tcp/127.0.0.1:0"], [])
    monkeypatch.setenv(ROUTER_ENV, "7447")
    with pytest.raises(TransportError, match="Zenoh endpoint '7447'"):
        session_endpoints(TransportOptions("zenoh"))


@pytest.mark.slow
def test_sessions_listen_on_ephemeral_loopback_ports_and_leave_the_router_its_port(
        types, router_port: int) -> None:
    before = listening_ports(os.getpid())
    a = Context.open(TransportOptions("zenoh"), types=types)
    try:
        b = Context.open(TransportOptions("zenoh"), types=types)
        try:
            ours = listening_ports(os.getpid()) - before
            assert len(ours) == 2, ours  # one free port each
            assert all(loopback(address) for address, _ in ours), ours
            assert 7447 not in {port for _, port in ours}
            assert router_port not in {port for _, port in ours}
            with router(router_port) as r:  # starts fine while the sessions run
                wait_for(lambda: len(list(r.info.peers_zid())) == 2,
                         "both sessions to find the router (they retry in the background)",
                         timeout=15.0)
        finally:
            b.close()
    finally:
        a.close()


def test_a_missing_router_is_no_error(types, router_port: int) -> None:
    with Context.open(TransportOptions("zenoh"), types=types) as ctx:
        ctx.transport.check_reachable(0.1)  # the router is optional: nothing to report
        assert not list(ctx.transport.session.info.routers_zid())


def test_peers_that_meet_one_peer_link_to_each_other_without_router_or_multicast(
        types, router_port: int) -> None:
    """Gossip: B and C both name A only, and end up linked directly."""
    port = free_port()
    a = Context.open(TransportOptions("zenoh", listen=[f"tcp/127.0.0.1:{port}"]), types=types)
    try:
        b = Context.open(TransportOptions("zenoh", connect=[f"tcp/127.0.0.1:{port}"]),
                         types=types)
        c = Context.open(TransportOptions("zenoh", connect=[f"tcp/127.0.0.1:{port}"]),
                         types=types)
        try:
            c_zid = c.transport.session.zid()
            wait_for(lambda: c_zid in list(b.transport.session.info.peers_zid()),
                     "B to link to C, whose endpoint it was never given")
        finally:
            c.close()
            b.close()
    finally:
        a.close()


def _env(router_port: int) -> dict[str, str]:
    return {**os.environ, ROUTER_ENV: f"tcp/127.0.0.1:{router_port}"}


def _echo_and_pub(echo_extra: list[str], pub_extra: list[str], probe: str, env: dict[str, str],
                  data: str) -> None:
    """A ``topic echo`` process hears a ``topic pub`` process, each with the endpoints given."""
    echo_args = [*SERVOLAB, "topic", "echo", "/chatter", "--type", STRING, "--count", "1",
                 *echo_extra]
    with started(echo_args, env=env) as echo:
        wait_for_graph_at(probe, ("MS", None, "/chatter"))
        pub = servolab("topic", "pub", "/chatter", STRING, f"{{data: {data}}}", "--rate", "5",
                       "--count", "10", *pub_extra, timeout=60, env=env)
        assert pub.returncode == 0, pub.stderr
        out, err = echo.communicate(timeout=15)
        assert echo.returncode == 0, err
        assert f"data: {data}" in out, (out, err)


@pytest.mark.slow
def test_two_processes_talk_through_a_router(router_port: int) -> None:
    env = _env(router_port)
    endpoint = f"tcp/127.0.0.1:{router_port}"
    with router(router_port):
        # neither process is given an endpoint: both find the router where rmw_zenoh's
        # sessions look for it ($SERVOLAB_ZENOH_ROUTER standing in for tcp/localhost:7447)
        _echo_and_pub([], [], endpoint, env, "through the router")


@pytest.mark.slow
def test_the_router_starts_while_servolab_processes_run(router_port: int) -> None:
    env = _env(router_port)
    echo_args = [*SERVOLAB, "topic", "echo", "/chatter", "--type", STRING, "--count", "1"]
    with started(echo_args, env=env) as echo:
        wait_for(lambda: any(port != router_port for _, port in listening_ports(echo.pid)),
                 "the echo process to listen")
        assert all(loopback(a) and p not in (7447, router_port)
                   for a, p in listening_ports(echo.pid)), listening_ports(echo.pid)
        with router(router_port):  # the port is free: servolab did not take it
            wait_for_graph_at(f"tcp/127.0.0.1:{router_port}", ("MS", None, "/chatter"))
            pub = servolab("topic", "pub", "/chatter", STRING, "{data: late}", "--rate", "5",
                           "--count", "10", timeout=60, env=env)
            assert pub.returncode == 0, pub.stderr
            out, err = echo.communicate(timeout=15)
            assert "data: late" in out, (out, err)


@pytest.mark.slow
def test_two_processes_talk_without_a_router(router_port: int) -> None:
    """No router (its endpoint is a free port nobody listens on) and no multicast: the
    processes meet on an endpoint one listens on and the other connects to."""
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    _echo_and_pub(["--listen", endpoint], ["--connect", endpoint], endpoint,
                  _env(router_port), "without a router")


@pytest.mark.parametrize("action", [["list"], ["echo", "/chatter"], ["hz", "/chatter"]])
@pytest.mark.slow
def test_connect_to_an_endpoint_nobody_answers_is_one_line_and_fails(action: list[str]) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    done = servolab("topic", *action, "--connect", endpoint, timeout=60)
    assert done.returncode == 2
    assert done.stdout == ""
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and endpoint in lines[0] and "no Zenoh peer or router" in lines[0], \
        done.stderr
