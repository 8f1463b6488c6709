"""ROS 2 ``rmw_zenoh``'s naming conventions, as pure functions (no session, no I/O).

A ROS 2 node on ``rmw_zenoh`` finds servolab's topics only if the key expressions, liveliness
tokens and attachments are byte-for-byte what ``rmw_zenoh_cpp`` writes, so they are spelled
out here once, following ``docs/design.md`` of ros2/rmw_zenoh (rolling), and tested against its
examples. Keeping them free of Zenoh lets the graph cache and ``topic list`` be tested alone.
"""

from __future__ import annotations

import hashlib
import re
import struct
from dataclasses import dataclass
from enum import StrEnum

from .errors import MessageError, NameValidationError

# Re-exported, explicitly: node.py imports them from here until it moves to .names.
from .names import (
    node_namespace,
    validate_enclave_name,
    validate_full_topic_name,
    validate_namespace,
    validate_node_name,
)
from .qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

ADMIN_SPACE = "@ros2_lv"
#: rmw_zenoh's default depth: a token leaves the depth empty only when it is this, so the
#: usual depths (rclcpp's 10, the talker's 7) are always written.
RMW_ZENOH_DEFAULT_DEPTH = 42
GID_SIZE = 16

_SESSION = re.compile(r"[0-9a-f]{1,32}")
_HASH = re.compile(r"RIHS[0-9]{2}_[0-9a-f]+")
_ROS_TYPE = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)/([a-z]+)/([A-Za-z_][A-Za-z0-9_]*)")
_DDS_TYPE = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)::([a-z]+)::dds_::([A-Za-z_][A-Za-z0-9_]*)_")
_NUMBER = re.compile(r"[0-9]+")
#: rmw_zenoh's 33-byte attachment (``attachment_helpers.cpp``): sequence number, source
#: timestamp (ns), GID length, GID, little-endian
ATTACHMENT = struct.Struct("<qqB16s")


class EntityKind(StrEnum):
    """The ``<entity_kind>`` chunk of a liveliness token."""

    NODE = "NN"
    PUBLISHER = "MP"
    SUBSCRIPTION = "MS"
    SERVICE = "SS"
    CLIENT = "SC"


# -- names ------------------------------------------------------------------------------------
# ROS names (node names, namespaces, topics) are checked by :mod:`.names`, with ROS 2's rules.

_RULES = {  # what -> (pattern, what it must be), for one-line errors that name the value
    "session id": (_SESSION, "1 to 32 lowercase hex digits"),
    "type hash": (_HASH, "RIHS01_<hex>"),
}


def _check(what: str, value: str) -> str:
    pattern, rule = _RULES[what]
    if not pattern.fullmatch(value):
        raise MessageError(f"invalid {what} {value!r}: must be {rule}")
    return value


def _check_id(value: int, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise MessageError(f"{what} {value!r} must be a non-negative integer")
    return value


def _enclave(enclave: str) -> str:
    """``/`` for ``""`` (rcl's default enclave), else a valid enclave name."""
    return validate_enclave_name(enclave or "/")


def mangle(name: str) -> str:
    """Every ``/`` as ``%`` (Zenoh chunks cannot hold ``/``); empty or root is ``%``."""
    return name.replace("/", "%") or "%"


def unmangle(text: str) -> str:
    """The inverse of :func:`mangle`; ``%`` comes back as the root ``/``."""
    return text.replace("%", "/")


def dds_type_name(ros_type_name: str) -> str:
    """``pkg::msg::dds_::Name_`` for ``pkg/msg/Name``: the name DDS and rmw_zenoh use."""
    if not (m := _ROS_TYPE.fullmatch(ros_type_name)):
        raise MessageError(f"type {ros_type_name!r} must be spelled pkg/msg/Name or pkg/srv/Name")
    return "{}::{}::dds_::{}_".format(*m.groups())


def ros_type_name(dds_name: str) -> str:
    """``pkg/msg/Name`` for ``pkg::msg::dds_::Name_``, the inverse of :func:`dds_type_name`."""
    if not (m := _DDS_TYPE.fullmatch(dds_name)):
        raise MessageError(f"type {dds_name!r} is not a DDS name pkg::msg::dds_::Name_")
    return "/".join(m.groups())


def topic_keyexpr(domain_id: int, fqn: str, ros_type_name: str, type_hash: str) -> str:
    """``0/robot1/chatter/std_msgs::msg::dds_::String_/RIHS01_...``: where data is put.

    The type name and hash are in the key so that endpoints of different types never meet."""
    _check_id(domain_id, "domain id")
    return (f"{domain_id}/{validate_full_topic_name(fqn)[1:]}/"
            f"{dds_type_name(ros_type_name)}/{_check('type hash', type_hash)}")


# -- QoS --------------------------------------------------------------------------------------

# rmw_zenoh writes rmw's policy numbers (rmw/types.h, the values of QoSProfile's policies);
# 0 is SYSTEM_DEFAULT, which rmw_zenoh resolves to RELIABLE, VOLATILE and KEEP_LAST
_RELIABILITY = {"": ReliabilityPolicy.RELIABLE, "0": ReliabilityPolicy.RELIABLE,
                "1": ReliabilityPolicy.RELIABLE, "2": ReliabilityPolicy.BEST_EFFORT}
_DURABILITY = {"": DurabilityPolicy.VOLATILE, "0": DurabilityPolicy.VOLATILE,
               "1": DurabilityPolicy.TRANSIENT_LOCAL, "2": DurabilityPolicy.VOLATILE}
_HISTORY = {"": HistoryPolicy.KEEP_LAST, "0": HistoryPolicy.KEEP_LAST,
            "1": HistoryPolicy.KEEP_LAST, "2": HistoryPolicy.KEEP_ALL}


def qos_to_keyexpr(qos: QoSProfile) -> str:
    """A token's QoS chunk, ``::,10:,:,:,,`` for the defaults: a component is empty when it
    is rmw_zenoh's default (RELIABLE, VOLATILE, KEEP_LAST, depth 42, infinite durations,
    AUTOMATIC liveliness). Deadline, lifespan and liveliness, which servolab does not keep,
    are always written as those defaults."""
    reliability = "" if qos.reliable else str(int(ReliabilityPolicy.BEST_EFFORT))
    durability = str(int(DurabilityPolicy.TRANSIENT_LOCAL)) if qos.transient_local else ""
    history = str(int(HistoryPolicy.KEEP_ALL)) if qos.keep_all else ""
    depth = "" if qos.depth == RMW_ZENOH_DEFAULT_DEPTH else str(qos.depth)
    return f"{reliability}:{durability}:{history},{depth}:,:,:,,"


def qos_from_keyexpr(text: str) -> QoSProfile:
    """Parse a token's QoS chunk, whether its components are empty or written out; deadline,
    lifespan and liveliness are checked and dropped. A KEEP_LAST depth of 0 (which a C++ node
    may announce) is read as 1, the least a KEEP_LAST history holds."""
    parts = text.split(":")
    shape = [len(p.split(",")) for p in parts]
    numbers = text.replace(":", "").replace(",", "")
    if shape != [1, 1, 2, 2, 2, 3] or (numbers and not _NUMBER.fullmatch(numbers)):
        raise MessageError(f"QoS {text!r} is not <rel>:<dur>:<hist>,<depth>:<s>,<ns>:<s>,"
                           "<ns>:<liveliness>,<s>,<ns>")
    history_text, depth_text = parts[2].split(",")
    try:
        history = _HISTORY[history_text]
        reliability, durability = _RELIABILITY[parts[0]], _DURABILITY[parts[1]]
    except KeyError as exc:
        raise MessageError(f"QoS {text!r}: unsupported policy value {exc}") from None
    depth = int(depth_text) if depth_text else RMW_ZENOH_DEFAULT_DEPTH
    if history == HistoryPolicy.KEEP_LAST:
        depth = max(1, depth)
    return QoSProfile(history=history, depth=depth, reliability=reliability,
                      durability=durability)


# -- liveliness tokens ------------------------------------------------------------------------

def _node_part(domain_id: int, session_id: str, node_id: int, entity_id: int, kind: EntityKind,
               node_name: str, namespace: str, enclave: str) -> str:
    return (f"{ADMIN_SPACE}/{_check_id(domain_id, 'domain id')}/{_check('session id', session_id)}/"
            f"{_check_id(node_id, 'node id')}/{_check_id(entity_id, 'entity id')}/{kind}/"
            f"{mangle(_enclave(enclave))}/{mangle(node_namespace(namespace))}/"
            f"{validate_node_name(node_name)}")


def node_token(domain_id: int, session_id: str, node_id: int, node_name: str,
               namespace: str = "/", enclave: str = "/") -> str:
    """``@ros2_lv/2/<session>/0/0/NN/%/%/listener``: a node's id stands as its entity id."""
    return _node_part(domain_id, session_id, node_id, node_id, EntityKind.NODE, node_name,
                      namespace, enclave)


def entity_token(domain_id: int, session_id: str, node_id: int, entity_id: int,
                 kind: EntityKind | str, node_name: str, topic: str, ros_type_name: str,
                 type_hash: str, *, namespace: str = "/", enclave: str = "/",
                 qos: QoSProfile | None = None) -> str:
    """The token of a publisher, subscription, service server or client on ``topic`` (a fully
    qualified name, see :func:`fully_qualified_name`)."""
    if kind not in ("MP", "MS", "SS", "SC"):
        raise MessageError(f"entity kind {kind!r} is not one of MP, MS, SS, SC (nodes: NN, "
                           "use node_token)")
    head = _node_part(domain_id, session_id, node_id, entity_id, EntityKind(kind), node_name,
                      namespace, enclave)
    topic = validate_full_topic_name(topic, is_service=kind in ("SS", "SC"))
    return (f"{head}/{mangle(topic)}/"
            f"{dds_type_name(ros_type_name)}/{_check('type hash', type_hash)}/"
            f"{qos_to_keyexpr(qos or QoSProfile())}")


@dataclass(frozen=True, slots=True)
class Entity:
    """A parsed liveliness token: what the graph cache keeps per node or endpoint.

    ``namespace`` and ``enclave`` are ``/`` at the root; ``topic`` is fully qualified and
    ``type_name`` is ``pkg/msg/Name``; the last four are None for a node."""

    domain_id: int
    session_id: str
    node_id: int
    entity_id: int
    kind: EntityKind
    enclave: str
    namespace: str
    node_name: str
    topic: str | None = None
    type_name: str | None = None
    type_hash: str | None = None
    qos: QoSProfile | None = None

    def to_token(self) -> str:
        """The token again; a node's is rebuilt from its ``node_id``."""
        if self.kind == EntityKind.NODE:
            return node_token(self.domain_id, self.session_id, self.node_id, self.node_name,
                              self.namespace, self.enclave)
        if not (self.topic and self.type_name and self.type_hash):
            raise MessageError(f"{self.kind} entity of node {self.node_name!r} needs a topic, "
                               "type name and type hash")
        return entity_token(self.domain_id, self.session_id, self.node_id, self.entity_id,
                            self.kind, self.node_name, self.topic, self.type_name,
                            self.type_hash, namespace=self.namespace, enclave=self.enclave,
                            qos=self.qos)


def parse_token(token: str) -> Entity:
    """The :class:`Entity` a liveliness token announces, or a :class:`MessageError` naming it."""
    chunks = token.split("/")
    try:
        if len(chunks) < 9 or chunks[0] != ADMIN_SPACE:
            raise MessageError(f"it is not {ADMIN_SPACE}/<domain>/<session>/<node>/<id>/<kind>/"
                               "<enclave>/<namespace>/<node name>[/<topic>/<type>/<hash>/<qos>]")
        if not all(_NUMBER.fullmatch(chunks[i]) for i in (1, 3, 4)):
            raise MessageError("domain, node and entity ids must be numbers")
        if not (chunks[6].startswith("%") and chunks[7].startswith("%")):
            raise MessageError("enclave and namespace must be mangled absolute names")
        if chunks[5] not in tuple(EntityKind):
            raise MessageError(f"entity kind {chunks[5]!r} is not one of NN, MP, MS, SS, SC")
        kind = EntityKind(chunks[5])
        expected = 9 if kind == EntityKind.NODE else 13
        if len(chunks) != expected:
            raise MessageError(f"a {kind} token has {expected} chunks, not {len(chunks)}")
        common = (int(chunks[1]), _check("session id", chunks[2]), int(chunks[3]), int(chunks[4]),
                  kind, validate_enclave_name(unmangle(chunks[6])),
                  validate_namespace(unmangle(chunks[7])), validate_node_name(chunks[8]))
        if kind == EntityKind.NODE:
            return Entity(*common)
        service = kind in (EntityKind.SERVICE, EntityKind.CLIENT)
        return Entity(*common, validate_full_topic_name(unmangle(chunks[9]), is_service=service),
                      ros_type_name(chunks[10]), _check("type hash", chunks[11]),
                      qos_from_keyexpr(chunks[12]))
    except NameValidationError as exc:  # one line here, with the token it is in
        raise MessageError(f"malformed liveliness token {token!r}: {exc.summary}") from None
    except ValueError as exc:  # MessageError is a ValueError too
        raise MessageError(f"malformed liveliness token {token!r}: {exc}") from None


# -- attachments and GIDs ---------------------------------------------------------------------

@dataclass(frozen=True, slots=True)
class Attachment:
    """What rmw_zenoh attaches to every put, query and reply: the sequence number pairs a
    reply with its request, the GID names the publisher or client."""

    sequence_number: int
    source_timestamp_ns: int
    gid: bytes


def encode_attachment(sequence_number: int, source_timestamp_ns: int, gid: bytes) -> bytes:
    """33 bytes: int64 LE sequence number, int64 LE ns since the epoch, ``16``, the GID."""
    if len(gid) != GID_SIZE:
        raise MessageError(f"GID is {len(gid)} bytes, not {GID_SIZE}")
    try:
        return ATTACHMENT.pack(sequence_number, source_timestamp_ns, GID_SIZE, bytes(gid))
    except struct.error as exc:
        raise MessageError(f"attachment sequence number or timestamp: {exc}") from None


def decode_attachment(data: bytes | bytearray | memoryview) -> Attachment:
    """The inverse of :func:`encode_attachment`; anything but 33 bytes with a 16-byte GID is
    refused rather than guessed at."""
    if len(data) != ATTACHMENT.size:
        raise MessageError(f"attachment is {len(data)} bytes, not {ATTACHMENT.size} "
                           "(sequence number, timestamp, GID length, GID)")
    sequence_number, timestamp, gid_size, gid = ATTACHMENT.unpack(data)
    if gid_size != GID_SIZE:
        raise MessageError(f"attachment GID length is {gid_size}, not {GID_SIZE}")
    return Attachment(sequence_number, timestamp, gid)


def gid_from(session_id_hex: str, entity_id: int) -> bytes:
    """A 16-byte GID for an entity. rmw_zenoh hashes the whole liveliness token (XXH3-128);
    ours only needs to be unique per entity, and entity ids count up per session, so a hash
    of the two is enough (BLAKE2b, as it is in :mod:`hashlib`)."""
    key = f"{_check('session id', session_id_hex)}/{_check_id(entity_id, 'entity id')}"
    return hashlib.blake2b(key.encode(), digest_size=GID_SIZE).digest()


# -- a failed service handler's reply -------------------------------------------------------

#: The Zenoh encoding that marks a reply as a failed handler's (see the module docstring).
ERROR_ENCODING = "servolab/service-error"
#: Zenoh writes an encoding's schema with a one-byte length: the whole encoding text must fit
#: in 255 bytes, or zenoh-python's transmit pipeline panics (and the session with it).
_ENCODING_BYTES = 255


def error_encoding(reason: str) -> str:
    """``servolab/service-error;<reason>``: the reason on one line, cut (at a character
    boundary, ending in ``…``) so that the whole text fits Zenoh's 255 bytes."""
    room = _ENCODING_BYTES - len(ERROR_ENCODING) - 1
    text = " ".join(reason.split()).encode()
    if len(text) > room:
        text = text[:room - 3].decode(errors="ignore").encode() + "…".encode()
    return f"{ERROR_ENCODING};{text.decode()}"


def error_reason(encoding: str) -> str | None:
    """The reason a reply's encoding (its text, e.g. ``str(sample.encoding)``) gives for a
    failed handler, or None if the reply is a real response."""
    if encoding == ERROR_ENCODING:
        return "the service's handler failed"
    if encoding.startswith(f"{ERROR_ENCODING};"):
        return encoding[len(ERROR_ENCODING) + 1:] or "the service's handler failed"
    return None
