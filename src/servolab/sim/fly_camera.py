"""The treadmill's camera in simulation: each call draws the fly where the world has it.

It belongs to the world (it reads :class:`~.ball.BallWorld`'s truth, which nothing on the
rig's side may) and gives what the rig's NIR camera gives: a 640 x 376 mono8 dark-field frame
with sensor noise (:func:`servolab.vision.fly_render.render_fly`). Its frames are the only way
the fly's position reaches the controller.
"""

from __future__ import annotations

import contextlib

import cv2
import numpy as np
import numpy.typing as npt

from ..vision.fly_render import FlyPose, render_fly
from .ball import BallWorld
from .errors import SimulationError
from .simulation import Simulation

#: frames of sensor noise drawn once and cycled: drawing 640 x 376 normal samples per frame
#: took half of a simulated frame's time, and no analysis here depends on noise that does not
#: repeat after half a second
NOISE_FRAMES = 32


class SimulatedFlyCamera:
    """``camera()`` -> the current frame of ``world``, with seeded Gaussian sensor noise of
    ``noise_std`` grey levels (:data:`NOISE_FRAMES` noise frames, cycled)."""

    def __init__(self, world: BallWorld, *, noise_std: float = 4.0, seed: int = 0,
                 simulation: Simulation | None = None) -> None:
        if not (np.isfinite(noise_std) and noise_std >= 0):
            raise SimulationError(f"noise_std {noise_std!r} must be >= 0 grey levels")
        self.world = world
        #: held while the fly's pose is read, when the simulation steps on its own thread (real
        #: time): x, y and theta then come from one step, not two
        self.lock: contextlib.AbstractContextManager[object] = (
            simulation.lock if simulation is not None else contextlib.nullcontext())
        self.noise_std = noise_std
        width, height = world.image_size
        rng = np.random.default_rng(seed)
        noise = np.rint(rng.normal(0.0, noise_std, (NOISE_FRAMES, height, width)))
        # kept as the positive and the negative part, each added with OpenCV's saturating
        # arithmetic: the same as clip(frame + noise, 0, 255), without int16 round trips
        self.brighter = np.clip(noise, 0, 255).astype(np.uint8)
        self.darker = np.clip(-noise, 0, 255).astype(np.uint8)
        self.frames = 0

    def __call__(self) -> npt.NDArray[np.uint8]:
        w = self.world
        with self.lock:
            pose = FlyPose(w.fly_x, w.fly_y, w.fly_theta)
        clean, _ = render_fly(pose, size=w.image_size, px_per_mm=w.px_per_m / 1000.0)
        k = self.frames % NOISE_FRAMES
        self.frames += 1
        out = cv2.subtract(cv2.add(clean, self.brighter[k]), self.darker[k])
        return np.asarray(out, dtype=np.uint8)
