"""Frames written by :class:`FrameWriter` (``--record-video``) read back through
:class:`FrameSource`: ``.bin`` exactly (Listing 1's raw layout, seed 002 line 1052:
``OutFile.write((char *)im.data, width*height*sizeof(uchar))``), ``.avi`` exactly with FFV1
(the codec this opencv-python-headless build writes losslessly), ``.mp4`` (mp4v) and the MJPG
fallback within a tolerance, since both are lossy.

What the installed wheel writes was checked by hand before these tests were written (OpenCV
5.0.0.93, its bundled FFmpeg, grey 640x376 noise frames): in .avi, FFV1, 'png ' and raw GREY
read back exactly, HFYU off by 1 level, MJPG and XVID by up to 57 (noise is JPEG's worst case);
in .mp4, mp4v by up to 41; LAGS cannot be written. Every codec silently rounds an odd width or
height down to even.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from servolab.vision import frame_writer
from servolab.vision.frame_source import STAMPS_VIDEO_MSEC, FrameSource
from servolab.vision.frame_writer import FrameWriter, FrameWriterError
from tests.clirun import one_line

W, H = 640, 376  # Listing 1
SMALL = (64, 48)


def noise(count: int, size: tuple[int, int] = (W, H)) -> list[np.ndarray]:
    """Random frames: any lossy step or mix-up of rows and columns shows."""
    rng = np.random.default_rng(7)
    return [rng.integers(0, 256, (size[1], size[0]), dtype=np.uint8) for _ in range(count)]


def scenes(count: int, size: tuple[int, int] = SMALL) -> list[np.ndarray]:
    """Dark frames with a bright blob moving right: what the rig sees, and what a lossy codec
    keeps well enough to compare."""
    out = []
    for n in range(count):
        frame = np.full((size[1], size[0]), 10, np.uint8)
        cv2.circle(frame, (16 + 4 * n, size[1] // 2), 8, 220, -1)
        out.append(frame)
    return out


def write(path: Path, images: list[np.ndarray], fps: float = 66.0) -> FrameWriter:
    size = (images[0].shape[1], images[0].shape[0])
    with FrameWriter.open(path, size, fps) as writer:
        for image in images:
            writer.write(image)
    assert writer.frames == len(images)
    return writer


def read_back(path: Path, size: tuple[int, int]) -> list[np.ndarray]:
    with FrameSource.open(path, size=size) as source:
        images = []
        while (image := source()) is not None:
            images.append(image)
    return images


def test_bin_round_trip_is_exact_and_is_listing_1s_layout(tmp_path: Path) -> None:
    path = tmp_path / "Fly_Image.bin"
    images = noise(3)
    writer = write(path, images)
    assert (writer.codec, writer.lossless, writer.note) == ("raw", True, None)
    # No header: the bytes of each frame, row after row, frame after frame.
    assert path.read_bytes() == b"".join(image.tobytes() for image in images)
    got = read_back(path, (W, H))
    assert len(got) == 3
    for image, back in zip(images, got, strict=True):
        np.testing.assert_array_equal(back, image)


def test_avi_is_ffv1_and_reads_back_exactly_with_its_rate(tmp_path: Path) -> None:
    path = tmp_path / "run.avi"
    images = noise(3, SMALL)
    writer = write(path, images, fps=66.0)
    assert writer.codec == "FFV1", "this OpenCV build lost FFV1: .avi would be lossy MJPG"
    assert writer.lossless and writer.note is None
    with FrameSource.open(path, size=SMALL) as source:
        assert source.frame_rate == 66.0 and source.stamps == STAMPS_VIDEO_MSEC
        frames = []
        while (frame := source.read()) is not None:
            frames.append(frame)
    assert [f.stamp for f in frames] == pytest.approx([0.0, 1 / 66, 2 / 66], abs=1e-9)
    for image, frame in zip(images, frames, strict=True):
        np.testing.assert_array_equal(frame.image, image)


def test_mp4_is_mp4v_and_reads_back_close(tmp_path: Path) -> None:
    path = tmp_path / "run.mp4"
    images = scenes(4)
    writer = write(path, images, fps=30.0)
    assert (writer.codec, writer.lossless) == ("mp4v", False)
    got = read_back(path, SMALL)
    assert len(got) == 4
    for image, back in zip(images, got, strict=True):
        difference = np.abs(back.astype(np.int16) - image.astype(np.int16))
        assert difference.mean() < 3.0, "mp4v is lossy, but not this lossy"


def test_avi_falls_back_to_mjpg_saying_it_is_lossy(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """A build without the first codec (here a made-up one) writes MJPG and says so."""
    monkeypatch.setattr(frame_writer, "AVI_CODECS", (("ZZZZ", True), ("MJPG", False)))
    path = tmp_path / "run.avi"
    images = scenes(3)
    writer = write(path, images)
    assert (writer.codec, writer.lossless) == ("MJPG", False)
    assert writer.note is not None and "lossy" in writer.note and "ZZZZ" in writer.note
    assert "\n" not in writer.note
    for image, back in zip(images, read_back(path, SMALL), strict=True):
        difference = np.abs(back.astype(np.int16) - image.astype(np.int16))
        assert difference.mean() < 3.0 and difference.max() < 80


def test_a_video_no_codec_can_write_is_refused_saying_to_use_bin(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(frame_writer, "AVI_CODECS", (("ZZZZ", True),))
    path = tmp_path / "run.avi"
    with pytest.raises(FrameWriterError) as error:
        FrameWriter.open(path, SMALL, 66.0)
    text = one_line(error)
    assert text.startswith(f"{path}: ") and "ZZZZ" in text and ".bin" in text


def test_an_unknown_suffix_is_refused_naming_the_known_ones(tmp_path: Path) -> None:
    path = tmp_path / "run.mkv"
    with pytest.raises(FrameWriterError) as error:
        FrameWriter.open(path, SMALL, 66.0)
    text = one_line(error)
    assert text.startswith(f"{path}: unknown suffix '.mkv'")
    assert ".bin" in text and ".avi" in text and ".mp4" in text


@pytest.mark.parametrize("name", ["run.bin", "run.avi"])
def test_a_missing_folder_is_refused_naming_it(tmp_path: Path, name: str) -> None:
    path = tmp_path / "nowhere" / name
    with pytest.raises(FrameWriterError) as error:
        FrameWriter.open(path, SMALL, 66.0)
    text = one_line(error)
    assert text.startswith(f"{path}: the folder {tmp_path / 'nowhere'} does not exist")


def test_an_odd_size_is_refused_for_video_but_not_for_bin(tmp_path: Path) -> None:
    with pytest.raises(FrameWriterError) as error:
        FrameWriter.open(tmp_path / "run.avi", (63, 48), 66.0)
    assert "63x48" in one_line(error) and ".bin" in one_line(error)
    images = noise(2, (63, 47))
    write(tmp_path / "odd.bin", images)
    for image, back in zip(images, read_back(tmp_path / "odd.bin", (63, 47)), strict=True):
        np.testing.assert_array_equal(back, image)


@pytest.mark.parametrize(("size", "fps"), [((64, 0), 66.0), ((64.0, 48), 66.0),
                                           (SMALL, 0.0), (SMALL, float("nan"))])
def test_a_bad_size_or_rate_is_refused(tmp_path: Path, size: tuple[int, int],
                                       fps: float) -> None:
    with pytest.raises(FrameWriterError):
        FrameWriter.open(tmp_path / "run.bin", size, fps)


@pytest.mark.parametrize("suffix", [".bin", ".avi"])
def test_a_frame_of_the_wrong_kind_is_refused_before_anything_is_written(
        tmp_path: Path, suffix: str) -> None:
    path = tmp_path / f"run{suffix}"
    with FrameWriter.open(path, SMALL, 66.0) as writer:
        writer.write(scenes(1)[0])
        bad: list[object] = [np.zeros((48, 64, 3), np.uint8), np.zeros((48, 64), np.uint16),
                             np.zeros((64, 48), np.uint8), [[0] * 64] * 48]
        for image in bad:
            with pytest.raises(FrameWriterError) as error:
                writer.write(image)
            assert one_line(error).startswith(f"{path} frame 1: ")
        assert writer.frames == 1
    assert len(read_back(path, SMALL)) == 1
    with pytest.raises(FrameWriterError, match="closed"):
        writer.write(scenes(1)[0])
    writer.close()  # again: nothing


def test_an_error_while_recording_keeps_the_frames_written(tmp_path: Path) -> None:
    path = tmp_path / "run.avi"
    images = noise(2, SMALL)
    with pytest.raises(RuntimeError), FrameWriter.open(path, SMALL, 66.0) as writer:
        for image in images:
            writer.write(image)
        raise RuntimeError("the run failed")
    for image, back in zip(images, read_back(path, SMALL), strict=True):
        np.testing.assert_array_equal(back, image)
