"""The frames a run tracked, written as they come (``servolab flyball --record-video PATH``), in
a form :class:`~servolab.vision.frame_source.FrameSource` reads back, so that a run on the rig
can be replayed and tracked again.

The suffix of the path chooses the format:

- ``.bin``: Listing 1's raw frame file (seed 002, ``OutFile.write((char *)im.data,
  width*height*sizeof(uchar))`` in ``imageCb``): every frame's bytes, ``height`` rows of
  ``width``, no header. Exact, and what the thesis's own analysis read; but the file holds
  neither the size nor the rate, which must be given to the reader (``--size``, ``--fps``).
- ``.avi``: ``cv2.VideoWriter`` with FFV1, FFmpeg's lossless intra-frame codec, which the
  opencv-python(-headless) wheels' bundled FFmpeg writes and reads (checked by
  ``tests/vision/test_frame_writer.py``). Smaller than ``.bin`` by what the sensor noise
  allows (a dark 640x376 frame with a bright blob: 0.4 % of the bytes without noise, 42 % with
  noise of 2 levels, 65 % with 8), and the rate is kept. If a build lacks FFV1, MJPG is used
  instead, and :attr:`FrameWriter.note` says that it is lossy (pixels off by tens of levels
  near edges, which moves a threshold-of-50 contour).
- ``.mp4``: MPEG-4 part 2 (``mp4v``), the one MP4 codec the wheels write; lossy, for looking
  at, not for tracking again.

Video codecs here store even sizes only (OpenCV's FFmpeg writer drops an odd last row or
column without a word, and the reader would then refuse every frame), so an odd size is refused
for ``.avi`` and ``.mp4`` when the writer is opened.

Errors are :class:`FrameWriterError`, one line naming the file and what to do.
"""

from __future__ import annotations

import io
import math
import os
from pathlib import Path
from types import TracebackType
from typing import Any, Self

import cv2
import numpy as np

from .errors import VisionValueError
from .frame_source import RAW_SUFFIX

#: The codecs tried for ``.avi``, in order, each with whether it is lossless: FFV1 if the
#: build has it, else MJPG, which every OpenCV build writes (its own encoder) but is lossy.
AVI_CODECS: tuple[tuple[str, bool], ...] = (("FFV1", True), ("MJPG", False))
#: The codecs tried for ``.mp4``; MPEG-4 part 2 is lossy (H.264 is not in the wheels).
MP4_CODECS: tuple[tuple[str, bool], ...] = (("mp4v", False),)

#: The suffixes :meth:`FrameWriter.open` knows (compared case-insensitively).
SUFFIXES = (RAW_SUFFIX, ".avi", ".mp4")


class FrameWriterError(VisionValueError):
    """A recording that cannot be written: an unknown suffix, a file or codec that cannot be
    opened, a frame of the wrong kind. ``str(error)`` is one line starting with the file."""


def _size_text(size: tuple[int, int]) -> str:
    return f"{size[0]}x{size[1]}"


class FrameWriter:
    """Writes mono8 frames of one size to a ``.bin``, ``.avi`` or ``.mp4`` file, one per
    :meth:`write` (see the module docstring for the formats). Make one with :meth:`open`; use
    it as a context manager, or :meth:`close` it, so that a video's index is written (an
    ``.avi`` left unclosed may not play; a ``.bin`` is flushed at every frame and survives a
    kill whole up to the frame being written).
    """

    def __init__(self, path: Path, size: tuple[int, int], fps: float, codec: str,
                 lossless: bool, *, file: io.BufferedWriter | None = None,
                 video: cv2.VideoWriter | None = None, note: str | None = None) -> None:
        """Use :meth:`open`; this only keeps what it opened."""
        self.path = path
        #: (width, height) of every frame.
        self.size = size
        #: Frames a second: stored in a video's container; a ``.bin`` has nowhere to keep it.
        self.fps = fps
        #: "raw" for a ``.bin``, else the FourCC written ("FFV1", "MJPG", "mp4v").
        self.codec = codec
        #: Whether frames read back equal the frames written, pixel for pixel.
        self.lossless = lossless
        #: A line for the user when the format is not what was asked for (MJPG instead of
        #: FFV1), else None.
        self.note = note
        #: Frames written so far.
        self.frames = 0
        self._file = file
        self._video = video

    @classmethod
    def open(cls, path: str | Path, size: tuple[int, int], fps: float) -> FrameWriter:
        """A writer of ``size`` (width, height) mono8 frames at ``fps`` frames a second to
        ``path``, in the format its suffix names (``.bin``, ``.avi``, ``.mp4``). An existing
        file is replaced, as Listing 1's ``ios::out`` does.

        Raises :class:`FrameWriterError` for an unknown suffix, a bad size or rate, a folder
        that does not exist or cannot be written in, or a video OpenCV cannot write.
        """
        p = Path(path)
        if (not isinstance(size, tuple) or len(size) != 2
                or not all(isinstance(v, int) and not isinstance(v, bool) and v > 0
                           for v in size)):
            raise FrameWriterError(
                f"{p}: size must be (width, height), two integers > 0, got {size!r}")
        if isinstance(fps, bool) or not isinstance(fps, (int, float)) or not (
                math.isfinite(fps) and fps > 0):
            raise FrameWriterError(f"{p}: fps must be a number of frames a second > 0, "
                                   f"got {fps!r}")
        suffix = p.suffix.lower()
        if suffix not in SUFFIXES:
            raise FrameWriterError(
                f"{p}: unknown suffix {p.suffix!r}; use .bin (Listing 1's raw frames, exact), "
                ".avi (FFV1, lossless) or .mp4 (mp4v, lossy)")
        folder = p.parent
        if not folder.is_dir():
            raise FrameWriterError(f"{p}: the folder {folder} does not exist; create it or "
                                   "record somewhere else")
        if p.is_dir():
            raise FrameWriterError(f"{p}: is a folder; give a file name ending in {suffix}")
        if suffix == RAW_SUFFIX:
            try:
                file = open(p, "wb")  # noqa: SIM115 (closed by close())
            except OSError as exc:
                raise FrameWriterError(f"{p}: cannot write it ({exc.strerror}); check the "
                                       "folder's permissions or record somewhere else") from None
            return cls(p, size, float(fps), "raw", True, file=file)
        if size[0] % 2 or size[1] % 2:
            raise FrameWriterError(
                f"{p}: {_size_text(size)} has an odd side, which OpenCV's video writer drops "
                "(the frames would read back a pixel smaller); record to .bin instead")
        if not os.access(folder, os.W_OK):
            raise FrameWriterError(f"{p}: cannot write in {folder} (permission denied); "
                                   "record somewhere else")
        codecs = AVI_CODECS if suffix == ".avi" else MP4_CODECS
        for codec, lossless in codecs:
            video = cv2.VideoWriter(str(p), cv2.VideoWriter.fourcc(*codec), float(fps), size,
                                    isColor=False)
            if video.isOpened():
                note = None
                if codec != codecs[0][0]:
                    note = (f"{p}: this OpenCV build cannot write {codecs[0][0]}; writing "
                            f"{codec}, which is {'lossless' if lossless else 'lossy'}"
                            f"{'' if lossless else ' (frames will not read back exactly)'}")
                return cls(p, size, float(fps), codec, lossless, video=video, note=note)
            video.release()
        tried = " or ".join(codec for codec, _ in codecs)
        raise FrameWriterError(
            f"{p}: this OpenCV build cannot write {suffix} with {tried}; record to .bin "
            "(Listing 1's raw frames) instead")

    def write(self, image: Any) -> None:
        """Append one frame: a ``size[1]`` x ``size[0]`` uint8 array. Anything else is refused
        rather than converted: a video writer given another size drops the frame silently,
        and a ``.bin`` has no header to tell a reader that the frames changed."""
        where = f"{self.path} frame {self.frames}"
        if self._file is None and self._video is None:
            raise FrameWriterError(f"{where}: written after the writer was closed")
        width, height = self.size
        if not isinstance(image, np.ndarray):
            raise FrameWriterError(f"{where}: got a {type(image).__name__}, expected a "
                                   f"{width}x{height} mono8 numpy array")
        if image.dtype != np.uint8 or image.shape != (height, width):
            shape = "x".join(str(n) for n in image.shape)
            raise FrameWriterError(
                f"{where}: got {image.dtype} of shape {shape}, expected uint8 of shape "
                f"{height}x{width} (mono8, {height} rows of {width} pixels)")
        frame = np.ascontiguousarray(image)
        if self._file is not None:
            try:
                self._file.write(frame.tobytes())
                # A kill keeps every frame written before it (Listing 1's ofstream would not).
                self._file.flush()
            except OSError as exc:
                raise FrameWriterError(f"{where}: cannot write it ({exc.strerror}); free some "
                                       "space or record somewhere else") from None
        elif self._video is not None:
            self._video.write(frame)
        self.frames += 1

    def close(self) -> None:
        """Finish the file (a video's index and trailer); again is a no-op."""
        if self._file is not None:
            self._file.close()
            self._file = None
        if self._video is not None:
            self._video.release()
            self._video = None

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        # Closed also after an error: the frames written so far are a valid recording.
        self.close()
