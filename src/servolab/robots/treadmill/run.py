"""``servolab flyball``'s run: seed 002's closed loop on a simulated fly, ball and robot.

One simulation owns the time of everything (:class:`~servolab.sim.Simulation`): the treadmill
(:class:`~servolab.sim.ball.BallWorld`, three emulated XM430-W210 wheels, IDs 100-102, at
1 Mbps) with a walking fly on it, its camera (:class:`~servolab.sim.fly_camera.
SimulatedFlyCamera`, 640 x 376 at 66 frames/s), and a TurtleBot3 Waffle
(the shipped ``turtlebot3_waffle`` base, its own emulated bus) on a floor. The nodes are the
thesis's (Figure 2):

- the camera PC's ``image_converter`` (:class:`~.node.TreadmillNode`): track, control,
  one SYNC_WRITE and one SYNC_READ on the treadmill's bus, ``/cmd_vel`` to the robot, the
  17-value record to ``fly_data.bin``;
- the robot's base node (:class:`~servolab.robots.base.node.BaseNode`): ``/cmd_vel`` to its wheels,
  ``/sensor_state`` with the encoders;
- Listing 2's ``mobrob_data_tracker`` (:class:`MobrobDataTracker`): each ``/sensor_state`` to
  ``robot_encoders.bin``.

The run folder then holds ``fly_data.bin``, ``robot_encoders.bin``, ``flyball_bag/`` (MCAP:
``/cmd_vel``, ``/fly/pose``, ``/treadmill/joint_states``, ``/sensor_state``, ``/odom``), the
analysis of :mod:`.analysis` in ``summary.json`` and its figures in ``flyball.png``.
"""

from __future__ import annotations

import math
import shutil
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ...harness import DeferredStop, RunEnding, stops_deferred
from ...middleware.context import Context
from ..errors import RobotError, RobotValueError
from . import ON_STOP
from .analysis import analysed_run
from .logs import EncoderLogWriter
from .node import (
    FRAME_RATE,
    TREADMILL_BAUDRATE,
    TreadmillNode,
    emulated_treadmill_bus,
    simulated_treadmill,
    stop_wheels,
)
from .rig import RECORDED, MobrobDataTracker

if TYPE_CHECKING:
    from ...runs import RunFolder
    from ...sim.fly_walk import FlyWalkConfig

Say = Callable[[str], None]


def run_flyball(run_folder: RunFolder, *, duration: float = 100.0, seed: int = 0,
                fly: FlyWalkConfig | None = None, say: Say = print,
                show_progress: bool = True, wheel_clamp: str = "scaled") -> dict[str, Any]:
    """Run the closed loop for ``duration`` simulated seconds (see the module docstring);
    returns the summary (the analysis and where the files are). ``wheel_clamp``
    ``"per-wheel"`` drives the robot as Listing 4 does (each wheel clamped on its own; see
    :mod:`servolab.robots.base.config`)."""

    from ...middleware.recorder import Recorder
    from ...sim import Simulation
    from ...sim.fly_camera import SimulatedFlyCamera
    from ...sim.fly_walk import FlyWalkConfig, FlyWalker
    from ..base.config import WHEEL_CLAMPS, shipped_base
    from ..base.config import load as load_base
    from ..base.mobile_base import MobileBase
    from ..base.node import BaseNode
    from .logs import FlyLogWriter

    if not (math.isfinite(duration) and duration > 0):
        raise RobotValueError(f"duration {duration!r} must be a number of seconds > 0")
    sim = Simulation()
    aot, world = simulated_treadmill(sim, FlyWalker(fly or FlyWalkConfig(), seed=seed))
    camera = SimulatedFlyCamera(world, seed=seed)
    if wheel_clamp not in WHEEL_CLAMPS:
        raise RobotValueError(f"wheel_clamp {wheel_clamp!r} must be one of "
                              f"{', '.join(WHEEL_CLAMPS)}")
    waffle = replace(load_base(shipped_base("turtlebot3_waffle")), wheel_clamp=wheel_clamp)
    base = MobileBase.emulated(waffle, sim)
    bag = run_folder.file("flyball_bag")
    if bag.exists():
        shutil.rmtree(bag)
    fly_path, encoder_path = run_folder.file("fly_data.bin"), run_folder.file("robot_encoders.bin")
    say(f"the fly walks on the simulated treadmill for {duration:g} s (seed {seed}); "
        "the robot follows the ball")
    node: TreadmillNode | None = None
    tracker: MobrobDataTracker | None = None
    ending = RunEnding(None)
    late = DeferredStop()
    summary: dict[str, Any] = {"duration_asked_s": duration, "seed": seed,
                               "wheel_clamp": wheel_clamp, "motors_on_stop": ON_STOP}
    with ExitStack() as way_out:
        with ending.step("closing the logs and the bag"), FlyLogWriter(fly_path) as fly_log, \
                EncoderLogWriter(encoder_path) as encoder_log, \
                Context.open(clock=sim) as context:
            try:
                node = TreadmillNode(context, aot, camera, log=fly_log)
                BaseNode(context, base)
                tracker = MobrobDataTracker(context, encoder_log)
                Recorder(context, str(bag), list(RECORDED))
                _spin(context, sim, duration, show_progress)
            except BaseException as error:  # a stop signal, a node's error: keep, analyse
                ending.error = error
            late = way_out.enter_context(stops_deferred())  # the way out is not cut short
            with ending.step("stopping the robot"):
                base.stop()
            with ending.step("stopping the treadmill"):
                stop_wheels(aot)
        with ending.step("analysing"):
            summary.update(analysed_run(run_folder, fly_path, encoder_path, bag))
        summary.update({"frames": node.frames if node is not None else 0,
                        "encoder_records": tracker.records if tracker is not None else 0,
                        "fly_walked_m": world.ground_truth()["fly_walked"]})
        run_folder.write_summary(summary, interrupted=ending.settle(late, summary))
    ending.raise_if_ended()
    a = summary["analysis"]
    if a is None:
        raise RobotError(f"{summary['frames']} frame(s) in {duration:g} s; the analysis "
                         "needs two")
    say(f"{summary['frames']} frames: mean distance error {a['mean_distance_error_mm']:.3f} mm "
        f"(thesis 1.821), mean angle error {a['mean_angle_error_deg']:.2f}° (thesis 7.039), "
        f"response delay {a['response_delay_s'] * 1000:.0f} ms (thesis about 110); "
        f"sphere path {a['sphere_path_length_m'] * 1000:.0f} mm, robot path "
        f"{a['robot_path_length_m']:.2f} m, shape disparity {a['path_disparity']:.2f}; "
        f"plot {summary['plot']}")
    return summary


def run_recorded(run_folder: RunFolder, frames: str | Path, *, port: str | None = None,
                 say: Say = print, show_progress: bool = True,
                 fps: float | None = None) -> dict[str, Any]:
    """Track a recording (a folder of images or a video, :class:`~servolab.vision.
    frame_source.FrameSource`) frame by frame, with the treadmill's motors emulated or, on
    ``port``, real (then by the wall clock). One record per frame in ``fly_data.bin``; no
    robot, so ``robot_encoders.bin`` stays empty. The recording is opened and checked before
    a motor is touched.

    The frames are played at the rate the recording was made at, since the controller divides
    by the time between frames: ``fps`` if given, else the video's own (``CAP_PROP_FPS``),
    else Listing 3's camera, 66 frames/s. ``summary.json`` says which (``time_base``)."""
    from ...clock import Clock, WallClock
    from ...dynamixel.bus import Bus
    from ...middleware.recorder import Recorder
    from ...sim import Simulation
    from ...vision.frame_source import FrameSource
    from .logs import FlyLogWriter

    if fps is not None and not (math.isfinite(fps) and fps > 0):
        raise RobotValueError(f"fps {fps!r} must be a number of frames a second > 0")
    source = FrameSource.open(frames)
    if fps is not None:
        frame_rate, time_base = fps, "given (--fps)"
    elif source.frame_rate is not None:
        frame_rate, time_base = source.frame_rate, "the video's own (CAP_PROP_FPS)"
    else:
        frame_rate = FRAME_RATE
        time_base = "assumed: Listing 3's camera (the recording says none)"
    clock: Clock
    if port is None:
        sim = Simulation()
        bus = emulated_treadmill_bus(sim)
        clock = sim
    else:
        bus = Bus.open(port, protocol=2, baudrate=TREADMILL_BAUDRATE)
        clock = WallClock()
    bag = run_folder.file("flyball_bag")
    if bag.exists():
        shutil.rmtree(bag)
    fly_path, encoder_path = run_folder.file("fly_data.bin"), run_folder.file("robot_encoders.bin")
    say(f"tracking {len(source) or 'the'} frames of {frames} at {frame_rate:g} frames/s "
        f"({time_base}) with the treadmill's motors {'on ' + port if port else 'emulated'}")
    from tqdm import tqdm

    node: TreadmillNode | None = None
    ending = RunEnding(None)
    late = DeferredStop()
    summary: dict[str, Any] = {"frames_source": str(frames), "port": port or "emulated",
                               "frame_rate_hz": frame_rate, "time_base": time_base,
                               "motors_on_stop": ON_STOP}
    with ExitStack() as way_out:
        with ending.step("closing the log, the bag and the port"):
            try:
                with FlyLogWriter(fly_path) as fly_log, EncoderLogWriter(encoder_path), \
                        Context.open(clock=clock) as context, \
                        tqdm(total=len(source) or None, unit="frame",
                             disable=not show_progress, leave=False) as bar:
                    try:
                        node = TreadmillNode(context, bus, source, log=fly_log,
                                             frame_rate=frame_rate)
                        Recorder(context, str(bag), ["/cmd_vel", "/fly/pose",
                                                     "/treadmill/joint_states"])
                        while not node.finished:
                            context.spin_until(lambda: node is not None and node.finished,
                                               timeout=1.0)
                            bar.update(node.frames - bar.n)
                            if not show_progress:  # a log (no terminal): a line a second
                                say(f"tracked {node.frames} of {len(source) or '?'} frames")
                    except BaseException as error:  # a bad frame mid-video, a stop
                        ending.error = error
                    late = way_out.enter_context(stops_deferred())  # not cut short
                    with ending.step("stopping the treadmill"):
                        stop_wheels(bus)  # whether or not the node got to start them
            finally:
                source.close()
                bus.close()
        with ending.step("analysing"):
            summary.update(analysed_run(run_folder, fly_path, encoder_path, bag))
        summary["frames"] = node.frames if node is not None else 0
        run_folder.write_summary(summary, interrupted=ending.settle(late, summary))
    ending.raise_if_ended()
    if summary["analysis"] is None:
        raise RobotError(f"{frames}: {summary['frames']} frame(s) tracked; the analysis "
                         "needs at least two")
    analysis = summary["analysis"]
    say(f"{summary['frames']} frames ({analysis['frames_with_fly']} with the fly): mean "
        f"distance "
        f"error {analysis['mean_distance_error_mm']:.3f} mm, mean angle error "
        f"{analysis['mean_angle_error_deg']:.2f}°; plot {summary['plot']}")
    return summary


def _spin(context: Context, sim: Any, duration: float, show_progress: bool) -> None:
    from tqdm import tqdm

    start = sim.now()
    with tqdm(total=round(duration, 1), unit="s", disable=not show_progress, leave=False,
              bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} s") as bar:
        while (elapsed := sim.now() - start) < duration:
            context.spin_for(min(1.0, duration - elapsed))
            bar.update(min(duration, sim.now() - start) - bar.n)
