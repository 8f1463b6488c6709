"""How ROS 2's DDS middlewares lay out a graph on DDS: the names, types, QoS and discovery
configuration servolab's DDS transport (:mod:`.dds_transport`) uses, so that a stock ROS 2 node
(``rmw_fastrtps_cpp``, ``rmw_cyclonedds_cpp``) and servolab see each other.

The facts, and where they come from:

* a topic ``/chatter`` is the DDS topic ``rt/chatter``; a service ``/add`` is the request topic
  ``rq/addRequest`` and the reply topic ``rr/addReply`` (ROS 2 design article "Topic and
  Service name mapping to DDS"; ``rmw_dds_common``'s ``_get_ros_prefix_if_exists``);
* the type ``geometry_msgs/msg/Twist`` is ``geometry_msgs::msg::dds_::Twist_`` and a service's
  halves are ``<pkg>::srv::dds_::<Srv>_Request_`` / ``_Response_`` (rosidl_typesupport_fastrtps
  and rmw_cyclonedds name them so), each in XCDR1 (``DataRepresentation`` CDR, as Fast DDS
  offers it in Jazzy);
* each endpoint's USER_DATA carries ``typehash=RIHS01_<hex>;`` (REP 2016; seen on every
  endpoint a Jazzy rclpy announces);
* the graph of nodes is the topic ``ros_discovery_info`` of
  ``rmw_dds_common/msg/ParticipantEntitiesInfo``, reliable, transient-local, keep-last 1:
  each participant publishes its nodes and the 16-byte GIDs (the DDS GUIDs) of their readers
  and writers (``rmw_dds_common/graph_cache.cpp``);
* ``ROS_AUTOMATIC_DISCOVERY_RANGE`` (REP 2009's successor, ROS 2 Iron and later):
  ``LOCALHOST`` keeps discovery on this machine, ``SUBNET`` uses multicast, ``OFF`` only the
  static peers ``ROS_STATIC_PEERS`` names. servolab's default is ``LOCALHOST`` (as for Zenoh:
  nothing leaves the machine unless asked); Jazzy's own default is ``SUBNET``.
* request/reply: a request from a Cyclone DDS client (servolab, rmw_cyclonedds) carries a
  16-byte header before the request, the client's id and the request's sequence number
  (``cdds_request_header_t``, rmw_cyclonedds ``serdata.hpp``), which the reply echoes.
  Fast DDS (``rmw_fastrtps``) carries that identity in the RTPS inline QoS
  (``related_sample_identity``, ``rmw_request.cpp`` / ``rmw_response.cpp``) instead, which the
  Cyclone DDS API cannot read or write: see :mod:`.dds_transport` for what follows.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from xml.sax.saxutils import escape

from .errors import TransportError

TOPIC_PREFIX = "rt"
REQUEST_PREFIX = "rq"
REPLY_PREFIX = "rr"
#: the graph's topic and type (rmw_dds_common)
DISCOVERY_TOPIC = "ros_discovery_info"
DISCOVERY_TYPE = "rmw_dds_common/msg/ParticipantEntitiesInfo"
#: RTPS vendor ids, the first two bytes of a GUID prefix (OMG DDSI-RTPS 2.5, 8.3.3.1.3 and
#: the OMG's vendor id list)
VENDOR_EPROSIMA = b"\x01\x0f"
VENDOR_ECLIPSE = b"\x01\x10"

DISCOVERY_RANGES = ("LOCALHOST", "SUBNET", "OFF", "SYSTEM_DEFAULT")

#: an action's parts are ``pkg::action::dds_::<Action>_SendGoal_Request_`` (its services'
#: halves) and ``…_FeedbackMessage_`` (its feedback topic), as rosidl names them
_DDS_TYPE = re.compile(r"^(\w+)::(msg|srv|action)::dds_::(\w+?)_(Request_|Response_)?$")


def topic_name(topic: str) -> str:
    """``/chatter`` -> ``rt/chatter``."""
    return TOPIC_PREFIX + topic


def request_topic(service: str) -> str:
    return f"{REQUEST_PREFIX}{service}Request"


def reply_topic(service: str) -> str:
    return f"{REPLY_PREFIX}{service}Reply"


def dds_type_name(type_name: str) -> str:
    """``geometry_msgs/msg/Twist`` -> ``geometry_msgs::msg::dds_::Twist_``; a service's halves
    (``std_srvs/srv/SetBool_Request``) -> ``std_srvs::srv::dds_::SetBool_Request_``."""
    pkg, kind, short = type_name.split("/")
    return f"{pkg}::{kind}::dds_::{short}_"


@dataclass(frozen=True)
class DdsName:
    """What a DDS endpoint is in ROS terms: a topic's, a service's request or its reply."""

    role: str          # topic | request | reply
    name: str          # the ROS name: /chatter, /add
    type_name: str     # pkg/msg/Name, or pkg/srv/Name for both halves of a service


def ros_name(topic: str, dds_type: str) -> DdsName | None:
    """The ROS view of a DDS topic and type, or None for a topic that is not ROS's
    (``ros_discovery_info``, a DDS tool's, another vendor's built-in)."""
    found = _DDS_TYPE.match(dds_type)
    if found is None:
        return None
    pkg, kind, short, half = found.groups()
    type_name = f"{pkg}/{kind}/{short}"
    if topic.startswith(TOPIC_PREFIX + "/") and kind != "srv" and half is None:
        return DdsName("topic", topic[len(TOPIC_PREFIX):], type_name)
    if kind == "msg":
        return None
    if (topic.startswith(REQUEST_PREFIX + "/") and topic.endswith("Request")
            and half == "Request_"):
        return DdsName("request", topic[len(REQUEST_PREFIX):-len("Request")], type_name)
    if topic.startswith(REPLY_PREFIX + "/") and topic.endswith("Reply") and half == "Response_":
        return DdsName("reply", topic[len(REPLY_PREFIX):-len("Reply")], type_name)
    return None


def type_hash_user_data(rihs01: str) -> bytes:
    """The USER_DATA a Jazzy endpoint announces: ``typehash=RIHS01_<64 hex>;``."""
    return f"typehash={rihs01};".encode()


def discovery_range(text: str) -> str:
    """``$ROS_AUTOMATIC_DISCOVERY_RANGE`` checked (empty: servolab's LOCALHOST)."""
    value = text.strip().upper() or "LOCALHOST"
    if value not in DISCOVERY_RANGES:
        raise TransportError(f"ROS_AUTOMATIC_DISCOVERY_RANGE={text!r}: use one of "
                             f"{', '.join(DISCOVERY_RANGES)}")
    return value


def static_peers(text: str) -> list[str]:
    """``$ROS_STATIC_PEERS``: addresses separated by ``;`` (ROS 2 Iron and later)."""
    return [peer.strip() for peer in text.split(";") if peer.strip()]


def discovery_from_environment(connect: list[str]) -> tuple[str, list[str]]:
    """The discovery range and static peers a ROS 2 program on this machine would use:
    ``$ROS_AUTOMATIC_DISCOVERY_RANGE`` and ``$ROS_STATIC_PEERS``, plus ``--connect``'s
    addresses (hosts or IP addresses, as ROS_STATIC_PEERS takes them)."""
    import os

    range_ = discovery_range(os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE", ""))
    peers = static_peers(os.environ.get("ROS_STATIC_PEERS", ""))
    for peer in connect:
        if not re.fullmatch(r"[\w.:-]+", peer):
            raise TransportError(f"--connect {peer!r}: over DDS a peer is a host name or an IP "
                                 "address, e.g. 192.168.1.20 or robot.local")
        peers.append(peer)
    return range_, peers


def is_loopback(host: str) -> bool:
    return host in ("localhost", "::1") or host.startswith("127.")


def cyclone_config(range_: str, peers: list[str], *, max_participants: int = 32) -> str:
    """Cyclone DDS's XML configuration for the discovery range and static peers.

    LOCALHOST binds to loopback, turns multicast off and makes 127.0.0.1 a peer, so that
    discovery goes by unicast to the well-known ports of participant indices 0..
    ``max_participants`` on this machine, where Fast DDS in LOCALHOST (and SUBNET) mode also
    listens. SUBNET keeps Cyclone's defaults (multicast on the default interface). OFF has
    no multicast and only the static peers."""
    general = ""
    peer_list = list(peers)
    if range_ == "LOCALHOST":
        # bound to loopback only while every peer is on this machine: a remote static peer
        # must be told an address it can answer (ROS 2: static peers extend LOCALHOST)
        local = all(is_loopback(peer) for peer in peer_list)
        interfaces = ("<Interfaces><NetworkInterface address=\"127.0.0.1\"/></Interfaces>"
                      if local else "")
        general = f"<General>{interfaces}<AllowMulticast>false</AllowMulticast></General>"
        peer_list = ["127.0.0.1", *peer_list]
    elif range_ == "OFF":
        general = "<General><AllowMulticast>false</AllowMulticast></General>"
    discovery = (f"<ParticipantIndex>auto</ParticipantIndex>"
                 f"<MaxAutoParticipantIndex>{max_participants}</MaxAutoParticipantIndex>")
    if peer_list:
        discovery += "<Peers>" + "".join(f"<Peer address=\"{escape(p)}\"/>"
                                         for p in peer_list) + "</Peers>"
    # Discovery's "gone" notices (a writer, a reader or the participant deleted) as Fast DDS
    # can read them: Cyclone sends them key-only, and without a key hash their payload is
    # 28 bytes, which Fast DDS 2.14 (ROS 2 Jazzy's) drops ("Ignoring Serialized Payload for
    # too large key-only data", MessageReceiver::proc_Submsg_Data takes 16 at most). A
    # servolab node's deleted endpoints then stayed in every rmw_fastrtps graph for as long
    # as the participant lived, and a participant that left was seen gone only when Cyclone's
    # 10 s lease ran out (an rclpy server waiting for count_clients to reach 0 waited 10 s).
    internal = "<Internal><GenerateKeyhash>true</GenerateKeyhash></Internal>"
    return (f"<CycloneDDS><Domain id=\"any\">{general}<Discovery>{discovery}</Discovery>"
            f"{internal}</Domain></CycloneDDS>")
