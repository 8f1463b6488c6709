"""Recordings: MCAP files in the rosbag2 layout, written, read and played back.

A bag is what ``ros2 bag record -s mcap`` leaves behind: a directory ``NAME/`` holding
``NAME_0.mcap`` and ``metadata.yaml``. The MCAP file follows the ``ros2`` profile as rosbag2's
MCAP storage plugin writes it (schemas are ``ros2msg`` text, messages are CDR, each channel
carries ``offered_qos_profiles`` and ``topic_type_hash``, and a ``rosbag2`` metadata record
holds the bag's metadata, as rosbag2 Jazzy writes them), so ``ros2 bag info/play`` (on the
directory or the lone ``.mcap``), Foxglove and ``rosbags`` open servolab's recordings, and
servolab opens theirs. ``metadata.yaml`` is version 9, Jazzy's: offered QoS profiles a list.

This package knows files and timestamps, never nodes or transports: the recorder node
subscribes and hands bytes to :class:`BagWriter`; :func:`play` hands bytes to whatever
``publish`` callable it is given. One module per job, so each can be read (and changed) alone:

- :mod:`.layout` — what every part shares: the rosbag2/MCAP constants, :func:`qos_profile`,
  and what a reader reports (:class:`TopicInfo`, :class:`BagMessage`, :class:`BagInfo`,
  :class:`BagDamage`, :class:`BagCheck`)
- :mod:`.writer` — :class:`BagWriter`, which a killed process leaves readable
- :mod:`.reader` — :class:`BagReader`, which recovers a cut-short file and reads past damage
  (a damaged chunk reported as a :class:`BagDamage` and skipped), its ``check``, and
  :func:`reindex`, which rewrites such a file as a complete one
- :mod:`.scan` — a file read record by record, on past damaged records: what the ``mcap``
  library's readers do not do
- :mod:`.playback` — :func:`play`, at the bag's own pace on any clock

How ``servolab bag info`` prints a bag is the app's business (:mod:`servolab.apps.bag`).
"""

from __future__ import annotations

from .layout import (
    LIBRARY,
    MCAP_MAGIC,
    METADATA_VERSION,
    ROS_DISTRO,
    BagCheck,
    BagDamage,
    BagInfo,
    BagMessage,
    TopicInfo,
    qos_profile,
)
from .playback import play
from .reader import BagReader, reindex
from .writer import BagWriter

__all__ = [
    "LIBRARY", "MCAP_MAGIC", "METADATA_VERSION", "ROS_DISTRO", "BagCheck", "BagDamage",
    "BagInfo", "BagMessage", "BagReader", "BagWriter", "TopicInfo", "play", "qos_profile",
    "reindex",
]
