"""What vectorising the walking-pattern generator buys: the time to generate a walk of N steps
(half cycles, seed 001 Appendix D) and solve both legs' inverse kinematics and motor angles
(Appendix E), through ``servolab.gait.walking.generate_walk`` (numpy, whole arrays), against a
per-sample Python loop of the same maths (Appendix D statement by statement, the closed-form
leg of seeds/README.md with ``math``, the same motor signs and arm swing).

Both are timed in the same run, best of a few repeats, so their ratio carries over to other
machines better than the absolute figures. The loop's result is checked against the
vectorised one (the run fails if they differ by more than 1e-9 degrees).

Run: ``.venv/bin/python benchmarks/gait.py [--quick]``.
"""

from __future__ import annotations

import argparse
import math
import platform
import sys
import timeit
from collections.abc import Sequence

import numpy as np

from servolab.gait.walking import GaitParameters, generate_walk
from servolab.kinematics.leg import ARMSTRONG_LEG, LegGeometry

FULL_STEPS, QUICK_STEPS = 1000, 20
LEFT_SIGNS = (1.0, -1.0, 1.0, -1.0, 1.0, -1.0)   # m11..m16 (seeds/README.md)
RIGHT_SIGNS = (1.0, -1.0, 1.0, 1.0, -1.0, -1.0)  # m21..m26

Point = tuple[float, float, float]


def loop_feet(p: GaitParameters, leg: LegGeometry) -> tuple[list[Point], list[Point]]:
    """Appendix D, one sample at a time."""
    z0 = -(leg.length - p.d_step)
    x1, y1, z1, x2, y2, z2 = p.l_step / 2, -p.y_start, z0, -p.l_step / 2, p.y_start, z0
    left, right = [(x1, y1, z1)], [(x2, y2, z2)]
    for half in range(1, p.c_step + 1):
        for phase in range(1, 5):
            sign = (-1) ** (4 * half - 4 + phase)
            if phase in (1, 4):
                n1, n2 = (x1, y1 + sign * p.s_step, z1), (x2, y2 - sign * p.s_step, z2)
            else:
                sway = sign * p.s_step * p.h_step / (leg.length - p.d_step)
                lift = p.h_step if phase == 2 else -p.h_step
                n1 = (x1 - p.l_step / 2, y1 + sway, z1)
                n2 = (x2 + p.l_step / 2, y2 - sway, z2 + lift)
            if half % 2 == 0:
                right.append((n1[0], n2[1] + p.d_step / 2, n1[2]))
                left.append((n2[0], n2[1] - p.d_step / 2, n2[2]))
            else:
                right.append((n2[0], n1[1] + p.d_step / 2, n2[2]))
                left.append((n1[0], n1[1] - p.d_step / 2, n1[2]))
            (x1, y1, z1), (x2, y2, z2) = n1, n2
            if phase == 4:
                x1, x2 = n2[0], n1[0]
    return left, right


def loop_motors(target: Point, leg: LegGeometry, signs: Sequence[float]) -> list[float]:
    """One foot: flat-foot IK in degrees, then the motor columns m?1..m?6."""
    x, y, z = target
    height = -(z + leg.l1 + leg.l4)
    distance = math.sqrt(x * x + y * y + height * height)
    if height <= 0 or distance > leg.l2 + leg.l3:
        raise ValueError(f"foot position {target} is out of reach")
    roll = math.atan2(y, height)
    at_hip = math.acos(min(1.0, (leg.l2**2 + distance**2 - leg.l3**2)
                           / (2 * leg.l2 * distance)))
    inner = math.acos(max(-1.0, min(1.0, (leg.l2**2 + leg.l3**2 - distance**2)
                                     / (2 * leg.l2 * leg.l3))))
    hip = math.atan2(x, math.hypot(y, height)) + at_hip
    knee = math.pi - inner
    joints = (0.0, hip, roll, knee, knee - hip, roll)  # motor order: yaw, pitch, roll, ...
    return [math.degrees(q) * s for q, s in zip(joints, signs, strict=True)]


def loop_walk(p: GaitParameters, leg: LegGeometry = ARMSTRONG_LEG) -> list[list[float]]:
    left, right = loop_feet(p, leg)
    rows = []
    for index, (lf, rf) in enumerate(zip(left, right, strict=True)):
        swing = p.arm_swing if index % 2 == 0 else -p.arm_swing
        upper = [swing, 0.0, 0.0, swing, 0.0, 0.0, 0.0, 0.0, 0.0]
        rows.append(loop_motors(lf, leg, LEFT_SIGNS) + loop_motors(rf, leg, RIGHT_SIGNS)
                    + upper)
    return rows


def best_time(work: object, repeat: int) -> float:
    return min(timeit.repeat(work, number=1, repeat=repeat))  # type: ignore[arg-type]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true",
                        help=f"{QUICK_STEPS} steps, one repeat: checks that it runs")
    args = parser.parse_args(argv)
    steps = QUICK_STEPS if args.quick else FULL_STEPS
    repeat = 1 if args.quick else 5
    params = GaitParameters(c_step=steps)

    vectorised = generate_walk(params).motors
    looped = np.asarray(loop_walk(params))
    error = float(np.max(np.abs(vectorised - looped)))
    t_vec = best_time(lambda: generate_walk(params), repeat)
    t_loop = best_time(lambda: loop_walk(params), repeat)
    samples = vectorised.shape[0]

    print(f"servolab gait benchmark: Python {platform.python_version()}, numpy "
          f"{np.__version__}, {platform.machine()}{' (quick)' if args.quick else ''}")
    print(f"{steps} steps = {samples} samples x 21 motors (generate + IK of both legs)")
    print(f"vectorised (numpy):  {t_vec * 1e3:9.3f} ms  ({t_vec / samples * 1e6:.2f} us/sample)")
    print(f"per-sample loop:     {t_loop * 1e3:9.3f} ms  ({t_loop / samples * 1e6:.2f} us/sample)")
    print(f"ratio loop / vectorised: x{t_loop / t_vec:.1f}")
    print(f"largest difference between the two: {error:.2e} deg")
    return 0 if error < 1e-9 and math.isfinite(t_loop / t_vec) else 1


if __name__ == "__main__":
    sys.exit(main())
