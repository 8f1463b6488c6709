"""The treadmill's camera as a node: frames from any source published as
``sensor_msgs/msg/Image`` (``mono8``) on ``/image_raw``, where Listing 1's ``image_converter``
subscribes (and where a ROS camera driver, such as the thesis's ``pointgrey_camera_driver``
of Listing 3, would publish instead of this node).

Each frame's stamp is its capture time, which the tracker's timing rests on
(:mod:`.timing`), in ROS time (:meth:`~servolab.middleware.node.Node.stamp`: the epoch's in
real time, simulated time in a simulation):

- a **recording** (a video, a folder of images, the thesis's ``Fly_Image.bin``) is read on a
  timer at its frame rate. A video with its own timestamps (``CAP_PROP_POS_MSEC``) is stamped
  with them, any other recording (or any recording given a rate by hand) with ``sequence /
  frame_rate``, both counted from the first frame's publication: a late timer tick delays a
  frame, it does not move its capture time;
- the **simulated camera** renders the world as it is when read, so its frames are stamped
  when read;
- a **live camera** (``live=True``) is read on a thread of its own, since a read waits for
  the device's next frame: each frame is stamped with its capture time on the source's clock
  (the clock when ``grab()`` returned), carried over to the node's clock by its age. The
  frame read ahead when the camera was opened is dropped: it was taken before anything ran.

Each frame's number in its source (a video's frame index, a camera's count of grabs, the
published count for the simulated camera) is kept by stamp, so an in-process tracker can
tell the camera's sequence exactly (:meth:`CameraNode.sequence_at`; ROS 2 headers carry no
``seq``). With ``record``, every frame read is also written there (``--record-video``):
written by the reader, not by a subscriber, so none is dropped by a queue.
"""

from __future__ import annotations

import threading
import time
from collections import OrderedDict
from collections.abc import Callable, Mapping
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from ...middleware.context import Context
from ...middleware.images import IMAGE, image_fields
from ...middleware.node import Node
from ..errors import RobotValueError

FRAME_ID = "camera"
#: how many recent frames' numbers are kept by stamp (seconds of frames at any camera rate)
KEPT_SEQUENCES = 1024


class Recorder(Protocol):
    def write(self, image: npt.NDArray[np.uint8]) -> None: ...


class CameraNode(Node):
    """See the module docstring. ``source`` is a frame source with ``read()`` (a
    :class:`~servolab.vision.frame_source.FrameSource`: frames with ``image`` and ``stamp``)
    or a plain callable returning an image (the simulated camera); ``None`` from either ends
    the frames (:attr:`finished`)."""

    def __init__(self, context: Context, source: Any, *, frame_rate: float,
                 live: bool = False, record: Recorder | None = None,
                 source_stamps: bool = True, pace: bool = False,
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
        #: a recording's own stamps are used; False: ``sequence / frame_rate`` (a rate given by
        #: hand overrides the video's own)
        self.source_stamps = source_stamps
        self.published = 0
        #: frames the source skipped (gaps in its own numbering), and whether a live camera
        #: stopped delivering before the node was stopped
        self.skipped = 0
        self.camera_stopped = False
        self._live = live
        self.pace = pace
        self._sequences: OrderedDict[int, int] = OrderedDict()
        self._lock = threading.Lock()
        self._last_sequence: int | None = None
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

    def _read(self) -> tuple[npt.NDArray[np.uint8], float | None, int | None] | None:
        """The next frame: image, stamp (None: the source has none) and the source's number
        (None: the source has no numbering, as the simulated camera)."""
        if hasattr(self.source, "read"):
            frame = self.source.read()
            return None if frame is None else (frame.image, frame.stamp, frame.sequence)
        image = self.source()
        return None if image is None else (image, None, None)

    def sequence_at(self, stamp_ns: int) -> int | None:
        """The source's number of the frame published with this stamp (ns), while it is among
        the last :data:`KEPT_SEQUENCES`; None otherwise."""
        with self._lock:
            return self._sequences.get(stamp_ns)

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
        image, stamp, sequence = got
        now = self.now()
        if sequence is not None:  # a recording: its capture time, from its first frame's
            if not (stamp is not None and self.source_stamps):
                stamp = sequence / self.frame_rate
            if self._first is None:
                self._first = (stamp, now)
            now = self._first[1] + (stamp - self._first[0])
        self._publish(image, now, sequence)

    def _read_live(self) -> None:
        first = True
        next_read: float | None = None
        while not self._stop.is_set():
            if self.pace and next_read is not None:  # a file standing in for a camera
                self._stop.wait(max(0.0, next_read - self.capture_clock()))
                next_read += 1.0 / self.frame_rate
            try:
                got = self._read()
            except Exception as error:
                self._end(error)
                return
            if got is None:
                self.camera_stopped = not self._stop.is_set()
                self._end()
                return
            if first:  # read ahead at open, before anything ran: stale (module docstring)
                first = False
                next_read = self.capture_clock()
                continue
            image, stamp, sequence = got
            if self._stop.is_set():  # the node is going: its publisher may be gone
                return
            now = self.now()
            if stamp is not None:  # captured a moment ago on the capture clock
                now -= max(0.0, self.capture_clock() - stamp)
            self._publish(image, now, sequence)

    def _publish(self, image: npt.NDArray[np.uint8], stamp: float,
                 sequence: int | None) -> None:
        if sequence is None:
            sequence = self.published
        if self._last_sequence is not None and sequence > self._last_sequence + 1:
            self.skipped += sequence - self._last_sequence - 1
        self._last_sequence = sequence
        ros_stamp = self.stamp(stamp)  # the capture time, in ROS time
        with self._lock:
            self._sequences[ros_stamp["sec"] * 1_000_000_000 + ros_stamp["nanosec"]] = sequence
            if len(self._sequences) > KEPT_SEQUENCES:
                self._sequences.popitem(last=False)
        if self.record is not None:
            self.record.write(image)
        self.publisher.publish(self.message(IMAGE, **image_fields(image, ros_stamp, FRAME_ID)))
        self.published += 1

    def destroy(self) -> None:
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        super().destroy()
