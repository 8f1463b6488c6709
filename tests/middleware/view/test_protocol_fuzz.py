"""The view's parsers of what a client sends (issue 45, fuzzing as a habit): random text,
mutated valid ops of the Foxglove WebSocket protocol
(https://github.com/foxglove/ws-protocol/blob/main/docs/spec.md: subscribe, unsubscribe,
getParameters, setParameters, subscribeParameterUpdates; binary Service Call Request 0x02 and
Playback Control Request 0x03) and random bytes give either an op or a one-line
ClientMessageError quoting at most a cut echo, never another exception."""

from __future__ import annotations

import json
import struct
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from servolab.middleware.view.protocol import ClientMessageError, parse_binary, parse_text
from tests.fuzzing import fuzzing

pytestmark = pytest.mark.fuzz

VALID_TEXT: list[dict[str, Any]] = [
    {"op": "subscribe", "subscriptions": [{"id": 1, "channelId": 3}]},
    {"op": "unsubscribe", "subscriptionIds": [1, 2]},
    {"op": "getParameters", "parameterNames": ["/talker.rate"], "id": "r1"},
    {"op": "setParameters", "parameters": [{"name": "/talker.rate", "value": 2.5}],
     "id": "r2"},
    {"op": "subscribeParameterUpdates", "parameterNames": ["/talker.rate"]},
]
VALID_BINARY = [
    b"\x02" + struct.pack("<III", 7, 1, 3) + b"cdr" + b"\x00\x01\x00\x00\x01\x00\x00\x00",
    b"\x03" + struct.pack("<BfBQ", 0, 1.0, 0, 0),
]

json_values = st.recursive(
    st.none() | st.booleans() | st.integers(-2**70, 2**70) | st.floats(allow_nan=False)
    | st.text(max_size=20),
    lambda children: st.lists(children, max_size=4)
    | st.dictionaries(st.text(max_size=12), children, max_size=4), max_leaves=20)


def _parsed_or_refused(parse: Any, data: Any) -> None:
    try:
        parse(data)
    except ClientMessageError as error:
        assert "\n" not in str(error) and len(str(error)) < 2000


@fuzzing(150)
@given(text=st.text(max_size=200))
def test_random_text_is_an_op_or_refused_in_one_line(text: str) -> None:
    _parsed_or_refused(parse_text, text)


@fuzzing(200)
@given(base=st.sampled_from(VALID_TEXT), data=st.data(), value=json_values,
       how=st.sampled_from(["replace", "replace inside", "drop", "add"]))
def test_mutated_ops_are_an_op_or_refused_in_one_line(base: dict[str, Any], data: Any,
                                                      value: Any, how: str) -> None:
    """A valid op with one of its fields (or a field of its first element) replaced by any
    JSON value, or dropped, or a field added."""
    message = json.loads(json.dumps(base))  # a deep copy
    field = data.draw(st.sampled_from(sorted(message)))
    if how == "replace":
        message[field] = value
    elif how == "replace inside" and isinstance(message[field], list) and message[field] \
            and isinstance(message[field][0], dict):
        inner = message[field][0]
        inner[data.draw(st.sampled_from(sorted(inner)))] = value
    elif how == "drop":
        message.pop(field)
    else:
        message[data.draw(st.text(max_size=12))] = value
    _parsed_or_refused(parse_text, json.dumps(message))


@fuzzing(150)
@given(base=st.sampled_from(VALID_BINARY), flips=st.lists(
    st.tuples(st.integers(0, 63), st.integers(0, 7)), max_size=4), cut=st.integers(0, 64),
    tail=st.binary(max_size=16))
def test_mutated_binary_ops_are_an_op_or_refused_in_one_line(
        base: bytes, flips: list[tuple[int, int]], cut: int, tail: bytes) -> None:
    data = bytearray(base)
    for where, bit in flips:
        data[where % len(data)] ^= 1 << bit
    _parsed_or_refused(parse_binary, bytes(data[:cut]) + tail)
