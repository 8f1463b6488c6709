"""Recorded frames for ``servolab flyball --frames``: folders in natural name order, videos
through OpenCV, colour made grey, and one-line refusals that name the file at fault.

Each frame written here carries its number as the x position of a bright square, so the order
the source hands frames out in can be read back from the pixels, not from the file names.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from servolab.errors import ServolabError
from servolab.vision.frame_source import FrameSource, FrameSourceError, natural_key
from tests.clirun import one_line

W, H = 640, 376


def marked(number: int, size: tuple[int, int] = (W, H)) -> np.ndarray:
    """A dark frame with a 20 px bright square whose left edge is at x = 20 * number."""
    frame = np.zeros((size[1], size[0]), np.uint8)
    x = 20 * number
    frame[100:120, x:x + 20] = 220
    return frame


def number_in(frame: np.ndarray) -> int:
    """The number :func:`marked` drew: the left edge of the bright columns over 20."""
    columns = np.flatnonzero(frame.max(axis=0) > 128)
    assert columns.size, "no bright square in the frame"
    return round(int(columns[0]) / 20)


def all_frames(source: FrameSource) -> list[np.ndarray]:
    frames = []
    while (frame := source()) is not None:
        frames.append(frame)
    return frames


def test_natural_key_orders_numbers_by_value() -> None:
    names = ["f10.png", "f2.png", "F1.png", "f1.png", "g0.png", "f11.png"]
    assert sorted(names, key=natural_key) == [
        "F1.png", "f1.png", "f2.png", "f10.png", "f11.png", "g0.png"]


def test_folder_frames_come_in_natural_order_and_other_files_are_ignored(
        tmp_path: Path) -> None:
    numbers = [1, 2, 3, 10, 11]  # plain sorting: f1, f10, f11, f2, f3
    for n in numbers:
        assert cv2.imwrite(str(tmp_path / f"f{n}.png"), marked(n))
    (tmp_path / "notes.txt").write_text("not a frame")
    (tmp_path / "timestamps.csv").write_text("0,1\n")
    with FrameSource.open(tmp_path) as source:
        assert len(source) == 5
        assert source.name_of_last == ""
        frames = all_frames(source)
        assert source.name_of_last == str(tmp_path / "f11.png")
        assert source() is None  # stays at the end
    assert [number_in(f) for f in frames] == numbers
    for n, frame in zip(numbers, frames, strict=True):
        assert frame.dtype == np.uint8 and frame.shape == (H, W)
        np.testing.assert_array_equal(frame, marked(n))  # PNG is lossless


def test_image_suffixes_are_case_insensitive(tmp_path: Path) -> None:
    assert cv2.imwrite(str(tmp_path / "a1.PNG"), marked(1))
    assert cv2.imwrite(str(tmp_path / "a2.Bmp"), marked(2))
    with FrameSource.open(tmp_path) as source:
        assert [number_in(f) for f in all_frames(source)] == [1, 2]


def test_a_colour_frame_becomes_grey_from_bgr(tmp_path: Path) -> None:
    bgr = np.zeros((H, W, 3), np.uint8)
    bgr[..., 0] = 255  # pure blue in OpenCV's BGR order
    assert cv2.imwrite(str(tmp_path / "c1.png"), bgr)
    bgra = np.dstack([bgr, np.full((H, W), 255, np.uint8)])
    assert cv2.imwrite(str(tmp_path / "c2.png"), bgra)
    with FrameSource.open(tmp_path) as source:
        frames = all_frames(source)
    assert len(frames) == 2
    for frame in frames:
        assert frame.shape == (H, W) and frame.dtype == np.uint8
        # 0.114 * 255 = 29 read as BGR; read as RGB it would be 0.299 * 255 = 76.
        assert np.all(frame == 29)


def test_a_wrong_size_first_frame_is_refused_at_open(tmp_path: Path) -> None:
    assert cv2.imwrite(str(tmp_path / "f1.png"), marked(1, (320, 240)))
    with pytest.raises(FrameSourceError) as error:
        FrameSource.open(tmp_path)
    text = one_line(error)
    assert text.startswith(str(tmp_path / "f1.png") + ":")
    assert "320x240" in text and "640x376" in text


def test_a_wrong_size_later_frame_is_refused_at_open(tmp_path: Path) -> None:
    """A folder is checked whole when opened: a bad frame halfway through must not be found
    after the motors have driven the first half."""
    assert cv2.imwrite(str(tmp_path / "f1.png"), marked(1))
    assert cv2.imwrite(str(tmp_path / "f2.png"), marked(2, (W + 1, H)))
    with pytest.raises(FrameSourceError) as error:
        FrameSource.open(tmp_path)
    text = one_line(error)
    assert str(tmp_path / "f2.png") in text and "641x376" in text and "640x376" in text


def test_a_custom_size_is_honoured(tmp_path: Path) -> None:
    assert cv2.imwrite(str(tmp_path / "f1.png"), marked(1, (320, 240)))
    with FrameSource.open(tmp_path, size=(320, 240)) as source:
        frame = source()
    assert frame is not None and frame.shape == (240, 320)


def test_a_16_bit_frame_is_refused_naming_file_and_dtype(tmp_path: Path) -> None:
    assert cv2.imwrite(str(tmp_path / "deep.png"), np.zeros((H, W), np.uint16))
    with pytest.raises(FrameSourceError) as error:
        FrameSource.open(tmp_path)
    text = one_line(error)
    assert str(tmp_path / "deep.png") in text and "uint16" in text


def test_an_unreadable_image_is_refused_naming_it(tmp_path: Path) -> None:
    (tmp_path / "broken.png").write_bytes(b"not a png at all")
    with pytest.raises(FrameSourceError) as error:
        FrameSource.open(tmp_path)
    assert one_line(error).startswith(str(tmp_path / "broken.png") + ":")


def test_a_folder_without_images_is_refused_naming_it(tmp_path: Path) -> None:
    (tmp_path / "readme.txt").write_text("no frames here")
    with pytest.raises(FrameSourceError) as error:
        FrameSource.open(tmp_path)
    text = one_line(error)
    assert text.startswith(f"{tmp_path}:") and "no image" in text


def test_a_missing_path_is_refused(tmp_path: Path) -> None:
    missing = tmp_path / "nowhere"
    with pytest.raises(FrameSourceError) as error:
        FrameSource.open(missing)
    assert one_line(error).startswith(f"{missing}:")
    assert isinstance(error.value, ServolabError) and isinstance(error.value, ValueError)


def write_video(path: Path, numbers: list[int]) -> None:
    """An MJPG .avi (opencv-python-headless here writes it without any extra codec)."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"MJPG"), 10.0, (W, H),
                             isColor=False)
    assert writer.isOpened(), "MJPG/avi not available in this OpenCV build"
    for n in numbers:
        writer.write(marked(n))
    writer.release()


def test_a_video_is_read_frame_by_frame(tmp_path: Path) -> None:
    video = tmp_path / "run.avi"
    numbers = [3, 1, 4, 15, 9]
    write_video(video, numbers)
    with FrameSource.open(video) as source:
        assert len(source) == 5
        frames = all_frames(source)
        assert source.name_of_last == f"{video} frame 4"
    assert [number_in(f) for f in frames] == numbers
    for n, frame in zip(numbers, frames, strict=True):
        assert frame.dtype == np.uint8 and frame.shape == (H, W)
        # JPEG is lossy: close, not equal.
        difference = np.abs(frame.astype(np.int16) - marked(n).astype(np.int16))
        assert difference.mean() < 2.0 and difference.max() < 80


def test_a_video_of_the_wrong_size_is_refused_naming_the_frame(tmp_path: Path) -> None:
    video = tmp_path / "run.avi"
    write_video(video, [1, 2])
    with pytest.raises(FrameSourceError) as error:
        FrameSource.open(video, size=(320, 240))
    text = one_line(error)
    assert text.startswith(f"{video} frame 0:") and "640x376" in text and "320x240" in text


def test_a_garbage_video_is_refused_in_one_line(tmp_path: Path) -> None:
    video = tmp_path / "garbage.avi"
    video.write_bytes(b"this is not a video" * 50)
    with pytest.raises(FrameSourceError) as error:
        FrameSource.open(video)
    assert one_line(error).startswith(f"{video}: OpenCV cannot open this video (")


def test_close_ends_the_recording(tmp_path: Path) -> None:
    video = tmp_path / "run.avi"
    write_video(video, [1, 2, 3])
    source = FrameSource.open(video)
    assert source() is not None
    source.close()
    assert source() is None
    assert bool(source)


def test_a_bad_size_argument_is_refused(tmp_path: Path) -> None:
    assert cv2.imwrite(str(tmp_path / "f1.png"), marked(1))
    with pytest.raises(ValueError, match="size"):
        FrameSource.open(tmp_path, size=(640, 0))
