"""The vision layer's errors.

Value errors are bad input (an image of the wrong kind, a board that cannot be found, a
point above the horizon, a recording that cannot be read), refused with one line:
``servolab`` exits 2 for them. :class:`~servolab.vision.calibration.CalibrationError` and
:class:`~servolab.vision.frame_source.FrameSourceError` are value errors of their modules.
"""

from __future__ import annotations

from ..errors import ServolabError


class VisionError(ServolabError):
    """Base of every error raised by :mod:`servolab.vision`."""


class VisionValueError(VisionError, ValueError):
    """An image, camera, point or parameter the vision cannot use; the message names it."""
