"""Where a lab's frames come from and what it sees of them (issue 28): the overlay on
Listing 1's /image_converter/output_video, frames with no fly reported as none (with the
lost-fly warning), a camera opened through OpenCV (a video file standing in for the device,
as cv2.VideoCapture accepts either), the raw frames written with --record-video, and the
thesis's Fly_Image.bin read by --frames (Listing 1: ``OutFile.write(im.data,
width*height)``, raw mono8 frames one after the other)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest

from servolab.cli import main
from servolab.clock import VirtualClock
from servolab.dynamixel.bus import Bus
from servolab.middleware.context import Context
from servolab.middleware.images import IMAGE
from servolab.middleware.node import Node
from servolab.robots.treadmill.camera_node import CameraNode
from servolab.robots.treadmill.logs import read_fly_log
from servolab.robots.treadmill.node import OVERLAY_TOPIC, TreadmillNode
from servolab.sim import Simulation
from servolab.vision.fly_render import FlyPose, render_fly
from servolab.vision.fly_tracker import CENTRE, DEAD_BAND, OUTLINE
from servolab.vision.frame_source import FrameSource

W, H = 640, 376


def _fly(k: int) -> np.ndarray:
    image, _ = render_fly(FlyPose(300.0 + 6 * k, 200.0 - 2 * k, 0.1 * k), noise_std=2.0,
                          rng=np.random.default_rng(k))
    return image


def test_the_overlay_shows_what_the_tracker_saw() -> None:
    """Listing 1's drawing: the fly's contour, a circle at its centre, the dead band's circle
    (limit_r = 50 px) round the target (320, 188): found in the published BGR image."""
    bus = Bus.open("emu://xm430-w210:100-102", baudrate=1_000_000, simulation=Simulation())
    frames = [_fly(0)]
    got: list[Any] = []
    with Context.open(clock=VirtualClock()) as context:
        node = TreadmillNode(context, bus)
        watcher = Node(context, "watcher")
        watcher.create_subscription(IMAGE, OVERLAY_TOPIC, got.append, 1)
        CameraNode(context, lambda: frames.pop() if frames else None, frame_rate=66.0)
        context.spin_until(lambda: bool(got), timeout=1.0)
    assert got and got[0].encoding == "bgr8"
    drawing = np.asarray(got[0].data).reshape(H, W, 3)
    sighting = node.last[0] if node.last else None
    assert sighting is not None and sighting.present

    def near(colour: tuple[int, int, int], x: float, y: float, r: float) -> bool:
        ys, xs = np.nonzero(np.all(drawing == colour, axis=2))
        return bool(np.any(np.abs(np.hypot(xs - x, ys - y) - r) <= 1.5))

    assert near(DEAD_BAND, 320, 188, 50)
    assert near(CENTRE, sighting.cx, sighting.cy, 3)
    outline = np.all(drawing == OUTLINE, axis=2)
    ys, xs = np.nonzero(outline)
    assert outline.sum() > 50 and abs(xs.mean() - sighting.cx) < 5 and abs(ys.mean()
                                                                         - sighting.cy) < 5


def _write_frames(folder: Path, images: list[np.ndarray]) -> None:
    folder.mkdir()
    for k, image in enumerate(images):
        cv2.imwrite(str(folder / f"frame{k:03d}.png"), image)


def _dark_fly_on_a_lit_ball() -> np.ndarray:
    image = np.zeros((H, W), np.uint8)
    cv2.circle(image, (W // 2, H // 2), 170, 200, -1)  # the lit ball, 90 000 px²
    cv2.ellipse(image, (340, 180), (40, 16), 20.0, 0, 360, 30, -1)  # the dark fly
    return image


@pytest.mark.slow
def test_frames_without_a_fly_are_no_fly_and_warned_of(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A blank white frame was a 239 625 px² fly and a lit ball a 102 140 px² one (issue 28):
    now no fly (max_area), the run warns that the fly was lost; the rig's dark polarity and a
    region of interest inside the ball find the dark fly."""
    frames = tmp_path / "frames"
    _write_frames(frames, [np.full((H, W), 255, np.uint8), _dark_fly_on_a_lit_ball()] * 3)
    out = tmp_path / "run"
    assert main(["flyball", "--frames", str(frames), "--out", str(out), "--no-progress"]) == 0
    said = capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    assert summary["analysis"]["frames_with_fly"] == 0
    assert summary["timing"]["fly_found_share"] == 0.0
    assert "found in only 0% of the frames" in summary["warnings"][0]
    assert "warning: the fly was found in only 0%" in said

    dark = tmp_path / "dark"
    _write_frames(dark, [_dark_fly_on_a_lit_ball()] * 4)
    out = tmp_path / "run-dark"
    assert main(["flyball", "--frames", str(dark), "--set", "tracker.polarity=dark",
                 "--set", "tracker.threshold=100", "--set", "tracker.roi=[200, 80, 240, 216]",
                 "--out", str(out), "--no-progress"]) == 0
    records = read_fly_log(out / "fly_data.bin")
    assert np.allclose(records["cx"], 340.0, atol=0.5)
    assert np.allclose(records["cy"], 180.0, atol=0.5)
    assert "warnings" not in json.loads((out / "summary.json").read_text())


def _video(path: Path, count: int, fps: float = 30.0) -> list[np.ndarray]:
    images = [_fly(k) for k in range(count)]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"FFV1"), fps, (W, H),
                             isColor=False)
    assert writer.isOpened()
    for image in images:
        writer.write(image)
    writer.release()
    return images


@pytest.mark.slow
@pytest.mark.realtime  # a camera paced at 30 frames/s: a busy machine drops a frame
def test_a_camera_by_opencv_with_its_frames_recorded(tmp_path: Path) -> None:
    """--camera takes whatever cv2.VideoCapture opens (a video file stands in for a device,
    read at its own 30 frames/s as a camera delivers them, not at decoding speed); the frame
    read ahead at open is stale and dropped; --record-video keeps every frame published, byte
    for byte in the thesis's raw .bin, which --frames then reads back."""
    video = tmp_path / "camera.avi"
    images = _video(video, 12)
    out, raw = tmp_path / "run", tmp_path / "Fly_Image.bin"
    assert main(["flyball", "--camera", str(video), "--record-video", str(raw), "--out",
                 str(out), "--no-progress"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["camera"] == str(video) and summary["time_base"] == \
        "the camera's capture times"
    timing = summary["timing"]
    assert timing["camera_frames"] == 11  # the camera's frames 1..11, by its own numbers
    assert timing["achieved_fps"] < 45.0  # paced at 30, not decoded at 100 or more
    assert timing["latency_ms"]["p50"] >= 0.0  # stamped at capture, before it was handled
    assert raw.stat().st_size == 11 * W * H  # every frame published, none lost to a queue
    recorded = np.fromfile(raw, dtype=np.uint8).reshape(11, H, W)  # Listing 1's layout
    assert all(np.array_equal(a, b) for a, b in zip(recorded, images[1:], strict=True))

    again = tmp_path / "again"
    assert main(["flyball", "--frames", str(raw), "--fps", "30", "--out", str(again),
                 "--no-progress"]) == 0
    records = read_fly_log(again / "fly_data.bin")
    assert len(records) == 11 and list(records["frame"]) == list(range(11))
    with FrameSource.open(raw) as source:
        assert len(source) == 11


def test_a_bin_of_another_size_needs_its_size(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    raw = tmp_path / "small.bin"
    np.zeros((3, 100, 160), np.uint8).tofile(raw)
    assert main(["flyball", "--frames", str(raw), "--out", str(tmp_path / "x"),
                 "--no-progress"]) == 2
    assert "size" in capsys.readouterr().err
    out = tmp_path / "run"
    assert main(["flyball", "--frames", str(raw), "--size", "160x100", "--set",
                 "controller.target=[80, 50, 0]", "--out", str(out), "--no-progress"]) == 0
    assert len(read_fly_log(out / "fly_data.bin")) == 3
