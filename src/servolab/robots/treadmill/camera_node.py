"""The treadmill's camera as a node: frames from any source published as
``sensor_msgs/msg/Image`` (``mono8``) on ``/image_raw``, where Listing 1's ``image_converter``
subscribes (and where a ROS camera driver, such as the thesis's ``pointgrey_camera_driver``
of Listing 3, would publish instead of this node).

Each frame's stamp is its capture time, which the tracker's timing rests on
(:mod:`.timing`):

- a **recording** (a video, a folder of images, the thesis's ``Fly_Image.bin``) or the
  **simulated camera** is read on a timer at the camera's frame rate; a video's frames are
  stamped with its own timestamps (``CAP_PROP_POS_MSEC``) counted from the first frame's
  publication, other sources with the time they were read;
- a **live camera** (``live=True``) is read on a thread of its own, since a read waits for
  the device's next frame: each frame is stamped with the clock's time at capture (the
  source's capture clock, carried over to the node's clock by the frame's age).

With ``record``, every frame read is also written there (``--record-video``): written by the
reader, not by a subscriber, so none is dropped by a queue.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Mapping
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from ...middleware.context import Context
from ...middleware.images import IMAGE, image_fields
from ...middleware.messages import time_of
from ...middleware.node import Node
from ..errors import RobotValueError

FRAME_ID = "camera"


class Recorder(Protocol):
    def write(self, image: npt.NDArray[np.uint8]) -> None: ...


class CameraNode(Node):
    """See the module docstring. ``source`` is a frame source with ``read()`` (a
    :class:`~servolab.vision.frame_source.FrameSource`: frames with ``image`` and ``stamp``)
    or a plain callable returning an image (the simulated camera); ``None`` from either ends
    the frames (:attr:`finished`)."""

    def __init__(self, context: Context, source: Any, *, frame_rate: float,
                 live: bool = False, record: Recorder | None = None,
                 source_stamps: bool = True,
                 capture_clock: Callable[[], float] = time.monotonic,
                 name: str = "camera", namespace: str = "/", topic: str = "/image_raw",
                 parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        if not frame_rate > 0:
            raise RobotValueError(f"camera: frame_rate {frame_rate!r} must be > 0 frames/s")
        self.source, self.record = source, record
        self.frame_rate = float(frame_rate)
        self.capture_clock = capture_clock
        #: a recording's stamps are used; False: frames are stamped when read (a rate given
        #: by hand overrides the video's own)
        self.source_stamps = source_stamps
        self.published = 0
        self.finished = False
        #: an error reading the source (a bad frame mid-video): the run reports it
        self.error: BaseException | None = None
        self._first: tuple[float, float] | None = None  # (source stamp, node time)
        self.publisher = self.create_publisher(IMAGE, topic, 1)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        if live:
            self._thread = threading.Thread(target=self._read_live, name=f"{name} reader",
                                            daemon=True)
            self._thread.start()
        else:
            self._timer = self.create_timer(1.0 / self.frame_rate, self._tick)

    def _read(self) -> tuple[npt.NDArray[np.uint8], float | None] | None:
        if hasattr(self.source, "read"):
            frame = self.source.read()
            return None if frame is None else (frame.image, frame.stamp)
        image = self.source()
        return None if image is None else (image, None)

    def _end(self, error: BaseException | None = None) -> None:
        self.error = error
        self.finished = True
        self.context.executor.wake()

    def _tick(self) -> None:
        if self.finished:
            return
        try:
            got = self._read()
        except Exception as error:  # a frame that cannot be read: the frames end here
            self._end(error)
            return
        if got is None:
            self._timer.cancel()
            self._end()
            return
        image, stamp = got
        now = self.now()
        if stamp is not None and self.source_stamps:  # its own time, from its first frame
            if self._first is None:
                self._first = (stamp, now)
            now = self._first[1] + (stamp - self._first[0])
        self._publish(image, now)

    def _read_live(self) -> None:
        while not self._stop.is_set():
            try:
                got = self._read()
            except Exception as error:
                self._end(error)
                return
            if got is None:
                self._end()
                return
            image, stamp = got
            if self._stop.is_set():  # the node is going: its publisher may be gone
                return
            now = self.now()
            if stamp is not None:  # captured a moment ago on the capture clock
                now -= max(0.0, self.capture_clock() - stamp)
            self._publish(image, now)

    def _publish(self, image: npt.NDArray[np.uint8], stamp: float) -> None:
        if self.record is not None:
            self.record.write(image)
        self.publisher.publish(self.message(IMAGE, **image_fields(image, time_of(stamp),
                                                                  FRAME_ID)))
        self.published += 1

    def destroy(self) -> None:
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        super().destroy()
