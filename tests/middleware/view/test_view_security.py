"""Nothing from outside stops, confuses or enters ``servolab view``.

What a client may send and what the server answers are the Foxglove WebSocket protocol's
(``foxglove/ws-protocol``, https://github.com/foxglove/ws-protocol/blob/main/docs/spec.md): the
op names ``subscribe``, ``getParameters``, ``setParameters`` (JSON), Service Call Request
(binary opcode 0x02: u32 service id, u32 call id, u32 encoding length, encoding, payload); the
answers ``status`` (``{"op": "status", "level": 0|1|2, "message": ...}``, 2 an error),
``serviceCallFailure`` (``serviceId``, ``callId``, ``message``), ``parameterValues``, Service
Call Response (binary 0x03) and Message Data (binary 0x01: u32 subscription id, u64 log time,
payload). The clients here are plain ``websockets`` connections written from that text; CDR is
written by ``mcap-ros2-support``.

- a client that sends 5 MB requests and never reads leaves the server's memory bounded (the
  server in a process of its own, its resident set measured);
- one whose answers pile up is disconnected past the control queue's bound, as foxglove-sdk
  disconnects a client whose control-plane queue is full;
- a malformed or deeply nested message is logged once per client, never as a traceback;
- a web page from a foreign origin is refused at the handshake (HTTP 403);
- beyond loopback, a client without the token may watch but not control; ``--ws-read-only``
  makes every client a watcher.
"""

from __future__ import annotations

import json
import logging
import socket
import struct
import subprocess
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import pytest
from mcap_ros2._dynamic import serialize_dynamic
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect
from websockets.typing import Origin

from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.middleware.view import ViewConfig, ViewServer
from servolab.middleware.view.access import TOKEN_ENV, is_loopback
from servolab.middleware.view.server import _Viewer
from tests.middleware.view.test_view_server import SpecClient
from tests.waiting import wait_for

STRING, SET_BOOL = "std_msgs/msg/String", "std_srvs/srv/SetBool"
SUBPROTOCOL = "foxglove.sdk.v1"
MB = 2**20


# -- a small graph: a talker, a parameter, a service ----------------------------------------


@dataclass
class Robot:
    ctx: Context
    node: Node
    calls: list[bool]
    #: set to let the service answer (it waits for it, up to 5 s)
    release: threading.Event


@pytest.fixture
def robot() -> Iterator[Robot]:
    with Context.open() as ctx:
        node = Node(ctx, "arm")
        node.declare_parameter("torque_enable", True)
        calls: list[bool] = []
        release = threading.Event()
        release.set()

        def set_bool(request: Any, response: Any) -> Any:
            release.wait(5)
            calls.append(bool(request.data))
            response.success = True
            return response

        node.create_service(SET_BOOL, "/arm/enable", set_bool)
        chatter = node.create_publisher(STRING, "/chatter", 10)
        node.create_timer(0.02, lambda: chatter.publish(node.message(STRING, data="hi")))
        thread = ctx.executor.spin_in_thread()
        try:
            yield Robot(ctx, node, calls, release)
        finally:
            release.set()
            ctx.shutdown()
            thread.join()


@contextmanager
def client(url: str, *, origin: str | None = None, token: str | None = None,
           sock: socket.socket | None = None) -> Iterator[SpecClient]:
    address = url if token is None else f"{url}/?token={token}"
    with connect(address, subprotocols=[SUBPROTOCOL], origin=Origin(origin) if origin else None,
                 open_timeout=5, sock=sock, max_size=None) as ws:
        c = SpecClient(ws)
        c.op("serverInfo")
        yield c


def set_torque(c: SpecClient, value: bool, request: str) -> None:
    c.send("setParameters", id=request,
           parameters=[{"name": "/arm.torque_enable", "value": value}])


def call_enable(c: SpecClient, call_id: int, data: bool = False) -> None:
    """A Service Call Request (0x02) of /arm/enable, its CDR written from the advertised
    schema."""
    service = c.service("/arm/enable")
    request = service["request"]
    encode = serialize_dynamic(request["schemaName"], request["schema"])[request["schemaName"]]
    c.ws.send(struct.pack("<BIII", 0x02, service["id"], call_id, 3) + b"cdr"
              + encode({"data": data}))


def service_answered(c: SpecClient, call_id: int) -> bool:
    """Whether the call got a Service Call Response (0x03); False on serviceCallFailure."""
    def fits(frame: str | bytes) -> bool:
        if isinstance(frame, bytes):
            return frame[0] == 0x03 and struct.unpack_from("<I", frame, 5)[0] == call_id
        op = json.loads(frame)
        return op["op"] == "serviceCallFailure" and op["callId"] == call_id
    return isinstance(c.expect(fits, f"an answer to call {call_id}"), bytes)


def never_reading(port: int) -> socket.socket:
    """A client that opens the connection (RFC 6455's handshake) and then only sends: it
    never reads a byte, not even the server's answer to the handshake."""
    sock = socket.create_connection(("127.0.0.1", port))
    sock.sendall(b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\n"
                 b"Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                 b"Sec-WebSocket-Version: 13\r\nSec-WebSocket-Protocol: " + SUBPROTOCOL.encode()
                 + b"\r\n\r\n")
    return sock


def text_frame(text: str) -> bytes:
    """A client's text frame (RFC 6455 5.2): FIN + opcode 1, masked with the all-zero key
    (a valid mask that leaves the payload as it is), 64-bit length."""
    payload = text.encode()
    return b"\x81\xff" + struct.pack(">Q", len(payload)) + bytes(4) + payload


def watches(c: SpecClient) -> None:
    """The client subscribes and gets /chatter's messages: watching works."""
    channel = c.channel("/chatter")
    c.send("subscribe", subscriptions=[{"id": 3, "channelId": channel["id"]}])
    c.message_data(3)


# -- memory: 60 x 5 MB from a client that never reads ----------------------------------------

SERVER = """
import sys
from servolab.middleware.context import Context
from servolab.middleware.view import ViewConfig, ViewServer
with Context.open() as ctx, ViewServer(ctx, ViewConfig(port=0)) as view:
    print(view.port, flush=True)
    sys.stdin.read()
"""

#: what the server's peak resident set may grow by while a client sends 60 x 5 MB requests
#: it never reads the answers of. It reads one message at a time, so a few copies of one
#: 5 MB message (the frame, its text, the parsed string) is what it needs; before answers
#: were cut and queues bounded it grew by 315 MB (44 -> 359 MB), answers echoing requests.
RSS_GROWTH_BOUND_MB = 64


def _memory(pid: int) -> dict[str, int]:
    """VmRSS and VmHWM (the peak resident set) of ``pid``, in MB."""
    with open(f"/proc/{pid}/status") as status:
        return {line.split(":")[0]: int(line.split()[1]) // 1024 for line in status
                if line.startswith(("VmRSS", "VmHWM"))}


@pytest.mark.skipif(not sys.platform.startswith("linux"),
                    reason="measures the server process's memory in /proc/PID/status, "
                    "which only Linux has; the queue bounds are tested on every system below")
@pytest.mark.slow
def test_a_client_sending_5_mb_requests_and_never_reading_leaves_memory_bounded() -> None:
    server = subprocess.Popen([sys.executable, "-c", SERVER], stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert server.stdout is not None
        url = f"ws://127.0.0.1:{int(server.stdout.readline())}"
        with client(url) as warm_up:  # the handshake's code loaded, then the baseline
            warm_up.send("getParameters", parameterNames=[], id="warm")
            warm_up.op("parameterValues", id="warm")
        before = _memory(server.pid)
        # an unknown op: the answer names it, once quoting all 5 MB of it
        request = text_frame(json.dumps({"op": "x" * (5 * MB)}))
        with never_reading(int(url.rsplit(":", 1)[1])) as sock:
            for _ in range(60):
                sock.sendall(request)
            with client(url) as other:  # the server still answers; its look at memory
                other.send("getParameters", parameterNames=[], id="alive")
                other.op("parameterValues", id="alive")
                after = _memory(server.pid)
        assert after["VmHWM"] - before["VmRSS"] < RSS_GROWTH_BOUND_MB, (before, after)
    finally:
        _, stderr = server.communicate(timeout=20)  # closes its stdin: it ends
    said = [line for line in stderr.splitlines() if "does not allow" in line]
    assert len(said) == 1, stderr[-2000:]        # one line for 60 bad messages
    assert len(said[0]) < 600 and "Traceback" not in stderr


@pytest.mark.slow
def test_answers_a_client_does_not_read_disconnect_it_past_the_control_bound(
        robot: Robot, caplog: pytest.LogCaptureFixture) -> None:
    """Answers must arrive, so they are never dropped: a client that owes more than the
    bound (here 2 MB) is disconnected, saying why, as foxglove-sdk disconnects a client whose
    control-plane queue is full."""
    robot.node.declare_parameter("blob", "x" * MB)  # each answer: 1 MB
    caplog.set_level(logging.WARNING, "servolab.view")
    config = ViewConfig(port=0, control_bytes=2 * MB)
    with ViewServer(robot.ctx, config) as view, never_reading(view.port) as sock:
        wait_for(lambda: view.viewers == 1, "the server to see the client")
        for i in range(60):  # 60 MB of answers, more than the sockets' buffers hold
            sock.sendall(text_frame(json.dumps({"op": "getParameters", "id": str(i),
                                                "parameterNames": ["/arm.blob"]})))
        wait_for(lambda: view.viewers == 0, "the server to drop the client", timeout=20)
    said = [r.getMessage() for r in caplog.records if "disconnecting client" in r.getMessage()]
    assert len(said) == 1 and "reads too slowly" in said[0], said


def test_each_queue_of_a_viewer_keeps_to_its_bounds() -> None:
    overflowed: list[_Viewer] = []
    limits = ViewConfig(send_queue=3, send_bytes=100, control_queue=4, control_bytes=50)
    viewer = _Viewer(ws=None, limits=limits, on_overflow=overflowed.append)  # type: ignore[arg-type]
    assert [viewer.send_data(bytes(10)) for _ in range(5)] == [0, 0, 0, 1, 1]  # 3 frames
    assert viewer.send_data(bytes(95)) == 3 and viewer.data_bytes == 95      # 100 bytes
    assert viewer.send_data(bytes(500)) == 1 and len(viewer.data) == 1  # one large still goes
    for _ in range(4):
        viewer.send("x" * 10)
    assert not overflowed and viewer.control_bytes == 40
    viewer.send("x" * 11)                                # 51 bytes: one too many
    assert overflowed == [viewer] and "reads too slowly" in viewer.closing
    assert not viewer.control and not viewer.data        # what it held is let go
    viewer.send("more")
    assert viewer.send_data(b"more") == 0 and not viewer.control and not viewer.data


# -- bad messages: logged once a client ------------------------------------------------------


def test_a_deeply_nested_message_is_answered_and_logged_once_a_client(
        robot: Robot, caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, "servolab.view")
    with ViewServer(robot.ctx, ViewConfig(port=0)) as view:
        with client(view.url) as c:
            for _ in range(100):
                c.ws.send("[" * 100_000)
            for _ in range(100):
                assert "nested deeper" in c.op("status", level=2)["message"]
            c.send("x" * MB)                   # a 1 MB op name is quoted, cut
            echo = c.op("status", level=2)["message"]
            assert echo.startswith("op: unknown op 'xxx") and len(echo) < 250
            c.send("getParameters", parameterNames=["/arm.torque_enable"], id="alive")
            assert c.op("parameterValues", id="alive")["parameters"][0]["value"] is True
        wait_for(lambda: view.viewers == 0, "the client to leave")
    lines = [r for r in caplog.records if r.name == "servolab.view"
             and "client 127.0.0.1:" in r.getMessage()]
    assert [r.levelno for r in lines] == [logging.WARNING, logging.INFO], \
        [r.getMessage() for r in lines]
    assert "101 bad message(s)" in lines[1].getMessage()
    assert not any(r.exc_info for r in caplog.records)  # no traceback


def test_a_client_has_at_most_in_flight_requests_served_at_once(robot: Robot) -> None:
    robot.release.clear()                       # the service waits
    with ViewServer(robot.ctx, ViewConfig(port=0, in_flight=2)) as view, \
            client(view.url) as c:
        for call_id in (1, 2, 3):
            call_enable(c, call_id)
        failure = c.op("serviceCallFailure", callId=3)
        assert "too many requests in flight" in failure["message"]
        robot.release.set()
        assert service_answered(c, 1) and service_answered(c, 2)
        assert robot.calls == [False, False]


def test_parameters_of_nodes_not_in_the_graph_make_no_service_clients(robot: Robot) -> None:
    with ViewServer(robot.ctx, ViewConfig(port=0)) as view, client(view.url) as c:
        c.send("getParameters", id="ghosts",
               parameterNames=[f"/ghost{i}.rate" for i in range(30)])
        assert c.op("parameterValues", id="ghosts")["parameters"] == []
        c.send("setParameters", parameters=[{"name": "/ghost.rate", "value": 1}])
        assert "no node '/ghost'" in c.op("status", level=2)["message"]
        clients = [e.name for e in robot.ctx.transport.graph(0.2)
                   if e.kind == "SC" and e.node == "/servolab_view"]
        assert not any("ghost" in name for name in clients), clients


# -- who may connect: the Origin of a browser page -------------------------------------------


#: programs (no Origin), Foxglove's and Lichtblick's web apps, pages served from this
#: computer, the desktop apps' file://
LET_IN = (None, "https://app.foxglove.dev", "https://lichtblick-suite.github.io",
          "http://localhost:5173", "http://127.0.0.1:8080", "file://")
#: any other site, and look-alikes of the ones let in
REFUSED = ("https://evil.example", "http://localhost.evil.example",
           "https://app.foxglove.dev.evil.example", "http://192.168.1.20:8080")


def test_the_apps_pages_localhost_and_programs_are_let_in(robot: Robot) -> None:
    with ViewServer(robot.ctx, ViewConfig(port=0)) as view:
        for value, origin in enumerate(LET_IN):
            with client(view.url, origin=origin) as c:
                watches(c)
                set_torque(c, value % 2 == 0, "set")
                c.op("parameterValues", id="set")
            assert robot.node.get_parameter("torque_enable").value is (value % 2 == 0)


def test_a_page_from_elsewhere_is_refused_at_the_handshake(
        robot: Robot, caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.WARNING, "servolab.view")
    with ViewServer(robot.ctx, ViewConfig(port=0)) as view:
        for origin in REFUSED * 2:
            with pytest.raises(InvalidStatus) as refused, client(view.url, origin=origin):
                pass
            assert refused.value.response.status_code == 403  # HTTP 403 Forbidden
        assert view.viewers == 0
    said = [r.getMessage() for r in caplog.records if "refused a connection" in r.getMessage()]
    assert len(said) == len(REFUSED)  # once an origin
    assert all(origin in line for origin, line in zip(REFUSED, said, strict=True))


def test_an_origin_allowed_on_the_command_line_is_let_in(robot: Robot) -> None:
    config = ViewConfig(port=0, allow_origins=("https://lab.example:8443",))
    with ViewServer(robot.ctx, config) as view:
        with client(view.url, origin="https://lab.example:8443") as c:
            watches(c)
        with pytest.raises(InvalidStatus), client(view.url, origin="https://lab.example"):
            pass


def test_a_page_with_the_null_origin_may_watch_but_not_control(robot: Robot) -> None:
    """``Origin: null``: a page opened from a file, or a sandboxed frame any site may embed."""
    with ViewServer(robot.ctx, ViewConfig(port=0)) as view, \
            client(view.url, origin="null") as c:
        told = c.op("status", level=1)["message"]
        assert "may watch, not control" in told and "Origin: null" in told
        watches(c)
        set_torque(c, False, "set")
        assert "setParameters refused" in c.op("status", level=2)["message"]
        assert robot.node.get_parameter("torque_enable").value is True
    config = ViewConfig(port=0, allow_origins=("null",))
    with ViewServer(robot.ctx, config) as view, client(view.url, origin="null") as c:
        set_torque(c, False, "set")
        c.op("parameterValues", id="set")
        assert robot.node.get_parameter("torque_enable").value is False


# -- who may control: the token beyond loopback, read-only anywhere --------------------------


def test_beyond_loopback_a_client_without_the_token_may_watch_not_control(
        robot: Robot) -> None:
    assert not is_loopback("0.0.0.0") and is_loopback("127.0.0.1") and is_loopback("::1")
    with ViewServer(robot.ctx, ViewConfig(host="0.0.0.0", port=0)) as view:
        assert view.token_required and view.token and len(view.token) >= 16
        assert view.control_url.endswith(f"/?token={view.token}")
        assert not any(view.token in line for line in view.access)
        url = f"ws://127.0.0.1:{view.port}"
        for token in (None, "not-the-token"):
            with client(url, token=token) as c:
                told = c.op("status", level=1)["message"]
                assert "may watch, not control" in told and "token" in told
                watches(c)                                # subscribe works
                c.send("getParameters", parameterNames=["/arm.torque_enable"], id="get")
                assert c.op("parameterValues", id="get")["parameters"][0]["value"] is True
                set_torque(c, False, "set")
                refused = c.op("status", level=2)["message"]
                assert refused.startswith("setParameters refused") and "token" in refused
                assert ("not it" in refused) == (token is not None)
                call_enable(c, 7)
                failure = c.op("serviceCallFailure", callId=7)
                assert failure["message"].startswith("callService refused")
        assert robot.node.get_parameter("torque_enable").value is True
        assert robot.calls == []
        with client(url, token=view.token) as c:          # with the token: control
            watches(c)
            set_torque(c, False, "set")
            c.op("parameterValues", id="set")
            call_enable(c, 8)
            assert service_answered(c, 8)
        assert robot.node.get_parameter("torque_enable").value is False
        assert robot.calls == [False]


def test_a_token_given_is_needed_on_loopback_too(robot: Robot,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(TOKEN_ENV, "lab-token-1234")
    with ViewServer(robot.ctx, ViewConfig(port=0)) as view:
        assert view.token == "lab-token-1234" and view.token_required
        with client(view.url) as c:
            set_torque(c, False, "set")
            assert "setParameters refused" in c.op("status", level=2)["message"]
        with client(view.url, token="lab-token-1234") as c:
            set_torque(c, False, "set")
            c.op("parameterValues", id="set")
    assert robot.node.get_parameter("torque_enable").value is False


def test_read_only_refuses_control_on_loopback_too(robot: Robot) -> None:
    with ViewServer(robot.ctx, ViewConfig(port=0, read_only=True)) as view, \
            client(view.url) as c:
        assert "read-only" in c.op("status", level=1)["message"]
        watches(c)
        set_torque(c, False, "set")
        assert "read-only" in c.op("status", level=2)["message"]
        call_enable(c, 9)
        assert "read-only" in c.op("serviceCallFailure", callId=9)["message"]
        assert any("read-only" in line for line in view.access)
    assert robot.node.get_parameter("torque_enable").value is True
    assert robot.calls == []
