"""What every part of a bag shares: the rosbag2 and MCAP facts, offered QoS profiles, and what
a reader reports.

The writer, the reader and playback each need some of these; keeping them here lets each of
those modules import only what it uses and none of the others, and puts the numbers that must
match rosbag2 Jazzy (metadata version, durations, opcodes) in one place to check.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from ... import __version__

MCAP_MAGIC = b"\x89MCAP0\r\n"
#: rosbag2 metadata version written: 9, as rosbag2 Jazzy writes it (``offered_qos_profiles`` a
#: list of profiles whose policies are names, ``keep_last``, ``reliable``; version 8 had a YAML
#: string of numbers).
METADATA_VERSION = 9
#: rmw's RMW_DURATION_INFINITE as rosbag2 writes a duration: what deadline, lifespan and the
#: liveliness lease are for every profile servolab offers.
_INFINITE = {"sec": 9223372036, "nsec": 854775807}
#: The distribution whose message definitions (and RIHS01 hashes) servolab's types are.
ROS_DISTRO = "jazzy"
LIBRARY = f"servolab {__version__}"

_OP_HEADER, _OP_FOOTER, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK = 1, 2, 3, 4, 5, 6
_OP_DATA_END = 0x0F
_FOOTER_TAIL = 9 + 20 + len(MCAP_MAGIC)  # footer record (opcode, length, 3 fields) + magic


def qos_profile(*, reliable: bool = True, transient_local: bool = False, keep_all: bool = False,
                depth: int = 10) -> dict[str, Any]:
    """One offered QoS profile, field for field as rosbag2 Jazzy writes it (``qos.cpp``,
    version 9): policies by name, durations as ``{sec, nsec}``, infinite where servolab has no
    deadline, lifespan or liveliness lease."""
    return {
        "history": "keep_all" if keep_all else "keep_last",
        "depth": depth,
        "reliability": "reliable" if reliable else "best_effort",
        "durability": "transient_local" if transient_local else "volatile",
        "deadline": dict(_INFINITE),
        "lifespan": dict(_INFINITE),
        "liveliness": "automatic",
        "liveliness_lease_duration": dict(_INFINITE),
        "avoid_ros_namespace_conventions": False,
    }


def _yaml(value: Any) -> str:
    """Block-style YAML, keys in the order given (as yaml-cpp's ``Dump`` writes them)."""
    return yaml.safe_dump(value, sort_keys=False, default_flow_style=False)


# -- what a reader reports -------------------------------------------------------------------


@dataclass(frozen=True)
class TopicInfo:
    """A topic of a bag, its message type and how many messages it holds."""

    name: str
    type: str
    count: int


@dataclass(frozen=True)
class BagMessage:
    """One recorded message: its topic, type, receive time and CDR bytes (not yet decoded, so
    playing a bag back costs no (de)serialization)."""

    topic: str
    type: str
    log_time_ns: int
    data: bytes
    publish_time_ns: int | None = None


@dataclass(frozen=True)
class BagInfo:
    """What ``ros2 bag info`` says of a bag; ``recovered`` is true for a file that was cut short
    (no footer or unreadable summary), whose messages come from its complete chunks, and
    ``lost_bytes`` is how much of its end could not be used."""

    path: Path
    topics: list[TopicInfo]
    message_count: int
    start_ns: int
    end_ns: int
    duration_s: float
    size_bytes: int
    recovered: bool
    lost_bytes: int = 0
