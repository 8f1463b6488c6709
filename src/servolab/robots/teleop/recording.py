"""The teleoperation's bag (its schema is in :mod:`servolab.robots.teleop`) and the camera on
the follower's MuJoCo world.

The loop only hands each sample over (:class:`EpisodeBag`'s methods put a tuple on a queue);
a thread of the bag's own builds the messages, serializes and writes them, and flushes the
open chunk every second, so that neither the loop's period nor its timing carry the cost of
the recording, and a killed run loses at most its last second. The camera renders in the
loop's thread (an OpenGL context belongs to the thread that made it), at ``camera_rate``; the
JPEG encoding is the bag thread's.
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import RobotError

if TYPE_CHECKING:
    from contextlib import ExitStack

    from ...sim.mujoco_world import MujocoWorld
    from .arms import ArmState

JOINT_STATE = "sensor_msgs/msg/JointState"
IMAGE = "sensor_msgs/msg/CompressedImage"
EPISODE = "std_msgs/msg/Int32"
#: the bag's topics and their types, in the order they are declared
TOPICS = {"/leader/joint_states": JOINT_STATE, "/follower/joint_commands": JOINT_STATE,
          "/follower/joint_states": JOINT_STATE, "/teleop/episode": EPISODE}
CAMERA_TOPIC = "/follower/camera/image/compressed"
#: the camera's frame id
CAMERA_FRAME = "follower_camera"
#: s between two flushes of the bag's open chunk
FLUSH_S = 1.0
#: JPEG quality of the camera's images (OpenCV's scale, 0 to 100)
JPEG_QUALITY = 90


class EpisodeBag:
    """``path``: the bag folder (rosbag2 layout, made here; refused if it holds anything).
    ``leader`` and ``follower`` are the arms' joint names, ``camera`` whether images come.
    Times are ROS times in seconds (the stamps and the log times)."""

    def __init__(self, path: Path, leader: Sequence[str], follower: Sequence[str], *,
                 camera: bool) -> None:
        from ...middleware.bag import BagWriter
        from ...middleware.messages import MessageTypes

        self.path = path
        self.types = types = MessageTypes()
        self.writer = BagWriter(path, types)
        for topic, kind in TOPICS.items():
            self.writer.add_topic(topic, kind)
        if camera:
            self.writer.add_topic(CAMERA_TOPIC, IMAGE)
        self.leader_names = list(leader)
        self.follower_names = list(follower)
        self.frames = 0
        self._queue: queue.SimpleQueue[tuple[Callable[..., None], tuple[Any, ...]] | None] = \
            queue.SimpleQueue()
        self._failed: BaseException | None = None
        self._thread = threading.Thread(target=self._drain, name="teleop bag", daemon=True)
        self._thread.start()

    # -- what the loop hands over (cheap: a tuple on a queue) ---------------------------------

    def leader(self, t: float, positions: Sequence[float]) -> None:
        self._queue.put((self._joints, ("/leader/joint_states", self.leader_names, t,
                                        positions, (), ())))

    def command(self, t: float, goals: Sequence[float]) -> None:
        self._queue.put((self._joints, ("/follower/joint_commands", self.follower_names, t,
                                        goals, (), ())))

    def follower(self, t: float, state: ArmState) -> None:
        self._queue.put((self._joints, ("/follower/joint_states", self.follower_names, t,
                                        state.position, state.velocity, state.effort)))

    def episode(self, t: float, k: int) -> None:
        self._queue.put((self._episode, (t, k)))

    def image(self, t: float, rgb: np.ndarray) -> None:
        self.frames += 1
        self._queue.put((self._image, (t, rgb)))

    # -- the bag's thread --------------------------------------------------------------------

    def _drain(self) -> None:
        flushed = time.monotonic()
        while True:
            item = self._queue.get()
            if item is None:
                return
            if self._failed is not None:
                continue  # the first failure is the one raised at close
            do, args = item
            try:
                do(*args)
                time.sleep(0)  # the GIL back to the loop between two messages
                if time.monotonic() - flushed > FLUSH_S:
                    self.writer.flush()
                    flushed = time.monotonic()
            except Exception as exc:  # raised by close(), in the loop's thread
                self._failed = exc

    def _write(self, topic: str, kind: str, fields: dict[str, Any], t: float) -> None:
        self.writer.write(topic, self.types.from_value(kind, fields), round(t * 1e9))

    def _joints(self, topic: str, names: list[str], t: float, position: Sequence[float],
                velocity: Sequence[float], effort: Sequence[float]) -> None:
        from ...middleware.messages import time_of

        self._write(topic, JOINT_STATE, {
            "header": {"stamp": time_of(t)}, "name": names, "position": list(position),
            "velocity": list(velocity), "effort": list(effort)}, t)

    def _episode(self, t: float, k: int) -> None:
        self._write("/teleop/episode", EPISODE, {"data": k}, t)

    def _image(self, t: float, rgb: np.ndarray) -> None:
        import cv2

        from ...middleware.messages import time_of

        ok, jpeg = cv2.imencode(".jpg", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR),
                                [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
        if not ok:
            raise RobotError("the camera's image could not be encoded as JPEG")
        self._write(CAMERA_TOPIC, IMAGE, {"header": {"stamp": time_of(t),
                                                     "frame_id": CAMERA_FRAME},
                                          "format": "jpeg", "data": jpeg.tobytes()}, t)

    def close(self) -> int:
        """Write what is queued, close the bag; returns the messages written. A write that
        failed in the bag's thread is raised here."""
        if self._thread.is_alive():
            self._queue.put(None)
            self._thread.join()
        self.writer.close()
        if self._failed is not None:
            raise RobotError(f"the bag {self.path}: {self._failed}") from self._failed
        return self.writer.message_count


#: the camera's view of the follower: from the front left, above, on the arm's workspace
#: (MuJoCo's free camera: the point looked at, m; distance, m; azimuth and elevation, deg)
LOOKAT, DISTANCE, AZIMUTH, ELEVATION = (0.12, 0.0, 0.12), 0.65, 150.0, -30.0


class FollowerCamera:
    """A fixed camera on the follower's world (a :class:`~servolab.sim.MujocoWorld`), drawn
    offscreen at ``width`` x ``height`` (:func:`servolab.sim.mujoco_video.offscreen`).
    ``lock`` is held while the scene is taken from the world's data (the simulation's, which
    its own thread steps in real time)."""

    def __init__(self, world: MujocoWorld, lock: Any, opened: ExitStack, *,
                 width: int = 320, height: int = 240) -> None:
        from ...sim import mujoco_video

        self.world = world
        self.lock = lock
        self.view = mujoco_video.camera(world.model, None, DISTANCE)
        self.view.lookat[:] = LOOKAT
        self.view.azimuth, self.view.elevation = AZIMUTH, ELEVATION
        self.renderer = opened.enter_context(mujoco_video.offscreen(world.model, width,
                                                                    height))

    def grab(self) -> np.ndarray:
        """The world now, RGB (height x width x 3)."""
        with self.lock:
            self.renderer.update_scene(self.world.data, self.view)
        image: np.ndarray = self.renderer.render()
        return image.copy()
