"""The thesis's ``Fly_Image.bin`` read back frame by frame by :meth:`FrameSource.open`.

Its layout is Listing 1 of seed 002 (../shared/seeds/002_*.txt): ``int width = 640; int
height = 376;`` (line 570), the file opened with ``OutFile.open("Fly_Image_Mar_28.bin",
ios::out | ios::binary)`` (line 602) and each frame appended, in ``imageCb``, as
``OutFile.write((char *)im.data, width*height*sizeof(uchar))`` (line 1052), where ``im`` is
the camera's image converted to MONO8 by cv_bridge (line 887): ``height`` rows of ``width``
bytes, row after row, frame after frame, no header, no time.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from servolab.vision.frame_source import FrameSource, FrameSourceError
from tests.clirun import one_line

W, H = 640, 376  # Listing 1
FRAME_BYTES = W * H  # 240 640


def frames(count: int, size: tuple[int, int] = (W, H)) -> list[np.ndarray]:
    """Distinct frames: noise, so that a shifted row or a swapped width and height shows."""
    rng = np.random.default_rng(2)
    return [rng.integers(0, 256, (size[1], size[0]), dtype=np.uint8) for _ in range(count)]


def write_as_listing_1(path: Path, images: list[np.ndarray]) -> None:
    """What ``OutFile.write((char *)im.data, width*height)`` leaves: the bytes, concatenated."""
    with open(path, "wb") as out:
        for image in images:
            out.write(image.tobytes())  # C order: row after row, like cv::Mat::data


def test_fly_image_bin_is_read_frame_by_frame(tmp_path: Path) -> None:
    path = tmp_path / "Fly_Image_Mar_28.bin"
    images = frames(3)
    write_as_listing_1(path, images)
    assert path.stat().st_size == 3 * FRAME_BYTES
    with FrameSource.open(path) as source:
        assert len(source) == 3
        assert source.stamps is None and source.frame_rate is None  # the rate is given elsewhere
        got = []
        while (frame := source.read()) is not None:
            got.append(frame)
        assert source.read() is None
    assert [f.sequence for f in got] == [0, 1, 2]
    assert [f.stamp for f in got] == [None, None, None]
    assert [f.name for f in got] == [f"{path} frame {n}" for n in range(3)]
    for image, frame in zip(images, got, strict=True):
        assert frame.image.shape == (H, W) and frame.image.dtype == np.uint8
        np.testing.assert_array_equal(frame.image, image)


def test_a_bin_is_read_from_the_file_as_it_plays_not_loaded_whole(tmp_path: Path) -> None:
    """Frames come from the file when asked for (runs are gigabytes): a file cut short after
    the source was opened is noticed at the frame that is missing."""
    path = tmp_path / "Fly_Image.bin"
    write_as_listing_1(path, frames(3))
    with FrameSource.open(path) as source:
        assert source.read() is not None
        os.truncate(path, FRAME_BYTES + FRAME_BYTES // 2)
        with pytest.raises(FrameSourceError) as error:
            source.read()
    text = one_line(error)
    assert text.startswith(f"{path} frame 1:") and "120320 of its 240640 bytes" in text


def test_a_bin_that_is_not_whole_frames_is_refused_saying_to_pass_the_size(
        tmp_path: Path) -> None:
    path = tmp_path / "Fly_Image.bin"
    write_as_listing_1(path, frames(2))
    with open(path, "ab") as out:
        out.write(b"\0" * 5)
    with pytest.raises(FrameSourceError) as error:
        FrameSource.open(path)
    text = one_line(error)
    assert text.startswith(f"{path}: {2 * FRAME_BYTES + 5} bytes")
    assert "640x376" in text and "240640 bytes" in text and "--size 640x376" in text


def test_a_bin_read_at_the_wrong_size_is_refused(tmp_path: Path) -> None:
    """Three 640x376 frames are 721 920 bytes, 2.35 frames of 640x480."""
    path = tmp_path / "Fly_Image.bin"
    write_as_listing_1(path, frames(3))
    with pytest.raises(FrameSourceError) as error:
        FrameSource.open(path, size=(640, 480))
    text = one_line(error)
    assert "721920 bytes" in text and "640x480" in text and "307200 bytes" in text


def test_a_bin_of_another_size_is_read_at_that_size(tmp_path: Path) -> None:
    path = tmp_path / "small.BIN"  # the suffix in any case
    images = frames(4, (64, 48))
    write_as_listing_1(path, images)
    with FrameSource.open(path, size=(64, 48)) as source:
        assert len(source) == 4
        got = [source() for _ in range(4)]
        assert source() is None
    for image, frame in zip(images, got, strict=True):
        assert frame is not None
        np.testing.assert_array_equal(frame, image)


def test_an_empty_bin_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "Fly_Image.bin"
    path.write_bytes(b"")
    with pytest.raises(FrameSourceError) as error:
        FrameSource.open(path)
    assert one_line(error).startswith(f"{path}: empty")
