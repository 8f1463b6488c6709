"""``ZENOH_CONFIG_OVERRIDE``, as rmw_zenoh reads it (ros2/rmw_zenoh PR #551, "feat: support
zenoh config override", and its README's examples): ``key=value`` pairs separated by ``;``,
each value json5, applied on top of the configuration (the file's or the default) of sessions
and of the router alike. servolab's command line goes on top of it. The examples here are the
pull request's own: a router moved to another port, and a node made to connect there."""

from __future__ import annotations

import json
import os

import pytest

from servolab.middleware.errors import TransportError
from servolab.middleware.router import RouterOptions, router_config
from servolab.middleware.transport import TransportOptions
from servolab.middleware.zenoh_config import OVERRIDE_ENV, SESSION_CONFIG_ENV
from servolab.middleware.zenoh_transport import session_config
from tests.clirun import SERVOLAB, servolab
from tests.middleware.conftest import free_port
from tests.processes import started
from tests.waiting import wait_for_line


def _get(config: object, key: str) -> object:
    return json.loads(config.get_json(key))  # type: ignore[attr-defined]


def test_an_override_goes_on_a_sessions_configuration_and_the_command_line_on_top() -> None:
    environ = {OVERRIDE_ENV: 'scouting/multicast/enabled=true;'
                             'connect/endpoints=["tcp/127.0.0.1:7448"]'}
    config = session_config(TransportOptions("zenoh"), environ)
    assert _get(config, "scouting/multicast/enabled") is True
    assert _get(config, "connect/endpoints") == ["tcp/127.0.0.1:7448"]
    given = session_config(TransportOptions("zenoh", connect=["tcp/127.0.0.1:7000"]), environ)
    assert _get(given, "connect/endpoints") == ["tcp/127.0.0.1:7000"]


def test_an_override_goes_on_the_session_file_too(tmp_path: os.PathLike[str]) -> None:
    path = f"{tmp_path}/peer.json5"
    with open(path, "w", encoding="utf-8") as file:
        file.write('{mode: "peer", listen: {endpoints: ["tcp/127.0.0.1:0"]}}')
    config = session_config(TransportOptions("zenoh"), {
        SESSION_CONFIG_ENV: path, OVERRIDE_ENV: 'mode="client"'})
    assert _get(config, "mode") == "client"


def test_a_client_made_by_the_override_fails_without_its_router_as_zenohs_do() -> None:
    config = session_config(TransportOptions("zenoh"), {OVERRIDE_ENV: 'mode="client"'})
    assert _get(config, "connect/exit_on_failure") is True


@pytest.mark.parametrize(("override", "says"), [
    ("multicast", "'multicast' is not key=value"),
    ('mode="router"', "mode 'router': a servolab session"),
    ("no/such/key=1", "'no/such/key=1'"),
])
def test_a_bad_override_is_refused_in_one_line(override: str, says: str) -> None:
    with pytest.raises(TransportError) as caught:
        session_config(TransportOptions("zenoh"), {OVERRIDE_ENV: override})
    assert says in str(caught.value) and "\n" not in str(caught.value), caught.value
    assert OVERRIDE_ENV in str(caught.value)


def test_semicolons_inside_json5_values_do_not_split_pairs() -> None:
    config = session_config(TransportOptions("zenoh"), {
        OVERRIDE_ENV: 'connect/endpoints=["tcp/127.0.0.1:7448", "tcp/127.0.0.1:7449"];'
                      'metadata={name: "a;b"}'})
    assert _get(config, "connect/endpoints") == ["tcp/127.0.0.1:7448", "tcp/127.0.0.1:7449"]
    assert _get(config, "metadata") == {"name": "a;b"}


def test_the_router_takes_the_override_and_its_listen_goes_on_top() -> None:
    environ = {OVERRIDE_ENV: 'listen/endpoints=["tcp/127.0.0.1:7448"]'}
    assert _get(router_config(RouterOptions(environ=environ)), "listen/endpoints") == \
        ["tcp/127.0.0.1:7448"]
    assert _get(router_config(RouterOptions(listen=("tcp/127.0.0.1:7500",), environ=environ)),
                "listen/endpoints") == ["tcp/127.0.0.1:7500"]
    with pytest.raises(TransportError, match="sets mode 'peer'"):
        router_config(RouterOptions(environ={OVERRIDE_ENV: 'mode="peer"'}))


@pytest.mark.slow
def test_the_pull_requests_example_a_router_on_another_port_and_a_client_of_it() -> None:
    """rmw_zenoh PR #551's example, with a free port for its 7448: the router listens where
    the override says, and a node whose override makes it a client connecting there reaches
    it (a client exits with 2 when its router does not answer, as the second call shows)."""
    port = free_port()
    env = {**os.environ, OVERRIDE_ENV: f'listen/endpoints=["tcp/127.0.0.1:{port}"]'}
    with started([*SERVOLAB, "router"], env) as router:
        wait_for_line(router, f"listening on tcp/127.0.0.1:{port}", timeout=20)
        client = f'mode="client";connect/endpoints=["tcp/127.0.0.1:{port}"]'
        listed = servolab("topic", "list", env={**os.environ, OVERRIDE_ENV: client})
        assert listed.returncode == 0, listed.stderr
    missing = servolab("topic", "list", env={**os.environ, OVERRIDE_ENV: client})
    assert missing.returncode == 2, missing.stderr
    assert "cannot open a Zenoh client session" in missing.stderr
