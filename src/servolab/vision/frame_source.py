"""Frames for the fly tracker, one at a time: a recording for ``servolab flyball --frames
DIR|VIDEO|FILE.bin`` (a folder of images, a video, or Listing 1's raw ``Fly_Image.bin``) or a
live camera for ``--camera INDEX|DEVICE``, handed out through the flyball node's camera
protocol (``camera()`` returns the next frame, or None when the recording has ended) and, with
the frame's time and index, by :meth:`FrameSource.read`.

The tracker (:mod:`servolab.vision.fly_tracker`) was written for the seed's 640 x 376 mono8
frames, so every frame is made mono8 here and its size is checked, never changed: a frame that
was resized would still be tracked, but at the wrong pixel scale (seed 002, section 3.2: 38.4
px/mm), and the stage would be driven by the wrong distances without any sign of it. Colour is
converted rather than refused because cameras and video codecs commonly save grey scenes as BGR;
16-bit and float frames are refused because mapping them to 0..255 needs a choice (a shift? a
stretch?) that the threshold of 50 depends on, and which the user, not this module, must make.

Each :class:`Frame` carries its ``stamp``, the capture time in the source's own time base
(seconds, None when the source has none), and its ``sequence``, the source's own index of it:
the controller divides by the time between frames, and a frame the source skipped shows as a
jump in ``sequence`` instead of passing unnoticed. :attr:`FrameSource.stamps` says where the
stamps come from:

- a video (:data:`STAMPS_VIDEO_MSEC`): the frame's presentation time in its container,
  ``CAP_PROP_POS_MSEC`` read just after the frame was decoded (OpenCV's FFmpeg backend then
  reports that frame's time, relative to the stream's start); when the backend gives none (0
  for every frame), the index over ``CAP_PROP_FPS`` (:data:`STAMPS_VIDEO_RATE`);
- a live camera (:data:`STAMPS_CAMERA_CLOCK`): a clock of the caller's (``time.monotonic``
  unless told) read when ``grab()`` returned, see :meth:`FrameSource.open_camera`;
- a folder of images or a ``.bin``: None, their files hold no time; their rate is given
  elsewhere (``--fps``, else Listing 3's 66 frames/s).

Every unusable input raises :class:`FrameSourceError`, one line that names the file (or the
video and its frame index, or the camera) and what is wrong, so that the ``servolab`` command
can print it as is.
"""

from __future__ import annotations

import io
import math
import os
import re
import threading
import time
from abc import ABC, abstractmethod
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any, Self

import cv2
import numpy as np
import numpy.typing as npt

from .errors import VisionValueError

Image = npt.NDArray[np.uint8]

#: The suffixes of a folder's files that are frames (compared case-insensitively); anything else
#: in the folder (a notes.txt, a timestamps.csv) is left alone rather than refused, since
#: recordings often carry such companions.
IMAGE_SUFFIXES = frozenset({".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm"})

#: The suffix of Listing 1's raw frame file (``Fly_Image_Mar_28.bin``), compared
#: case-insensitively: headerless mono8 frames, ``height`` rows of ``width`` bytes each.
RAW_SUFFIX = ".bin"

#: Listing 1's frames: width x height (seed 002, section 3.2).
DEFAULT_SIZE = (640, 376)

#: :attr:`FrameSource.stamps` of a video whose backend reports each frame's time.
STAMPS_VIDEO_MSEC = "video CAP_PROP_POS_MSEC"
#: :attr:`FrameSource.stamps` of a video whose backend does not: frame index / frame rate.
STAMPS_VIDEO_RATE = "video frame index / CAP_PROP_FPS"
#: :attr:`FrameSource.stamps` of a live camera: the caller's clock when ``grab()`` returned.
STAMPS_CAMERA_CLOCK = "camera clock"

_DIGITS = re.compile(r"(\d+)")


class FrameSourceError(VisionValueError):
    """A recording that cannot be tracked: missing, empty, unreadable, or a frame of the wrong
    kind or size; or a camera that cannot be opened. ``str(error)`` is one line starting with
    the file (or camera) at fault."""


@dataclass(frozen=True, eq=False)
class Frame:
    """One frame and where it sits in its source (see the module docstring).

    ``eq=False``: frames compare and hash by identity, since the generated ``==`` would compare
    the images element-wise and fail ("the truth value of an array is ambiguous").
    """

    #: The frame, mono8, ``size[1]`` rows of ``size[0]`` pixels.
    image: Image
    #: Capture time in seconds in the source's own time base (:attr:`FrameSource.stamps`);
    #: None when the source has none (a folder, a ``.bin``).
    stamp: float | None
    #: The source's index of the frame: a video's ``CAP_PROP_POS_FRAMES`` before it was read,
    #: a folder's or ``.bin``'s index of the file or frame, a camera's count of frames grabbed
    #: before it; all from 0.
    sequence: int
    #: What errors call it: the image file, or "<video> frame 12", "camera 0 frame 12".
    name: str


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


def _checked_size(size: tuple[int, int]) -> tuple[int, int]:
    if (not isinstance(size, tuple) or len(size) != 2
            or not all(isinstance(v, int) and not isinstance(v, bool) and v > 0 for v in size)):
        raise VisionValueError(f"size must be (width, height), two integers > 0, got {size!r}")
    return size


def _rate(fps: float) -> float | None:
    """A capture's ``CAP_PROP_FPS`` as a rate, None for what backends report when they do not
    know (0, -1, NaN) or nonsense (a container claiming 90000 frames/s, its time base)."""
    return float(fps) if math.isfinite(fps) and 0 < fps <= 10_000 else None


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
    """Frames of a recording or a camera, one at a time, as mono8 arrays of the expected size.

    Make one with :meth:`open` (a recording) or :meth:`open_camera`; call it for the next
    image (None at the end), as the flyball node calls its camera, or :meth:`read` it for the
    image with its time and index. The first frame (a video's first two, to tell where its
    stamps come from) is read when the source is made, so a recording or camera that is
    unusable from its start is refused before any node or bus is set up. Once the end has been
    returned, every later call returns None too.
    """

    def __init__(self, label: str, size: tuple[int, int], path: Path | None = None) -> None:
        #: The recording's file or folder, or a camera's device path; None for a camera given
        #: by index (or a URL).
        self.path = path
        #: What errors name the source by: its path, or "camera 0".
        self.label = label
        self.size = size
        #: Which file, or which frame of the video, the last frame returned came from ("" before
        #: the first), so that a later error (the tracker's, the log's) can point at it.
        self.name_of_last = ""
        #: Where :attr:`Frame.stamp` comes from (:data:`STAMPS_VIDEO_MSEC`,
        #: :data:`STAMPS_VIDEO_RATE`, :data:`STAMPS_CAMERA_CLOCK`), None when frames have no
        #: stamp and the rate must be given elsewhere.
        self.stamps: str | None = None
        self._pending: deque[Frame] = deque()
        self._closed = False
        self._ended = False

    @property
    def frame_rate(self) -> float | None:
        """Frames a second the source says it delivers (a video's or camera's
        ``CAP_PROP_FPS``), None when it does not say (a folder of images, a ``.bin``, a
        container or driver without it)."""
        return None

    @classmethod
    def open(cls, path: str | Path, *, size: tuple[int, int] = DEFAULT_SIZE) -> FrameSource:
        """A folder of images (in natural name order), Listing 1's raw frame file (a ``.bin``
        of ``size`` frames) or a video file, by what ``path`` is.

        ``size`` is (width, height). Raises :class:`FrameSourceError` for a path that does not
        exist, a folder without images, a ``.bin`` that is not a whole number of frames, a
        video OpenCV cannot open, or a first frame that is not usable. Cameras are not opened
        here (a ``/dev/video0`` is refused, pointing at ``--camera``): use :meth:`open_camera`.
        """
        size = _checked_size(size)
        p = Path(path)
        source: FrameSource
        if p.is_dir():
            source = _FolderSource(p, size)
        elif p.is_file() and p.suffix.lower() == RAW_SUFFIX:
            source = _RawSource(p, size)
        elif p.is_file():
            source = _VideoSource(p, size)
        elif p.is_char_device():
            raise FrameSourceError(f"{p}: a device, not a recording; open it as a camera "
                                   f"(--camera {p})")
        elif p.exists():
            raise FrameSourceError(f"{p}: neither a folder of images nor a video or .bin file")
        else:
            raise FrameSourceError(f"{p}: no such file or folder")
        return source._started()

    @classmethod
    def open_camera(cls, device: int | str | os.PathLike[str], *,
                    size: tuple[int, int] = DEFAULT_SIZE,
                    clock: Callable[[], float] = time.monotonic) -> FrameSource:
        """A live camera through ``cv2.VideoCapture(device)``: an index (``0``, or the text
        ``"0"`` as a command line gives it) or a device path (``/dev/video0``); any other path
        OpenCV opens works as well, so a video file can stand in for the camera (tests, or
        replaying a recording as if live).

        The camera is asked for ``size`` but its frames are checked, not resized, as a
        recording's are: a camera that cannot deliver ``size`` is refused at the first frame,
        naming both sizes. ``len()`` is 0 (a camera has no known length); :attr:`frame_rate`
        is its ``CAP_PROP_FPS`` if the driver says one. A camera that stops delivering (its
        ``grab()`` or ``retrieve()`` fails: unplugged, the stream stopped, the stand-in video
        at its end) ends the source: :meth:`read` returns None from then on, as at the end of
        a recording, so a run ends rather than hangs.

        Each frame's stamp is ``clock()`` read as soon as ``grab()`` returned, i.e. when the
        frame reached this process (:data:`STAMPS_CAMERA_CLOCK`), not ``CAP_PROP_POS_MSEC``:
        for live devices that is whatever the backend has (0 from some V4L2 drivers, a buffer
        timestamp in a driver-dependent base from others, a stream time elsewhere) and
        cannot be compared with the times the rest of the program keeps (motor commands,
        logs), which use the same ``clock``. The cost is the delivery latency (exposure to
        ``grab()``: transfer and the driver's queue), about constant for a camera read at its
        rate. The thesis's Point Grey camera was read through its own ROS driver (Listing 3);
        a camera that is not a V4L2 (UVC) device is not seen by the opencv-python wheels,
        whose camera backend on Linux is V4L2: record it with its own tools and replay the
        recording with :meth:`open`.

        Read it from one thread at a time (a reader thread, since ``grab()`` waits for the
        next frame); :meth:`close` may come from another thread and waits for a ``grab()`` in
        progress, after which reads return None.

        Raises :class:`FrameSourceError`, one line naming the device and what to check
        (``v4l2-ctl --list-devices``, the ``video`` group), if it cannot be opened or gives no
        first frame.
        """
        size = _checked_size(size)
        if isinstance(device, bool) or (isinstance(device, int) and device < 0):
            raise VisionValueError(
                f"camera index must be an integer >= 0 (N of /dev/videoN), got {device!r}")
        if not isinstance(device, int):
            device = os.fspath(device)
            if re.fullmatch(r"\d+", device, re.ASCII):
                device = int(device)  # "0" from a command line is the index, not a file "0"
        return _CameraSource(device, size, clock)._started()

    def read(self) -> Frame | None:
        """The next frame with its stamp and sequence, or None once the source has ended (or
        is closed)."""
        if self._closed or self._ended:
            return None
        try:
            frame: Frame | None = self._pending.popleft()
        except IndexError:  # (not a test first: close() may empty it from another thread)
            frame = self._read()
        if frame is None:
            self._ended = True
            return None
        self.name_of_last = frame.name
        return frame

    def __call__(self) -> Image | None:
        """The next frame's image, or None once the source has ended (or is closed): the
        flyball node's camera protocol."""
        frame = self.read()
        return None if frame is None else frame.image

    @abstractmethod
    def __len__(self) -> int:
        """The number of frames: exact for a folder or a ``.bin``; for a video, what its
        container claims (``CAP_PROP_FRAME_COUNT``), which can be off or 0 when unknown; 0
        (unknown, endless) for a camera."""

    def __bool__(self) -> bool:
        """Always true: a video or camera whose length is unknown (``len() == 0``) still has
        frames, and ``if source:`` must not say otherwise."""
        return True

    def close(self) -> None:
        """Release the video, camera or file (a no-op for a folder); later calls return
        None."""
        self._closed = True
        self._pending.clear()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def _started(self) -> Self:
        """The source with its first frame(s) read, or closed and the error raised."""
        try:
            self._start()
        except BaseException:
            self.close()
            raise
        return self

    def _start(self) -> None:
        """Read the first frame ahead, refusing a source without one."""
        frame = self._read()
        if frame is None:
            raise FrameSourceError(self._empty_message())
        self._pending.append(frame)

    @abstractmethod
    def _read(self) -> Frame | None:
        """The next frame, None at the end."""

    @abstractmethod
    def _empty_message(self) -> str:
        """Why a source without a single frame is refused (one line)."""


class _FolderSource(FrameSource):
    """A folder whose image files are the frames, in natural name order."""

    def __init__(self, path: Path, size: tuple[int, int]) -> None:
        super().__init__(str(path), size, path)
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

    def _start(self) -> None:
        super()._start()
        self.check_all()

    def _read(self) -> Frame | None:
        if self._next >= len(self.files):
            return None
        index, file = self._next, self.files[self._next]
        self._next += 1
        return Frame(self._load(file), None, index, str(file))

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


class _RawSource(FrameSource):
    """Listing 1's frame file: every frame's bytes as the tracker got them,
    ``OutFile.write((char *)im.data, width*height*sizeof(uchar))`` (seed 002, Listing 1, in
    ``imageCb``; the file opened in ``save_init``), with no header, no stamp and no size.

    Read a frame at a time from the file, not mapped or loaded whole: a run is 240 640 bytes a
    frame at 66 frames/s, gigabytes in minutes. The size must be given (``size``) since the
    file does not say it; a file that is not a whole number of such frames is refused, as the
    likeliest sign of a wrong size.
    """

    def __init__(self, path: Path, size: tuple[int, int]) -> None:
        super().__init__(str(path), size, path)
        self._frame_bytes = size[0] * size[1]
        try:
            file_size = path.stat().st_size
        except OSError as exc:
            raise FrameSourceError(f"{path}: cannot read it ({exc.strerror})") from None
        count, rest = divmod(file_size, self._frame_bytes)
        if rest:
            raise FrameSourceError(
                f"{path}: {file_size} bytes is not a whole number of {_size_text(size)} mono8 "
                f"frames ({self._frame_bytes} bytes each, {rest} bytes left over); pass the "
                f"size the frames were written at (e.g. --size {_size_text(DEFAULT_SIZE)}, "
                "Listing 1's)")
        self._count = count
        self._next = 0
        try:
            self._file: io.BufferedReader | None = open(path, "rb")  # noqa: SIM115 (closed by close())
        except OSError as exc:
            raise FrameSourceError(f"{path}: cannot read it ({exc.strerror})") from None

    def __len__(self) -> int:
        return self._count

    def _empty_message(self) -> str:
        return f"{self.path}: empty (0 bytes), no frames in it"

    def _read(self) -> Frame | None:
        if self._file is None:
            return None
        where = f"{self.path} frame {self._next}"
        image = np.empty((self.size[1], self.size[0]), np.uint8)
        try:
            got = self._file.readinto(image.data.cast("B"))
        except OSError as exc:
            raise FrameSourceError(f"{where}: cannot read it ({exc.strerror})") from None
        if got == 0:
            return None
        if got < self._frame_bytes:
            raise FrameSourceError(
                f"{where}: only {got} of its {self._frame_bytes} bytes are in the file (it was "
                "cut short while it was read)")
        frame = Frame(image, None, self._next, where)
        self._next += 1
        return frame

    def close(self) -> None:
        super().close()
        if self._file is not None:
            self._file.close()
            self._file = None


class _VideoSource(FrameSource):
    """A video file read with ``cv2.VideoCapture``; frames are named by their index from 0."""

    def __init__(self, path: Path, size: tuple[int, int]) -> None:
        super().__init__(str(path), size, path)
        self.capture = cv2.VideoCapture(str(path))
        if not self.capture.isOpened():
            self.capture.release()
            raise FrameSourceError(
                f"{path}: OpenCV cannot open this video (not a video, or a container or codec "
                "this OpenCV build does not decode)")
        self._next = 0
        count = self.capture.get(cv2.CAP_PROP_FRAME_COUNT)
        # Streams and some containers report -1, 0 or NaN: "unknown", which len() says as 0.
        self._count = int(count) if math.isfinite(count) and count > 0 else 0
        self._fps = _rate(self.capture.get(cv2.CAP_PROP_FPS))
        self._use_msec = False
        self._last_msec: float | None = None

    def __len__(self) -> int:
        return self._count

    @property
    def frame_rate(self) -> float | None:
        return self._fps

    def _empty_message(self) -> str:
        return f"{self.path}: OpenCV opened this video but could not read a frame from it"

    def _decode(self) -> tuple[Image, int, float, str] | None:
        """The next frame, its sequence, ``CAP_PROP_POS_MSEC`` after decoding, and its name."""
        # CAP_PROP_POS_FRAMES is "0-based index of the frame to be decoded/captured next"
        # (OpenCV, VideoCaptureProperties): read before the frame, it is the frame's index.
        position = self.capture.get(cv2.CAP_PROP_POS_FRAMES)
        sequence = (round(position) if math.isfinite(position) and position >= 0
                    else self._next)
        ok, image = self.capture.read()
        if not ok or image is None:
            return None
        # After the read, the FFmpeg backend's CAP_PROP_POS_MSEC is the decoded frame's
        # presentation time (before it, the previous frame's).
        msec = float(self.capture.get(cv2.CAP_PROP_POS_MSEC))
        self._next = sequence + 1
        where = f"{self.path} frame {sequence}"
        return _to_mono8(np.asarray(image), where, self.size), sequence, msec, where

    def _start(self) -> None:
        """Read the first two frames ahead and decide where stamps come from: from
        ``CAP_PROP_POS_MSEC`` if the first is a time (>= 0) and the second a later one, since a
        backend without times reports 0 for every frame; else from the index and the rate.
        Deciding once keeps every frame of a video in one time base."""
        first = self._decode()
        if first is None:
            raise FrameSourceError(self._empty_message())
        second = self._decode()
        msec0 = first[2]
        self._use_msec = math.isfinite(msec0) and msec0 >= 0 and (
            second is None or (math.isfinite(second[2]) and second[2] > msec0))
        if self._use_msec:
            self.stamps = STAMPS_VIDEO_MSEC
        elif self._fps is not None:
            self.stamps = STAMPS_VIDEO_RATE
        for decoded in (first, second):
            if decoded is not None:
                self._pending.append(self._frame(*decoded))

    def _read(self) -> Frame | None:
        decoded = self._decode()
        return None if decoded is None else self._frame(*decoded)

    def _frame(self, image: Image, sequence: int, msec: float, where: str) -> Frame:
        stamp: float | None = None
        if self._use_msec:
            if not math.isfinite(msec) or (self._last_msec is not None
                                           and msec <= self._last_msec):
                raise FrameSourceError(
                    f"{where}: its time (CAP_PROP_POS_MSEC) is {msec:g} ms, not after the "
                    f"previous frame's {self._last_msec:g} ms; the video's timestamps are "
                    "broken: remux it (ffmpeg -i IN -c copy OUT.mkv) or convert it to a "
                    "folder of images and give its rate")
            self._last_msec = msec
            stamp = msec / 1000.0
        elif self._fps is not None:
            stamp = sequence / self._fps
        return Frame(image, stamp, sequence, where)

    def close(self) -> None:
        super().close()
        self.capture.release()


def _camera_open_message(device: int | str) -> str:
    """Why the camera did not open, as far as can be told, and what to check (one line)."""
    label = f"camera {device}"
    listing = "list the cameras with `v4l2-ctl --list-devices`"
    if isinstance(device, str) and "://" not in device:
        path = Path(device)
        if not path.exists():
            return (f"{label}: no such device or file; {listing} and pass its /dev/videoN or "
                    "its index N")
        if not os.access(path, os.R_OK):
            return (f"{label}: permission denied; add yourself to the 'video' group (sudo "
                    f"usermod -aG video $USER, then log in again) or check `ls -l {device}`")
    return (f"{label}: OpenCV cannot open it; {listing} and check the index or device, that "
            "no other program is using it, and that you may read it (the 'video' group: sudo "
            "usermod -aG video $USER, then log in again)")


class _CameraSource(FrameSource):
    """A live camera, or any capture OpenCV opens standing in for one: see
    :meth:`FrameSource.open_camera`."""

    def __init__(self, device: int | str, size: tuple[int, int],
                 clock: Callable[[], float]) -> None:
        super().__init__(f"camera {device}", size,
                         None if isinstance(device, int) or "://" in device else Path(device))
        self.device = device
        self._clock = clock
        self.stamps = STAMPS_CAMERA_CLOCK
        self._grabbed = 0
        # A live camera is read on a thread of its own (the grab waits for the next frame)
        # and closed from another: the lock keeps release() from freeing the capture under a
        # grab() in progress, which OpenCV does not guard against.
        self._lock = threading.Lock()
        self.capture = cv2.VideoCapture(device)
        if not self.capture.isOpened():
            self.capture.release()
            raise FrameSourceError(_camera_open_message(device))
        # Ask for the expected size: a V4L2 camera starts in its default mode (often 640x480),
        # and may have the one wanted. Whether it took is for the first frame's check to say;
        # a file standing in for the camera ignores the request.
        self.capture.set(cv2.CAP_PROP_FRAME_WIDTH, size[0])
        self.capture.set(cv2.CAP_PROP_FRAME_HEIGHT, size[1])
        self._fps = _rate(self.capture.get(cv2.CAP_PROP_FPS))

    def __len__(self) -> int:
        return 0

    @property
    def frame_rate(self) -> float | None:
        return self._fps

    def _empty_message(self) -> str:
        return (f"{self.label}: opened, but it delivered no frame; check that no other program "
                "is using it and that it streams (`v4l2-ctl --list-devices`, then "
                "`v4l2-ctl -d /dev/videoN --stream-mmap --stream-count=1`)")

    def _read(self) -> Frame | None:
        with self._lock:
            if self._closed:
                return None
            ok = self.capture.grab()
            stamp = float(self._clock())  # the frame has just arrived: see open_camera
            if not ok:
                return None
            ok, image = self.capture.retrieve()
        if not ok or image is None:
            return None
        sequence = self._grabbed
        self._grabbed += 1
        where = f"{self.label} frame {sequence}"
        return Frame(_to_mono8(np.asarray(image), where, self.size), stamp, sequence, where)

    def close(self) -> None:
        """Safe from another thread than the reader's: waits for a grab() in progress."""
        super().close()
        with self._lock:
            self.capture.release()
