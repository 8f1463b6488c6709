"""Recorded frames for ``servolab flyball --frames DIR|VIDEO``: a folder of images or a video,
handed out one at a time through the flyball node's camera protocol (``camera()`` returns the
next frame, or None when the recording has ended).

The tracker (:mod:`servolab.vision.fly_tracker`) was written for the seed's 640 x 376 mono8
frames, so every frame is made mono8 here and its size is checked, never changed: a frame that
was resized would still be tracked, but at the wrong pixel scale (seed 002, section 3.2: 38.4
px/mm), and the stage would be driven by the wrong distances without any sign of it. Colour is
converted rather than refused because cameras and video codecs commonly save grey scenes as BGR;
16-bit and float frames are refused because mapping them to 0..255 needs a choice (a shift? a
stretch?) that the threshold of 50 depends on, and which the user, not this module, must make.

Every unusable input raises :class:`FrameSourceError`, one line that names the file (or the
video and its frame index) and what is wrong, so that the ``servolab`` command can print it as
is.
"""

from __future__ import annotations

import math
import re
from abc import ABC, abstractmethod
from pathlib import Path
from types import TracebackType
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from .errors import VisionValueError

Image = npt.NDArray[np.uint8]

#: The suffixes of a folder's files that are frames (compared case-insensitively); anything else
#: in the folder (a notes.txt, a timestamps.csv) is left alone rather than refused, since
#: recordings often carry such companions.
IMAGE_SUFFIXES = frozenset({".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm"})

#: Listing 1's frames: width x height (seed 002, section 3.2).
DEFAULT_SIZE = (640, 376)

_DIGITS = re.compile(r"(\d+)")


class FrameSourceError(VisionValueError):
    """A recording that cannot be tracked: missing, empty, unreadable, or a frame of the wrong
    kind or size. ``str(error)`` is one line starting with the file at fault."""


def natural_key(name: str) -> tuple[tuple[Any, ...], str]:
    """Sort key putting ``frame2`` before ``frame10``: cameras and ``ffmpeg -i %d.png`` number
    frames without leading zeros, and plain string order would then shuffle the recording.

    The text between numbers is compared case-insensitively; the name itself breaks ties, so
    the order is total and the same on every file system.
    """
    parts = _DIGITS.split(name)
    # split() puts text at even indices and digit runs at odd ones, so each position always
    # holds the same type and tuples compare without mixing str and int.
    return tuple(int(p) if i % 2 else p.casefold() for i, p in enumerate(parts)), name


def _size_text(size: tuple[int, int]) -> str:
    return f"{size[0]}x{size[1]}"


def _to_mono8(frame: npt.NDArray[Any], where: str, size: tuple[int, int]) -> Image:
    """The frame as a mono8 array of ``size`` (width, height), or a one-line error naming
    ``where``: see the module docstring for why colour is converted but depth and size are not.
    """
    if frame.dtype != np.uint8:
        raise FrameSourceError(
            f"{where}: frame is {frame.dtype}, expected 8-bit (uint8); convert the recording "
            "to 8-bit grey first (the tracker's threshold is a level in 0..255)")
    if frame.ndim == 3 and frame.shape[2] == 1:
        frame = frame[:, :, 0]
    elif frame.ndim == 3 and frame.shape[2] == 3:
        frame = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
    elif frame.ndim == 3 and frame.shape[2] == 4:
        frame = cv2.cvtColor(frame, cv2.COLOR_BGRA2GRAY)
    elif frame.ndim != 2:
        raise FrameSourceError(
            f"{where}: frame has shape {tuple(frame.shape)}, expected a grey, BGR or BGRA image")
    got = (int(frame.shape[1]), int(frame.shape[0]))
    if got != size:
        raise FrameSourceError(
            f"{where}: frame is {_size_text(got)}, expected {_size_text(size)} "
            "(frames are not resized: the tracker's pixel scale would be wrong)")
    return np.ascontiguousarray(frame, dtype=np.uint8)


class FrameSource(ABC):
    """Frames of a recording, one at a time, as mono8 arrays of the expected size.

    Make one with :meth:`open`; call it for the next frame (None at the end), as the flyball
    node calls its camera. The first frame is read by :meth:`open`, so a recording that is
    unusable from its start is refused before any node or bus is set up.
    """

    def __init__(self, path: Path, size: tuple[int, int]) -> None:
        self.path = path
        self.size = size
        #: Which file, or which frame of the video, the last frame returned came from ("" before
        #: the first), so that a later error (the tracker's, the log's) can point at it.
        self.name_of_last = ""
        self._pending: tuple[Image, str] | None = None
        self._closed = False

    @property
    def frame_rate(self) -> float | None:
        """Frames a second the recording says it was made at (a video's ``CAP_PROP_FPS``),
        None when it does not say (a folder of images, a container without it)."""
        return None

    @classmethod
    def open(cls, path: str | Path, *, size: tuple[int, int] = DEFAULT_SIZE) -> FrameSource:
        """A folder of images (in natural name order) or a video file, by what ``path`` is.

        ``size`` is (width, height). Raises :class:`FrameSourceError` for a path that does not
        exist, a folder without images, a video OpenCV cannot open, or a first frame that is
        not usable.
        """
        if (not isinstance(size, tuple) or len(size) != 2
                or not all(isinstance(v, int) and not isinstance(v, bool) and v > 0
                           for v in size)):
            raise VisionValueError(f"size must be (width, height), two integers > 0, got {size!r}")
        p = Path(path)
        source: FrameSource
        if p.is_dir():
            source = _FolderSource(p, size)
        elif p.is_file():
            source = _VideoSource(p, size)
        elif p.exists():
            raise FrameSourceError(f"{p}: neither a folder of images nor a video file")
        else:
            raise FrameSourceError(f"{p}: no such file or folder")
        try:
            source._pending = source._read()
            if source._pending is None:
                raise FrameSourceError(source._empty_message())
            if isinstance(source, _FolderSource):
                source.check_all()
        except BaseException:
            source.close()
            raise
        return source

    def __call__(self) -> Image | None:
        """The next frame, or None once the recording has ended (or the source is closed)."""
        if self._closed:
            return None
        item = self._pending if self._pending is not None else self._read()
        self._pending = None
        if item is None:
            return None
        frame, self.name_of_last = item
        return frame

    @abstractmethod
    def __len__(self) -> int:
        """The number of frames: exact for a folder; for a video, what its container claims
        (``CAP_PROP_FRAME_COUNT``), which can be off or 0 when unknown."""

    def __bool__(self) -> bool:
        """Always true: a video whose length is unknown (``len() == 0``) still has frames, and
        ``if source:`` must not say otherwise."""
        return True

    def close(self) -> None:
        """Release the video (a no-op for a folder); later calls return None."""
        self._closed = True
        self._pending = None

    def __enter__(self) -> FrameSource:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    @abstractmethod
    def _read(self) -> tuple[Image, str] | None:
        """The next frame and where it came from, None at the end."""

    @abstractmethod
    def _empty_message(self) -> str:
        """Why a recording without a single frame is refused (one line)."""


class _FolderSource(FrameSource):
    """A folder whose image files are the frames, in natural name order."""

    def __init__(self, path: Path, size: tuple[int, int]) -> None:
        super().__init__(path, size)
        try:
            entries = list(path.iterdir())
        except OSError as exc:
            raise FrameSourceError(f"{path}: cannot list the folder ({exc.strerror})") from None
        # Hidden files are skipped: "._frame1.png" from macOS is metadata, not a frame.
        files = [e for e in entries if e.suffix.lower() in IMAGE_SUFFIXES
                 and not e.name.startswith(".") and e.is_file()]
        self.files = sorted(files, key=lambda f: natural_key(f.name))
        self._next = 0

    def __len__(self) -> int:
        return len(self.files)

    def _empty_message(self) -> str:
        kinds = " ".join(sorted(IMAGE_SUFFIXES))
        return f"{self.path}: no image files in this folder (looked for {kinds})"

    def _read(self) -> tuple[Image, str] | None:
        if self._next >= len(self.files):
            return None
        file = self.files[self._next]
        self._next += 1
        return self._load(file), str(file)

    def _load(self, file: Path) -> Image:
        frame = cv2.imread(str(file), cv2.IMREAD_UNCHANGED)
        if frame is None:
            raise FrameSourceError(f"{file}: OpenCV cannot read this image")
        return _to_mono8(np.asarray(frame), str(file), self.size)

    def check_all(self) -> None:
        """Read every frame once and check it, so that a bad file is found before a motor
        turns, not after half the recording was driven (a folder is read twice; a video
        cannot be, and is checked frame by frame as it plays)."""
        for file in self.files[self._next:]:
            self._load(file)


class _VideoSource(FrameSource):
    """A video file read with ``cv2.VideoCapture``; frames are named by their index from 0."""

    def __init__(self, path: Path, size: tuple[int, int]) -> None:
        super().__init__(path, size)
        self.capture = cv2.VideoCapture(str(path))
        if not self.capture.isOpened():
            self.capture.release()
            raise FrameSourceError(
                f"{path}: OpenCV cannot open this video (not a video, or a container or codec "
                "this OpenCV build does not decode)")
        self._index = 0
        count = self.capture.get(cv2.CAP_PROP_FRAME_COUNT)
        # Streams and some containers report -1, 0 or NaN: "unknown", which len() says as 0.
        self._count = int(count) if math.isfinite(count) and count > 0 else 0
        fps = self.capture.get(cv2.CAP_PROP_FPS)
        self._fps = float(fps) if math.isfinite(fps) and 0 < fps <= 10_000 else None

    def __len__(self) -> int:
        return self._count

    @property
    def frame_rate(self) -> float | None:
        return self._fps

    def _empty_message(self) -> str:
        return f"{self.path}: OpenCV opened this video but could not read a frame from it"

    def _read(self) -> tuple[Image, str] | None:
        ok, frame = self.capture.read()
        if not ok or frame is None:
            return None
        where = f"{self.path} frame {self._index}"
        self._index += 1
        return _to_mono8(np.asarray(frame), where, self.size), where

    def close(self) -> None:
        super().close()
        self.capture.release()
