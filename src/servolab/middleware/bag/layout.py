"""What every part of a bag shares: the rosbag2 and MCAP facts, offered QoS profiles, and what
a reader reports.

The writer, the reader and playback each need some of these; keeping them here lets each of
those modules import only what it uses and none of the others, and puts the numbers that must
match rosbag2 Jazzy (metadata version, durations) in one place to check.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from ... import __version__
from ..errors import BagError

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
    #: the damaged parts found so far, in file order (a summary's file has its chunks checked
    #: as they are read, or all at once by :meth:`~.reader.BagReader.check`)
    damage: tuple[BagDamage, ...] = ()


class BagDamage(BagError):
    """One damaged part of a bag file: where it is (``offset``, in bytes from the start of
    ``path``) and what it is, in one line (``text``). ``lost`` is false when nothing was lost
    by it (a damaged magic, a summary the records it indexes stand in for).

    A reader reports it (to its ``on_damage``, or the log) and reads on past it; nothing raises
    it, unless an ``on_damage`` that wants a damaged bag refused does: it is a
    :class:`~servolab.middleware.errors.BagError` whose message names the file and offset."""

    def __init__(self, path: Path, offset: int, text: str, *, lost: bool = True) -> None:
        super().__init__(f"{path} at byte {offset}: {text}")
        self.path = path
        self.offset = offset
        self.text = text
        self.lost = lost

    def __reduce__(self) -> tuple[Any, ...]:
        return _damage, (self.path, self.offset, self.text, self.lost)


def _damage(path: Path, offset: int, text: str, lost: bool) -> BagDamage:
    return BagDamage(path, offset, text, lost=lost)


@dataclass(frozen=True)
class BagCheck:
    """What :meth:`~.reader.BagReader.check` found: the sound chunks and the messages they
    hold, and every problem (none: the bag is sound)."""

    path: Path
    chunks: int
    messages: int
    problems: tuple[BagDamage, ...]

    @property
    def sound(self) -> bool:
        return not self.problems
