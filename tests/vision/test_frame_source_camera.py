"""Per-frame time and index (:class:`Frame`, :meth:`FrameSource.read`) for videos, and a live
camera (:meth:`FrameSource.open_camera`) with a video file standing in for the device.

Sources for what is expected:

- OpenCV, ``cv::VideoCaptureProperties``
  (https://docs.opencv.org/4.x/d4/d15/group__videoio__flags__base.html):
  ``CAP_PROP_POS_MSEC`` "Current position of the video file in milliseconds",
  ``CAP_PROP_POS_FRAMES`` "0-based index of the frame to be decoded/captured next",
  ``CAP_PROP_FPS`` "Frame rate"; and "Effective behaviour depends from device hardware, driver
  and API Backend", which is why a camera's frames are stamped with our clock instead.
- Seed 002, Listing 3: the rig's camera runs at 66 frames/s and 640x376 (format7 ROI).

The videos are tiny (64x48, FFV1, lossless, so pixels compare exactly) to keep the file fast.
"""

from __future__ import annotations

import dataclasses
import itertools
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest

from servolab.vision.frame_source import (
    STAMPS_CAMERA_CLOCK,
    STAMPS_VIDEO_MSEC,
    STAMPS_VIDEO_RATE,
    Frame,
    FrameSource,
    FrameSourceError,
)
from tests.clirun import one_line

SIZE = (64, 48)
REAL_CAPTURE = cv2.VideoCapture


def numbered(n: int) -> np.ndarray:
    """A frame that says its number: every pixel is 10 * n (and a gradient to be a picture)."""
    frame = np.full((SIZE[1], SIZE[0]), 10 * n, np.uint8)
    frame[:, : SIZE[0] // 2] += np.arange(SIZE[0] // 2, dtype=np.uint8)
    return frame


def write_video(path: Path, count: int, fps: float) -> None:
    """``count`` numbered frames in an FFV1 .avi (lossless: frames read back equal)."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"FFV1"), fps, SIZE,
                             isColor=False)
    assert writer.isOpened(), "FFV1/avi not available in this OpenCV build"
    for n in range(count):
        writer.write(numbered(n))
    writer.release()


def read_all(source: FrameSource) -> list[Frame]:
    frames = []
    while (frame := source.read()) is not None:
        frames.append(frame)
    return frames


@pytest.fixture
def video30(tmp_path: Path) -> Path:
    path = tmp_path / "run30.avi"
    write_video(path, 6, 30.0)
    return path


# -- videos: stamps and sequence -------------------------------------------------------------

def test_a_30_fps_video_gives_stamps_a_30th_of_a_second_apart_from_pos_msec(
        video30: Path) -> None:
    with FrameSource.open(video30, size=SIZE) as source:
        assert source.stamps == STAMPS_VIDEO_MSEC
        assert source.frame_rate == 30.0
        frames = read_all(source)
    assert [f.sequence for f in frames] == [0, 1, 2, 3, 4, 5]
    stamps = [f.stamp for f in frames if f.stamp is not None]
    assert stamps == pytest.approx([n / 30 for n in range(6)], abs=1e-9)
    assert np.diff(stamps) == pytest.approx(np.full(5, 1 / 30), abs=1e-9)
    assert [f.name for f in frames] == [f"{video30} frame {n}" for n in range(6)]
    for n, frame in enumerate(frames):
        np.testing.assert_array_equal(frame.image, numbered(n))


def test_call_and_read_share_one_stream(video30: Path) -> None:
    """``source()`` (the node's camera protocol) still hands out images, and ``read()`` goes on
    from where it left off."""
    with FrameSource.open(video30, size=SIZE) as source:
        image = source()
        assert isinstance(image, np.ndarray)
        np.testing.assert_array_equal(image, numbered(0))
        frame = source.read()
        assert frame is not None and frame.sequence == 1
        assert source.name_of_last == f"{video30} frame 1"


def test_a_frame_is_frozen_and_compares_by_identity(video30: Path) -> None:
    with FrameSource.open(video30, size=SIZE) as source:
        frame = source.read()
    assert frame is not None
    with pytest.raises(dataclasses.FrozenInstanceError):
        frame.stamp = 1.0  # type: ignore[misc]
    assert frame == frame and hash(frame) == hash(frame)  # no element-wise array compare


class _Capture:
    """A real capture whose ``CAP_PROP_POS_MSEC`` is replaced by ``msec(frames_read)``, for the
    backends that do not report times (or report broken ones)."""

    msec: Any = None

    def __init__(self, *args: Any) -> None:
        self._capture = REAL_CAPTURE(*args)

    def get(self, prop: int) -> float:
        if prop == cv2.CAP_PROP_POS_MSEC:
            return float(type(self).msec(int(self._capture.get(cv2.CAP_PROP_POS_FRAMES))))
        return float(self._capture.get(prop))

    def __getattr__(self, name: str) -> Any:
        return getattr(self._capture, name)


def test_a_video_without_times_is_stamped_by_index_over_its_rate(
        video30: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    class NoTimes(_Capture):
        msec = staticmethod(lambda frames_read: 0.0)  # what a backend without times says

    monkeypatch.setattr(cv2, "VideoCapture", NoTimes)
    with FrameSource.open(video30, size=SIZE) as source:
        assert source.stamps == STAMPS_VIDEO_RATE
        frames = read_all(source)
    assert [f.stamp for f in frames] == pytest.approx([n / 30 for n in range(6)])
    assert [f.sequence for f in frames] == list(range(6))


def test_a_video_whose_time_goes_back_is_refused_naming_the_frame(
        video30: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    class Broken(_Capture):
        # after frame k is read, k + 1 frames were read; frame 3 claims 10 ms
        msec = staticmethod(lambda frames_read: 10.0 if frames_read == 4
                            else (frames_read - 1) * 1000 / 30)

    monkeypatch.setattr(cv2, "VideoCapture", Broken)
    with FrameSource.open(video30, size=SIZE) as source:
        assert source.stamps == STAMPS_VIDEO_MSEC
        assert [source.read() is not None for _ in range(3)] == [True] * 3
        with pytest.raises(FrameSourceError) as error:
            source.read()
    text = one_line(error)
    assert text.startswith(f"{video30} frame 3:") and "CAP_PROP_POS_MSEC" in text
    assert "10 ms" in text and "66.6667 ms" in text


def test_a_folder_has_no_stamps_but_a_sequence(tmp_path: Path) -> None:
    for n in range(3):
        assert cv2.imwrite(str(tmp_path / f"f{n + 1}.png"), numbered(n))
    with FrameSource.open(tmp_path, size=SIZE) as source:
        assert source.stamps is None and source.frame_rate is None
        frames = read_all(source)
    assert [(f.stamp, f.sequence) for f in frames] == [(None, 0), (None, 1), (None, 2)]
    assert frames[2].name == str(tmp_path / "f3.png")


# -- cameras -----------------------------------------------------------------------------------

def test_a_video_standing_in_for_a_camera_gives_clock_stamps_and_a_grab_count(
        video30: Path) -> None:
    ticks = itertools.count(100.0, 0.25)
    with FrameSource.open_camera(video30, size=SIZE, clock=lambda: next(ticks)) as camera:
        assert len(camera) == 0 and bool(camera)  # unknown length, endless
        assert camera.stamps == STAMPS_CAMERA_CLOCK
        assert camera.frame_rate == 30.0  # CAP_PROP_FPS
        assert camera.label == f"camera {video30}"
        frames = read_all(camera)
        assert camera.read() is None and camera() is None  # stays ended
    assert [f.sequence for f in frames] == list(range(6))
    assert [f.stamp for f in frames] == [100.0 + 0.25 * n for n in range(6)]
    assert frames[4].name == f"camera {video30} frame 4"
    for n, frame in enumerate(frames):
        np.testing.assert_array_equal(frame.image, numbered(n))


def test_camera_stamps_from_the_default_clock_are_monotonic(video30: Path) -> None:
    with FrameSource.open_camera(str(video30), size=SIZE) as camera:
        frames = read_all(camera)
    stamps = [f.stamp for f in frames if isinstance(f.stamp, float)]
    assert len(stamps) == 6
    assert stamps == sorted(stamps)  # time.monotonic never goes back


def test_a_camera_of_the_wrong_size_is_refused_at_open(video30: Path) -> None:
    with pytest.raises(FrameSourceError) as error:
        FrameSource.open_camera(video30)  # Listing 3's 640x376 expected
    text = one_line(error)
    assert text.startswith(f"camera {video30} frame 0:")
    assert "64x48" in text and "640x376" in text


def test_a_missing_camera_device_is_refused_saying_what_to_do(tmp_path: Path) -> None:
    device = str(tmp_path / "video7")
    with pytest.raises(FrameSourceError) as error:
        FrameSource.open_camera(device)
    text = one_line(error)
    assert text.startswith(f"camera {device}: no such device")
    assert "v4l2-ctl --list-devices" in text


def test_a_camera_index_that_does_not_open_is_refused_saying_what_to_do(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The index as a command line gives it ("7") is an index, not a file called 7."""
    opened: list[Any] = []

    class Nothing:
        def __init__(self, device: Any) -> None:
            opened.append(device)

        def isOpened(self) -> bool:  # OpenCV's name
            return False

        def release(self) -> None:
            pass

    monkeypatch.setattr(cv2, "VideoCapture", Nothing)
    with pytest.raises(FrameSourceError) as error:
        FrameSource.open_camera("7")
    assert opened == [7]
    text = one_line(error)
    assert text.startswith("camera 7: OpenCV cannot open it")
    assert "v4l2-ctl --list-devices" in text and "video' group" in text


def test_a_real_index_without_a_camera_is_refused() -> None:
    """No camera at index 63 on a test machine: OpenCV itself fails to open it."""
    with pytest.raises(FrameSourceError) as error:
        FrameSource.open_camera(63)
    assert one_line(error).startswith("camera 63: ")


def test_a_bad_camera_index_or_size_is_refused() -> None:
    with pytest.raises(ValueError, match="index"):
        FrameSource.open_camera(-1)
    with pytest.raises(ValueError, match="size"):
        FrameSource.open_camera(0, size=(640, 0))


def test_a_device_given_as_a_recording_is_refused_pointing_at_the_camera_option() -> None:
    device = Path("/dev/null")  # a character device on every POSIX system
    if not device.is_char_device():
        pytest.skip("no /dev/null character device here")
    with pytest.raises(FrameSourceError) as error:
        FrameSource.open(device)
    assert one_line(error) == "/dev/null: a device, not a recording; open it as a camera " \
                              "(--camera /dev/null)"


def test_a_camera_closed_from_another_thread_ends_its_reader(video30: Path) -> None:
    """The flyball node reads a live camera on a thread of its own and closes it from the
    main one; a close while the reader grabs must end the reader, not crash OpenCV."""
    import threading

    camera = FrameSource.open_camera(video30, size=SIZE)
    got: list[Frame] = []
    first = threading.Event()

    def reader() -> None:
        while (frame := camera.read()) is not None:
            got.append(frame)
            first.set()

    thread = threading.Thread(target=reader)
    thread.start()
    assert first.wait(5.0)
    camera.close()
    thread.join(5.0)
    assert not thread.is_alive()
    assert camera.read() is None
    assert [f.sequence for f in got] == list(range(len(got)))
