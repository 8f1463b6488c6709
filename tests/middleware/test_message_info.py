"""The Zenoh transport's fast path for rmw_zenoh's attachment: a publisher packs it without
:func:`encode_attachment`'s checks and a subscription unpacks it with one struct call, so both
must still agree byte for byte with :mod:`.rmw_zenoh`."""

from __future__ import annotations

import zenoh

from servolab.middleware.rmw_zenoh import encode_attachment
from servolab.middleware.zenoh_inbox import message_info

GID = bytes(range(16))


def test_message_info_reads_rmw_zenohs_attachment() -> None:
    info = message_info(zenoh.ZBytes(encode_attachment(7, 1_700_000_000_123, GID)), 42)
    assert (info.sequence_number, info.source_timestamp_ns, info.publisher_gid,
            info.received_timestamp_ns) == (7, 1_700_000_000_123, GID, 42)


def test_a_sample_without_rmw_zenohs_attachment_is_stamped_on_arrival() -> None:
    """A plain Zenoh put (no attachment, or one of another layout) is still data."""
    for attachment in (None, zenoh.ZBytes(b"not rmw_zenoh's"),
                       zenoh.ZBytes(encode_attachment(1, 2, GID)[:16] + b"\x08" + GID)):
        info = message_info(attachment, 42)
        assert (info.source_timestamp_ns, info.received_timestamp_ns,
                info.sequence_number, info.publisher_gid) == (42, 42, 0, b"")
