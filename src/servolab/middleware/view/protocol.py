"""The Foxglove WebSocket protocol v1, as pure functions: no sockets, no threads, no graph.

The server (:mod:`.server`) builds every frame it sends through here and parses every frame
a client sends through here, so the wire format is in one place and testable without a
network. The layout follows the published spec (``foxglove/ws-protocol``, ``docs/spec.md``):
JSON text messages carry an ``op`` field; binary messages start with a one-byte opcode, and
every integer in them is little-endian.

A client's message that breaks the spec raises :class:`ClientMessageError` with one line
naming the field at fault; the server answers it with a ``status`` error op and keeps the
connection, as foxglove_bridge does, rather than dropping a viewer over one bad message.
"""

from __future__ import annotations

import base64
import json
import math
import reprlib
import struct
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from ..errors import MiddlewareValueError

#: The subprotocol names a client may ask for. They are one protocol under two names: the
#: Foxglove SDK renamed ``foxglove.websocket.v1`` to ``foxglove.sdk.v1`` without changing a
#: byte of it (foxglove discussion #1131; Lichtblick offers both since lichtblick-suite
#: PR #819), so a server that speaks one speaks the other.
SUBPROTOCOLS = ("foxglove.websocket.v1", "foxglove.sdk.v1")

#: The message encoding servolab's topics and services carry (ROS 2's CDR).
ENCODING = "cdr"
#: How a ROS 2 schema is written: the concatenated ``.msg`` text rosbag2 and MCAP store.
SCHEMA_ENCODING = "ros2msg"

# Capabilities (spec, "Server Info").
PARAMETERS = "parameters"
PARAMETERS_SUBSCRIBE = "parametersSubscribe"
TIME = "time"
SERVICES = "services"
#: the server plays recorded data that the app may pause, seek and speed up (foxglove-sdk's
#: ``Capability.PlaybackControl``; its serverInfo then gives dataStartTime / dataEndTime)
PLAYBACK_CONTROL = "playbackControl"

# Status levels (spec, "Status").
INFO, WARNING, ERROR = 0, 1, 2

# Binary opcodes, server to client.
OP_MESSAGE_DATA = 0x01
OP_TIME = 0x02
OP_SERVICE_CALL_RESPONSE = 0x03
OP_PLAYBACK_STATE = 0x05
# Binary opcodes, client to server.
OP_CLIENT_MESSAGE_DATA = 0x01
OP_SERVICE_CALL_REQUEST = 0x02
OP_PLAYBACK_CONTROL_REQUEST = 0x03

# Playback commands (client) and statuses (server), as foxglove-sdk numbers them.
PLAY, PAUSE = 0, 1
PLAYING, PAUSED, BUFFERING, ENDED = 0, 1, 2, 3
_PLAYBACK_REQUEST = struct.Struct("<BBfBQI")  # op, command, speed, had seek, seek ns, id len
_PLAYBACK_STATE = struct.Struct("<BBQfBI")    # op, status, time ns, speed, did seek, id len

_U32_MAX = 0xFFFF_FFFF
_U64_MAX = 0xFFFF_FFFF_FFFF_FFFF


class ClientMessageError(MiddlewareValueError):
    """A client's message the spec does not allow: one line, naming the field at fault."""


#: The most of a client's own text an answer quotes back: a 5 MB request earns a short error,
#: not a 5 MB one (which a client that never reads would make the server keep).
ECHO_LIMIT = 200
#: The longest status or failure message sent, whatever it quotes (a node's reason, an error).
MESSAGE_LIMIT = 1000


def cut(text: str, limit: int) -> str:
    """``text``, cut to ``limit`` characters with "…" when longer."""
    return text if len(text) <= limit else text[:limit - 1] + "…"


_ECHO = reprlib.Repr()
_ECHO.maxstring = ECHO_LIMIT   # reprlib keeps the end of a string too: "'abc...xyz'"
_ECHO.maxother = ECHO_LIMIT
_ECHO.maxlevel = 4             # deeply nested values: "[[[[...]]]]", no recursion
_ECHO.maxlist = _ECHO.maxtuple = _ECHO.maxdict = _ECHO.maxset = 10
_ECHO.maxlong = 40


def echo(value: Any) -> str:
    """A client's value as an error message quotes it: its repr, cut to :data:`ECHO_LIMIT`
    characters with "…" (built without ever making the whole repr of a huge value)."""
    return cut(_ECHO.repr(value), ECHO_LIMIT)


# -- what the server describes -------------------------------------------------------------


@dataclass(frozen=True)
class Channel:
    """A topic as a client sees it (spec, "Advertise"): one per topic and type."""

    id: int
    topic: str
    schema_name: str
    schema: str
    encoding: str = ENCODING
    schema_encoding: str = SCHEMA_ENCODING

    def to_json(self) -> dict[str, Any]:
        return {"id": self.id, "topic": self.topic, "encoding": self.encoding,
                "schemaName": self.schema_name, "schema": self.schema,
                "schemaEncoding": self.schema_encoding}


@dataclass(frozen=True)
class ServiceChannel:
    """A service as a client sees it (spec, "Advertise Services"). Both the ``request`` /
    ``response`` objects and the older ``requestSchema`` / ``responseSchema`` strings are
    sent, so clients of either generation can call it."""

    id: int
    name: str
    type: str
    request_schema_name: str
    request_schema: str
    response_schema_name: str
    response_schema: str

    def to_json(self) -> dict[str, Any]:
        def part(schema_name: str, schema: str) -> dict[str, str]:
            return {"encoding": ENCODING, "schemaName": schema_name,
                    "schemaEncoding": SCHEMA_ENCODING, "schema": schema}

        return {"id": self.id, "name": self.name, "type": self.type,
                "request": part(self.request_schema_name, self.request_schema),
                "response": part(self.response_schema_name, self.response_schema),
                "requestSchema": self.request_schema,
                "responseSchema": self.response_schema}


@dataclass(frozen=True)
class ParameterValue:
    """One parameter as the protocol carries it: ``/node.param`` and a Python value
    (``bytes`` for a byte array, ``float`` / a list of floats for doubles; None: unset)."""

    name: str
    value: Any


# -- JSON ops the server sends ---------------------------------------------------------------


def _text(op: str, **fields: Any) -> str:
    return json.dumps({"op": op, **fields}, separators=(",", ":"))


def server_info(name: str, capabilities: Sequence[str], *,
                supported_encodings: Sequence[str] = (ENCODING,),
                metadata: Mapping[str, str] | None = None, session_id: str = "",
                data_range_ns: tuple[int, int] | None = None) -> str:
    """``serverInfo``: sent first on every connection (spec, "Server Info"); a server that
    plays recorded data says its time range (``dataStartTime``, ``dataEndTime``)."""
    fields: dict[str, Any] = {"name": name, "capabilities": list(capabilities),
                              "supportedEncodings": list(supported_encodings),
                              "metadata": dict(metadata or {})}
    if session_id:
        fields["sessionId"] = session_id
    if data_range_ns is not None:
        start, end = data_range_ns
        fields["dataStartTime"] = {"sec": start // 1_000_000_000, "nsec": start % 1_000_000_000}
        fields["dataEndTime"] = {"sec": end // 1_000_000_000, "nsec": end % 1_000_000_000}
    return _text("serverInfo", **fields)


def status(level: int, message: str, status_id: str | None = None) -> str:
    """``status``: 0 info, 1 warning, 2 error; the message cut to :data:`MESSAGE_LIMIT`."""
    if level not in (INFO, WARNING, ERROR):
        raise MiddlewareValueError(f"status level {level!r}: 0 (info), 1 (warning) or 2 (error)")
    fields: dict[str, Any] = {"level": level, "message": cut(message, MESSAGE_LIMIT)}
    if status_id is not None:
        fields["id"] = status_id
    return _text("status", **fields)


def remove_status(status_ids: Sequence[str]) -> str:
    if not status_ids:
        raise MiddlewareValueError("removeStatus needs at least one status id (spec)")
    return _text("removeStatus", statusIds=list(status_ids))


def advertise(channels: Sequence[Channel]) -> str:
    return _text("advertise", channels=[c.to_json() for c in channels])


def unadvertise(channel_ids: Sequence[int]) -> str:
    return _text("unadvertise", channelIds=list(channel_ids))


def advertise_services(services: Sequence[ServiceChannel]) -> str:
    return _text("advertiseServices", services=[s.to_json() for s in services])


def unadvertise_services(service_ids: Sequence[int]) -> str:
    return _text("unadvertiseServices", serviceIds=list(service_ids))


def service_call_failure(service_id: int, call_id: int, message: str) -> str:
    return _text("serviceCallFailure", serviceId=service_id, callId=call_id,
                 message=cut(message, MESSAGE_LIMIT))


def parameter_json(param: ParameterValue) -> dict[str, Any]:
    """One entry of ``parameterValues``: bytes go as base64 with ``type`` ``byte_array``,
    doubles with ``type`` ``float64`` (or ``float64_array``) so that a client keeps ``2.0`` a
    double although JSON writes it ``2`` (foxglove_bridge does the same)."""
    value = param.value
    entry: dict[str, Any] = {"name": param.name}
    if isinstance(value, bytes | bytearray):
        entry["value"] = base64.b64encode(bytes(value)).decode("ascii")
        entry["type"] = "byte_array"
    elif isinstance(value, float):
        entry["value"] = value
        entry["type"] = "float64"
    elif (isinstance(value, list | tuple) and value
          and all(isinstance(v, float) for v in value)):
        entry["value"] = list(value)
        entry["type"] = "float64_array"
    elif isinstance(value, tuple):
        entry["value"] = list(value)
    elif value is not None:
        entry["value"] = value
    return entry


def parameter_values(params: Sequence[ParameterValue], request_id: str | None = None) -> str:
    fields: dict[str, Any] = {"parameters": [parameter_json(p) for p in params]}
    if request_id is not None:
        fields["id"] = request_id
    return _text("parameterValues", **fields)


# -- binary ops the server sends -------------------------------------------------------------


def _u32(value: int, what: str) -> int:
    if not 0 <= value <= _U32_MAX:
        raise MiddlewareValueError(f"{what} {value} does not fit a uint32")
    return value


def message_data(subscription_id: int, log_time_ns: int, payload: bytes) -> bytes:
    """Message Data (0x01): u32 subscription id, u64 log time (ns), the payload."""
    return (struct.pack("<BIQ", OP_MESSAGE_DATA, _u32(subscription_id, "subscription id"),
                        min(max(log_time_ns, 0), _U64_MAX)) + payload)


def time_op(time_ns: int) -> bytes:
    """Time (0x02): u64 ns, the server's clock for clients to follow (capability ``time``)."""
    return struct.pack("<BQ", OP_TIME, min(max(time_ns, 0), _U64_MAX))


def service_call_response(service_id: int, call_id: int, encoding: str, payload: bytes) -> bytes:
    """Service Call Response (0x03): u32 service id, u32 call id, u32 encoding length, the
    encoding, the response payload."""
    enc = encoding.encode()
    return (struct.pack("<BIII", OP_SERVICE_CALL_RESPONSE, _u32(service_id, "service id"),
                        _u32(call_id, "call id"), len(enc)) + enc + payload)


def playback_state(status: int, current_ns: int, speed: float, did_seek: bool,
                   request_id: str = "") -> bytes:
    """Playback State (0x05): u8 status, u64 current time (ns), f32 speed, u8 did seek, u32
    request id length, the id (empty: not an answer to a request)."""
    if status not in (PLAYING, PAUSED, BUFFERING, ENDED):
        raise MiddlewareValueError(f"playback status {status!r} is not 0..3")
    rid = request_id.encode()
    return _PLAYBACK_STATE.pack(OP_PLAYBACK_STATE, status, min(max(current_ns, 0), _U64_MAX),
                                speed, int(did_seek), len(rid)) + rid


# -- what a client sends ---------------------------------------------------------------------


@dataclass(frozen=True)
class Subscribe:
    #: (subscription id, channel id) pairs
    subscriptions: tuple[tuple[int, int], ...]


@dataclass(frozen=True)
class Unsubscribe:
    subscription_ids: tuple[int, ...]


@dataclass(frozen=True)
class GetParameters:
    names: tuple[str, ...]            # empty: all
    request_id: str | None = None


@dataclass(frozen=True)
class SetParameters:
    parameters: tuple[ParameterValue, ...]
    request_id: str | None = None


@dataclass(frozen=True)
class SubscribeParameterUpdates:
    names: tuple[str, ...]            # empty: all currently known


@dataclass(frozen=True)
class UnsubscribeParameterUpdates:
    names: tuple[str, ...]            # empty: all


@dataclass(frozen=True)
class ServiceCallRequest:
    service_id: int
    call_id: int
    encoding: str
    payload: bytes = field(repr=False)


@dataclass(frozen=True)
class PlaybackControlRequest:
    command: int                      # PLAY or PAUSE
    speed: float
    seek_ns: int | None               # None: no seek
    request_id: str


ClientOp = (Subscribe | Unsubscribe | GetParameters | SetParameters
            | SubscribeParameterUpdates | UnsubscribeParameterUpdates | ServiceCallRequest
            | PlaybackControlRequest)

#: Ops of the spec that need a capability this server does not offer: said as such.
_NOT_OFFERED = {"advertise": "clientPublish", "unadvertise": "clientPublish",
                "subscribeConnectionGraph": "connectionGraph",
                "unsubscribeConnectionGraph": "connectionGraph", "fetchAsset": "assets"}


def _field(obj: Mapping[str, Any], key: str, where: str) -> Any:
    if key not in obj:
        raise ClientMessageError(f"{where}: missing field {echo(key)}")
    return obj[key]


def _uint(value: Any, where: str, limit: int = _U32_MAX) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= limit:
        raise ClientMessageError(f"{where}: {echo(value)} is not an unsigned 32-bit integer")
    return value


def _array(value: Any, where: str) -> list[Any]:
    if not isinstance(value, list):
        raise ClientMessageError(f"{where}: {echo(value)} is not an array")
    return value


def _strings(value: Any, where: str) -> tuple[str, ...]:
    items = _array(value, where)
    for i, item in enumerate(items):
        if not isinstance(item, str):
            raise ClientMessageError(f"{where}[{i}]: {echo(item)} is not a string")
    return tuple(items)


def _request_id(obj: Mapping[str, Any], op: str) -> str | None:
    value = obj.get("id")
    if value is not None and not isinstance(value, str):
        raise ClientMessageError(f"{op}.id: {echo(value)} is not a string")
    return value


def parameter_from_json(entry: Any, where: str) -> ParameterValue:
    """A ``setParameters`` entry as a Python value: ``byte_array`` base64-decoded to bytes,
    ``float64`` / ``float64_array`` made floats (JSON may write 3.0 as 3)."""
    if not isinstance(entry, dict):
        raise ClientMessageError(f"{where}: {echo(entry)} is not an object")
    name = _field(entry, "name", where)
    if not isinstance(name, str) or not name:
        raise ClientMessageError(f"{where}.name: {echo(name)} is not a parameter name")
    value = entry.get("value")
    kind = entry.get("type")
    try:
        if kind == "byte_array":
            if not isinstance(value, str):
                raise ValueError
            value = base64.b64decode(value, validate=True)
        elif kind == "float64":
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ValueError
            value = float(value)
        elif kind == "float64_array":
            if not isinstance(value, list) or any(
                    isinstance(v, bool) or not isinstance(v, int | float) for v in value):
                raise ValueError
            value = [float(v) for v in value]
        elif kind is not None:
            raise ClientMessageError(f"{where}.type: {echo(kind)} is not byte_array, float64 or "
                                     "float64_array")
    except (ValueError, TypeError) as exc:
        if isinstance(exc, ClientMessageError):
            raise
        raise ClientMessageError(f"{where}.value: {echo(value)} is not a {kind}") from None
    return ParameterValue(name, value)


def parse_text(text: str) -> ClientOp:
    """The op a client's text message asks for, or :class:`ClientMessageError`."""
    try:
        obj = json.loads(text)
    except ValueError as exc:
        raise ClientMessageError(f"not JSON: {exc}") from None
    except RecursionError:  # "[" x 100 000: Python's parser recurses once a level
        raise ClientMessageError("not JSON this server reads: nested deeper than "
                                 f"{sys.getrecursionlimit()} levels") from None
    if not isinstance(obj, dict):
        raise ClientMessageError("a text message must be a JSON object with an 'op'")
    op = _field(obj, "op", "message")
    if op == "subscribe":
        pairs = []
        for i, sub in enumerate(_array(_field(obj, "subscriptions", op),
                                       "subscribe.subscriptions")):
            where = f"subscribe.subscriptions[{i}]"
            if not isinstance(sub, dict):
                raise ClientMessageError(f"{where}: {echo(sub)} is not an object")
            pairs.append((_uint(_field(sub, "id", where), f"{where}.id"),
                          _uint(_field(sub, "channelId", where), f"{where}.channelId")))
        return Subscribe(tuple(pairs))
    if op == "unsubscribe":
        ids = _array(_field(obj, "subscriptionIds", op), "unsubscribe.subscriptionIds")
        return Unsubscribe(tuple(_uint(v, f"unsubscribe.subscriptionIds[{i}]")
                                 for i, v in enumerate(ids)))
    if op == "getParameters":
        return GetParameters(_strings(_field(obj, "parameterNames", op),
                                      "getParameters.parameterNames"), _request_id(obj, op))
    if op == "setParameters":
        entries = _array(_field(obj, "parameters", op), "setParameters.parameters")
        return SetParameters(tuple(parameter_from_json(e, f"setParameters.parameters[{i}]")
                                   for i, e in enumerate(entries)), _request_id(obj, op))
    if op in ("subscribeParameterUpdates", "unsubscribeParameterUpdates"):
        names = _strings(_field(obj, "parameterNames", op), f"{op}.parameterNames")
        return (SubscribeParameterUpdates(names) if op == "subscribeParameterUpdates"
                else UnsubscribeParameterUpdates(names))
    if isinstance(op, str) and op in _NOT_OFFERED:
        raise ClientMessageError(f"op {echo(op)} needs capability {_NOT_OFFERED[op]!r}, which "
                                 "this server does not offer")
    raise ClientMessageError(f"op: unknown op {echo(op)}")


def parse_binary(data: bytes) -> ClientOp:
    """The op a client's binary message asks for: Service Call Request (0x02) or Playback
    Control Request (0x03)."""
    if not data:
        raise ClientMessageError("empty binary message: no opcode")
    opcode = data[0]
    if opcode == OP_SERVICE_CALL_REQUEST:
        if len(data) < 13:
            raise ClientMessageError(f"serviceCallRequest: {len(data)} bytes, shorter than "
                                     "its 13-byte header")
        service_id, call_id, length = struct.unpack_from("<III", data, 1)
        if 13 + length > len(data):
            raise ClientMessageError(f"serviceCallRequest.encoding length {length} runs past "
                                     f"the message's {len(data)} bytes")
        try:
            encoding = data[13:13 + length].decode()
        except UnicodeDecodeError:
            raise ClientMessageError("serviceCallRequest.encoding is not UTF-8") from None
        return ServiceCallRequest(service_id, call_id, encoding, bytes(data[13 + length:]))
    if opcode == OP_PLAYBACK_CONTROL_REQUEST:
        return _playback_request(data)
    if opcode == OP_CLIENT_MESSAGE_DATA:
        raise ClientMessageError("binary op 0x01 (client message data) needs capability "
                                 "'clientPublish', which this server does not offer")
    raise ClientMessageError(f"binary opcode 0x{opcode:02x} is unknown")


def _playback_request(data: bytes) -> PlaybackControlRequest:
    where = "playbackControlRequest"
    if len(data) < _PLAYBACK_REQUEST.size:
        raise ClientMessageError(f"{where}: {len(data)} bytes, shorter than its "
                                 f"{_PLAYBACK_REQUEST.size}-byte header")
    _, command, speed, had_seek, seek_ns, length = _PLAYBACK_REQUEST.unpack_from(data)
    if command not in (PLAY, PAUSE):
        raise ClientMessageError(f"{where}.playbackCommand {command} is not 0 (play) or 1 "
                                 "(pause)")
    if not (math.isfinite(speed) and speed > 0):
        raise ClientMessageError(f"{where}.playbackSpeed {echo(speed)} is not a number > 0")
    if had_seek not in (0, 1):
        raise ClientMessageError(f"{where}.hadSeek {had_seek} is not 0 or 1")
    if _PLAYBACK_REQUEST.size + length != len(data):
        raise ClientMessageError(f"{where}.requestId length {length} does not fit the "
                                 f"message's {len(data)} bytes")
    try:
        request_id = data[_PLAYBACK_REQUEST.size:].decode()
    except UnicodeDecodeError:
        raise ClientMessageError(f"{where}.requestId is not UTF-8") from None
    return PlaybackControlRequest(command, speed, seek_ns if had_seek else None, request_id)


# -- parameter names -------------------------------------------------------------------------


def parameter_name(node: str, name: str) -> str:
    """foxglove_bridge's name of a node's parameter: ``<node>.<param>`` (``/talker.rate``)."""
    return f"{node}.{name}"


def split_parameter_name(full: str) -> tuple[str, str]:
    """``/ns/talker.a.b`` -> (``/ns/talker``, ``a.b``): a ROS node name has no dot, so the
    first one ends it; a parameter name may have more."""
    node, dot, name = full.partition(".")
    if not dot or not node.startswith("/") or not name or len(node) < 2:
        raise ClientMessageError(f"parameter name {echo(full)} is not '/<node>.<parameter>'")
    return node, name
