"""``sensor_msgs/msg/Image`` to and from numpy arrays: what ``cv_bridge`` does for ROS nodes.

Why here, not in each node: a camera driver may send ``mono8``, ``bgr8`` or ``rgb8`` with a
row ``step`` wider than the image, and every node that takes frames must read them the same
way and refuse the same bad ones, with one line naming what was wrong.
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from ..errors import ServolabError

IMAGE = "sensor_msgs/msg/Image"
#: channels of each encoding read (sensor_msgs/image_encodings.hpp's names)
ENCODINGS = {"mono8": 1, "bgr8": 3, "rgb8": 3}


class ImageMessageError(ServolabError, ValueError):
    """An Image message that cannot be read as a picture."""


def image_fields(image: npt.NDArray[np.uint8], stamp: Any, frame_id: str) -> dict[str, Any]:
    """The fields of an Image message holding ``image`` (``mono8`` for 2-D, ``bgr8`` for
    3-channel, OpenCV's order), for ``node.message(IMAGE, **fields)``."""
    image = np.ascontiguousarray(image, dtype=np.uint8)
    if image.ndim == 2:
        encoding, channels = "mono8", 1
    elif image.ndim == 3 and image.shape[2] == 3:
        encoding, channels = "bgr8", 3
    else:
        raise ImageMessageError(f"an image to publish must be mono8 (h, w) or bgr8 (h, w, 3), "
                                f"not shape {image.shape}")
    height, width = image.shape[:2]
    return {"header": {"stamp": stamp, "frame_id": frame_id}, "height": height,
            "width": width, "encoding": encoding, "is_bigendian": 0, "step": width * channels,
            "data": image.reshape(-1)}


def mono8_of(msg: Any) -> npt.NDArray[np.uint8]:
    """The message's picture as a ``mono8`` array (colour converted as ``cv2.cvtColor`` does);
    an :class:`ImageMessageError` names what is wrong with a bad one."""
    encoding = str(msg.encoding)
    channels = ENCODINGS.get(encoding)
    if channels is None:
        raise ImageMessageError(f"image encoding {encoding!r} is not read; send one of "
                                f"{', '.join(ENCODINGS)}")
    width, height, step = int(msg.width), int(msg.height), int(msg.step)
    data = np.asarray(msg.data, dtype=np.uint8)
    if width <= 0 or height <= 0 or step < width * channels or data.size != step * height:
        raise ImageMessageError(f"image {width}x{height} {encoding} with step {step} does not "
                                f"match its {data.size} bytes of data")
    rows = data.reshape(height, step)[:, :width * channels]
    if channels == 1:
        return np.ascontiguousarray(rows)
    colour = rows.reshape(height, width, 3)
    code = cv2.COLOR_BGR2GRAY if encoding == "bgr8" else cv2.COLOR_RGB2GRAY
    return np.asarray(cv2.cvtColor(colour, code), dtype=np.uint8)
