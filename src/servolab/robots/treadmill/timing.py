"""How well a run kept up with its camera, from each frame's capture stamp, its number in the
camera's sequence and the time it was handled: what a lab checks before it trusts a run's
numbers.

Why numbers and stamps: Listing 1 takes its sampling time from the clock when each frame
arrives and keeps ROS 1's ``header.seq`` as the frame's number. A gap in the numbers is
frames the camera took and the tracker never saw: *dropped* (a queue of one, as Listing 1
subscribes, keeps only the newest). A frame handled more than ``late_after`` seconds after
its capture is *late*: its command reaches the ball that much after the fly moved.

A ROS 2 header has no ``seq``. servolab's own camera node says each frame's number
(:meth:`~.camera_node.CameraNode.sequence_at`); for another driver's frames the number is
read from the stamps (:func:`sequence_of`): frame ``k`` is the one captured ``k`` nominal
frame periods after the first, rounded, and always one more than the frame before. A camera
whose real rate is not its nominal one, or whose stamps jitter by half a period, then shows
false drops: say the camera's true rate in the rig file.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import RobotValueError

FloatArray = npt.NDArray[np.float64]


def sequence_of(stamp: float, first: float, frame_rate: float, previous: int = -1) -> int:
    """The camera's frame number of a frame captured at ``stamp`` (s), counted from the frame
    captured at ``first`` (see the module docstring); at least one more than the frame before
    (``previous``), since two frames are never one, however late the first was stamped."""
    return max(previous + 1, round((stamp - first) * frame_rate))


def sequences_of(stamps: npt.ArrayLike, frame_rate: float) -> npt.NDArray[np.int64]:
    """:func:`sequence_of` for each of a run's stamps, in order."""
    t = np.asarray(stamps, dtype=np.float64)
    out = np.empty(t.size, dtype=np.int64)
    previous = -1
    for k, stamp in enumerate(t):
        previous = out[k] = sequence_of(float(stamp), float(t[0]), frame_rate, previous)
    return out


def frame_timing(stamps: npt.ArrayLike, handled: npt.ArrayLike,
                 sequences: npt.ArrayLike | None = None, *, frame_rate: float,
                 late_after: float) -> dict[str, Any]:
    """The run's frame timing: frames handled, achieved rate, the interval between handled
    frames (median, 99th percentile, largest: ms), the latency from capture to handling (ms),
    late and dropped frames. ``stamps`` are capture times and ``handled`` the times each frame
    was taken up, both seconds on one clock; ``sequences`` the frames' numbers in the camera's
    sequence (None: read from the stamps, :func:`sequences_of`); ``frame_rate`` is the
    camera's nominal rate."""
    t = np.asarray(stamps, dtype=np.float64)
    h = np.asarray(handled, dtype=np.float64)
    if t.shape != h.shape or t.ndim != 1:
        raise RobotValueError(f"stamps {t.shape} and handled {h.shape} must be one value per frame")
    if sequences is not None and np.shape(sequences) != t.shape:
        raise RobotValueError(f"sequences {np.shape(sequences)} must be one value per frame")
    count = int(t.size)
    out: dict[str, Any] = {"frames": count, "camera_frame_rate_hz": frame_rate,
                           "late_after_ms": late_after * 1000.0}
    nan = math.nan
    if count == 0:
        return out | {"achieved_fps": nan, "interval_ms": {"p50": nan, "p99": nan, "max": nan},
                      "latency_ms": {"p50": nan, "p99": nan, "max": nan},
                      "late_frames": 0, "dropped_frames": 0, "camera_frames": 0}
    sequence = (sequences_of(t, frame_rate) if sequences is None
                else np.asarray(sequences, dtype=np.int64))
    camera_frames = int(sequence[-1] - sequence[0]) + 1
    dropped = camera_frames - count
    latency = (h - t) * 1000.0
    intervals = np.diff(h) * 1000.0
    span = float(h[-1] - h[0])
    return out | {
        "achieved_fps": (count - 1) / span if count > 1 and span > 0 else nan,
        "interval_ms": _spread(intervals),
        "latency_ms": _spread(latency),
        "late_frames": int(np.sum(latency > late_after * 1000.0)),
        "dropped_frames": dropped,
        "camera_frames": camera_frames,
    }


def _spread(values: FloatArray) -> dict[str, float]:
    if values.size == 0:
        return {"p50": math.nan, "p99": math.nan, "max": math.nan}
    return {"p50": float(np.percentile(values, 50)), "p99": float(np.percentile(values, 99)),
            "max": float(np.max(values))}


def lost_fly_warning(found_share: float, lost_fly_share: float) -> str | None:
    """The warning a run ends with when the fly was not found in more than
    ``lost_fly_share`` of its frames (the rig's ``run.lost_fly_share``), or None."""
    if not math.isfinite(found_share) or 1.0 - found_share <= lost_fly_share:
        return None
    return (f"the fly was found in only {found_share:.0%} of the frames (lost in more than "
            f"run.lost_fly_share {lost_fly_share:.0%}): check the tracker's threshold, "
            "polarity and roi against the overlay (/image_converter/output_video)")
