"""Big messages without a page fault per page: the C heap keeps what it freed.

Why: a camera frame crosses servolab in buffers of its size (240 kB for the fly treadmill's
640x376 mono8 frame): Zenoh's payload copied out as ``bytes``, the CDR ``bytearray`` a publish
builds, the copy an in-process publish makes for value semantics. glibc's ``malloc`` gives a
buffer that big from the top of the heap and, once two or three such buffers are free there,
gives the memory back to the kernel (``M_TRIM_THRESHOLD``, which glibc sets to twice the
largest buffer it has freed), so the next frame's buffer is new memory that faults in page by
page (docs/middleware.md, "How fast", has the figures: 86 faults per frame, none now).

So a :class:`~servolab.middleware.context.Context` asks glibc (``mallopt``) to keep up to
:data:`DEFAULT_KEEP_MB` of freed memory at the top of each of its heaps (each malloc arena:
Zenoh's threads have their own), and to serve every buffer it can from a heap rather than
from ``mmap``, whose every buffer is new memory (the mmap threshold at glibc's most: 32 MiB
on a 64-bit machine). It is the fix real-time guides give for ROS 2 nodes
(``M_TRIM_THRESHOLD``, ``M_MMAP_THRESHOLD`` in ``mallopt(3)``). What a process then holds
and no longer uses is memory it used at its peak: up to that much at each heap's top, and
what lies freed below memory still in use, which glibc never gives back anyway.
``SERVOLAB_KEEP_FREED_MB`` sets the amount for a process and the ones it starts; ``0``
leaves glibc's defaults, and so does any other C library (musl, macOS).

The setting is the process's, not a context's: the C heap is one per process, and a program
that set these two thresholds itself has them set again by its first context (``0`` keeps
its own).
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
#: The most MB the variable takes: mallopt's values are C ints (bytes).
MAX_KEEP_MB = (2**31 - 1) / 1_000_000
# mallopt's parameter numbers (glibc's malloc.h)
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3


def keep_mb(environ: Mapping[str, str] | None = None) -> float:
    """MB of freed memory to keep, from :data:`KEEP_FREED_ENV` (default
    :data:`DEFAULT_KEEP_MB`); a value that is not a number from 0 to :data:`MAX_KEEP_MB`
    is refused, naming it."""
    text = (os.environ if environ is None else environ).get(KEEP_FREED_ENV, "")
    if not text.strip():
        return DEFAULT_KEEP_MB
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0 <= value <= MAX_KEEP_MB:
        raise ServolabValueError(f"{KEEP_FREED_ENV}={text!r}: give a number of MB from 0 to "
                                 f"{MAX_KEEP_MB:.0f} (0 leaves the C library's defaults; "
                                 f"default {DEFAULT_KEEP_MB:g})")
    return value


def keep_freed_memory(megabytes: float | None = None) -> int:
    """Ask glibc to keep up to ``megabytes`` (default :func:`keep_mb`) of freed memory; the
    bytes it keeps (0 where nothing was changed: asked for 0, or not glibc). Asking again
    sets the same again: every context of a process asks, and none needs to know if another
    did."""
    if megabytes is not None and not 0 <= megabytes <= MAX_KEEP_MB:
        raise ServolabValueError(f"keep {megabytes!r} MB of freed memory: from 0 to "
                                 f"{MAX_KEEP_MB:.0f}")
    size = int((keep_mb() if megabytes is None else megabytes) * 1_000_000)
    if not size:
        return 0
    mallopt = _glibc_mallopt()
    if mallopt is None:
        return 0
    # every buffer glibc allows below the mmap threshold comes from the heap, whose freed top
    # is then kept; the trim threshold only where that took (setting it alone fixes the mmap
    # threshold at 128 KiB, and every frame would be mmap's new memory)
    if mallopt(_M_MMAP_THRESHOLD, _mmap_threshold_max()) != 1:
        return 0
    return size if mallopt(_M_TRIM_THRESHOLD, size) == 1 else 0


def _mmap_threshold_max() -> int:
    """glibc's bound on M_MMAP_THRESHOLD (mallopt(3)): 512 KiB on a 32-bit machine (a
    32-bit Raspberry Pi OS), 4 MiB * sizeof(long) on a 64-bit one (32 MiB)."""
    long_size = ctypes.sizeof(ctypes.c_long)
    return 512 * 1024 if long_size == 4 else 4 * 1024 * 1024 * long_size


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
