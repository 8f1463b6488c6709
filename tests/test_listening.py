"""Loopback means loopback (issue 45): with default settings no socket servolab opens is
reachable from another computer, read from the kernel's own table (``servolab.listening``,
checked against iproute2's ``ss``), not from servolab's configuration. Cyclone DDS is the
one exception servolab cannot close (it binds its unicast ports to every interface when it
uses one: ``ddsi_init.c``, ``make_uc_sockets``); it is named when the domain opens."""

from __future__ import annotations

import logging
import os
import re
import shutil
import socket
import subprocess
from pathlib import Path

import pytest

from servolab.listening import ListeningSocket, beyond_loopback, listening
from servolab.middleware.context import Context
from servolab.middleware.transport import TransportOptions
from tests.clirun import SERVOLAB
from tests.middleware.conftest import free_port
from tests.processes import started
from tests.waiting import wait_for_line


def _ss(pid: int) -> set[ListeningSocket]:
    """What ``ss -ltunpH`` says process ``pid`` listens on (iproute2: the oracle)."""
    out = subprocess.run(["ss", "-ltunpH"], capture_output=True, text=True, check=True).stdout
    found = set()
    for line in out.splitlines():
        if f"pid={pid}," not in line:
            continue
        fields = line.split()
        host, _, port = fields[4].rpartition(":")
        found.add(ListeningSocket(fields[0], host.strip("[]").split("%")[0]
                                  .replace("*", "0.0.0.0"), int(port)))
    return found


def test_the_listing_agrees_with_ss() -> None:
    with socket.socket() as tcp, socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as udp:
        tcp.bind(("127.0.0.1", 0))
        tcp.listen()
        udp.bind(("0.0.0.0", 0))
        mine = {ListeningSocket("tcp", "127.0.0.1", tcp.getsockname()[1]),
                ListeningSocket("udp", "0.0.0.0", udp.getsockname()[1])}
        listed = set(listening())
        assert mine <= listed
        assert beyond_loopback(sorted(mine)) == [ListeningSocket("udp", "0.0.0.0",
                                                                 udp.getsockname()[1])]
        if shutil.which("ss") is not None:  # iproute2, on every Debian and Ubuntu
            assert listed == _ss(os.getpid())


def test_a_zenoh_context_by_default_listens_on_loopback_only() -> None:
    before = set(listening())
    with Context.open(TransportOptions("zenoh")):
        opened = [s for s in listening() if s not in before]
    assert opened, "a Zenoh peer listens for the others of its machine"
    assert beyond_loopback(opened) == []


@pytest.mark.slow
def test_a_watched_walk_listens_on_loopback_only(tmp_path: Path) -> None:
    """``servolab walk --view``: the view's WebSocket on 127.0.0.1 and nothing else."""
    port = free_port()
    with started([*SERVOLAB, "walk", "--steps", "1", "--view", str(port), "--no-progress",
                  "--out", str(tmp_path)], stderr_to_stdout=True) as proc:
        wait_for_line(proc, "waiting for a viewer", timeout=90)
        sockets = listening(proc.pid)
    assert ListeningSocket("tcp", "127.0.0.1", port) in sockets
    assert beyond_loopback(sockets) == []


def test_dds_names_the_ports_cyclone_binds_to_every_interface(
        monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    from tests.rosoracle import free_domain_id

    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.delenv("ROS_STATIC_PEERS", raising=False)
    domain = free_domain_id()
    before = set(listening())
    with caplog.at_level(logging.INFO, logger="servolab.middleware.dds_transport"), \
            Context.open(TransportOptions("dds", domain_id=domain)):
        opened = [s for s in listening() if s not in before]
    said = [r.getMessage() for r in caplog.records if "listens on" in r.getMessage()]
    assert len(said) == 1
    for s in opened:  # every socket the domain opened is named, with its address
        assert str(s) in said[0]
    # DDSI-RTPS 2.5, 9.6.1.1: unicast ports PB + DG * domain + d1/d3 + PG * participant index,
    # PB 7400, DG 250, PG 2, d1 10 (discovery), d3 11 (user data)
    wide = sorted(s.port for s in beyond_loopback(opened))
    assert len(wide) == 2 and wide[1] == wide[0] + 1
    assert (wide[0] - 7400 - 250 * domain - 10) % 2 == 0
    assert re.search(r"every interface: Cyclone DDS cannot bind", said[0])
