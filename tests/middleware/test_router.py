"""``servolab router`` and the sessions that meet at it (the fleets issue, part one): a Zenoh
router configured as rmw_zenohd's, rmw_zenoh's ZENOH_ROUTER_CONFIG_URI,
ZENOH_SESSION_CONFIG_URI and ZENOH_ROUTER_CHECK_ATTEMPTS, and two processes that meet through
a router process, lose it and find it again.

Every router here listens on a loopback port chosen free at run time (never 7447), and every
process a test starts is stopped by it. What each test relies on of rmw_zenoh is cited in
:mod:`servolab.middleware.zenoh_config` and :mod:`servolab.middleware.router`.
"""

from __future__ import annotations

import json
import math
import os
import signal
import socket
import subprocess
import threading
import time
from pathlib import Path

import pytest

from servolab.errors import ConfigFileError
from servolab.middleware.errors import TransportError
from servolab.middleware.router import (
    RMW_ZENOHD_DEFAULTS,
    Router,
    RouterOptions,
    listen_endpoints,
    router_config,
)
from servolab.middleware.transport import TransportOptions
from servolab.middleware.zenoh_config import (
    CHECK_ATTEMPTS_ENV,
    GAVE_UP,
    ROUTER_CONFIG_ENV,
    SESSION_CONFIG_ENV,
    WAITING,
    router_check,
    wait_for_router,
)
from servolab.middleware.zenoh_transport import (
    DEFAULT_LISTEN,
    DEFAULT_ROUTER,
    ROUTER_ENV,
    open_session,
    session_config,
)
from tests.clirun import SERVOLAB, refusal, servolab
from tests.middleware.conftest import free_port
from tests.processes import started
from tests.waiting import wait_for, wait_for_graph_at, wait_for_line

STRING = "std_msgs/msg/String"
#: rmw_zenoh's README ("Connecting to the Zenoh router on another host"): a node on another
#: machine is made the router's client, so that the router forwards its traffic.
CLIENT = '{mode: "client"}'


def _get(config: object, key: str) -> object:
    return json.loads(config.get_json(key))  # type: ignore[attr-defined]


def _port_free(port: int) -> bool:
    with socket.socket() as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
        return True


# -- the router's configuration ---------------------------------------------------------------


def test_the_default_router_is_rmw_zenohds_on_loopback() -> None:
    config = router_config(RouterOptions(environ={}))
    assert _get(config, "mode") == "router"
    # where every servolab and rmw_zenoh session looks for it, this machine only
    assert listen_endpoints(config) == [DEFAULT_ROUTER] == ["tcp/localhost:7447"]
    assert _get(config, "connect/endpoints") == []
    assert _get(config, "scouting/multicast/enabled") is False
    assert _get(config, "scouting/gossip/enabled") is True
    assert _get(config, "scouting/gossip/target") == {"router": ["router", "peer"],
                                                     "peer": ["router"]}
    assert _get(config, "timestamping/enabled") == {"router": True, "peer": True, "client": True}
    assert _get(config, "queries_default_timeout") == 600000
    assert "routing/router/peers_failover_brokering" not in RMW_ZENOHD_DEFAULTS
    # --listen replaces the endpoint, nothing else
    listened = router_config(RouterOptions(listen=("tcp/127.0.0.1:9000", "tcp/127.0.0.2:9000"),
                                           environ={}))
    assert listen_endpoints(listened) == ["tcp/127.0.0.1:9000", "tcp/127.0.0.2:9000"]
    assert _get(listened, "scouting/gossip/enabled") is True


def test_a_config_file_replaces_the_defaults_as_rmw_zenohd_takes_it(tmp_path: Path) -> None:
    from_env = tmp_path / "env.json5"
    from_env.write_text('{listen: {endpoints: ["tcp/127.0.0.1:7001"]}, '
                        'scouting: {gossip: {enabled: false}}}')
    given = tmp_path / "given.json5"
    given.write_text('{mode: "router", listen: {endpoints: ["tcp/127.0.0.1:7002"]}}')
    environ = {ROUTER_CONFIG_ENV: str(from_env)}

    config = router_config(RouterOptions(environ=environ))
    assert listen_endpoints(config) == ["tcp/127.0.0.1:7001"]
    assert _get(config, "mode") == "router"  # a file without a mode still runs a router
    assert _get(config, "scouting/gossip/enabled") is False  # the file's, not the defaults'
    assert _get(config, "queries_default_timeout") is None   # nor any default of rmw_zenohd's
    # --config takes precedence over the variable; --listen over the file's endpoints
    assert listen_endpoints(router_config(RouterOptions(config=given, environ=environ))) == [
        "tcp/127.0.0.1:7002"]
    assert listen_endpoints(router_config(RouterOptions(
        listen=("tcp/127.0.0.1:7003",), config=given, environ=environ))) == ["tcp/127.0.0.1:7003"]
    # an empty variable is unset (rmw_zenoh: the default configuration)
    assert listen_endpoints(router_config(RouterOptions(environ={ROUTER_CONFIG_ENV: ""}))) == [
        DEFAULT_ROUTER]
    # a file that names no endpoint listens on this machine only, as without a file (Zenoh's
    # own default would be tcp/[::]:7447, every network)
    quiet = tmp_path / "quiet.json5"
    quiet.write_text("{scouting: {gossip: {enabled: false}}}")
    assert listen_endpoints(router_config(RouterOptions(config=quiet))) == [DEFAULT_ROUTER]


def test_a_session_config_file_that_asks_for_a_router_is_refused(tmp_path: Path) -> None:
    router = tmp_path / "session.json5"
    router.write_text('{mode: "router"}')
    with pytest.raises(TransportError, match=r"session.json5: mode 'router': a servolab "
                       r"session is a peer or a client"):
        session_config(TransportOptions("zenoh"), {SESSION_CONFIG_ENV: str(router)})


@pytest.mark.parametrize(("text", "expected"), [
    ('{mode: "router",, }', ":1: column 17: not a Zenoh configuration: expected identifier "
                            "or string"),
    ("{\n  mode: \"router\"\n  listen: {}\n}", ":2: column 9: "),
    ("{listen: {endpoints: [\"7447\"]}}", "Endpoints must be of the form"),
    ("{no_such_key: 1}", "unknown field `no_such_key`"),
    ('{mode: "peer"}', "mode 'peer': servolab router runs a Zenoh router"),
])
def test_a_bad_config_file_is_one_line_naming_it(tmp_path: Path, text: str,
                                                 expected: str) -> None:
    bad = tmp_path / "router.json5"
    bad.write_text(text)
    with pytest.raises((ConfigFileError, TransportError)) as raised:
        router_config(RouterOptions(config=bad, environ={}))
    message = str(raised.value)
    assert "\n" not in message and str(bad) in message and expected in message, message


def test_a_missing_or_huge_config_file_is_one_line(tmp_path: Path) -> None:
    with pytest.raises(ConfigFileError, match=r"missing\.json5: cannot read it: No such file.*"
                       r"\$ZENOH_ROUTER_CONFIG_URI names"):
        router_config(RouterOptions(environ={ROUTER_CONFIG_ENV: str(tmp_path / "missing.json5")}))
    huge = tmp_path / "huge.json5"
    huge.write_bytes(b" " * 1_000_001)
    with pytest.raises(ConfigFileError, match=r"over the limit of 1 MB.*SERVOLAB_MAX_ZENOH_CONFIG"):
        router_config(RouterOptions(config=huge, environ={}))


def test_the_command_refuses_bad_input_in_one_line_before_anything_listens(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    port = free_port()
    bad = tmp_path / "bad.json5"
    bad.write_text("{mode: router}")
    status, line = refusal(["router", "--listen", f"tcp/127.0.0.1:{port}", "--config", str(bad)],
                           capsys)
    assert status == 2
    assert line.startswith(f"servolab router: error: {bad}:1: column 8: ") and "--config" in line
    assert _port_free(port)  # it never listened
    status, line = refusal(["router", "--listen", "7447"], capsys)
    assert (status, line) == (2, "servolab router: error: Zenoh endpoint '7447' is not "
                                 "<protocol>/<host>:<port>, e.g. tcp/127.0.0.1:7447")


def test_a_port_already_taken_is_one_line() -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        endpoint = f"tcp/127.0.0.1:{taken.getsockname()[1]}"
        with pytest.raises(TransportError, match=f"cannot start a Zenoh router on {endpoint}: "
                           ".*Address already in use.*another router there"):
            Router(RouterOptions(listen=(endpoint,), environ={}))


# -- the command as a process ------------------------------------------------------------------


@pytest.mark.parametrize("stop", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_the_command_says_where_it_listens_and_stops_on_a_signal(stop: signal.Signals) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with started([*SERVOLAB, "router", "--listen", endpoint]) as router:
        line = wait_for_line(router, "listening on", timeout=20)[-1]
        assert line.endswith(f"listening on {endpoint}; Ctrl-C stops it"), line
        router.send_signal(stop)
        _, err = router.communicate(timeout=15)
        assert router.returncode == 128 + stop, err
        assert err.strip() == f"servolab router: stopped by {stop.name}", err


def test_zenoh_router_config_uri_is_the_commands_configuration(tmp_path: Path) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    file = tmp_path / "router.json5"
    file.write_text(json.dumps({"listen": {"endpoints": [endpoint]}}))
    with started([*SERVOLAB, "router"], env={**os.environ, ROUTER_CONFIG_ENV: str(file)}) as r:
        assert wait_for_line(r, "listening on", timeout=20)[-1].endswith(
            f"listening on {endpoint}; Ctrl-C stops it")


# -- sessions ----------------------------------------------------------------------------------


def test_a_session_config_file_is_the_base_with_servolabs_keys_on_top(tmp_path: Path) -> None:
    peer = tmp_path / "peer.json5"
    peer.write_text('{timestamping: {enabled: false}, queries_default_timeout: 1234}')
    environ = {SESSION_CONFIG_ENV: str(peer)}
    config = session_config(TransportOptions("zenoh"), environ)
    assert _get(config, "queries_default_timeout") == 1234            # the file's
    assert _get(config, "timestamping/enabled") is True               # servolab needs it
    assert _get(config, "listen/endpoints") == [DEFAULT_LISTEN]       # not Zenoh's [::]:0
    assert _get(config, "connect/endpoints") == []                    # $SERVOLAB_ZENOH_ROUTER=""
    assert _get(config, "scouting/multicast/enabled") is False
    assert (_get(config, "connect/exit_on_failure"), _get(config, "connect/timeout_ms")) == (
        False, -1)
    # the file's endpoints stand unless the command line gives others
    peer.write_text('{listen: {endpoints: ["tcp/127.0.0.5:0"]}, '
                    'connect: {endpoints: ["tcp/127.0.0.1:7001"]}}')
    config = session_config(TransportOptions("zenoh"), environ)
    assert (_get(config, "listen/endpoints"), _get(config, "connect/endpoints")) == (
        ["tcp/127.0.0.5:0"], ["tcp/127.0.0.1:7001"])
    config = session_config(TransportOptions("zenoh", listen=["tcp/127.0.0.6:0"],
                                             connect=["tcp/127.0.0.1:7002"]), environ)
    assert (_get(config, "listen/endpoints"), _get(config, "connect/endpoints")) == (
        ["tcp/127.0.0.6:0"], ["tcp/127.0.0.1:7002"])
    # a client: its mode kept, no listener added, the router as its endpoint
    peer.write_text(CLIENT)
    config = session_config(TransportOptions("zenoh"), {**environ})
    assert _get(config, "mode") == "client"
    assert _get(config, "connect/exit_on_failure") is None   # Zenoh's: a client needs its router
    assert DEFAULT_LISTEN not in json.dumps(_get(config, "listen/endpoints"))


def test_a_bad_session_config_file_is_one_line_naming_it(tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    bad = tmp_path / "session.json5"
    bad.write_text("{mode: client}")
    monkeypatch.setenv(SESSION_CONFIG_ENV, str(bad))
    with pytest.raises(ConfigFileError) as raised:
        open_session(TransportOptions("zenoh"))
    assert str(raised.value).startswith(f"{bad}:1: column 8: ")
    assert "$ZENOH_SESSION_CONFIG_URI names" in str(raised.value)


def test_a_client_without_its_router_is_one_line(tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    client = tmp_path / "client.json5"
    client.write_text(CLIENT)
    monkeypatch.setenv(SESSION_CONFIG_ENV, str(client))
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with pytest.raises(TransportError, match=f"cannot open a Zenoh client session: .*{endpoint}"
                       r".*a client needs its router running"):
        open_session(TransportOptions("zenoh", connect=[endpoint]))


def _heard(session: object, key: str) -> list[str]:
    heard: list[str] = []
    session.declare_subscriber(  # type: ignore[attr-defined]
        key, lambda sample: heard.append(sample.payload.to_string()))
    return heard


@pytest.mark.parametrize("mode", ["peer", "client"])
@pytest.mark.slow
def test_peers_meet_through_the_router_and_keep_talking_without_it_clients_do_not(
        mode: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """rmw_zenoh's two ways of using a router: its peers learn of each other from it (gossip)
    and then link directly, so they go on talking when it goes (the router carries discovery);
    its clients send everything through it, so they stop, and resume when it is back."""
    if mode == "client":
        client = tmp_path / "client.json5"
        client.write_text(CLIENT)
        monkeypatch.setenv(SESSION_CONFIG_ENV, str(client))
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    options = RouterOptions(listen=(endpoint,), environ={})
    router = Router(options)
    a = open_session(TransportOptions("zenoh", listen=["tcp/127.0.0.2:0"], connect=[endpoint]))
    b = open_session(TransportOptions("zenoh", listen=["tcp/127.0.0.3:0"], connect=[endpoint]))
    try:
        heard = _heard(b, "fleet/test")

        def put_until_heard() -> bool:
            a.put("fleet/test", "hello")
            return bool(heard)
        wait_for(put_until_heard, "B to hear A through the router", timeout=10, step=0.05)
        if mode == "peer":
            wait_for(lambda: b.zid() in list(a.info.peers_zid()), "A and B to link directly")
        router.close()
        wait_for(lambda: not list(a.info.routers_zid()), "A to see the router go")
        heard.clear()
        if mode == "peer":
            wait_for(put_until_heard, "B to go on hearing A without the router", step=0.05)
            return
        for _ in range(10):  # the router carried them: nothing gets through now
            a.put("fleet/test", "lost")
        router = Router(options)
        wait_for(put_until_heard, "B to hear A again once the router is back", timeout=20,
                 step=0.1)
        assert "lost" not in heard
    finally:
        a.close()
        b.close()
        router.close()


# -- two processes and a router process --------------------------------------------------------


class Lines:
    """What a process prints on stdout, read on a thread as it comes."""

    def __init__(self, proc: subprocess.Popen[str]) -> None:
        self.lines: list[str] = []
        self.changed = time.monotonic()
        assert proc.stdout is not None
        self._thread = threading.Thread(target=self._read, args=(proc.stdout,), daemon=True)
        self._thread.start()

    def _read(self, stream: object) -> None:
        for line in stream:  # type: ignore[attr-defined]
            self.lines.append(line.rstrip("\n"))
            self.changed = time.monotonic()

    def count(self, text: str) -> int:
        return sum(text in line for line in list(self.lines))

    def quiet_for(self, seconds: float) -> bool:
        return time.monotonic() - self.changed >= seconds


def _router(endpoint: str) -> list[str]:
    return [*SERVOLAB, "router", "--listen", endpoint]


@pytest.mark.slow
def test_two_processes_on_two_addresses_meet_through_a_router_process() -> None:
    """Each process connects to the router alone and listens on an address of its own (as two
    machines would); they meet through the router, as rmw_zenoh's peers do."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with started(_router(endpoint)) as router:
        wait_for_line(router, "listening on", timeout=20)
        with started([*SERVOLAB, "topic", "echo", "/chatter", "--type", STRING, "--count", "1",
                      "--listen", "tcp/127.0.0.2:0", "--connect", endpoint]) as echo:
            wait_for_graph_at(endpoint, ("MS", None, "/chatter"))
            pub = servolab("topic", "pub", "/chatter", STRING, "{data: fleet}", "--rate", "5",
                           "--count", "10", "--listen", "tcp/127.0.0.3:0", "--connect",
                           endpoint, timeout=60)
            assert pub.returncode == 0, pub.stderr
            out, err = echo.communicate(timeout=15)
            assert echo.returncode == 0, err
            assert "data: fleet" in out, (out, err)


@pytest.mark.slow
def test_the_router_killed_stops_its_clients_messages_and_restarted_brings_them_back(
        tmp_path: Path) -> None:
    """Two client processes (rmw_zenoh's way for nodes on other machines) exchange messages
    only through the router: killed, the subscriber hears nothing more; restarted on the same
    endpoint, the same two processes, never restarted, talk again."""
    client = tmp_path / "client.json5"
    client.write_text(CLIENT)
    env = {**os.environ, SESSION_CONFIG_ENV: str(client)}
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with started(_router(endpoint)) as router:
        wait_for_line(router, "listening on", timeout=20)
        with started([*SERVOLAB, "topic", "echo", "/chatter", "--type", STRING,
                      "--listen", "tcp/127.0.0.2:0", "--connect", endpoint], env=env) as echo, \
                started([*SERVOLAB, "topic", "pub", "/chatter", STRING, "{data: fleet}",
                         "--rate", "10", "--listen", "tcp/127.0.0.3:0", "--connect", endpoint],
                        env=env) as pub:
            heard = Lines(echo)
            wait_for(lambda: heard.count("data: fleet") >= 3, lambda: "the echo to hear the "
                     f"publisher through the router; it printed {heard.lines[-5:]}", timeout=30)
            router.kill()
            router.wait(5)
            wait_for(lambda: heard.quiet_for(1.5), "the echo to stop hearing (10 messages a "
                     "second were published)", timeout=10, step=0.1)
            before = heard.count("data: fleet")
            with started(_router(endpoint)) as again:
                wait_for_line(again, "listening on", timeout=20)
                wait_for(lambda: heard.count("data: fleet") >= before + 3,
                         "the same echo to hear the same publisher again", timeout=30)
            assert echo.poll() is None and pub.poll() is None  # never restarted


# -- ZENOH_ROUTER_CHECK_ATTEMPTS ---------------------------------------------------------------


@pytest.mark.parametrize(("text", "attempts"), [
    (None, None), ("", None), ("3", 3.0), ("1", 1.0), ("0", math.inf), ("-1", None),
    (" 2 ", 2.0)])
def test_router_check_attempts_mean_what_they_mean_to_rmw_zenoh(text: str | None,
                                                                attempts: float | None) -> None:
    environ = {} if text is None else {CHECK_ATTEMPTS_ENV: text}
    assert router_check(environ) == attempts


def test_a_router_check_that_is_no_number_is_refused_in_one_line() -> None:
    with pytest.raises(TransportError, match=r"ZENOH_ROUTER_CHECK_ATTEMPTS='two' is not a whole "
                       "number: 0 waits for a router for ever"):
        router_check({CHECK_ATTEMPTS_ENV: "two"})


class _Session:
    """A session whose router answers from its ``answers_at``-th check on (never: 0)."""

    def __init__(self, answers_at: int = 0) -> None:
        self.checks = 0
        self.answers_at = answers_at
        self.info = self

    def routers_zid(self) -> list[str]:
        self.checks += 1
        return ["router"] if self.answers_at and self.checks >= self.answers_at else []


def test_wait_for_router_checks_n_times_a_second_apart_saying_rmw_zenohs_messages() -> None:
    said: list[str] = []
    slept: list[float] = []
    session = _Session()
    assert not wait_for_router(session, 3, warn=said.append,  # type: ignore[arg-type]
                               sleep=slept.append)
    assert session.checks == 3 and slept == [1.0, 1.0]
    assert said == [WAITING] * 3 + [GAVE_UP.format(attempts=3)]
    assert said[-1].startswith("Unable to connect to a Zenoh router after 3 attempt(s). ")
    said.clear()
    found = _Session(answers_at=4)  # for ever (0): until the router answers
    assert wait_for_router(found, math.inf, warn=said.append,  # type: ignore[arg-type]
                           sleep=lambda s: None)
    assert found.checks == 4 and said == [WAITING] * 3
    said.clear()
    assert wait_for_router(_Session(answers_at=1), 5, warn=said.append,  # type: ignore[arg-type]
                           sleep=lambda s: None)
    assert said == []


def _no_router_env(attempts: str) -> tuple[dict[str, str], str]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    return {**os.environ, ROUTER_ENV: endpoint, CHECK_ATTEMPTS_ENV: attempts}, endpoint


@pytest.mark.slow
def test_a_positive_count_without_a_router_gives_up_after_it_and_goes_on() -> None:
    env, _ = _no_router_env("2")
    done = subprocess.run([*SERVOLAB, "topic", "list"], capture_output=True, text=True,
                          env=env, timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stderr.splitlines() == [WAITING, WAITING, GAVE_UP.format(attempts=2)]


@pytest.mark.slow
def test_with_a_router_or_a_negative_count_nothing_is_said() -> None:
    env, endpoint = _no_router_env("-1")
    done = subprocess.run([*SERVOLAB, "topic", "list"], capture_output=True, text=True,
                          env=env, timeout=60)
    assert (done.returncode, done.stderr) == (0, "")
    with Router(RouterOptions(listen=(endpoint,), environ={})):
        done = subprocess.run([*SERVOLAB, "topic", "list"], capture_output=True, text=True,
                              env={**env, CHECK_ATTEMPTS_ENV: "3"}, timeout=60)
    assert (done.returncode, done.stderr) == (0, "")


@pytest.mark.slow
def test_zero_waits_until_a_router_comes() -> None:
    env, endpoint = _no_router_env("0")
    with started([*SERVOLAB, "topic", "list"], env=env, stderr_to_stdout=True) as waiting:
        said = Lines(waiting)
        wait_for(lambda: said.count(WAITING) >= 2, lambda: f"two checks; it said {said.lines}",
                 timeout=20)
        assert waiting.poll() is None
        with Router(RouterOptions(listen=(endpoint,), environ={})):
            assert waiting.wait(20) == 0
        assert not any("after" in line for line in said.lines), said.lines
