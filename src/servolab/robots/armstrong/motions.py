"""Armstrong's motions: the motion files and gaits it plays, checked against its joints'
configured limits before any motor moves.

Why apart from :mod:`.hardware`: the bus and configuration are what the description is built
on; a gait (:func:`zmp_motion`) is built on the description (its hip width, its centre of
mass). With both in one module, ``hardware`` and ``description`` imported each other; here
the order is one way: hardware -> description -> motions.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

from ...gait.motionfile import MotionFile, read_motion_file
from ...gait.walking import GaitParameters, generate_walk
from ...gait.zmp_walk import ZmpWalkParameters, generate_zmp_walk
from .description import Assumptions, describe, stand_com_offset
from .hardware import joint_limits, load_config
from .poses import MOTORS


def load_motion(path: str | Path | None, config: str | Path | None = None,
                parameters: GaitParameters | None = None) -> MotionFile:
    """The motion to play: the file at ``path`` (all 21 columns, within the configured
    joints' limits), or the seed's gait generated with ``parameters``."""
    limits = joint_limits(load_config(config))
    if path is not None:
        return read_motion_file(path, limits=limits, required=MOTORS)
    # checked against the same limits as a file, at generation (gait.walking)
    return generate_walk(parameters or GaitParameters(), limits=limits).motion()


def zmp_motion(steps: int = 10, config: str | Path | None = None,
               assumptions: Assumptions | None = None,
               parameters: ZmpWalkParameters | None = None) -> tuple[MotionFile, float]:
    """servolab's own gait (:mod:`servolab.gait.zmp_walk`, Kajita's preview control) for
    this robot: ``steps`` footsteps, with the hip width and the centre of mass's offset of
    the robot's description (under ``assumptions``), within the configured joints' limits.
    Returns the motion and the rate (rows a second) it must be played at."""
    a = assumptions if assumptions is not None else Assumptions()
    robot_config = load_config(config)
    base = parameters if parameters is not None else ZmpWalkParameters()
    # the legs' servos move at their controllers' joint_speed: the plan must not ask more
    legs = [min(c.joint_speed, c.joint_max_speed or math.inf)   # as the controller clamps
            for c in robot_config.controllers if f"m{c.motor.id}" in MOTORS[:12]]
    fitted = replace(base, steps=steps, hip_width=a.hip_width,
                     com_offset=stand_com_offset(describe(a, robot_config)),
                     max_joint_speed=min([base.max_joint_speed, *legs]))
    return generate_zmp_walk(fitted, joint_limits(robot_config)), fitted.rate
