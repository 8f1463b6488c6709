"""What every part of the bus shares: the value types of its API and its logger."""

from __future__ import annotations

import logging
from collections.abc import Sequence

#: One logger for the whole bus, under the name it always had (tests and users filter on it).
log = logging.getLogger("servolab.dynamixel.bus")

Value = float | int
Names = str | Sequence[str]
#: Several register names. The overloads of read/sync_read/sync_write take a list or tuple
#: rather than any Sequence[str], because a str is itself a Sequence[str]: with Sequence the
#: one-name and several-names call shapes would overlap and neither could have a precise type.
NameList = list[str] | tuple[str, ...]
#: The longest a motor waits before its status: Return Delay Time 254, 2 us a unit (e-Manual).
MAX_RETURN_DELAY = 254 * 2e-6
