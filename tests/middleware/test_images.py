"""sensor_msgs/msg/Image to and from numpy (middleware/images.py), against OpenCV's own
conversions and rosbags' CDR round trip, the two things a ROS camera driver's frames pass."""

from __future__ import annotations

from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from servolab.middleware.images import IMAGE, ImageMessageError, image_fields, mono8_of
from servolab.middleware.messages import MessageTypes, time_of


def _message(**fields: object) -> SimpleNamespace:
    return SimpleNamespace(**fields)


def test_mono8_round_trips_through_cdr() -> None:
    image = np.random.default_rng(1).integers(0, 256, (376, 640), dtype=np.uint8)
    types = MessageTypes()
    msg = types.from_value(IMAGE, image_fields(image, time_of(12.5), "camera"))
    back = types.deserialize(types.serialize(msg, IMAGE), IMAGE)
    assert back.encoding == "mono8" and back.step == 640
    assert np.array_equal(mono8_of(back), image)


@pytest.mark.parametrize("encoding", ["bgr8", "rgb8"])
def test_colour_frames_become_grey_as_opencv_makes_them(encoding: str) -> None:
    colour = np.random.default_rng(2).integers(0, 256, (6, 5, 3), dtype=np.uint8)
    code = cv2.COLOR_BGR2GRAY if encoding == "bgr8" else cv2.COLOR_RGB2GRAY
    msg = _message(encoding=encoding, width=5, height=6, step=15, data=colour.reshape(-1))
    assert np.array_equal(mono8_of(msg), cv2.cvtColor(colour, code))


def test_a_padded_row_step_is_read() -> None:
    """A driver may pad each row (step > width): the padding is not the picture."""
    image = np.arange(12, dtype=np.uint8).reshape(3, 4)
    padded = np.hstack([image, np.full((3, 4), 255, np.uint8)])
    msg = _message(encoding="mono8", width=4, height=3, step=8, data=padded.reshape(-1))
    assert np.array_equal(mono8_of(msg), image)


@pytest.mark.parametrize(("fields", "says"), [
    ({"encoding": "16UC1", "width": 2, "height": 2, "step": 4, "data": np.zeros(8, np.uint8)},
     "encoding '16UC1' is not read"),
    ({"encoding": "mono8", "width": 4, "height": 3, "step": 4, "data": np.zeros(11, np.uint8)},
     "does not match its 11 bytes"),
    ({"encoding": "bgr8", "width": 4, "height": 1, "step": 4, "data": np.zeros(4, np.uint8)},
     "step 4"),
])
def test_a_bad_frame_is_one_line(fields: dict[str, object], says: str) -> None:
    with pytest.raises(ImageMessageError, match=says) as caught:
        mono8_of(_message(**fields))
    assert "\n" not in str(caught.value)


def test_only_grey_or_bgr_is_published() -> None:
    with pytest.raises(ImageMessageError, match="mono8"):
        image_fields(np.zeros((2, 2, 4), np.uint8), time_of(0.0), "camera")
