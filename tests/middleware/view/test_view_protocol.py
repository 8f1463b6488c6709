"""The Foxglove WebSocket protocol's frames, built and parsed without a socket, checked
against the byte layouts and JSON fields of the published spec (ws-protocol ``docs/spec.md``)."""

from __future__ import annotations

import json
import struct

import pytest

from servolab.middleware.view import protocol as p


def test_binary_frames_are_laid_out_as_the_spec_says() -> None:
    frame = p.message_data(7, 1_700_000_000_123_456_789, b"\x00\x01\x00\x00abc")
    assert frame[0] == 0x01
    assert struct.unpack_from("<IQ", frame, 1) == (7, 1_700_000_000_123_456_789)
    assert frame[13:] == b"\x00\x01\x00\x00abc"
    assert p.time_op(42) == b"\x02" + (42).to_bytes(8, "little")
    response = p.service_call_response(3, 9, "cdr", b"xyz")
    assert response == b"\x03" + struct.pack("<III", 3, 9, 3) + b"cdr" + b"xyz"


def test_server_json_ops() -> None:
    info = json.loads(p.server_info("s", ["parameters"], metadata={"k": "v"}, session_id="1"))
    assert info == {"op": "serverInfo", "name": "s", "capabilities": ["parameters"],
                    "supportedEncodings": ["cdr"], "metadata": {"k": "v"}, "sessionId": "1"}
    channel = p.Channel(4, "/chatter", "std_msgs/msg/String", "string data\n")
    assert json.loads(p.advertise([channel]))["channels"] == [{
        "id": 4, "topic": "/chatter", "encoding": "cdr", "schemaName": "std_msgs/msg/String",
        "schema": "string data\n", "schemaEncoding": "ros2msg"}]
    assert json.loads(p.unadvertise([4])) == {"op": "unadvertise", "channelIds": [4]}
    values = json.loads(p.parameter_values([
        p.ParameterValue("/n.d", 2.0), p.ParameterValue("/n.i", 3),
        p.ParameterValue("/n.b", b"AB"), p.ParameterValue("/n.fa", [1.0, 2.5]),
        p.ParameterValue("/n.s", ["a"])], "r"))
    assert values == {"op": "parameterValues", "id": "r", "parameters": [
        {"name": "/n.d", "value": 2.0, "type": "float64"}, {"name": "/n.i", "value": 3},
        {"name": "/n.b", "value": "QUI=", "type": "byte_array"},
        {"name": "/n.fa", "value": [1.0, 2.5], "type": "float64_array"},
        {"name": "/n.s", "value": ["a"]}]}
    assert json.loads(p.status(p.ERROR, "bad")) == {"op": "status", "level": 2,
                                                    "message": "bad"}
    assert json.loads(p.service_call_failure(1, 2, "no")) == {
        "op": "serviceCallFailure", "serviceId": 1, "callId": 2, "message": "no"}


def test_client_ops_parse() -> None:
    assert p.parse_text('{"op":"subscribe","subscriptions":[{"id":1,"channelId":5}]}') == \
        p.Subscribe(((1, 5),))
    assert p.parse_text('{"op":"unsubscribe","subscriptionIds":[1,2]}') == p.Unsubscribe((1, 2))
    assert p.parse_text('{"op":"getParameters","parameterNames":[],"id":"x"}') == \
        p.GetParameters((), "x")
    op = p.parse_text(json.dumps({"op": "setParameters", "parameters": [
        {"name": "/n.a", "value": 3, "type": "float64"},
        {"name": "/n.b", "value": "QUI=", "type": "byte_array"},
        {"name": "/n.c", "value": True}]}))
    assert op == p.SetParameters((p.ParameterValue("/n.a", 3.0), p.ParameterValue("/n.b", b"AB"),
                                  p.ParameterValue("/n.c", True)))
    request = b"\x02" + struct.pack("<III", 4, 8, 3) + b"cdr" + b"\x00\x01\x00\x00"
    assert p.parse_binary(request) == p.ServiceCallRequest(4, 8, "cdr", b"\x00\x01\x00\x00")


@pytest.mark.parametrize(("text", "named"), [
    ("[1]", "JSON object"),
    ('{"op":"subscribe"}', "'subscriptions'"),
    ('{"op":"subscribe","subscriptions":[{"id":-1,"channelId":1}]}', "subscriptions[0].id"),
    ('{"op":"unsubscribe","subscriptionIds":"all"}', "unsubscribe.subscriptionIds"),
    ('{"op":"getParameters","parameterNames":[1]}', "parameterNames[0]"),
    ('{"op":"setParameters","parameters":[{"name":"/n.a","value":"x","type":"float64"}]}',
     "parameters[0].value"),
    ('{"op":"advertise","channels":[]}', "clientPublish"),
    ('{"op":"fly"}', "'fly'"),
])
def test_a_bad_client_op_is_named_in_one_line(text: str, named: str) -> None:
    with pytest.raises(p.ClientMessageError) as error:
        p.parse_text(text)
    assert named in str(error.value) and "\n" not in str(error.value)


@pytest.mark.parametrize(("data", "named"), [
    (b"", "no opcode"),
    (b"\x02\x00", "13-byte header"),
    (b"\x02" + struct.pack("<III", 1, 1, 50) + b"cdr", "encoding length 50"),
    (b"\x01\x00\x00\x00\x00", "clientPublish"),
    (b"\x09", "0x09"),
])
def test_a_bad_binary_op_is_named(data: bytes, named: str) -> None:
    with pytest.raises(p.ClientMessageError, match=named):
        p.parse_binary(data)


def test_parameter_names_are_foxglove_bridges() -> None:
    assert p.parameter_name("/ns/talker", "a.b") == "/ns/talker.a.b"
    assert p.split_parameter_name("/ns/talker.a.b") == ("/ns/talker", "a.b")
    for bad in ("talker.rate", "/talker", "/.rate", "/talker."):
        with pytest.raises(p.ClientMessageError):
            p.split_parameter_name(bad)
