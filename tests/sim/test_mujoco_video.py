"""Rendering a MuJoCo run headless: the video read back by OpenCV's own reader (frame count,
size, content that changes as the joint turns), the PNG still, the refusals, and the one line
when there is no OpenGL."""

from __future__ import annotations

import itertools
import math
import sys
from pathlib import Path
from typing import Any

import cv2
import mujoco
import numpy as np
import pytest

from servolab.sim.errors import SimError, SimulationError
from servolab.sim.mujoco_video import (
    gl_backend,
    looking_at,
    render_frame,
    render_grid,
    render_video,
)

#: A box, long in x with a ball on its +x end, on a vertical hinge over a floor: turning it
#: changes the picture (the box seen from the diagonal looks alike at 0 and 90 deg; the ball
#: does not), while the camera tracks its subtree centre, near the axis.
MJCF = """
<mujoco>
  <worldbody>
    <light pos="0 0 3" dir="0 0 -1" castshadow="false"/>
    <geom type="plane" size="2 2 0.1" rgba="0.3 0.4 0.5 1"/>
    <body name="pelvis" pos="0 0 0.2">
      <joint name="yaw" type="hinge" axis="0 0 1"/>
      <geom type="box" size="0.15 0.03 0.1" rgba="0.9 0.3 0.1 1"/>
      <geom type="sphere" size="0.06" pos="0.15 0 0.1" rgba="0.9 0.9 0.2 1"/>
    </body>
  </worldbody>
</mujoco>
"""
W, H = 160, 120  # small, and no shadow: software GL draws a frame in a few ms
FRAMES = 10


@pytest.fixture(scope="module")
def model() -> Any:
    return mujoco.MjModel.from_xml_string(MJCF)


@pytest.fixture(scope="module")
def qpos() -> np.ndarray:
    """Rows 0 and 1 the same pose, then the box turns a quarter turn."""
    angles = np.concatenate([[0.0], np.linspace(0.0, math.pi / 2, FRAMES - 1)])
    return angles[:, np.newaxis]


@pytest.fixture(scope="module")
def gl(model: Any, tmp_path_factory: pytest.TempPathFactory) -> None:
    """Skip the tests that draw where there is no OpenGL, with the one line saying why."""
    try:
        render_frame(model, np.zeros(model.nq), tmp_path_factory.mktemp("gl") / "probe.png",
                     width=W, height=H)
    except SimError as exc:
        pytest.skip(str(exc))


def _read(path: Path) -> list[np.ndarray]:
    capture = cv2.VideoCapture(str(path))
    assert capture.isOpened(), path
    frames = []
    while True:
        ok, frame = capture.read()
        if not ok:
            break
        frames.append(frame)
    capture.release()
    return frames


def _difference(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a.astype(float) - b.astype(float)).mean())


@pytest.mark.usefixtures("gl")
@pytest.mark.parametrize("suffix", [".mp4", ".avi"])
def test_a_video_reads_back_frame_for_frame(model: Any, qpos: np.ndarray, tmp_path: Path,
                                            suffix: str) -> None:
    holder = mujoco.rendering.classic.gl_context
    before = holder.GLContext
    path = render_video(model, qpos, tmp_path / f"run{suffix}", fps=25.0, width=W, height=H)
    assert path == tmp_path / f"run{suffix}"
    assert holder.GLContext is before  # a backend swapped in for the renderer is put back
    frames = _read(path)
    assert len(frames) == FRAMES
    assert all(f.shape == (H, W, 3) for f in frames)
    assert frames[0].std() > 10  # a scene, not a blank
    same, turned = _difference(frames[0], frames[1]), _difference(frames[0], frames[-1])
    # (measured: 0.0 for the same pose, 1.6 a step of 10 deg, 3.4 for the quarter turn)
    assert same < 0.5, same  # the same pose: at most the codec's noise
    assert turned > 2.5, turned
    steps = [_difference(a, b) for a, b in itertools.pairwise(frames[1:])]
    assert min(steps) > 1.0, steps  # every step of the turn shows


@pytest.mark.usefixtures("gl")
def test_a_frame_is_a_png_of_the_size_asked_beyond_the_models_buffer(
        model: Any, tmp_path: Path) -> None:
    """720 is wider than the default offscreen buffer (640): made big enough for the render,
    the model given back as it was."""
    path = render_frame(model, np.array([0.3]), tmp_path / "still.png", width=720, height=90)
    image = cv2.imread(str(path))
    assert image is not None and image.shape == (90, 720, 3)
    assert model.vis.global_.offwidth == 640


def test_a_bad_suffix_is_refused_with_the_path(model: Any, qpos: np.ndarray,
                                               tmp_path: Path) -> None:
    path = tmp_path / "run.mkv"
    with pytest.raises(SimulationError, match=r"run\.mkv.*\.mp4 or \.avi") as caught:
        render_video(model, qpos, path, fps=25.0)
    assert str(path) in str(caught.value) and "\n" not in str(caught.value)
    assert not path.exists()
    with pytest.raises(SimulationError, match=r"still\.jpg.*\.png"):
        render_frame(model, qpos[0], tmp_path / "still.jpg")


@pytest.mark.parametrize(("change", "message"), [
    ({"qpos": np.zeros((3, 2))}, r"qpos must be \(frames, 1\)"),
    ({"qpos": np.array([[0.0], [math.nan]])}, r"row 1 is not finite"),
    ({"width": 161}, "odd side"),
    ({"fps": 0}, "fps must be"),
    ({"track_body": "torso"}, r"no body 'torso'.*\(pelvis\)"),
    ({"path": "missing/run.mp4"}, "does not exist"),
])
def test_bad_input_is_refused_before_rendering(model: Any, qpos: np.ndarray, tmp_path: Path,
                                               change: dict[str, Any], message: str) -> None:
    arguments: dict[str, Any] = {"qpos": qpos, "path": "run.mp4", "fps": 25.0, "width": W,
                                 "height": H, **change}
    arguments["path"] = tmp_path / arguments["path"]
    with pytest.raises(SimulationError, match=message):
        render_video(model, **arguments)


def test_no_opengl_is_one_line_saying_what_to_do(model: Any, qpos: np.ndarray, tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    def no_gl(*args: object, **kwargs: object) -> None:
        raise mujoco.FatalError("an OpenGL platform library has not been loaded\ninto this "
                                "process")

    monkeypatch.setattr(mujoco, "Renderer", no_gl)
    monkeypatch.delenv("MUJOCO_GL", raising=False)
    path = tmp_path / "run.mp4"
    with pytest.raises(SimError) as caught:
        render_video(model, qpos, path, fps=25.0, width=W, height=H)
    text = str(caught.value)
    assert not isinstance(caught.value, ValueError)  # a failure at run time: exit 1, not 2
    assert "\n" not in text
    assert text.startswith("cannot render the video: no OpenGL here (MUJOCO_GL=egl: ")
    assert "has not been loaded into this process" in text
    assert "install EGL (libegl1)" in text and text.endswith("or leave out --video")
    assert not path.exists()  # nothing written when nothing can be drawn


def test_the_backend_is_mujoco_gl_or_egl(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MUJOCO_GL", " OSMesa ")
    assert gl_backend() == "osmesa"
    monkeypatch.delenv("MUJOCO_GL")
    assert gl_backend() == ("egl" if sys.platform.startswith("linux") else "")


@pytest.mark.usefixtures("gl")
def test_a_grid_draws_each_pose_in_its_tile_and_a_blank_where_none_is(
        model: Any, tmp_path: Path) -> None:
    """Three poses two a row: two rows, the tiles of 0 and 90 deg apart, the fourth white."""
    view = looking_at((0.0, 0.0, 0.2), 1.0)
    path = render_grid(model, np.array([[0.0], [math.pi / 2], [0.0]]), tmp_path / "g.png",
                       labels=["a", "b", "c"], view=view, width=W, height=H, columns=2)
    image = cv2.imread(str(path)).astype(int)
    assert image.shape == (2 * H, 2 * W, 3)
    tiles = [image[r * H:(r + 1) * H, c * W:(c + 1) * W] for r in range(2) for c in range(2)]
    assert np.abs(tiles[0] - tiles[1]).mean() > 1.0      # the box turned
    assert np.abs(tiles[0] - tiles[2]).mean() < 0.5      # the same pose, the same picture
    assert (tiles[3] == 255).all()


def test_a_grid_needs_a_label_a_pose(model: Any, tmp_path: Path) -> None:
    with pytest.raises(SimulationError, match=r"2 poses need as many labels, got 1"):
        render_grid(model, np.zeros((2, 1)), tmp_path / "g.png", labels=["a"],
                    view=looking_at((0, 0, 0), 1.0))
    with pytest.raises(SimulationError, match=r"a point \(x, y, z\) and a distance > 0"):
        looking_at((0, 0, 0), 0.0)
