"""rmw_zenoh's naming conventions, checked against the examples of its design document.

The expected strings are copied from ``docs/design.md`` of ros2/rmw_zenoh (rolling): they are
what ``rmw_zenoh_cpp`` writes for the ``demo_nodes_cpp`` talker, listener and AddTwoInts
nodes, so matching them is what lets a ROS 2 node and servolab see each other. The type names
and hashes in them are computed by :class:`MessageTypes`, not copied, so the same tests also
show that our REP-2016 hashes are rosidl's.
"""

from __future__ import annotations

import struct

import pytest
from hypothesis import given
from hypothesis import strategies as st

from servolab.middleware.errors import MessageError, NameValidationError
from servolab.middleware.messages import MessageTypes
from servolab.middleware.names import fully_qualified_name
from servolab.middleware.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from servolab.middleware.rmw_zenoh import (
    RMW_ZENOH_DEFAULT_DEPTH,
    Attachment,
    Entity,
    EntityKind,
    dds_type_name,
    decode_attachment,
    encode_attachment,
    entity_token,
    gid_from,
    mangle,
    node_token,
    parse_token,
    qos_from_keyexpr,
    qos_to_keyexpr,
    ros_type_name,
    topic_keyexpr,
    unmangle,
)

STRING = "std_msgs/msg/String"
ADD_TWO_INTS = "example_interfaces/srv/AddTwoInts"
# From the design document, to check the computed hashes against.
STRING_HASH = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
ADD_TWO_INTS_HASH = "RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a"

LISTENER_SESSION = "aac3178e146ba6f1fc6e6a4085e77f21"
TALKER_SESSION = "8b20917502ee955ac4476e0266340d5c"
SERVER_SESSION = "f9980ee0495eaafb3e38f0d19e2eae12"
CLIENT_SESSION = "e1dc8d1b45ae8717fce78689cc655685"

DOC_LISTENER_NODE = "@ros2_lv/2/aac3178e146ba6f1fc6e6a4085e77f21/0/0/NN/%/%/listener"
DOC_LISTENER_SUB = (
    "@ros2_lv/2/aac3178e146ba6f1fc6e6a4085e77f21/0/10/MS/%/%/listener/%chatter/"
    "std_msgs::msg::dds_::String_/"
    "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/::,10:,:,:,,")
DOC_TALKER_PUB = (
    "@ros2_lv/2/8b20917502ee955ac4476e0266340d5c/0/10/MP/%/%/talker/%chatter/"
    "std_msgs::msg::dds_::String_/"
    "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/::,7:,:,:,,")
DOC_SERVER = (
    "@ros2_lv/2/f9980ee0495eaafb3e38f0d19e2eae12/0/10/SS/%/%/add_two_ints_server/"
    "%add_two_ints/example_interfaces::srv::dds_::AddTwoInts_/"
    "RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a/::,10:,:,:,,")
DOC_CLIENT = (
    "@ros2_lv/2/e1dc8d1b45ae8717fce78689cc655685/0/10/SC/%/%/add_two_ints_client/"
    "%add_two_ints/example_interfaces::srv::dds_::AddTwoInts_/"
    "RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a/::,10:,:,:,,")


# -- type names and hashes --------------------------------------------------------------------

def test_our_type_hashes_are_rosidls(types: MessageTypes) -> None:
    assert types.rihs01(STRING) == STRING_HASH
    assert types.rihs01(ADD_TWO_INTS) == ADD_TWO_INTS_HASH


@pytest.mark.parametrize("name", [STRING, ADD_TWO_INTS, "geometry_msgs/msg/Twist"])
def test_dds_type_name_agrees_with_message_types(types: MessageTypes, name: str) -> None:
    assert dds_type_name(name) == types.dds_name(name)
    assert ros_type_name(dds_type_name(name)) == name


def test_dds_type_names_of_the_design_document() -> None:
    assert dds_type_name(STRING) == "std_msgs::msg::dds_::String_"
    assert dds_type_name(ADD_TWO_INTS) == "example_interfaces::srv::dds_::AddTwoInts_"


@pytest.mark.parametrize("bad", ["String", "std_msgs/String", "std_msgs/msg/", "a/msg/B/c"])
def test_bad_type_names_are_refused(bad: str) -> None:
    with pytest.raises(MessageError, match="must be spelled"):
        dds_type_name(bad)


@pytest.mark.parametrize("bad", ["std_msgs::msg::String_", "std_msgs::msg::dds_::String"])
def test_bad_dds_names_are_refused(bad: str) -> None:
    with pytest.raises(MessageError, match="not a DDS name"):
        ros_type_name(bad)


# -- topic and service key expressions --------------------------------------------------------

def test_topic_keyexprs_of_the_design_document(types: MessageTypes) -> None:
    string_hash = types.rihs01(STRING)
    assert (topic_keyexpr(0, "/chatter", STRING, string_hash)
            == f"0/chatter/std_msgs::msg::dds_::String_/{STRING_HASH}")
    robot1 = fully_qualified_name("chatter", "/robot1")
    assert (topic_keyexpr(0, robot1, STRING, string_hash)
            == f"0/robot1/chatter/std_msgs::msg::dds_::String_/{STRING_HASH}")
    assert (topic_keyexpr(2, "/add_two_ints", ADD_TWO_INTS, types.rihs01(ADD_TWO_INTS))
            == f"2/add_two_ints/example_interfaces::srv::dds_::AddTwoInts_/{ADD_TWO_INTS_HASH}")


@pytest.mark.parametrize(("domain", "fqn", "hash_", "error", "match"), [
    (-1, "/chatter", STRING_HASH, MessageError, "domain id"),
    (0, "chatter", STRING_HASH, NameValidationError, r"must be absolute(.|\n)*'chatter'"),
    (0, "/chatter", "df668c74", MessageError, "type hash"),
])
def test_topic_keyexpr_refuses_bad_parts(domain: int, fqn: str, hash_: str,
                                         error: type[Exception], match: str) -> None:
    with pytest.raises(error, match=match):
        topic_keyexpr(domain, fqn, STRING, hash_)


# -- names ------------------------------------------------------------------------------------

# Node names, namespaces and topic names themselves: tests/middleware/test_names.py.

def test_mangling() -> None:
    assert mangle("/robot1") == "%robot1"
    assert mangle("/a/b") == "%a%b"
    assert mangle("") == mangle("/") == "%"
    assert unmangle("%robot1") == "/robot1"
    assert unmangle("%") == "/"


# -- liveliness tokens ------------------------------------------------------------------------

def test_node_token_of_the_design_document() -> None:
    assert node_token(2, LISTENER_SESSION, 0, "listener") == DOC_LISTENER_NODE
    assert node_token(2, LISTENER_SESSION, 0, "listener", "", "") == DOC_LISTENER_NODE


def test_entity_tokens_of_the_design_document(types: MessageTypes) -> None:
    string_hash, add_hash = types.rihs01(STRING), types.rihs01(ADD_TWO_INTS)
    chatter = fully_qualified_name("chatter", "/")
    service = fully_qualified_name("add_two_ints", "/")
    assert entity_token(2, LISTENER_SESSION, 0, 10, EntityKind.SUBSCRIPTION, "listener",
                        chatter, STRING, string_hash, qos=QoSProfile(depth=10)) == DOC_LISTENER_SUB
    assert entity_token(2, TALKER_SESSION, 0, 10, "MP", "talker", chatter, STRING, string_hash,
                        qos=QoSProfile(depth=7)) == DOC_TALKER_PUB
    assert entity_token(2, SERVER_SESSION, 0, 10, EntityKind.SERVICE, "add_two_ints_server",
                        service, ADD_TWO_INTS, add_hash) == DOC_SERVER
    assert entity_token(2, CLIENT_SESSION, 0, 10, EntityKind.CLIENT, "add_two_ints_client",
                        service, ADD_TWO_INTS, add_hash) == DOC_CLIENT


def test_namespaced_tokens_mangle_the_namespace() -> None:
    assert (node_token(0, LISTENER_SESSION, 3, "listener", "/robot1")
            == f"@ros2_lv/0/{LISTENER_SESSION}/3/3/NN/%/%robot1/listener")
    topic = fully_qualified_name("chatter", "/robot1")
    token = entity_token(0, LISTENER_SESSION, 3, 4, "MS", "listener", topic, STRING,
                         STRING_HASH, namespace="/robot1", enclave="/secure")
    assert token.startswith(f"@ros2_lv/0/{LISTENER_SESSION}/3/4/MS/%secure/%robot1/listener/"
                            "%robot1%chatter/std_msgs::msg::dds_::String_/")


def test_entity_token_refuses_node_kind_and_bad_parts() -> None:
    with pytest.raises(MessageError, match="use node_token"):
        entity_token(0, LISTENER_SESSION, 0, 0, "NN", "n", "/t", STRING, STRING_HASH)
    with pytest.raises(MessageError, match="session id"):
        entity_token(0, "not-hex", 0, 1, "MP", "n", "/t", STRING, STRING_HASH)
    with pytest.raises(NameValidationError, match=r"Invalid topic name(.|\n)*'t'"):
        entity_token(0, LISTENER_SESSION, 0, 1, "MP", "n", "t", STRING, STRING_HASH)
    with pytest.raises(NameValidationError, match="Invalid service name"):
        entity_token(0, LISTENER_SESSION, 0, 1, "SS", "n", "/a//b", ADD_TWO_INTS, STRING_HASH)
    with pytest.raises(NameValidationError, match="Invalid node name"):
        entity_token(0, LISTENER_SESSION, 0, 1, "MP", "1n", "/t", STRING, STRING_HASH)


def test_parse_the_design_documents_tokens() -> None:
    assert parse_token(DOC_LISTENER_NODE) == Entity(
        2, LISTENER_SESSION, 0, 0, EntityKind.NODE, "/", "/", "listener")
    assert parse_token(DOC_TALKER_PUB) == Entity(
        2, TALKER_SESSION, 0, 10, EntityKind.PUBLISHER, "/", "/", "talker", "/chatter",
        STRING, STRING_HASH, QoSProfile(depth=7))
    server = parse_token(DOC_SERVER)
    assert (server.kind, server.topic, server.type_name, server.type_hash, server.qos) == (
        "SS", "/add_two_ints", ADD_TWO_INTS, ADD_TWO_INTS_HASH, QoSProfile())
    for token in (DOC_LISTENER_NODE, DOC_LISTENER_SUB, DOC_TALKER_PUB, DOC_SERVER, DOC_CLIENT):
        assert parse_token(token).to_token() == token


@pytest.mark.parametrize("bad", [
    "",
    "@ros2_lv/2",
    "@other/2/aac3/0/0/NN/%/%/listener",
    "@ros2_lv/x/aac3/0/0/NN/%/%/listener",
    "@ros2_lv/2/AAC3/0/0/NN/%/%/listener",
    "@ros2_lv/2/aac3/0/0/XX/%/%/listener",
    "@ros2_lv/2/aac3/0/0/NN/%/robot1/listener",
    "@ros2_lv/2/aac3/0/0/NN/%/%/1listener",
    "@ros2_lv/2/aac3/0/0/NN/%/%/listener/extra",
    DOC_TALKER_PUB.rsplit("/", 1)[0],
    DOC_TALKER_PUB.replace("%chatter", "chatter"),
    DOC_TALKER_PUB.replace("%chatter", "%chatter%"),
    DOC_TALKER_PUB.replace("dds_::", ""),
    DOC_TALKER_PUB.replace("RIHS01_", "RIHS_"),
    DOC_TALKER_PUB.replace("::,7:,:,:,,", "::,7:,:,"),
    DOC_TALKER_PUB.replace("::,7:,:,:,,", "9::,7:,:,:,,"),
])
def test_malformed_tokens_are_refused_naming_the_token(bad: str) -> None:
    with pytest.raises(MessageError, match="malformed liveliness token") as info:
        parse_token(bad)
    assert repr(bad) in str(info.value)
    assert "\n" not in str(info.value)


# -- QoS --------------------------------------------------------------------------------------

def test_qos_chunks_of_the_design_document() -> None:
    assert qos_to_keyexpr(QoSProfile()) == "::,10:,:,:,,"
    assert qos_to_keyexpr(QoSProfile(depth=7)) == "::,7:,:,:,,"
    assert qos_from_keyexpr("::,10:,:,:,,") == QoSProfile()


def test_qos_writes_only_what_differs_from_rmw_zenohs_defaults() -> None:
    # rmw_zenoh leaves a component empty when it equals its own default; its default depth is
    # 42, which is why the examples' 10 and 7 are written out.
    assert qos_to_keyexpr(QoSProfile(depth=RMW_ZENOH_DEFAULT_DEPTH)) == "::,:,:,:,,"
    assert qos_from_keyexpr("::,:,:,:,,").depth == RMW_ZENOH_DEFAULT_DEPTH
    assert qos_to_keyexpr(QoSProfile(
        history=HistoryPolicy.KEEP_ALL, depth=5, reliability=ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL)) == "2:1:2,5:,:,:,,"


def test_qos_parses_explicit_components() -> None:
    # The example of rmw_zenoh's qos_to_keyexpr documentation: reliable, volatile, keep_last 10
    # with a deadline, lifespan and liveliness, which servolab does not keep.
    assert qos_from_keyexpr("1:2:1,10:0,0:60,3000:1,0,0") == QoSProfile()
    assert qos_from_keyexpr("2:1:2,3:,:,:,,") == QoSProfile(
        history=HistoryPolicy.KEEP_ALL, depth=3, reliability=ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL)
    assert qos_from_keyexpr("0:0:0,10:,:,:,,") == QoSProfile()  # SYSTEM_DEFAULT everywhere
    assert qos_from_keyexpr("::,0:,:,:,,") == QoSProfile(depth=1)  # KEEP_LAST holds >= 1


@pytest.mark.parametrize("bad", ["", "::", "::,10:,:,:,", "::10:,:,:,,", "a::,10:,:,:,,",
                                 "::,-1:,:,:,,", "3::,10:,:,:,,", ":3:,10:,:,:,,",
                                 "::3,10:,:,:,,"])
def test_bad_qos_is_refused(bad: str) -> None:
    with pytest.raises(MessageError, match="QoS"):
        qos_from_keyexpr(bad)


# -- attachments and GIDs ---------------------------------------------------------------------

def test_attachment_layout() -> None:
    gid = bytes(range(16))
    data = encode_attachment(5, 1_700_000_000_123_456_789, gid)
    assert data == (struct.pack("<q", 5) + struct.pack("<q", 1_700_000_000_123_456_789)
                    + b"\x10" + gid)
    assert decode_attachment(data) == Attachment(5, 1_700_000_000_123_456_789, gid)
    assert decode_attachment(memoryview(data)) == decode_attachment(bytearray(data))


def test_bad_attachments_are_refused() -> None:
    good = encode_attachment(1, 2, bytes(16))
    with pytest.raises(MessageError, match="attachment is 32 bytes, not 33"):
        decode_attachment(good[:-1])
    with pytest.raises(MessageError, match="attachment is 34 bytes"):
        decode_attachment(good + b"\0")
    with pytest.raises(MessageError, match="GID length is 8, not 16"):
        decode_attachment(good[:16] + b"\x08" + good[17:])
    with pytest.raises(MessageError, match="GID is 8 bytes"):
        encode_attachment(1, 2, bytes(8))
    with pytest.raises(MessageError, match="sequence number or timestamp"):
        encode_attachment(2**63, 2, bytes(16))


def test_gids_are_deterministic_and_distinct() -> None:
    gid = gid_from(LISTENER_SESSION, 10)
    assert len(gid) == 16
    assert gid == gid_from(LISTENER_SESSION, 10)
    assert len({gid, gid_from(LISTENER_SESSION, 11), gid_from(TALKER_SESSION, 10)}) == 3
    with pytest.raises(MessageError, match="session id"):
        gid_from("XYZ", 1)
    with pytest.raises(MessageError, match="entity id"):
        gid_from(LISTENER_SESSION, -1)


# -- round trips ------------------------------------------------------------------------------

_tokens = st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,7}", fullmatch=True)
_absolute = st.lists(_tokens, min_size=1, max_size=3).map(lambda ts: "/" + "/".join(ts))
_namespaces = st.one_of(st.just("/"), _absolute)
_qos = st.builds(QoSProfile, history=st.sampled_from([HistoryPolicy.KEEP_LAST,
                                                      HistoryPolicy.KEEP_ALL]),
                 depth=st.integers(1, 2**32 - 1) | st.just(RMW_ZENOH_DEFAULT_DEPTH),
                 reliability=st.sampled_from([ReliabilityPolicy.RELIABLE,
                                              ReliabilityPolicy.BEST_EFFORT]),
                 durability=st.sampled_from([DurabilityPolicy.VOLATILE,
                                             DurabilityPolicy.TRANSIENT_LOCAL]))
_ids = st.integers(0, 2**31)
_sessions = st.from_regex(r"[0-9a-f]{1,32}", fullmatch=True)
_types = st.builds(lambda pkg, kind, name: f"{pkg}/{kind}/{name}", _tokens,
                   st.sampled_from(["msg", "srv"]), _tokens)
_hashes = st.from_regex(r"RIHS01_[0-9a-f]{64}", fullmatch=True)


@given(_qos)
def test_qos_round_trip(qos: QoSProfile) -> None:
    assert qos_from_keyexpr(qos_to_keyexpr(qos)) == qos


@given(domain=_ids, session=_sessions, node_id=_ids, node=_tokens, namespace=_namespaces,
       enclave=_namespaces)
def test_node_token_round_trip(domain: int, session: str, node_id: int, node: str,
                               namespace: str, enclave: str) -> None:
    token = node_token(domain, session, node_id, node, namespace, enclave)
    entity = parse_token(token)
    assert (entity.domain_id, entity.session_id, entity.node_id, entity.entity_id,
            entity.kind, entity.namespace, entity.enclave, entity.node_name) == (
        domain, session, node_id, node_id, EntityKind.NODE, namespace, enclave, node)
    assert entity.to_token() == token


@given(domain=_ids, session=_sessions, node_id=_ids, entity_id=_ids,
       kind=st.sampled_from([k for k in EntityKind if k != EntityKind.NODE]), node=_tokens,
       namespace=_namespaces, topic=_absolute, type_name=_types, type_hash=_hashes, qos=_qos)
def test_entity_token_round_trip(domain: int, session: str, node_id: int, entity_id: int,
                                 kind: EntityKind, node: str, namespace: str, topic: str,
                                 type_name: str, type_hash: str, qos: QoSProfile) -> None:
    token = entity_token(domain, session, node_id, entity_id, kind, node, topic, type_name,
                         type_hash, namespace=namespace, qos=qos)
    entity = parse_token(token)
    assert entity == Entity(domain, session, node_id, entity_id, kind, "/", namespace, node,
                            topic, type_name, type_hash, qos)
    assert entity.to_token() == token


@given(st.integers(-(2**63), 2**63 - 1), st.integers(-(2**63), 2**63 - 1),
       st.binary(min_size=16, max_size=16))
def test_attachment_round_trip(sequence_number: int, timestamp: int, gid: bytes) -> None:
    data = encode_attachment(sequence_number, timestamp, gid)
    assert len(data) == 33
    assert decode_attachment(data) == Attachment(sequence_number, timestamp, gid)


@given(st.binary(max_size=64).filter(lambda b: len(b) != 33))
def test_attachments_of_any_other_length_are_refused(data: bytes) -> None:
    with pytest.raises(MessageError, match=f"attachment is {len(data)} bytes"):
        decode_attachment(data)
