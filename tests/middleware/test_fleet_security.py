"""Who may join a fleet (the fleets issue): ``servolab certs`` makes the fleet's authority and
its members' certificates, ``servolab router --security FILE`` asks every client for one
(Zenoh's mutual TLS) and drops, at the router, what a member may not publish (Zenoh's access
control, by the certificate's common name).

Oracles outside this code: the certificates are checked with pyca ``cryptography``'s own
verifier (``verify_directly_issued_by``) and accepted by Zenoh's TLS (rustls); the rules are
enforced by Zenoh's own access control, whose decision point (zenoh
``net/routing/interceptor/authorization.rs``, ``policy_decision_point``) checks deny rules
before allow rules and, with ``default_permission: deny``, lets through only what a subject is
allowed. The topic keys are rmw_zenoh's (``<domain>/<name>/<type>/<hash>``, its
``liveliness_utils.cpp``), which :func:`~servolab.middleware.rmw_zenoh.topic_keyexpr` writes.

Every router listens on a loopback port chosen free at run time; every process is stopped by
the test that starts it.
"""

from __future__ import annotations

import base64
import json
import os
import signal
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
import zenoh
from cryptography import x509
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from servolab.errors import ConfigFileError
from servolab.middleware.certificates import issue
from servolab.middleware.errors import TransportError
from servolab.middleware.fleet_security import load, topic_keyexpr_pattern
from servolab.middleware.rmw_zenoh import topic_keyexpr
from servolab.middleware.router import RouterOptions, router_config
from servolab.middleware.zenoh_config import SESSION_CONFIG_ENV
from tests.clirun import SERVOLAB, one_line, refusal, servolab
from tests.middleware.conftest import free_port
from tests.processes import started
from tests.waiting import wait_for_line

TWIST_STAMPED = "geometry_msgs/msg/TwistStamped"
STRING = "std_msgs/msg/String"
HASH = "RIHS01_" + "0" * 64
#: The Waffle's command topic under ros2_control, in /robot1 (diff_drive_controller's
#: ~/cmd_vel).
CMD_VEL = "/robot1/diff_drive_controller/cmd_vel"
#: rad/s: a wheel turning at 0.1 m/s (3 rad/s on a 33 mm wheel), and one at rest (an XM430's
#: Present Velocity unit, 0.229 rev/min, is 0.024 rad/s).
TURNING, AT_REST = 1.0, 0.05

SECURITY = """\
tls:
  ca: certs/ca.pem
  certificate: certs/router.pem
  private_key: certs/router-key.pem
members:
  fleet_manager: [/**]
  robot1: [/robot1/**, /tf, /tf_static, /rosout, /parameter_events]
  operator: [/operator/**, /rosout, /parameter_events]
  monitor: []
"""


def _certificates(folder: Path, *names: str) -> None:
    for name in names:
        issue(folder, name, router=name == "router")


@pytest.mark.slow
def test_servolab_certs_makes_an_authority_and_members_it_signed(tmp_path: Path) -> None:
    folder = tmp_path / "certs"
    done = servolab("certs", str(folder), "router", "--router", "--host", "127.0.0.2")
    assert done.returncode == 0, done.stderr
    assert servolab("certs", str(folder), "robot1").returncode == 0
    authority = x509.load_pem_x509_certificate((folder / "ca.pem").read_bytes())
    for name in ("router", "robot1"):
        member = x509.load_pem_x509_certificate((folder / f"{name}.pem").read_bytes())
        member.verify_directly_issued_by(authority)   # raises if not signed by the authority
        assert member.subject.get_attributes_for_oid(NameOID.COMMON_NAME)[0].value == name
        uses = member.extensions.get_extension_for_class(x509.ExtendedKeyUsage).value
        if name == "router":   # serves TLS where it is reached
            hosts = member.extensions.get_extension_for_class(
                x509.SubjectAlternativeName).value
            assert [str(a) for a in hosts.get_values_for_type(x509.IPAddress)] == ["127.0.0.2"]
            assert ExtendedKeyUsageOID.SERVER_AUTH in uses
        else:                  # a member cannot pose as the router: no host, client use only
            assert list(uses) == [ExtendedKeyUsageOID.CLIENT_AUTH]
            with pytest.raises(x509.ExtensionNotFound):
                member.extensions.get_extension_for_class(x509.SubjectAlternativeName)
        assert (folder / f"{name}-key.pem").stat().st_mode & 0o077 == 0   # owner only
        # the member's session file holds its certificate itself: it can be copied anywhere
        session = json.loads("".join(line for line in (folder / f"{name}.json5").open()
                                     if not line.startswith("//")))
        tls = session["transport"]["link"]["tls"]
        assert base64.b64decode(tls["connect_certificate_base64"]) == \
            (folder / f"{name}.pem").read_bytes()
        assert (folder / f"{name}.json5").stat().st_mode & 0o077 == 0
    # a second member joins the same fleet: the authority is reused, nothing overwritten
    assert servolab("certs", str(folder), "robot2").returncode == 0
    x509.load_pem_x509_certificate((folder / "robot2.pem").read_bytes()) \
        .verify_directly_issued_by(authority)
    again = servolab("certs", str(folder), "robot1")
    assert again.returncode == 2 and "robot1.json5 exists" in again.stderr, again.stderr


def test_a_bad_member_name_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    status, line = refusal(["certs", str(tmp_path), "robot 1"], capsys)
    assert status == 2 and "'robot 1'" in line, line
    assert not (tmp_path / "ca.pem").exists()


@pytest.mark.parametrize(("pattern", "topic", "matches"), [
    ("/**/cmd_vel", "/robot1/diff_drive_controller/cmd_vel", True),
    ("/**/cmd_vel", "/cmd_vel", True),
    ("/*/cmd_vel", "/robot1/cmd_vel", True),
    ("/*/cmd_vel", "/cmd_vel", False),
    ("/*/cmd_vel", "/robot1/cmd_vel_raw", False),
    ("/robot1/**", "/robot1/odom", True),
    ("/robot1/**", "/robot2/odom", False),
])
def test_a_topic_pattern_matches_the_keys_rmw_zenoh_puts_the_topic_at(
        pattern: str, topic: str, matches: bool) -> None:
    key = zenoh.KeyExpr(topic_keyexpr(0, topic, TWIST_STAMPED, HASH))
    assert zenoh.KeyExpr(topic_keyexpr_pattern(pattern)).includes(key) is matches
    # in any domain
    key7 = zenoh.KeyExpr(topic_keyexpr(7, topic, TWIST_STAMPED, HASH))
    assert zenoh.KeyExpr(topic_keyexpr_pattern(pattern)).includes(key7) is matches


def _security_file(tmp_path: Path, text: str = SECURITY) -> Path:
    _certificates(tmp_path / "certs", "router")
    path = tmp_path / "fleet_security.yaml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(("text", "line", "says"), [
    (SECURITY.replace("  ca: certs/ca.pem\n", ""), 2, "key 'ca' missing"),
    (SECURITY.replace("certs/router.pem", "certs/nobody.pem"), 3, "no such file"),
    (SECURITY.replace("/operator/**", "/operator-1/**"), 8, "'operator-1'"),
    (SECURITY.replace("  monitor: []", "  monitor 1: []"), 9, "'monitor 1'"),
    (SECURITY.replace("members:", "memebers:"), 5, "did you mean 'members'"),
    (SECURITY.replace("  monitor: []", "  robot1: []"), 9, "duplicate"),
])
def test_a_bad_security_file_is_refused_in_one_line_naming_where(
        tmp_path: Path, text: str, line: int, says: str) -> None:
    path = _security_file(tmp_path, text)
    with pytest.raises(ConfigFileError) as caught:
        load(path)
    assert one_line(caught, says).startswith(f"{path}:{line}: "), caught.value


def test_with_security_the_router_listens_on_tls_only(tmp_path: Path) -> None:
    path = _security_file(tmp_path)
    config = router_config(RouterOptions(security=path, environ={}))
    assert '"tls/localhost:7447"' in config.get_json("listen/endpoints")
    assert config.get_json("transport/link/tls/enable_mtls") == "true"
    with pytest.raises(TransportError, match=r"tcp/127\.0\.0\.1:1234.*every endpoint is tls/"):
        router_config(RouterOptions(listen=("tcp/127.0.0.1:1234",), security=path, environ={}))


def _at_rest(messages: list[Any]) -> bool:
    return all(abs(v) <= AT_REST for m in messages for v in m.velocity)


def _wire_command(node: Any) -> tuple[bytes, bytes]:
    """A TwistStamped at 0.1 m/s as rmw_zenoh carries it: the CDR and the attachment
    (sequence number, source time, publisher gid)."""
    from servolab.middleware.rmw_zenoh import encode_attachment

    msg = node.message(TWIST_STAMPED, twist={"linear": {"x": 0.1}})
    return (node.context.types.serialize(msg, TWIST_STAMPED),
            encode_attachment(1, time.time_ns(), bytes(16)))


@contextmanager
def _putting(folder: Path, member: str, endpoint: str, key: str,
             wire: tuple[bytes, bytes]) -> Iterator[None]:
    """A bare Zenoh client with ``member``'s certificate putting ``wire`` on ``key`` ten
    times a second (stamped now, as diff_drive_controller wants a fresh command)."""
    config = zenoh.Config.from_file(str(folder / f"{member}.json5"))
    config.insert_json5("connect/endpoints", json.dumps([endpoint]))
    session = zenoh.open(config)
    stop = threading.Event()
    payload, attachment = wire

    def put() -> None:
        from servolab.middleware.messages import MessageTypes

        types = MessageTypes()
        msg = types.deserialize(payload, TWIST_STAMPED)
        while not stop.wait(0.1):
            now = time.time_ns()
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(now, 1_000_000_000)
            session.put(key, types.serialize(msg, TWIST_STAMPED), attachment=attachment)

    thread = threading.Thread(target=put, daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join()
        session.close()


def _client_env(folder: Path, name: str) -> dict[str, str]:
    return {**os.environ, SESSION_CONFIG_ENV: str(folder / f"{name}.json5")}


@pytest.mark.slow
@pytest.mark.realtime
def test_only_members_get_in_and_only_the_fleet_manager_drives(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from servolab.middleware.context import Context
    from servolab.middleware.node import Node
    from servolab.middleware.transport import TransportOptions

    folder = tmp_path / "certs"
    assert servolab("certs", str(folder), "router", "--router").returncode == 0
    assert servolab("certs", str(folder), "fleet_manager", "robot1", "operator", "monitor",
                    "stranger").returncode == 0
    security = tmp_path / "fleet_security.yaml"
    security.write_text(SECURITY)
    endpoint = f"tls/127.0.0.1:{free_port()}"
    # a client that trusts the router but shows no certificate of its own
    no_certificate = tmp_path / "no_certificate.json5"
    no_certificate.write_text(json.dumps({"mode": "client", "transport": {"link": {"tls": {
        "root_ca_certificate": str((folder / "ca.pem").resolve()), "enable_mtls": True}}}}))

    def pub(topic: str, type_name: str, value: str) -> list[str]:
        return [*SERVOLAB, "topic", "pub", topic, type_name, value, "--rate", "10",
                "--connect", endpoint]

    drive = "{twist: {linear: {x: 0.1}}}"
    with started([*SERVOLAB, "router", "--security", str(security), "--listen", endpoint]) \
            as router:
        wait_for_line(router, "listening on", timeout=20)
        refused = servolab("topic", "pub", CMD_VEL, TWIST_STAMPED, drive, "--count", "1",
                           "--connect", endpoint,
                           env={**os.environ, SESSION_CONFIG_ENV: str(no_certificate)})
        assert refused.returncode == 2, refused.stderr
        assert "cannot open a Zenoh client session" in refused.stderr, refused.stderr
        robot = [*SERVOLAB, "control", "run", "turtlebot3_waffle", "--world", "robot",
                 "--namespace", "/robot1", "--spawn", "joint_state_broadcaster",
                 "diff_drive_controller", "--connect", endpoint]
        with started(robot, _client_env(folder, "robot1"), stderr_to_stdout=True) as running:
            wait_for_line(running, "running; Ctrl-C stops it", timeout=60)
            monkeypatch.setenv(SESSION_CONFIG_ENV, str(folder / "monitor.json5"))
            with Context.open(TransportOptions("zenoh", connect=[endpoint])) as ctx:
                probe = Node(ctx, "monitor")
                states: list[Any] = []
                commands: list[Any] = []
                said: dict[str, int] = {"operator": 0, "stranger": 0}
                probe.create_subscription("sensor_msgs/msg/JointState", "/robot1/joint_states",
                                          states.append, 0)
                probe.create_subscription(TWIST_STAMPED, CMD_VEL, commands.append, 10)
                for who in said:
                    probe.create_subscription(
                        STRING, f"/{who}/chatter",
                        lambda _m, who=who: said.__setitem__(who, said[who] + 1), 10)
                assert ctx.spin_until(lambda: len(states) >= 5, timeout=30.0), \
                    "the robot's joint states never came through the secure router"
                with started(pub(CMD_VEL, TWIST_STAMPED, drive),
                             _client_env(folder, "operator")), \
                        started(pub("/operator/chatter", STRING, "{data: hi}"),
                                _client_env(folder, "operator")), \
                        started(pub("/stranger/chatter", STRING, "{data: hi}"),
                                _client_env(folder, "stranger")) as stranger:
                    # the operator is a member: what it may publish arrives, 2 s of it
                    assert ctx.spin_until(lambda: said["operator"] >= 20, timeout=30.0), said
                    since = len(states)
                    assert ctx.spin_until(lambda: len(states) >= since + 5, timeout=10.0)
                    assert commands == [], "the router let the operator's cmd_vel through"
                    assert _at_rest(states), [list(m.velocity) for m in states
                                              if max(map(abs, m.velocity)) > AT_REST]
                    # a certificate of the fleet's authority but no member: nothing it sends
                    # arrives, though it is connected and publishing all along
                    assert said["stranger"] == 0, said
                    assert stranger.poll() is None, stranger.communicate()
                # the positive control: the fleet manager's own command moves the robot
                with started(pub(CMD_VEL, TWIST_STAMPED, drive),
                             _client_env(folder, "fleet_manager")):
                    assert ctx.spin_until(
                        lambda: any(min(abs(v) for v in m.velocity) > TURNING
                                    for m in states[-5:]), timeout=30.0), \
                        "the fleet manager's cmd_vel never reached the robot"
                    assert commands, "the monitor never saw the fleet manager's cmd_vel"
                wire = _wire_command(probe)
                assert ctx.spin_until(lambda: _at_rest(states[-5:]), timeout=10.0)
                # a publication on a wildcard key reaches every subscriber it covers: the
                # operator's on 0/robot1/** is dropped at the router (an allow-list: a deny of
                # */*/cmd_vel/*/* would not cover it)
                with _putting(folder, "operator", endpoint, "0/robot1/**", wire):
                    since = len(states)
                    assert ctx.spin_until(lambda: len(states) >= since + 50, timeout=30.0)
                    assert _at_rest(states[since:]), "the operator's wildcard put moved it"
                # the same bytes on the same key from the fleet manager drive it
                with _putting(folder, "fleet_manager", endpoint, "0/robot1/**", wire):
                    assert ctx.spin_until(
                        lambda: any(min(abs(v) for v in m.velocity) > TURNING
                                    for m in states[-5:]), timeout=30.0), \
                        "the fleet manager's wildcard put never moved the robot"
            running.send_signal(signal.SIGINT)
            said_out, _ = running.communicate(timeout=60)
            assert running.returncode == 128 + signal.SIGINT, said_out
