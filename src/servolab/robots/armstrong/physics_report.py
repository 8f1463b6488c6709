"""What a walk in the MuJoCo world comes to: did the robot fall, when, over which edge of its
feet, how far its torso went, how hard each joint worked — for ``summary.json``, a plot and a
video.

Everything here is read from the world's samples (:attr:`MujocoWorld.samples
<servolab.sim.mujoco_world.MujocoWorld.samples>`, 50 a second): the ground truth, not the
motors' readings over the bus.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ...sim.mujoco_world import MujocoWorld, Sample
from .description import Description

if TYPE_CHECKING:
    from .physics import Physics

#: A foot carries weight when the floor pushes it with more than this (N): the robot's weight
#: is about 20 N, so 1 N is a toe touching.
FOOT_DOWN_N = 1.0
#: How far back from the fall the cause is looked for (s): a biped that tips goes over in
#: about half a second (its pendulum's time constant, sqrt(0.27 m / g), is 0.17 s).
CAUSE_WINDOW_S = 1.0
#: A zero-moment point this near the support polygon's edge (m) is on it: the foot is
#: pivoting on that edge (the point cannot be outside while the foot is flat, only on the
#: edge while it tips; the momentum's 20 ms differences scatter it by about a millimetre).
EDGE_M = 0.002


def physics_summary(world: MujocoWorld, description: Description, gait_start: float,
                    gait_end: float) -> dict[str, Any]:
    """The walk's physics for ``summary.json``; ``gait_start``/``gait_end`` are the times
    (simulation s) the motion's first row was sent and its last row played."""
    samples = world.samples
    if not samples:
        return {"world": "mujoco", "fell": False, "fell_at_s": None}
    fell_at = world.fell_at
    fall = _fall(world, samples, fell_at) if fell_at is not None else {}
    standing = [s for s in samples if not s.fallen]
    during = [s for s in standing if gait_start <= s.t <= gait_end] or standing[-1:]
    first = _at(samples, gait_start)
    # how far it walked: up to where it began to tip, not where the fall threw it
    upright = fall.get("tipping_from_s", math.inf)
    last = ([s for s in standing if s.t <= upright] or standing or samples)[-1]
    summary: dict[str, Any] = {
        "world": "mujoco",
        "fell": fell_at is not None,
        "fell_at_s": None if fell_at is None else round(fell_at, 3),
        "fell_after_gait_start_s": None if fell_at is None else round(fell_at - gait_start, 3),
        "torso_forward_m": round(last.base[0] - first.base[0], 4),
        "torso_sideways_m": round(last.base[1] - first.base[1], 4),
        "torso_turned_deg": round(math.degrees(math.remainder(last.base[5] - first.base[5],
                                                               2 * math.pi)), 1),
        "mass_kg": round(description.total_mass, 3),
    }
    margins = [(s.t, s.margin) for s in during if math.isfinite(s.margin)]
    if margins:
        t_min, m_min = min(margins, key=lambda p: p[1])
        summary["zmp_margin_min_m"] = round(m_min, 4)
        summary["zmp_margin_min_at_s"] = round(t_min, 3)
        summary["zmp_on_edge_share"] = round(sum(m < EDGE_M for _, m in margins)
                                             / len(margins), 3)
    summary.update(fall)
    loads = np.abs(np.array([s.load for s in samples]))
    temps = np.array([s.temperature for s in samples])
    summary["joints"] = {
        f"m{j.motor.id}": {"joint": j.joint, "peak_load": round(float(loads[:, k].max()), 3),
                           "peak_temperature_c": round(float(temps[:, k].max()), 2)}
        for k, j in enumerate(world.joints)}
    return summary


def served_figures(physics: Physics, plot: Path, now: float) -> dict[str, Any]:
    """What ``servolab sim --robot armstrong`` adds to its summary when it stops: the
    physics since it started (whatever walked the robot over the pty), and its plot."""
    released = physics.world.released_at
    return {"physics": physics_summary(physics.world, physics.description, 0.0, now),
            "fell": physics.world.fell_at is not None,
            # the harness held it until every servo's torque was on (None: never let go)
            "harness_released_at_s": None if released is None else round(released, 3),
            "physics_plot": str(plot_physics(physics.world, plot, 0.0))}


def _at(samples: list[Sample], t: float) -> Sample:
    for s in samples:
        if s.t >= t:
            return s
    return samples[-1]


def _fall(world: MujocoWorld, samples: list[Sample], fell_at: float) -> dict[str, Any]:
    """Which feet were down just before the fall, and why it fell: since when, in the
    :data:`CAUSE_WINDOW_S` before it, the zero-moment point had been on the support
    polygon's edge (:data:`EDGE_M`) — the robot pivoting over it — and which edge."""
    before = [s for s in samples if s.t < fell_at]
    last = before[-1] if before else samples[0]
    out: dict[str, Any] = {"feet_down_before_fall": [
        foot for foot, force in zip(world.feet, last.feet, strict=True) if force > FOOT_DOWN_N]}
    window = [s for s in before if s.t >= fell_at - CAUSE_WINDOW_S]
    tipping: Sample | None = None
    for s in reversed(window):   # back from the fall while the point is on the edge
        if math.isfinite(s.margin) and s.margin < EDGE_M:
            tipping = s
        elif math.isfinite(s.margin):
            break
    if tipping is None:
        out["fall_cause"] = ("the zero-moment point stayed inside the support polygon: the "
                             "robot was pushed over (a foot caught, or slid)")
        return out
    # which way it went: the centre of mass from where the tipping began to the fall
    dx, dy = last.com[0] - tipping.com[0], last.com[1] - tipping.com[1]
    way = ("forwards" if dx > 0 else "backwards") if abs(dx) >= abs(dy) else \
        ("to its left" if dy > 0 else "to its right")
    # over which edge: where the zero-moment point sat, last, from the support's middle
    edge_sample = next((s for s in reversed(window) if math.isfinite(s.margin)), tipping)
    ex, ey = (edge_sample.zmp[0] - edge_sample.support[0],
              edge_sample.zmp[1] - edge_sample.support[1])
    edge = ("front" if ex > 0 else "back") if abs(ex) >= abs(ey) else \
        ("left" if ey > 0 else "right")
    feet = [f for f, force in zip(world.feet, edge_sample.feet, strict=True)
            if force > FOOT_DOWN_N]
    out["tipping_from_s"] = round(tipping.t, 3)
    out["tipped"] = way
    out["fall_cause"] = (
        f"from {tipping.t:.2f} s the zero-moment point was on the edge of the support "
        f"polygon until the fall at {fell_at:.2f} s, last on its {edge} edge "
        f"({' and '.join(feet) if feet else 'no foot'} down): the robot pivoted over the "
        f"edge of its feet and fell {way}")
    return out


def plot_physics(world: MujocoWorld, path: Path, gait_start: float) -> Path:
    """Four panels over time: the zero-moment point's margin inside the support polygon;
    the centre of mass and the zero-moment point, forwards and sideways; the floor's force on
    each foot; the torso's height and tilt — with the gait's start and the fall marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    end = math.inf if world.fell_at is None else world.fell_at + 0.5
    samples = [s for s in world.samples if s.t <= end]   # on the floor, nothing to judge
    t = np.array([s.t for s in samples])
    figure, axes = plt.subplots(4, 1, figsize=(10, 11), sharex=True)
    margin, plane, feet, torso = axes
    margin.plot(t, [1000 * s.margin for s in samples], color="C0")
    margin.axhline(0.0, color="red", linestyle=":")
    margin.axhline(1000 * EDGE_M, color="orange", linestyle=":", label="on the edge")
    margin.set_ylabel("ZMP margin [mm]\n(> 0 inside)")
    margin.set_title("Inside the support polygon? (the zero-moment point's distance from "
                     "its edge)")
    for k, (name, colour) in enumerate((("forwards (x)", "C0"), ("sideways (y)", "C1"))):
        plane.plot(t, [1000 * s.com[k] for s in samples], color=colour, label=f"CoM {name}")
        plane.plot(t, [1000 * s.zmp[k] for s in samples], color=colour, alpha=0.5,
                   linestyle="--", label=f"ZMP {name}")
    plane.set_ylabel("[mm]")
    plane.legend(loc="upper left", fontsize="small", ncol=2)
    for k, foot in enumerate(world.feet):
        feet.plot(t, [s.feet[k] for s in samples], label=foot)
    feet.set_ylabel("floor's force [N]")
    feet.legend(loc="upper left", fontsize="small")
    torso.plot(t, [1000 * s.base[2] for s in samples], color="C2", label="height [mm]")
    tilt = torso.twinx()
    tilt.plot(t, [math.degrees(math.acos(max(-1.0, min(1.0, math.cos(s.base[3])
                                                      * math.cos(s.base[4])))))
                  for s in samples], color="C3", label="tilt [deg]")
    tilt.set_ylabel("tilt [deg]")
    torso.set_ylabel("torso height [mm]")
    torso.set_xlabel("time [s] (simulated)")
    for ax in axes:
        ax.axvline(gait_start, color="grey", linestyle="--", alpha=0.7)
        if world.fell_at is not None:
            ax.axvline(world.fell_at, color="red", alpha=0.7)
        ax.grid(True, alpha=0.3)
    figure.suptitle("Armstrong in MuJoCo: " + (f"fell at {world.fell_at:.2f} s"
                                               if world.fell_at is not None else "did not fall")
                    + " (grey: the gait starts)")
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)
    return path


#: Frames a second of a run's video (every other sample at 50 samples a second).
VIDEO_FPS = 25.0


def video_frames(world: MujocoWorld, fps: float = VIDEO_FPS) -> tuple[np.ndarray, float]:
    """The rows of ``qpos`` to render, one every ``1 / fps`` s as near as the samples allow,
    and the frame rate they make."""
    every = max(1, round(1.0 / (fps * world.record_period)))
    rows = np.array([s.qpos for s in world.samples[::every]])
    return rows, 1.0 / (every * world.record_period)


def render_walk(world: MujocoWorld, path: Path) -> Path:
    """The run as a video (``.mp4`` or ``.avi``), the camera following the pelvis."""
    from ...sim.mujoco_video import render_video

    rows, fps = video_frames(world)
    return render_video(world.model, rows, path, fps,
                        track_body=world.model.body(world.base).name)
