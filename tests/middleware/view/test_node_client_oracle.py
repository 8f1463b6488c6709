"""The Foxglove WebSocket oracle checked against Foxglove's own server, apart from servolab.

``servolab view`` is tested with a client servolab did not write (:mod:`tests.viewclient`:
``@foxglove/ws-protocol``'s FoxgloveClient and ``@foxglove/rosmsg2-serialization``'s CDR
decoder, run by Node). These tests show that client is right on its own: against the Foxglove
SDK's Python server (``foxglove.start_server``), carrying ROS 2 CDR that servolab's message
types wrote, it decodes exactly what was logged, at the log time it was logged with; it reads
and sets parameters and calls a service; and it is refused with the subprotocol that server
does not speak. So a failure of the same client against ``servolab view`` is servolab's.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import foxglove
import pytest
from foxglove import Channel, Context, MessageSchema, Parameter, Schema, Service, ServiceSchema
from foxglove.websocket import (
    Capability,
    Client,
    ServerListener,
    ServiceRequest,
    WebSocketServer,
)

from servolab.middleware.messages import MessageTypes
from tests.viewclient import SDK_V1, WEBSOCKET_V1, node_client, run_client, started_client

TWIST = "geometry_msgs/msg/Twist"
JOINTS = "sensor_msgs/msg/JointState"
ADD = "example_interfaces/srv/AddTwoInts"
#: log times of the i-th message: T0 + i ns (well above any real clock's bits of a double)
T0 = 1_700_000_000_123_456_789

TYPES = MessageTypes()


def twist_of(i: int) -> dict[str, Any]:
    """The i-th Twist logged, as the decoder gives it (every field; floats exact in binary)."""
    return {"linear": {"x": 0.5 * i, "y": -0.25 * i, "z": 1.0},
            "angular": {"x": 0.0, "y": 0.0, "z": i / 8}}


def joints_of(i: int) -> dict[str, Any]:
    """The i-th JointState logged: a nested Time, strings, float64 arrays, an empty array."""
    return {"header": {"stamp": {"sec": 1_700_000_000 + i, "nanosec": 999_999_999 - i},
                       "frame_id": "base_link"},
            "name": ["hip", "knee"], "position": [0.125 * i, -3.5],
            "velocity": [], "effort": [1.0e-3]}


def schema_of(name: str) -> Schema:
    return Schema(name=name, encoding="ros2msg", data=TYPES.msgdef(name).encode())


def cdr(name: str, value: dict[str, Any]) -> bytes:
    return TYPES.serialize(TYPES.from_value(name, value), name)


class Parameters(ServerListener):
    """The server's parameters: read and set by the client."""

    def __init__(self) -> None:
        self.values: dict[str, Any] = {"gain": 1.5, "mode": "walk", "limits": [1, 2, 3]}

    def on_get_parameters(self, client: Client, param_names: list[str],
                          request_id: str | None = None) -> list[Parameter]:
        names = param_names or list(self.values)
        return [Parameter(n, value=self.values[n]) for n in names if n in self.values]

    def on_set_parameters(self, client: Client, parameters: list[Parameter],
                          request_id: str | None = None) -> list[Parameter]:
        for parameter in parameters:
            self.values[parameter.name] = parameter.get_value()
        return [Parameter(n, value=v) for n, v in self.values.items()]


@dataclass
class FoxgloveServer:
    server: WebSocketServer
    listener: Parameters
    channels: dict[str, Channel]
    calls: list[tuple[int, int]] = field(default_factory=list)

    @property
    def url(self) -> str:
        return f"ws://127.0.0.1:{self.server.port}"


@pytest.fixture
def fox() -> Iterator[FoxgloveServer]:
    """Foxglove SDK's server on a free port with its own context: /twist (Twist) and /joints
    (JointState) in CDR, three parameters, and the service /add (AddTwoInts)."""
    node_client()  # skip before starting anything where the client cannot run
    context = Context()
    listener = Parameters()
    calls: list[tuple[int, int]] = []

    def add(request: ServiceRequest) -> bytes:
        value = TYPES.deserialize(request.payload, f"{ADD}_Request")
        calls.append((int(value.a), int(value.b)))
        return cdr(f"{ADD}_Response", {"sum": int(value.a) + int(value.b)})

    def message_schema(name: str) -> MessageSchema:
        return MessageSchema(encoding="cdr", schema=schema_of(name))

    service = Service("/add", handler=add, schema=ServiceSchema(
        ADD, request=message_schema(f"{ADD}_Request"), response=message_schema(f"{ADD}_Response")))
    server = foxglove.start_server(
        name="oracle-check", host="127.0.0.1", port=0, context=context,
        capabilities=[Capability.Parameters, Capability.Services], server_listener=listener,
        supported_encodings=["cdr"], services=[service])
    try:
        channels = {topic: Channel(topic, schema=schema_of(name), message_encoding="cdr",
                                   context=context)
                    for topic, name in (("/twist", TWIST), ("/joints", JOINTS))}
        yield FoxgloveServer(server, listener, channels, calls)
    finally:
        server.stop()


def test_decodes_what_foxglove_sdk_logged(fox: FoxgloveServer) -> None:
    count = 5
    with started_client(fox.url, SDK_V1, ["/twist", "/joints"], count=count,
                        timeout=30) as client:
        client.wait_until(lambda c: len(c.of("subscribe")) == 2, "subscriptions to both topics")
        # The server drops what is logged before it has handled a subscription: keep logging,
        # one of each at a time, until the client has its messages.
        i = 0
        while client.returncode is None and i < 2000:
            fox.channels["/twist"].log(cdr(TWIST, twist_of(i)), log_time=T0 + i)
            fox.channels["/joints"].log(cdr(JOINTS, joints_of(i)), log_time=T0 + i)
            client.wait_for_more("message", timeout=0.05)
            i += 1
        assert client.wait(10) == 0, client.describe()
        events = client.events

    assert events[-1] == {"op": "done"}
    info = next(e for e in events if e["op"] == "serverInfo")
    assert info["name"] == "oracle-check"
    advertised = {e["topic"]: e for e in events if e["op"] == "advertise"}
    assert advertised["/twist"]["schemaName"] == TWIST
    assert advertised["/joints"]["schemaName"] == JOINTS
    assert advertised["/twist"]["encoding"] == "cdr"
    for topic, expected in (("/twist", twist_of), ("/joints", joints_of)):
        got = [e for e in events if e["op"] == "message" and e["topic"] == topic]
        assert len(got) == count
        indices = [int(e["logTime"]) - T0 for e in got]
        assert indices == sorted(set(indices)) and all(0 <= n < i for n in indices), indices
        for n, event in zip(indices, got, strict=True):
            assert event["message"] == expected(n), (topic, n)


def test_foxglove_sdk_refuses_websocket_v1(fox: FoxgloveServer) -> None:
    with started_client(fox.url, WEBSOCKET_V1, ["/twist"], timeout=20) as client:
        assert client.wait(30) == 1, client.describe()
        events = client.events
    assert not [e for e in events if e["op"] in ("open", "serverInfo", "message")], events
    assert any(e["op"] == "error" and "400" in e["error"] for e in events), events
    assert events[-1]["op"] == "close"


def test_reads_and_sets_parameters(fox: FoxgloveServer) -> None:
    events = run_client(fox.url, SDK_V1, get_parameters=["gain", "mode", "limits"])
    assert events[-1] == {"op": "done"}, events
    [got] = [e for e in events if e["op"] == "parameterValues"]
    assert got["id"] == "get"
    assert {p["name"]: p["value"] for p in got["parameters"]} == {
        "gain": 1.5, "mode": "walk", "limits": [1, 2, 3]}

    events = run_client(fox.url, SDK_V1, set_parameters={"gain": 2.25, "mode": "trot"})
    assert events[-1] == {"op": "done"}, events
    [got] = [e for e in events if e["op"] == "parameterValues"]
    assert got["id"] == "set"
    assert {p["name"]: p["value"] for p in got["parameters"]}["gain"] == 2.25
    assert fox.listener.values["gain"] == 2.25
    assert fox.listener.values["mode"] == "trot"


def test_calls_a_service_in_cdr(fox: FoxgloveServer) -> None:
    a, b = 2**40 + 1, -(2**41)  # beyond 32 bits: int64 both ways (bigint in the client)
    events = run_client(fox.url, SDK_V1, call_service="/add", request={"a": a, "b": b})
    assert events[-1] == {"op": "done"}, events
    [response] = [e for e in events if e["op"] == "serviceResponse"]
    assert response["service"] == "/add"
    assert response["response"] == {"sum": str(a + b)}
    assert fox.calls == [(a, b)]
