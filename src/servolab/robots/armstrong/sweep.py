"""Does a gait stand whatever the seed left unsaid? One motion walked in the MuJoCo world
under many sets of the description's assumptions.

Seed 001 gives the leg's lengths and the motors, not the masses, the hip's width or the
feet's size (:class:`~.description.Assumptions` states a guess for each). A gait that walks
under one guess may fall under another, so :func:`sweep` walks the same motion under every
combination of a few values of the three that matter most for balance — every guessed mass
scaled (the 72 g servos are the datasheet's and stay), the hip width, the feet scaled in
length and width — and reports for each whether it fell, when, and over which edge.

Each walk is :class:`~.control_node.Armstrong` in the MuJoCo world, standing up (Table 4.2)
and playing the motion, as ``servolab walk --world mujoco`` does, without the recording.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any

from ...gait.errors import GaitValueError
from ...gait.motionfile import MotionFile
from ..errors import RobotValueError
from .control_node import PLAY_RATE, Armstrong
from .description import Assumptions
from .physics_report import physics_summary

#: The sweep's values: every guessed mass x 0.5, 1, 1.5 (the issue's +-50 %); the hip width
#: from a tight 90 mm (two RX-28 side by side with brackets need about 75) to a wide 120 mm;
#: the feet 0.8, 1 and 1.2 times the stated 120 x 70 mm.
MASS_SCALES = (0.5, 1.0, 1.5)
HIP_WIDTHS = (0.09, 0.10, 0.12)
FOOT_SCALES = (0.8, 1.0, 1.2)


@dataclass(frozen=True)
class Case:
    """One set of the unknowns, relative to the stated :class:`Assumptions`."""

    mass_scale: float = 1.0
    hip_width: float | None = None      # m; None: the stated one
    foot_scale: float = 1.0

    def assumptions(self, base: Assumptions | None = None) -> Assumptions:
        """The stated assumptions (or ``base``) with this case's changes; refused, naming the
        value, where they make no robot (feet wider than the hips)."""
        a = base or Assumptions()
        masses = {f.name: getattr(a, f.name) * self.mass_scale for f in fields(a)
                  if f.name.endswith("_mass")}
        return replace(a, **masses,
                       hip_width=a.hip_width if self.hip_width is None else self.hip_width,
                       foot_length=a.foot_length * self.foot_scale,
                       foot_width=a.foot_width * self.foot_scale)

    @property
    def label(self) -> str:
        hip = "stated" if self.hip_width is None else f"{self.hip_width * 1000:g} mm"
        return f"masses x{self.mass_scale:g}, hip {hip}, feet x{self.foot_scale:g}"


def cases(mass_scales: Iterable[float] = MASS_SCALES,
          hip_widths: Iterable[float] = HIP_WIDTHS,
          foot_scales: Iterable[float] = FOOT_SCALES) -> list[Case]:
    """Every combination of the values given."""
    return [Case(m, h, f) for m, h, f in itertools.product(mass_scales, hip_widths,
                                                           foot_scales)]


def walk_once(motion: MotionFile, case: Case = Case(), *, steps: int = 1,
              rate: float = PLAY_RATE, config: str | Path | None = None,
              settle: float = 1.0) -> dict[str, Any]:
    """Stand up, play ``motion`` ``steps`` times at ``rate``, then stand ``settle`` s more
    (a robot that tips on the last row falls after it): the physics summary
    (:func:`~.physics_report.physics_summary`) with the case's values."""
    assumptions = case.assumptions()
    with Armstrong(world="mujoco", config=config, assumptions=assumptions) as robot:
        robot.stand()
        start = robot.context.clock.now()
        robot.play(motion, steps, rate)
        end = robot.context.clock.now()
        if not robot.fallen:
            robot.context.spin_until(lambda: robot.fallen, timeout=settle)
        physics = robot.physics
        assert physics is not None
        summary = physics_summary(physics.world, physics.description, start, end)
    summary.pop("joints")
    return {"case": asdict(case), "label": case.label, **summary}


#: A gait made for the robot a case describes: (motion, rows a second to play it at).
MakeGait = Callable[[Case], tuple[MotionFile, float]]


def sweep(motion: MotionFile | MakeGait, sweep_cases: Sequence[Case], *, steps: int = 1,
          rate: float = PLAY_RATE, config: str | Path | None = None,
          progress: Callable[[int, int], None] | None = None) -> list[dict[str, Any]]:
    """:func:`walk_once` for each case, in order. ``motion`` is one motion for every case
    (the seed's, which knows no robot), or a function making one for each case's robot
    (servolab's own gait, planned with the case's hip width and centre of mass); a case
    that makes no robot, or for which no gait can be made, is reported as such
    (``"refused"``, the one-line reason) rather than walked."""
    results = []
    for k, case in enumerate(sweep_cases):
        try:
            played, played_rate = (motion, rate) if isinstance(motion, MotionFile) \
                else motion(case)
            results.append(walk_once(played, case, steps=steps, rate=played_rate,
                                     config=config))
        except (RobotValueError, GaitValueError) as error:
            results.append({"case": asdict(case), "label": case.label,
                            "refused": str(error)})
        if progress is not None:
            progress(k + 1, len(sweep_cases))
    return results
