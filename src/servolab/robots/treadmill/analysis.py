"""What seed 002's chapter 3 reports, computed from a run's two logs (``fly_data.bin``,
``robot_encoders.bin``), and its figures.

- **Distance error** (eq. 6): ``hypot(cx - 320, cy - 188) / 38.4`` mm per frame, averaged over
  the frames where the fly was found (its contour larger than the tracker's minimum); the
  thesis reports 1.821 mm.
- **Angle error**: ``|theta|`` in degrees, averaged the same way; the thesis reports 7.039°.
- **The sphere's path** (Figure 20): the three wheel encoders (``present_position``, 4096 ticks
  a turn on the X series) give each frame's wheel turns; eq. 3b turns them into the ball's
  surface motion (:class:`~servolab.kinematics.aot.AotKinematics`, from the rig's geometry),
  seen in the camera's frame; the fly walks against it, and the ball's turns about its axis
  turn the fly's heading: the fly's fictive path (:func:`fictive_path`).
- **The robot's path** (Figure 21): the wheel encoders of Listing 2's log through the
  differential drive's odometry.
- **How alike the two paths are**: both resampled to 200 points evenly spaced along their
  length, then the best translation, rotation and scale of one onto the other, as
  ``scipy.spatial.procrustes`` fits them but without its mirror image (:func:`path_disparity`):
  0 for the same shape, near 1 for unrelated ones. The thesis compares them by eye and notes
  that the robot "does not switch directions as much".
- **The response delay** (Figure 15): for each frame where the wheels are told to move after
  standing, the time until their encoders first show motion; the thesis measured about
  110 ms. Frames come every 15 ms and a slow wheel needs a while to turn one tick, so this
  measure reads up to a frame and a tick late (the simulator's 110 ms stiction reads as
  about 120 ms).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from ...kinematics.aot import AotGeometry, AotKinematics, surface_in_camera
from ...kinematics.diffdrive import DiffDrive
from ...vision.fly_tracker import DEFAULT_MAX_AREA, PX_PER_MM

if TYPE_CHECKING:
    from ...runs import RunFolder
    from .config import RigConfig

FloatArray = npt.NDArray[np.float64]
#: the X series' position resolution (e-Manual: 4096 ticks a revolution)
TICKS_PER_REV = 4096
#: seed 002 chapter 3
THESIS_DISTANCE_ERROR_MM = 1.821
THESIS_ANGLE_ERROR_DEG = 7.039
THESIS_DELAY_S = 0.110


@dataclass(frozen=True)
class FlyAnalysis:
    frames: int
    frames_with_fly: int
    duration_s: float
    mean_distance_error_mm: float
    mean_angle_error_deg: float
    sphere_path_length_m: float
    robot_path_length_m: float
    path_disparity: float
    response_delay_s: float
    response_events: int

    def summary(self) -> dict[str, Any]:
        out = asdict(self)
        out["thesis"] = {"mean_distance_error_mm": THESIS_DISTANCE_ERROR_MM,
                         "mean_angle_error_deg": THESIS_ANGLE_ERROR_DEG,
                         "response_delay_s": THESIS_DELAY_S}
        return out


def errors(fly: npt.NDArray[np.void], *, target: tuple[float, float] = (320.0, 188.0),
           px_per_mm: float = PX_PER_MM, min_area: float = 100.0,
           max_area: float | None = DEFAULT_MAX_AREA
           ) -> tuple[FloatArray, FloatArray, npt.NDArray[np.bool_]]:
    """Per frame: distance error (mm), angle error (deg), and whether the fly was found (its
    logged contour area within the tracker's bounds, :mod:`servolab.vision.fly_tracker`)."""
    area = fly["contour_area"]
    found = np.asarray((area > min_area) & (area <= (np.inf if max_area is None
                                                      else max_area)))
    distance = np.hypot(fly["cx"] - target[0], fly["cy"] - target[1]) / px_per_mm
    angle = np.degrees(np.abs(fly["theta"]))
    return np.asarray(distance, dtype=np.float64), np.asarray(angle, dtype=np.float64), found


def _unwrapped_turns(positions: FloatArray) -> FloatArray:
    """Encoder ticks to wheel angle (rad), unwrapped across the register's wrap."""
    angle = positions * (2 * math.pi / TICKS_PER_REV)
    return np.asarray(np.unwrap(angle, period=TICKS_PER_REV * 2 * math.pi / TICKS_PER_REV),
                      dtype=np.float64)


def sphere_motion(fly: npt.NDArray[np.void], geometry: AotGeometry
                  ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(t, dt, (N-1, 3) surface motion per frame)`` from the wheels' encoders: each frame's
    change of the three wheel angles through eq. 3b (linear, so no division by a frame time
    can lose a tick), in the camera's image frame
    (:func:`~servolab.kinematics.aot.surface_in_camera`): x, y in m, theta in rad."""
    kinematics = AotKinematics.from_geometry(geometry)
    t = np.asarray(fly["time"], dtype=np.float64)
    wheels = np.column_stack([_unwrapped_turns(np.asarray(fly[f"position{i}"], dtype=float))
                              for i in (1, 2, 3)])
    motion = kinematics.ball_velocity(np.diff(wheels, axis=0).T)
    camera = surface_in_camera(motion, geometry).T
    return t[1:], np.diff(t), np.asarray(camera, dtype=np.float64)


def fictive_path(motion: FloatArray) -> FloatArray:
    """``(N + 1, 2)`` points (m) of the path the fly walked, rebuilt from the ball's surface
    motion per frame in the image frame, as the thesis's Figure 20 does: the fly walks
    against the surface (``-motion``), and each turn of the ball about its axis turns the
    fly's fictive heading the other way. Drawn seen from above with y up (image y
    negated), so that it turns the way the robot's odometry does."""
    if len(motion) == 0:
        return np.zeros((1, 2))
    turns = -motion[:, 2]
    heading = np.concatenate([[0.0], np.cumsum(turns)])[:-1] + turns / 2  # mid-step
    dx = -(motion[:, 0] * np.cos(heading) - motion[:, 1] * np.sin(heading))
    dy = -(motion[:, 0] * np.sin(heading) + motion[:, 1] * np.cos(heading))
    x = np.concatenate([[0.0], np.cumsum(dx)])
    y = np.concatenate([[0.0], np.cumsum(dy)])
    return np.column_stack([x, -y])


def robot_path(encoders: npt.NDArray[np.void], drive: DiffDrive,
               ticks_per_rev: int = TICKS_PER_REV) -> FloatArray:
    """``(N, 2)`` odometry of Listing 2's encoder log (left, right ticks)."""
    if len(encoders) == 0:
        return np.zeros((0, 2))
    rad = 2 * math.pi / ticks_per_rev
    left = np.diff(np.asarray(encoders["left"], dtype=np.float64)) * rad * drive.wheel_radius
    right = np.diff(np.asarray(encoders["right"], dtype=np.float64)) * rad * drive.wheel_radius
    ds = (left + right) / 2
    dtheta = (right - left) / drive.wheel_separation
    heading = np.concatenate([[0.0], np.cumsum(dtheta)])
    mid = heading[:-1] + dtheta / 2
    x = np.concatenate([[0.0], np.cumsum(ds * np.cos(mid))])
    y = np.concatenate([[0.0], np.cumsum(ds * np.sin(mid))])
    return np.column_stack([x, y])


def _length(path: FloatArray) -> float:
    return float(np.sum(np.hypot(*np.diff(path, axis=0).T))) if len(path) > 1 else 0.0


def _resample(path: FloatArray, count: int = 200) -> FloatArray:
    steps = np.hypot(*np.diff(path, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(steps)])
    u = np.linspace(0.0, s[-1], count)
    return np.column_stack([np.interp(u, s, path[:, 0]), np.interp(u, s, path[:, 1])])


def path_disparity(a: FloatArray, b: FloatArray) -> float:
    """How unlike the two paths' shapes are (see the module docstring): both resampled to 200
    points along their length, centred and scaled to unit size, then ``b`` turned onto ``a``
    by the best rotation -- a proper one: ``scipy.spatial.procrustes`` would also mirror,
    and a path turning left is not the shape of one turning right. The disparity is
    ``1 - (sum of the singular values, the last one signed)^2`` (Kabsch), 0 for the same
    shape; NaN when either path has (almost) no length."""
    if _length(a) < 1e-6 or _length(b) < 1e-6:
        return math.nan
    x, y = _resample(a), _resample(b)
    x, y = x - x.mean(axis=0), y - y.mean(axis=0)
    x, y = x / np.linalg.norm(x), y / np.linalg.norm(y)
    u, singular, vt = np.linalg.svd(y.T @ x)
    sign = 1.0 if np.linalg.det(u @ vt) >= 0 else -1.0
    fit = singular[0] + sign * singular[1]
    return float(max(0.0, 1.0 - fit * fit))


def response_delay(fly: npt.NDArray[np.void]) -> tuple[float, int]:
    """Mean time from a frame that starts the standing wheels to the first frame whose
    encoders moved (see the module docstring), and how many such starts there were."""
    t = np.asarray(fly["time"], dtype=np.float64)
    commanded = np.column_stack([np.trunc(fly[f"omega{i}"]) for i in (1, 2, 3)]) != 0
    positions = np.column_stack([np.asarray(fly[f"position{i}"]) for i in (1, 2, 3)])
    moved = np.zeros(len(t), dtype=bool)
    moved[1:] = np.any(positions[1:] != positions[:-1], axis=1)
    delays: list[float] = []
    k = 1
    while k < len(t):
        if commanded[k].any() and not commanded[k - 1].any() and not moved[k]:
            j = k + 1
            while j < len(t) and not moved[j] and commanded[j - 1].any():
                j += 1
            if j < len(t) and moved[j]:
                delays.append(float(t[j] - t[k]))
            k = j
        k += 1
    return (float(np.mean(delays)) if delays else math.nan, len(delays))


def analyze(fly: npt.NDArray[np.void], encoders: npt.NDArray[np.void], *,
            geometry: AotGeometry | None = None, drive: DiffDrive | None = None,
            min_area: float = 100.0, max_area: float | None = DEFAULT_MAX_AREA,
            target: tuple[float, float] = (320.0, 188.0),
            px_per_mm: float = PX_PER_MM
            ) -> tuple[FlyAnalysis, dict[str, FloatArray]]:
    """The figures of chapter 3 (see the module docstring) and the series the plots draw;
    the defaults are the thesis's rig (a run passes its own, :func:`analysed_run`)."""
    distance, angle, found = errors(fly, target=target, px_per_mm=px_per_mm,
                                    min_area=min_area, max_area=max_area)
    t_sphere, dt, motion = sphere_motion(fly, geometry or AotGeometry())
    sphere = fictive_path(motion)
    with np.errstate(divide="ignore", invalid="ignore"):
        velocity = np.where(dt[:, None] > 0, motion / dt[:, None], 0.0)
    robot = robot_path(encoders, drive or DiffDrive(0.033, 0.287))
    delay, events = response_delay(fly)
    t = np.asarray(fly["time"], dtype=np.float64)
    result = FlyAnalysis(
        frames=len(fly), frames_with_fly=int(found.sum()),
        duration_s=float(t[-1] - t[0]) if len(t) else 0.0,
        mean_distance_error_mm=float(distance[found].mean()) if found.any() else math.nan,
        mean_angle_error_deg=float(angle[found].mean()) if found.any() else math.nan,
        sphere_path_length_m=_length(sphere), robot_path_length_m=_length(robot),
        path_disparity=path_disparity(sphere, robot), response_delay_s=delay,
        response_events=events)
    series = {"t": t, "distance_mm": distance, "angle_deg": angle, "t_sphere": t_sphere,
              "sphere_velocity": velocity, "sphere_path": sphere, "robot_path": robot}
    return result, series


def plot_analysis(result: FlyAnalysis, series: dict[str, FloatArray], fly: npt.NDArray[np.void],
                  path: Path) -> Path:
    """Figures 14, 16, 18 (motors 1 and 2), 20 and 21 of the thesis, on one page."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t0 = series["t"][0] if len(series["t"]) else 0.0
    figure, axes = plt.subplots(3, 2, figsize=(11, 11))
    (a, b), (c, d), (e, f) = axes
    a.plot(series["t"] - t0, series["distance_mm"], lw=0.8, label="distance error (mm)")
    speed = np.hypot(series["sphere_velocity"][:, 0], series["sphere_velocity"][:, 1]) * 1000
    a2 = a.twinx()
    a2.plot(series["t_sphere"] - t0, speed, color="tab:orange", lw=0.6, alpha=0.7)
    a2.set_ylabel("sphere surface speed (mm/s)", color="tab:orange")
    a.set_title(f"distance error (Fig. 14): mean {result.mean_distance_error_mm:.3f} mm "
                f"(thesis {THESIS_DISTANCE_ERROR_MM})", fontsize=9)
    a.set_xlabel("t (s)")
    a.set_ylabel("mm")
    b.plot(series["t"] - t0, series["angle_deg"], lw=0.8)
    b2 = b.twinx()
    b2.plot(series["t_sphere"] - t0, series["sphere_velocity"][:, 2], color="tab:orange",
            lw=0.6, alpha=0.7)
    b2.set_ylabel("sphere angular velocity (rad/s)", color="tab:orange")
    b.set_title(f"angle error (Fig. 16): mean {result.mean_angle_error_deg:.2f}° "
                f"(thesis {THESIS_ANGLE_ERROR_DEG})", fontsize=9)
    b.set_xlabel("t (s)")
    b.set_ylabel("deg")
    for i, ax in ((1, c), (2, d)):
        ax.plot(series["t"] - t0, fly[f"omega{i}"], lw=0.8, label="input (goal_velocity)")
        positions = _unwrapped_turns(np.asarray(fly[f"position{i}"], dtype=float))
        dt = np.diff(series["t"])
        dt[dt <= 0] = np.nan
        out = np.diff(positions) / dt / (0.229 * 2 * math.pi / 60)
        ax.plot(series["t_sphere"] - t0, out, lw=0.6, alpha=0.7, label="output (encoder)")
        ax.set_title(f"motor {i}: input and output velocity (Fig. 18)", fontsize=9)
        ax.set_xlabel("t (s)")
        ax.set_ylabel("units of 0.229 rpm")
        ax.legend(fontsize=7)
    sphere, robot = series["sphere_path"], series["robot_path"]
    e.plot(sphere[:, 0] * 1000, sphere[:, 1] * 1000)
    e.set_title(f"sphere's path (Fig. 20): {result.sphere_path_length_m * 1000:.0f} mm",
                fontsize=9)
    e.set_xlabel("x (mm)")
    e.set_ylabel("y (mm)")
    e.set_aspect("equal", adjustable="datalim")
    f.plot(robot[:, 0], robot[:, 1], color="tab:green")
    f.set_title(f"robot's path (Fig. 21): {result.robot_path_length_m:.2f} m, shape "
                f"disparity to the sphere's {result.path_disparity:.2f}", fontsize=9)
    f.set_xlabel("x (m)")
    f.set_ylabel("y (m)")
    f.set_aspect("equal", adjustable="datalim")
    figure.tight_layout()
    figure.savefig(path, dpi=90)
    plt.close(figure)
    return path


def analysed_run(run_folder: RunFolder, fly_path: Path, encoder_path: Path, bag: Path | None,
                 rig: RigConfig | None = None) -> dict[str, Any]:
    """The run's logs read back and analysed with the run's ``rig`` (default the thesis's),
    the figure drawn: the summary's common part."""
    from .logs import read_encoder_log, read_fly_log

    fly_records, encoders = read_fly_log(fly_path), read_encoder_log(encoder_path)
    files = {"fly_data": str(fly_path), "robot_encoders": str(encoder_path),
             "bag": None if bag is None else str(bag)}
    if len(fly_records) < 2:
        return {"analysis": None, **files, "plot": None}
    if rig is None:
        result, series = analyze(fly_records, encoders)
    else:
        result, series = analyze(
            fly_records, encoders, geometry=rig.geometry, min_area=rig.tracker.min_area,
            max_area=rig.tracker.max_area, px_per_mm=rig.camera.px_per_mm,
            target=(rig.controller.target[0], rig.controller.target[1]))
    plot = plot_analysis(result, series, fly_records, run_folder.file("flyball.png"))
    return {"analysis": result.summary(), **files, "plot": str(plot)}
