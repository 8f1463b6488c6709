"""Plots of a generated walk like seed 001's Figure 5.6 (foot positions over time, Appendix D's
``figure(5)``) and Figure 5.8 (the legs' motor angles over time, Appendix E's ``figure(12)``),
and of a planned ZMP walk (footsteps, zero-moment point, centre of mass).

Pure except for writing the PNG file they are given. Matplotlib is imported inside the
functions (importing servolab.gait must stay cheap and must not need a display) and drawn on
an Agg canvas owned by the figure, so no global pyplot state or backend is touched.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from servolab.gait.walking import WalkingSequence
from servolab.gait.zmp_walk import ZmpWalkPlan
from servolab.kinematics.dh import FloatArray

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


def _figure(rows: int) -> Figure:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=(9.0, 3.2 * rows), layout="constrained")
    FigureCanvasAgg(figure)
    return figure


def _panel(axes: Axes, time_ms: FloatArray, series: FloatArray, labels: tuple[str, ...],
           title: str, ylabel: str) -> None:
    for column, label in enumerate(labels):
        axes.plot(time_ms, series[:, column], marker=".", label=label)
    axes.set_title(title)
    axes.set_xlabel("Time [ms]")
    axes.set_ylabel(ylabel)
    axes.grid(True)
    axes.legend(loc="upper right", fontsize="small")


def _save(figure: Figure, path: str | os.PathLike[str]) -> Path:
    target = Path(path)
    figure.savefig(target, format="png", dpi=100)
    return target


def plot_foot_positions(walk: WalkingSequence, path: str | os.PathLike[str]) -> Path:
    """Figure 5.6: x, y, z of the right foot (top) and the left foot (bottom) over time."""
    figure = _figure(2)
    top, bottom = figure.subplots(2, 1, sharex=True)
    feet = walk.feet
    for axes, positions, name in ((top, feet.right, "Right"), (bottom, feet.left, "Left")):
        _panel(axes, feet.time_ms, positions, ("x", "y", "z"),
               f"{name} Leg - Position xyz", "Position [mm]")
    return _save(figure, path)


def plot_joint_angles(walk: WalkingSequence, path: str | os.PathLike[str]) -> Path:
    """Figure 5.8: the motor angles m11..m16 (left leg, top) and m21..m26 (right leg,
    bottom) in degrees over time, as the robot receives them."""
    figure = _figure(2)
    top, bottom = figure.subplots(2, 1, sharex=True)
    for axes, first, name in ((top, 0, "Left"), (bottom, 6, "Right")):
        _panel(axes, walk.time_ms, np.asarray(walk.motors[:, first:first + 6]),
               walk.columns[first:first + 6], f"{name} Leg - motor angles", "Angle [deg]")
    return _save(figure, path)


def plot_zmp_walk(plan: ZmpWalkPlan, path: str | os.PathLike[str]) -> Path:
    """A planned ZMP walk (:mod:`servolab.gait.zmp_walk`): seen from above, the soles' places,
    the zero-moment point's reference and the centre of mass preview control makes of it;
    below, the sideways coordinate over time: the centre of mass sets off before the
    reference moves (the controller previews it: the mass must move before the point on
    the floor can) and follows it smoothed."""
    figure = _figure(2)
    top, bottom = figure.subplots(2, 1)
    mm = 1000.0
    for k, (name, marker) in enumerate((("left sole", "s"), ("right sole", "D"))):
        soles = plan.footsteps[:, k, :]
        top.plot(soles[:, 0] * mm, soles[:, 1] * mm, linestyle="none", marker=marker,
                 markersize=7, label=name)
    top.plot(plan.zmp_ref[:, 0] * mm, plan.zmp_ref[:, 1] * mm, label="ZMP reference")
    top.plot(plan.com[:, 0] * mm, plan.com[:, 1] * mm, label="centre of mass (planned)")
    top.set_title(f"Planned from above: {len(plan.footsteps) - 1} steps")
    top.set_xlabel("forward [mm]")
    top.set_ylabel("left [mm]")
    top.set_aspect("equal", adjustable="datalim")
    top.grid(True)
    top.legend(loc="upper left", fontsize="small", ncol=2)
    bottom.plot(plan.time, plan.zmp_ref[:, 1] * mm, label="ZMP reference")
    bottom.plot(plan.time, plan.zmp[:, 1] * mm, linestyle="--", label="ZMP of the plan")
    bottom.plot(plan.time, plan.com[:, 1] * mm, label="centre of mass")
    bottom.set_title("Sideways over time (preview control, Kajita et al. 2003)")
    bottom.set_xlabel("time [s]")
    bottom.set_ylabel("left [mm]")
    bottom.grid(True)
    bottom.legend(loc="upper right", fontsize="small")
    return _save(figure, path)
