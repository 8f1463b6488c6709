"""Big messages without a page fault per page: the C heap keeps what it freed.

Why: a camera frame crosses servolab in buffers of its size (240 kB for the fly treadmill's
640x376 mono8 frame): Zenoh's payload copied out as ``bytes``, the CDR ``bytearray`` a publish
builds, the copy an in-process publish makes for value semantics. glibc's ``malloc`` gives a
buffer that big from the top of the heap and, once two or three such buffers are free there,
gives the memory back to the kernel (``M_TRIM_THRESHOLD``, which glibc sets to twice the
largest buffer it has freed), so the next frame's buffer is new memory that faults in page by
page. Measured on the project's machine (``benchmarks/middleware.py``'s Image echo): the
process that republishes each frame took 86 minor page faults per frame, and a frame's
one-way p50 was 389 us; with the heap keeping its freed memory, 0 faults and 294 us.

So a :class:`~servolab.middleware.context.Context` asks glibc (``mallopt``) to keep up to
:data:`DEFAULT_KEEP_MB` of freed memory at the top of its heap, and to serve buffers below
that size from the heap rather than from ``mmap`` (whose every buffer is new memory): the
fix real-time guides give for ROS 2 nodes (``M_TRIM_THRESHOLD``, ``M_MMAP_THRESHOLD`` in
``mallopt(3)``). A process then holds at most that much memory it no longer uses, memory it
did use at its peak. ``SERVOLAB_KEEP_FREED_MB`` sets the amount for a process and the ones it
starts; ``0`` leaves glibc's defaults. Other C libraries (musl, macOS) are left as they are.

The setting is the process's, not a context's: the C heap is one per process.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import math
import os
import platform
from collections.abc import Callable, Mapping

from ..errors import ServolabValueError

#: The environment variable that sets how much freed memory the heap keeps (MB, 10**6 bytes).
KEEP_FREED_ENV = "SERVOLAB_KEEP_FREED_MB"
#: MB of freed memory kept by default: a few 1080p RGB frames (6.2 MB each).
DEFAULT_KEEP_MB = 64.0
#: glibc's bound on M_MMAP_THRESHOLD on a 64-bit machine (HEAP_MAX_SIZE / 2, mallopt(3)).
_MMAP_THRESHOLD_MAX = 32 * 1024 * 1024
# mallopt's parameter numbers (glibc's malloc.h)
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3


def keep_mb(environ: Mapping[str, str] | None = None) -> float:
    """MB of freed memory to keep, from :data:`KEEP_FREED_ENV` (default
    :data:`DEFAULT_KEEP_MB`); a value that is not a number >= 0 is refused, naming it."""
    text = (os.environ if environ is None else environ).get(KEEP_FREED_ENV, "")
    if not text.strip():
        return DEFAULT_KEEP_MB
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0 <= value < math.inf:
        raise ServolabValueError(f"{KEEP_FREED_ENV}={text!r}: give a number of MB >= 0 "
                                 f"(0 leaves the C library's defaults; default "
                                 f"{DEFAULT_KEEP_MB:g})")
    return value


def keep_freed_memory(megabytes: float | None = None) -> int:
    """Ask glibc to keep up to ``megabytes`` (default :func:`keep_mb`) of freed memory; the
    bytes it keeps (0 where nothing was changed: asked for 0, or not glibc). Asking again
    sets the same again: every context of a process asks, and none needs to know if another
    did."""
    size = int((keep_mb() if megabytes is None else megabytes) * 1_000_000)
    if not size:
        return 0
    mallopt = _glibc_mallopt()
    if mallopt is None:
        return 0
    # below the mmap threshold a buffer comes from the heap, whose top is then kept
    took_mmap = mallopt(_M_MMAP_THRESHOLD, min(size, _MMAP_THRESHOLD_MAX)) == 1
    took_trim = mallopt(_M_TRIM_THRESHOLD, size) == 1
    return size if took_mmap and took_trim else 0


@functools.cache
def _glibc_mallopt() -> Callable[[int, int], int] | None:
    """glibc's ``mallopt``, or None under another C library."""
    if platform.system() != "Linux" or platform.libc_ver()[0] != "glibc":
        return None
    try:
        mallopt = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").mallopt
    except (OSError, AttributeError):
        return None
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    return mallopt
