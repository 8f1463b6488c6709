"""The generated CDR codec (servolab.middleware.fast_cdr) against rosbags, its oracle.

rosbags' ``Typestore.serialize_cdr`` / ``deserialize_cdr`` (rosbags.serde.cdr) are what
servolab used before and what ROS 2 tools (rosbag2, rmw) agree with; the generated code must
write the same bytes and read back the same objects. For every message type servolab ships
(``MessageTypes().names()``) and every service's request and response, random messages built
from the type description (field by field: every primitive over its whole range, NaN and
infinities included, unicode strings, empty and non-empty sequences, bounded strings and
sequences within their bounds, nested sequences of messages) must:

- serialize byte for byte as rosbags serializes them;
- deserialize (ours, from our bytes, as a memoryview as the Zenoh inbox hands them over)
  back to an equal message, field by field, of the same Python types;
- and our reading of rosbags' bytes, little- and big-endian, must equal rosbags' reading of
  them, down to each numpy array's dtype and whether it is writable (a view of the bytes).

The alignment rule is OMG CDR's as XCDR1 has it (OMG DDS-XTypes 1.3, 7.4.3 "Extended CDR
encoding version 1", and the CORBA 3 CDR transfer syntax it builds on): each primitive, and
each ``uint32`` string length or sequence count, starts at an offset that is a multiple of its
own size (8 for 8-byte types: XCDR1, unlike XCDR2, does not cap it at 4), the offset counted
from the start of the payload after the 4-byte encapsulation header. The edge cases below
check it directly on a type of their own (a uint8 before a float64, a float64 after a string,
an empty sequence before a float64).
"""

from __future__ import annotations

import dataclasses
import math
import struct
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rosbags.interfaces import Nodetype
from rosbags.typesys.base import normalize_fieldname

from servolab.middleware.errors import MessageError
from servolab.middleware.fast_cdr import FastCdr, _plain_fields
from servolab.middleware.messages import MessageTypes

#: Edge cases the shipped types do not all have: alignment after a uint8, after a string and
#: after an empty sequence; fixed arrays of strings and of messages (loops over elements);
#: a sequence element whose later field needs more alignment than its first (no fast path);
#: bounded sequences and strings; sequences of messages holding sequences of messages.
EDGE_MSGS = {
    "fastcdr_test/msg/Inner": "uint8 tag\nfloat64 value\nstring label\n",
    "fastcdr_test/msg/Flat": "float32 a\nuint16 b\nuint16 c\n",
    "fastcdr_test/msg/Deep": "fastcdr_test/Inner[] inners\nstring[] words\nint16[<=3] small\n",
    "fastcdr_test/msg/Edge": """\
uint8 a
float64 b
string s
float64 c
float64[] empty_then
float64 d
string[2] pair
fastcdr_test/Flat[2] flats
fastcdr_test/Flat[] flat_seq
fastcdr_test/Inner[] inners
fastcdr_test/Deep[] deep
string<=5 bounded
bool[] flags
byte[3] raw
char ch
uint8 last
""",
}

TYPES = MessageTypes(extra_msgs=EDGE_MSGS)
TYPES.load_all()  # every shipped package, read when first used, read now
SHIPPED = MessageTypes().names()
SERVICE_TYPES = [f"{s}{part}" for s in MessageTypes().service_names()
                 for part in ("_Request", "_Response")]
EDGE = "fastcdr_test/msg/Edge"

_INTS = {"byte": (-(2**7), 2**7 - 1),  # rosbags packs byte signed ('b') and reads int8 arrays
         "char": (0, 255), "int8": (-(2**7), 2**7 - 1), "uint8": (0, 255),
         "int16": (-(2**15), 2**15 - 1), "uint16": (0, 2**16 - 1),
         "int32": (-(2**31), 2**31 - 1), "uint32": (0, 2**32 - 1),
         "int64": (-(2**63), 2**63 - 1), "uint64": (0, 2**64 - 1)}
#: numpy dtypes rosbags gives primitive arrays (rosbags.serde.utils.ndtype)
_DTYPES = {"bool": np.bool_, "byte": np.int8, "char": np.uint8, "int8": np.int8,
           "uint8": np.uint8, "int16": np.int16, "uint16": np.uint16, "int32": np.int32,
           "uint32": np.uint32, "int64": np.int64, "uint64": np.uint64,
           "float32": np.float32, "float64": np.float64}
_TEXT = st.text(st.characters(exclude_categories=("Cs",)), max_size=6)  # UTF-8 encodable
_MAX_SEQ = 3


def _scalar(base: str, bound: int = 0) -> st.SearchStrategy[Any]:
    if base == "string":
        return _TEXT if not bound else st.text(st.characters(exclude_categories=("Cs",)),
                                               max_size=bound)
    if base == "bool":
        return st.booleans()
    if base == "float32":
        return st.floats(width=32)
    if base == "float64":
        return st.floats()
    low, high = _INTS[base]
    return st.integers(low, high)


def _array(base: str, min_size: int, max_size: int) -> st.SearchStrategy[Any]:
    return st.lists(_scalar(base), min_size=min_size, max_size=max_size).map(
        lambda values: np.array(values, dtype=_DTYPES[base]))


def _field(types: MessageTypes, desc: Any) -> st.SearchStrategy[Any]:
    if desc[0] == Nodetype.BASE:
        return _scalar(*desc[1])
    if desc[0] == Nodetype.NAME:
        return message(types, desc[1])
    sub, count = desc[1]
    primitive = sub[0] == Nodetype.BASE and sub[1][0] != "string"
    if desc[0] == Nodetype.ARRAY:
        low = high = count
    else:
        low, high = 0, min(count, _MAX_SEQ) if count else _MAX_SEQ
    if primitive:
        return _array(sub[1][0], low, high + 2 if desc[0] == Nodetype.SEQUENCE and not count
                      else high)
    return st.lists(_field(types, sub), min_size=low, max_size=high)


_STRATEGIES: dict[str, st.SearchStrategy[Any]] = {}


def message(types: MessageTypes, name: str) -> st.SearchStrategy[Any]:
    """Random messages of a type, built from its description as rosbags holds it."""
    if name not in _STRATEGIES:
        cls = types.store.types[name]
        fields = {normalize_fieldname(f): _field(types, d)
                  for f, d in types.store.fielddefs[name][1]}
        _STRATEGIES[name] = st.fixed_dictionaries(fields).map(lambda kw: cls(**kw))
    return _STRATEGIES[name]


def same(a: Any, b: Any, strict: bool = True, where: str = "msg") -> None:
    """Field by field equality, of the same Python types; arrays by dtype, shape and bytes
    (NaNs compare), and with ``strict``, also by writability (a view or a copy)."""
    assert type(a) is type(b), (where, type(a), type(b))
    if hasattr(a, "__dataclass_fields__"):
        # the same instance state, not only the same attributes: the generated code builds
        # a message without its __init__ and must set what that sets (its __msgtype__)
        assert vars(a).keys() == vars(b).keys(), (where, vars(a).keys(), vars(b).keys())
        for name in a.__dataclass_fields__:
            same(getattr(a, name), getattr(b, name), strict, f"{where}.{name}")
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, (where, a.dtype, b.dtype)
        assert np.array_equal(a.view(np.uint8), b.view(np.uint8)), (where, a, b)
        if strict:
            assert a.flags.writeable == b.flags.writeable, where
    elif isinstance(a, list):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            same(x, y, strict, f"{where}[{i}]")
    elif isinstance(a, float):
        assert a == b or (math.isnan(a) and math.isnan(b)), (where, a, b)
        assert math.copysign(1, a) == math.copysign(1, b), (where, a, b)
    else:
        assert a == b, (where, a, b)


def check(types: MessageTypes, name: str, msg: Any) -> None:
    codec = types.cdr
    assert codec.source(name) is not None, f"{name} is left to rosbags"
    ours = codec.serializer(name)(msg)  # the generated code itself, not its fallback
    theirs = bytes(types.store.serialize_cdr(msg, name, little_endian=True))
    assert ours == theirs, name
    same(msg, codec.deserializer(name)(memoryview(ours)), strict=False)
    same(types.store.deserialize_cdr(theirs, name), codec.deserializer(name)(theirs))
    big = bytes(types.store.serialize_cdr(msg, name, little_endian=False))
    same(types.store.deserialize_cdr(big, name), codec.deserializer(name, False)(big))
    # and through MessageTypes, as the transports call it
    assert types.serialize(msg, name) == theirs
    same(types.deserialize(big, name), types.store.deserialize_cdr(big, name))


_SETTINGS = settings(max_examples=12, deadline=None, derandomize=True,
                     suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


@pytest.mark.parametrize("name", SHIPPED + SERVICE_TYPES)
@_SETTINGS
@given(data=st.data())
def test_every_type_writes_rosbags_bytes_and_reads_them_back(name: str,
                                                             data: st.DataObject) -> None:
    check(TYPES, name, data.draw(message(TYPES, name)))


def test_every_type_is_covered() -> None:
    assert len(SHIPPED) == 195 and len(SERVICE_TYPES) == 2 * 34
    assert all(TYPES.cdr.source(n) is not None for n in SHIPPED + SERVICE_TYPES)


@settings(max_examples=150, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(data=st.data())
def test_edge_type(data: st.DataObject) -> None:
    check(TYPES, EDGE, data.draw(message(TYPES, EDGE)))


def _edge(**values: Any) -> Any:
    return TYPES.from_value(EDGE, values)


def test_edge_cases_by_hand() -> None:
    """Empty strings and sequences, unicode, one of everything, and no element at all."""
    inner = {"tag": 7, "value": -1.5, "label": "ünïcødé ✓ 🤖"}
    for msg in (
            _edge(),
            _edge(s="", bounded="", pair=["", ""], flags=[], inners=[], deep=[]),
            _edge(s="🤖", bounded="ab✓", pair=["ä", "\u00e9t\u00e9"], flags=[True, False, True],
                  inners=[inner, {**inner, "label": ""}], ch=255,
                  flat_seq=[{"a": 1.5, "b": 2, "c": 3}] * 3, empty_then=[1.0],
                  deep=[{"inners": [inner] * 2, "words": ["", "x", "yz"], "small": [1, -2]},
                        {"inners": [], "words": [], "small": []}])):
        msg.raw = msg.raw.view(np.int8)  # as rosbags reads a byte[] (see below)
        check(TYPES, EDGE, msg)
    # byte[]: from_value makes uint8 arrays (0..255), rosbags reads int8 ones; the bytes are
    # the same either way
    msg = _edge(raw=[255, 0, 127])
    assert msg.raw.dtype == np.uint8
    assert TYPES.serialize(msg, EDGE) == bytes(TYPES.store.serialize_cdr(msg, EDGE))
    msg.raw = np.array([-128, 0, 127], dtype=np.int8)
    check(TYPES, EDGE, msg)


def _layout(msg: Any) -> bytes:
    return TYPES.serialize(msg, EDGE)


def test_alignment_after_uint8_string_and_empty_sequence() -> None:
    """The XCDR1 rule, read off the bytes: a float64 after a uint8 starts at payload offset 8;
    after a string, at the next multiple of 8; after an empty float64[], the count is
    followed directly by the next float64, aligned on its own."""
    data = _layout(_edge(a=1, b=2.0, s="abc", c=3.0, d=4.0))
    assert data[:4] == b"\x00\x01\x00\x00"
    payload = data[4:]
    assert payload[0] == 1 and payload[1:8] == bytes(7)
    assert struct.unpack_from("<d", payload, 8) == (2.0,)
    assert struct.unpack_from("<I", payload, 16) == (4,)  # "abc" and its NUL
    assert payload[20:24] == b"abc\x00"
    assert struct.unpack_from("<d", payload, 24) == (3.0,)  # 24 is a multiple of 8 already
    assert struct.unpack_from("<I", payload, 32) == (0,)  # empty_then: no elements, no pad
    assert payload[36:40] == bytes(4) and struct.unpack_from("<d", payload, 40) == (4.0,)

    data = _layout(_edge(s="abcd", empty_then=[5.0]))
    payload = data[4:]
    assert struct.unpack_from("<I", payload, 16) == (5,) and payload[20:25] == b"abcd\x00"
    assert payload[25:32] == bytes(7)  # c, a float64, at 32
    assert struct.unpack_from("<I", payload, 40) == (1,)  # the count at 40, its double at 48
    assert payload[44:48] == bytes(4) and struct.unpack_from("<d", payload, 48) == (5.0,)


def test_twist_is_one_struct() -> None:
    """What makes it fast: a Twist is one ``pack`` with the header inside, one ``unpack``."""
    source = TYPES.cdr.source("geometry_msgs/msg/Twist")
    assert source is not None
    assert source.count(".pack(") == 1 and source.count(".unpack_from(") == 1
    msg = TYPES.from_value("geometry_msgs/msg/Twist", {"linear": {"x": 0.1},
                                                       "angular": {"z": 0.5}})
    assert len(TYPES.serialize(msg)) == 52


def test_what_rosbags_refuses_is_still_refused_the_same_way() -> None:
    """Values the generated code does not take go to rosbags, which refuses them as before;
    so do malformed bytes, with rosbags' message."""
    name = "sensor_msgs/msg/JointState"
    msg = TYPES.default(name)
    # a list where rosbags wants a numpy array (set past the field check, which would make it
    # the array.array rclpy makes: tests/middleware/test_field_assignment.py)
    object.__setattr__(msg, "position", [1.0, 2.0])
    with pytest.raises(AttributeError):
        TYPES.store.serialize_cdr(msg, name)
    with pytest.raises(AttributeError):
        TYPES.serialize(msg, name)
    msg.position = np.zeros(4)[::2]  # strided doubles: rosbags cannot view them as bytes
    with pytest.raises(ValueError, match="contiguous"):
        TYPES.serialize(msg, name)
    image = TYPES.default("sensor_msgs/msg/Image")
    image.data = np.arange(8, dtype=np.uint8)[::2]  # strided bytes: rosbags copies them
    assert TYPES.serialize(image) == bytes(TYPES.store.serialize_cdr(image, image.__msgtype__))
    cov = TYPES.default("geometry_msgs/msg/PoseWithCovariance")
    with pytest.raises(MessageError, match="covariance: needs exactly 36 values"):
        cov.covariance = np.zeros(35)  # refused where it is assigned, as rclpy refuses it
    object.__setattr__(cov, "covariance", np.zeros(35))
    with pytest.raises(Exception, match="array length"):
        TYPES.serialize(cov)

    good = TYPES.serialize(TYPES.from_value("std_msgs/msg/String", {"data": "hello"}))
    for bad in (good[:-3], good[:3], b"\x00\x02" + good[2:], good[:8] + b"\xff" + good[9:],
                good[:-1] + b"x", good + bytes(8)):
        with pytest.raises(Exception) as rosbags:
            TYPES.store.deserialize_cdr(bad, "std_msgs/msg/String")
        with pytest.raises(MessageError) as ours:
            TYPES.deserialize(bad, "std_msgs/msg/String")
        assert str(rosbags.value) in str(ours.value)


def test_a_second_store_is_independent() -> None:
    """A codec belongs to its store: types registered in one are not seen by another."""
    codec = FastCdr(MessageTypes().store)
    with pytest.raises(KeyError):
        codec.serializer(EDGE)


def test_messages_are_built_without_init_only_where_init_just_sets_fields() -> None:
    """The deserializer sets a plain dataclass's fields on ``object.__new__(cls)`` (faster
    than calling it); any class whose ``__init__`` does more is called as it is."""

    @dataclasses.dataclass
    class Plain:
        x: float
        y: float
        kind: str = "point"

    @dataclasses.dataclass(frozen=True)
    class Frozen:
        x: float

    @dataclasses.dataclass
    class Checked:
        x: float

        def __post_init__(self) -> None:
            raise AssertionError("called")

    @dataclasses.dataclass
    class Made:
        x: float
        extra: list[float] = dataclasses.field(default_factory=list)

    @dataclasses.dataclass(init=False)
    class OwnInit:
        x: float

        def __init__(self, x: float) -> None:
            self.x = x
            self.scaled = 2 * x

    @dataclasses.dataclass
    class Hidden:
        x: float
        cache: list[float] = dataclasses.field(default_factory=list, init=False)

    assert _plain_fields(Plain, ["x", "y"]) == {"kind": "point"}
    assert _plain_fields(Plain, ["y", "x"]) is None  # fields not in __init__'s order
    assert _plain_fields(Frozen, ["x"]) is None
    assert _plain_fields(Checked, ["x"]) is None
    assert _plain_fields(Made, ["x"]) is None
    assert _plain_fields(OwnInit, ["x"]) is None

    registry: list[object] = []

    @dataclasses.dataclass(init=False)
    class Registered:  # its __init__ sets only its field, and does more
        x: float

        def __init__(self, x: float) -> None:
            self.x = x
            registry.append(self)

    assert _plain_fields(Registered, ["x"]) is None
    assert _plain_fields(Hidden, ["x"]) is None
    assert _plain_fields(type("NotADataclass", (), {}), []) is None
    source = TYPES.cdr.source("geometry_msgs/msg/Twist")
    assert source is not None and "_new(" in source and "__msgtype__" in source
