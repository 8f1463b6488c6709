"""A MuJoCo run rendered to a video file (or one frame to a PNG), with no display: what a
student watches to see the gait the numbers describe.

Each frame is one row of joint positions (``qpos``) put into an ``MjData``, brought up to date
by ``mj_forward`` and drawn by :class:`mujoco.Renderer` offscreen; OpenCV's ``VideoWriter``
writes the frames (``.mp4`` as MPEG-4 part 2, ``mp4v``, the one MP4 codec the OpenCV wheels
write; ``.avi`` as Motion-JPEG, which every OpenCV build writes). Both are lossy: the video is
for looking at, not for measuring.

The camera is a free camera that follows a body (``track_body``, by default the pelvis: the
root of a walking robot) through MuJoCo's tracking camera, which looks at the body's subtree
centre of mass (for the root body, the robot's), from the front left, a little above: a 3/4
view where both legs and the stepping can be seen. Its direction stays fixed in the world
while it follows, so the floor's checkers show how far the robot went.

Which OpenGL. MuJoCo chooses its backend once, from the environment variable ``MUJOCO_GL``,
when ``mujoco`` is first imported in the process (``mujoco.rendering.classic.gl_context``):
``egl`` or ``osmesa`` headless, else GLFW, which needs a display. By the time a run asks for
a video, the physics has long imported ``mujoco``, so setting ``MUJOCO_GL`` here would come too
late; setting it when this module is imported would be on time only if nothing imported
``mujoco`` before, and is not harmless either: with ``MUJOCO_GL=egl`` on a machine with no
OpenGL library at all, ``import mujoco`` itself fails (PyOpenGL cannot load its GL), taking
the physics down with the video. So the environment is left alone, and the backend is chosen
when the renderer is made: ``MUJOCO_GL`` as it is then, or EGL if it is unset (on Linux). If
that is not what ``mujoco`` chose at import, the renderer is made with the chosen backend's
context class instead (the class ``mujoco.Renderer`` reads, swapped for its construction
only). A backend that cannot give a context raises :class:`~.errors.SimError`, one line.

Measured on a 2-core machine without a GPU (EGL on Mesa's llvmpipe, software): 12 to 14
frames a second at 640x480 for Armstrong (its light casts shadows, its floor reflects), about
50 with shadows and reflections off; writing the frames costs little beside that. A GPU's EGL
is many times faster.
"""

from __future__ import annotations

import importlib
import math
import os
import sys
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import cv2
import mujoco  # type: ignore[import-untyped,unused-ignore]
import numpy as np

from .errors import SimError, SimulationError

#: The FourCC written for each suffix the video may have.
FOURCC = {".mp4": "mp4v", ".avi": "MJPG"}
#: The camera's direction: azimuth 225 deg looks back along -x and -y, i.e. from the front
#: left of a robot facing +x with its left at +y (MJCF's convention, and Armstrong's); 15 deg
#: above the horizontal.
AZIMUTH, ELEVATION = 225.0, -15.0
#: The distance from the tracked point (m): with the default 45 deg field of view the frame is
#: 0.83 m high there, so a 0.4 m robot fills about half of it and has room to bob and step.
DISTANCE = 1.0
#: The modules of the backends MUJOCO_GL names (Linux's); their GLContext is what the
#: renderer is made with.
_BACKENDS = {"egl": "mujoco.egl", "osmesa": "mujoco.osmesa", "glfw": "mujoco.glfw"}
#: What to do when a backend gives no context, by backend.
_GL_HINTS = {
    "egl": "install EGL (libegl1) or run with MUJOCO_GL=osmesa (libosmesa6)",
    "osmesa": "install OSMesa (libosmesa6) or run with MUJOCO_GL=egl (libegl1)",
    "glfw": "run with MUJOCO_GL=egl (libegl1) or with a display",
}


def render_video(model: mujoco.MjModel, qpos: np.ndarray, path: str | Path, fps: float, *,
                 width: int = 640, height: int = 480, track_body: str | None = "pelvis",
                 distance: float = DISTANCE, progress: bool = False) -> Path:
    """Render each row of ``qpos`` (frames x ``model.nq``) as one frame of a video at ``fps``
    frames a second to ``path`` (``.mp4`` or ``.avi``; an existing file is replaced), seen by
    the camera of :func:`camera` (``track_body`` followed from ``distance`` m; None: the
    model's centre). ``progress`` shows a progress bar on stderr. Returns the path.

    Raises :class:`~.errors.SimulationError` for bad input (suffix, size, rate, rows, body,
    folder) before anything is rendered, and :class:`~.errors.SimError` when there is no
    OpenGL or OpenCV cannot write the file.
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in FOURCC:
        raise SimulationError(f"{p}: cannot write a video with the suffix {p.suffix!r}; "
                              f"name it {' or '.join(FOURCC)}")
    _check_size(p, width, height, video=True)
    if isinstance(fps, bool) or not isinstance(fps, (int, float)) or not (
            math.isfinite(fps) and fps > 0):
        raise SimulationError(f"{p}: fps must be a number of frames a second > 0, got {fps!r}")
    rows = _rows(p, model, qpos)
    _check_folder(p)
    view = camera(model, track_body, distance)
    from tqdm import tqdm

    with _renderer(model, width, height, "the video") as renderer:
        writer = cv2.VideoWriter(str(p), cv2.VideoWriter.fourcc(*FOURCC[suffix]), float(fps),
                                 (width, height))
        try:
            if not writer.isOpened():
                raise SimError(f"{p}: OpenCV cannot open it to write {FOURCC[suffix]}; check "
                               "that the folder can be written in, or try the other suffix")
            data = mujoco.MjData(model)
            for row in tqdm(rows, unit="frame", disable=not progress, leave=False,
                            desc=p.name):
                image = _draw(renderer, model, data, row, view)
                writer.write(cv2.cvtColor(image, cv2.COLOR_RGB2BGR))
        finally:
            # Released also after an error: the frames written so far make a video.
            writer.release()
    return p


def check_video(model: mujoco.MjModel, path: str | Path) -> Path:
    """What :func:`render_video` would refuse about ``path`` (its suffix, its folder) and
    whether OpenGL can draw here (a renderer is made and closed), checked before a run
    whose video it will be: a walk must not end in an error that was known at its start."""
    p = Path(path)
    if p.suffix.lower() not in FOURCC:
        raise SimulationError(f"{p}: cannot write a video with the suffix {p.suffix!r}; "
                              f"name it {' or '.join(FOURCC)}")
    _check_folder(p)
    with _renderer(model, 16, 16, "the video"):
        pass
    return p


def render_frame(model: mujoco.MjModel, qpos_row: np.ndarray, path: str | Path, *, width: int = 640,
                 height: int = 480, track_body: str | None = "pelvis",
                 distance: float = DISTANCE) -> Path:
    """Render one pose (``qpos_row``, ``model.nq`` values) to a PNG at ``path``, with the same
    camera as :func:`render_video`: the still for the docs of what the video shows. Returns
    the path; raises as :func:`render_video` does."""
    p = Path(path)
    if p.suffix.lower() != ".png":
        raise SimulationError(f"{p}: cannot write a frame with the suffix {p.suffix!r}; "
                              "name it .png")
    _check_size(p, width, height, video=False)
    row = np.asarray(qpos_row, dtype=float)
    if row.ndim != 1:
        raise SimulationError(f"{p}: qpos_row must be one pose of {model.nq} values, got an "
                              f"array of shape {row.shape}; pass qpos[i], not qpos")
    (row,) = _rows(p, model, row[np.newaxis, :])
    _check_folder(p)
    view = camera(model, track_body, distance)
    with _renderer(model, width, height, "the frame") as renderer:
        image = _draw(renderer, model, mujoco.MjData(model), row, view)
    if not cv2.imwrite(str(p), cv2.cvtColor(image, cv2.COLOR_RGB2BGR)):
        raise SimError(f"{p}: OpenCV could not write it; check that the folder can be "
                       "written in")
    return p


def render_grid(model: mujoco.MjModel, qpos: np.ndarray, path: str | Path, *,
                labels: Sequence[str], view: Any, width: int = 400, height: int = 300,
                columns: int = 3) -> Path:
    """Several poses (the rows of ``qpos``) side by side in one PNG, ``columns`` a row, each
    tile ``width`` x ``height`` with its label in its corner, all seen by the camera ``view``
    (:func:`camera` or :func:`looking_at`): the stages of a run on one page, a pick's grasp
    beside its place. Returns the path; raises as :func:`render_frame` does."""
    p = Path(path)
    if p.suffix.lower() != ".png":
        raise SimulationError(f"{p}: cannot write a grid with the suffix {p.suffix!r}; "
                              "name it .png")
    _check_size(p, width, height, video=False)
    rows = _rows(p, model, np.asarray(qpos, dtype=float))
    if len(labels) != len(rows) or columns < 1:
        raise SimulationError(f"{p}: {len(rows)} poses need as many labels, got "
                              f"{len(labels)}, and at least one column, got {columns}")
    _check_folder(p)
    across = min(columns, len(rows))
    grid = np.full((height * -(-len(rows) // across), width * across, 3), 255, np.uint8)
    with _renderer(model, width, height, "the grid") as renderer:
        data = mujoco.MjData(model)
        for i, (row, label) in enumerate(zip(rows, labels, strict=True)):
            tile = np.ascontiguousarray(_draw(renderer, model, data, row, view))
            cv2.putText(tile, label, (8, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (255, 255, 255),
                        3, cv2.LINE_AA)
            cv2.putText(tile, label, (8, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (20, 20, 20), 1,
                        cv2.LINE_AA)
            top, left = (i // across) * height, (i % across) * width
            grid[top:top + height, left:left + width] = tile
    if not cv2.imwrite(str(p), cv2.cvtColor(grid, cv2.COLOR_RGB2BGR)):
        raise SimError(f"{p}: OpenCV could not write it; check that the folder can be "
                       "written in")
    return p


def looking_at(point: Sequence[float], distance: float, *, azimuth: float = AZIMUTH,
               elevation: float = ELEVATION) -> Any:
    """A free ``mujoco.MjvCamera`` looking at ``point`` (world m) from ``distance`` m, at
    ``azimuth`` and ``elevation`` degrees (MuJoCo's: azimuth about +z, elevation below the
    horizontal when negative): a scene's fixed view, a table top's."""
    numbers = [*point, distance, azimuth, elevation]
    if len(point) != 3 or not all(isinstance(v, int | float) and math.isfinite(v)
                                  for v in numbers) or not distance > 0:
        raise SimulationError(f"the camera needs a point (x, y, z) and a distance > 0, all "
                              f"finite, got {tuple(point)!r} and {distance!r} (azimuth "
                              f"{azimuth!r}, elevation {elevation!r})")
    view = mujoco.MjvCamera()
    view.type = mujoco.mjtCamera.mjCAMERA_FREE
    view.lookat[:] = [float(v) for v in point]
    view.distance, view.azimuth, view.elevation = float(distance), azimuth, elevation
    return view


@contextmanager
def offscreen(model: mujoco.MjModel, width: int = 640, height: int = 480) -> Iterator[Any]:
    """A ``mujoco.Renderer`` of ``width`` x ``height`` on the backend the videos use, closed
    when the block ends: a run's camera images of its live ``MjData``
    (``renderer.update_scene(data, view); renderer.render()``). Raises as
    :func:`render_frame` does: :class:`~.errors.SimError` when there is no OpenGL here."""
    _check_size(Path("camera"), width, height, video=False)
    with _renderer(model, width, height, "camera images") as renderer:
        yield renderer


def camera(model: mujoco.MjModel, track_body: str | None = "pelvis",
           distance: float = DISTANCE) -> Any:
    """The ``mujoco.MjvCamera`` both renders use: MuJoCo's tracking camera on ``track_body``
    (it looks at the body's subtree centre of mass; None: a free camera on the model's
    centre) from :data:`AZIMUTH` and :data:`ELEVATION`, ``distance`` m away."""
    if isinstance(distance, bool) or not isinstance(distance, (int, float)) or not (
            math.isfinite(distance) and distance > 0):
        raise SimulationError(f"the camera's distance must be metres > 0, got {distance!r}")
    view = mujoco.MjvCamera()
    if track_body is None:
        mujoco.mjv_defaultFreeCamera(model, view)
        view.type = mujoco.mjtCamera.mjCAMERA_FREE
    else:
        body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, track_body)
        if body < 0:
            names = [model.body(i).name for i in range(1, model.nbody)]
            shown = ", ".join(names[:12]) + (", ..." if len(names) > 12 else "")
            raise SimulationError(f"the model has no body {track_body!r} to follow; name one "
                                  f"of its bodies ({shown}) or None")
        view.type = mujoco.mjtCamera.mjCAMERA_TRACKING
        view.trackbodyid = body
    view.distance = float(distance)
    view.azimuth = AZIMUTH
    view.elevation = ELEVATION
    return view


def gl_backend() -> str:
    """The OpenGL backend the renderer is made with: ``MUJOCO_GL`` as set now, else ``egl``
    on Linux (headless), else "" (MuJoCo's own choice: CGL on macOS, GLFW elsewhere)."""
    chosen = os.environ.get("MUJOCO_GL", "").strip().lower()
    if chosen:
        return chosen
    return "egl" if sys.platform.startswith("linux") else ""


def _draw(renderer: Any, model: Any, data: Any, row: np.ndarray, view: Any) -> np.ndarray:
    """One frame (height x width x 3, RGB) of the pose ``row``."""
    data.qpos[:] = row
    mujoco.mj_forward(model, data)
    renderer.update_scene(data, view)
    image: np.ndarray = renderer.render()
    return image


@contextmanager
def _renderer(model: Any, width: int, height: int, what: str) -> Iterator[Any]:
    """A ``mujoco.Renderer`` of ``width`` x ``height`` on :func:`gl_backend`'s backend, closed
    when the block ends (its GL context and buffers are not the garbage collector's to
    free: a context freed on another thread, or after the display, can crash)."""
    backend = gl_backend()
    # The offscreen buffer is made at the model's offwidth x offheight (640x480 unless the
    # MJCF says); a larger picture is refused, so the buffer is made big enough, and the
    # model given back as it was (the context keeps the size it was made with).
    visual = model.vis.global_
    buffer = (visual.offwidth, visual.offheight)
    visual.offwidth, visual.offheight = max(buffer[0], width), max(buffer[1], height)
    caught: list[warnings.WarningMessage] = []
    try:
        with warnings.catch_warnings(record=True) as caught, _context_class(backend):
            warnings.simplefilter("always")
            renderer = mujoco.Renderer(model, height=height, width=width)
    except Exception as exc:
        # GLFW warns the cause (no display) before MuJoCo fails on what follows from it
        first = [f"{caught[0].message}, then "] if caught else []
        reason = " ".join(" ".join([*first, f"{type(exc).__name__}: {exc}"]).split())
        reason = reason if len(reason) <= 240 else reason[:237] + "..."
        name = f"MUJOCO_GL={backend}" if backend else "MUJOCO_GL unset"
        hint = _GL_HINTS.get(backend, "run with MUJOCO_GL=egl (libegl1) or osmesa")
        leave_out = ", or leave out --video" if what == "the video" else ""
        raise SimError(f"cannot render {what}: no OpenGL here ({name}: {reason}); "
                       f"{hint}{leave_out}") from None
    finally:
        visual.offwidth, visual.offheight = buffer
    try:
        yield renderer
    finally:
        renderer.close()


@contextmanager
def _context_class(backend: str) -> Iterator[None]:
    """Make ``mujoco.Renderer`` use ``backend``'s GL context class while the block runs, if
    MuJoCo chose another one when it was imported (the module docstring says why)."""
    module = _BACKENDS.get(backend)
    # the module whose GLContext the Renderer reads when it is made (mujoco 4:
    # mujoco.rendering.classic.gl_context)
    holder = getattr(sys.modules.get(getattr(mujoco.Renderer, "__module__", "")),
                     "gl_context", None)
    current = getattr(holder, "GLContext", None)
    if module is None or holder is None or getattr(current, "__module__", None) == module:
        yield
        return
    holder.GLContext = importlib.import_module(module).GLContext
    try:
        yield
    finally:
        holder.GLContext = current


def _check_size(path: Path, width: int, height: int, *, video: bool) -> None:
    """Refuse a size that is not two integers > 0, or, for a video, an odd one (OpenCV's
    writer drops an odd last row or column without a word)."""
    for name, value in (("width", width), ("height", height)):
        if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
            raise SimulationError(f"{path}: {name} must be a number of pixels > 0, "
                                  f"got {value!r}")
    if video and (width % 2 or height % 2):
        raise SimulationError(f"{path}: {width}x{height} has an odd side, which the video "
                              "writer would drop; give an even width and height")


def _rows(path: Path, model: Any, qpos: np.ndarray) -> np.ndarray:
    """``qpos`` as a (frames, nq) float array with at least one finite row, or refused."""
    rows = np.asarray(qpos, dtype=float)
    if rows.ndim != 2 or rows.shape[1] != model.nq or rows.shape[0] == 0:
        raise SimulationError(f"{path}: qpos must be (frames, {model.nq}): one row of the "
                              f"model's {model.nq} positions a frame, got shape {rows.shape}")
    bad = np.flatnonzero(~np.isfinite(rows).all(axis=1))
    if bad.size:
        raise SimulationError(f"{path}: qpos row {bad[0]} is not finite ({bad.size} such "
                              "rows); cut the run before the simulation diverged")
    return rows


def _check_folder(path: Path) -> None:
    """Refuse a file in a folder that does not exist (OpenCV would only say it cannot open
    it)."""
    if not path.parent.is_dir():
        raise SimulationError(f"{path}: the folder {path.parent} does not exist; create it "
                              "or write somewhere else")
