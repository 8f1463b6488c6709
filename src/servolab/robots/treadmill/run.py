"""``servolab flyball``'s run: seed 002's closed loop on a simulated fly, ball and robot.

One simulation owns the time of everything (:class:`~servolab.sim.Simulation`): the treadmill
(:class:`~servolab.sim.ball.BallWorld`, three emulated XM430-W210 wheels, IDs 100-102, at
1 Mbps) with a walking fly on it, its camera (:class:`~servolab.sim.fly_camera.
SimulatedFlyCamera`, 640 x 376 at 66 frames/s), and a TurtleBot3 Waffle
(the shipped ``turtlebot3_waffle`` base, its own emulated bus) on a floor. The nodes are the
thesis's (Figure 2):

- the camera (:class:`~.camera_node.CameraNode`): the simulated camera's frames on
  ``/image_raw`` at the rig's frame rate;
- the camera PC's ``image_converter`` (:class:`~.node.TreadmillNode`): track, control,
  one SYNC_WRITE and one SYNC_READ on the treadmill's bus, ``/cmd_vel`` to the robot, the
  17-value record to ``fly_data.bin``;
- the robot's base node (:class:`~servolab.robots.base.node.BaseNode`): ``/cmd_vel`` to its wheels,
  ``/sensor_state`` with the encoders;
- Listing 2's ``mobrob_data_tracker`` (:class:`MobrobDataTracker`): each ``/sensor_state`` to
  ``robot_encoders.bin``.

The run folder then holds ``fly_data.bin``, ``robot_encoders.bin``, ``flyball_bag/`` (MCAP:
``/cmd_vel``, ``/fly/pose``, ``/treadmill/joint_states``, ``/sensor_state``, ``/odom``), the
analysis of :mod:`.analysis` and the frame timing of :mod:`.timing` in ``summary.json``,
and the figures in ``flyball.png``. The rig (ball, camera, tracker, controller) is
:mod:`.config`'s, the thesis's unless given. Stamps, the logs' times and the bag's are the
simulated time, which the run publishes on ``/clock`` for ROS tools with ``use_sim_time``
(:mod:`servolab.middleware.clock_node`).

With ``view`` (``servolab flyball --view``) the run's context is served to Foxglove while it
runs (:func:`~servolab.middleware.view.run_view.serve_run`): the camera's ``/image_raw``, the
tracker's overlay on ``/image_converter/output_video`` (drawn only while watched), ``/fly/pose``,
``/cmd_vel``, the robot's ``/odom`` and ``/tf``, and the rest of the graph.
"""

from __future__ import annotations

import math
import shutil
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ...harness import DeferredStop, RunEnding, stops_deferred
from ...middleware.clock_node import start_clock
from ...middleware.context import Context
from ..errors import RobotError, RobotValueError
from . import ON_STOP
from .analysis import analysed_run
from .camera_node import CameraNode
from .config import RigConfig
from .fictrac import FICTRAC_FILE, FicTracWriter
from .logs import EncoderLogWriter
from .node import (
    TREADMILL_BAUDRATE,
    TreadmillNode,
    emulated_treadmill_bus,
    simulated_treadmill,
    stop_wheels,
)
from .rig import RECORDED, MobrobDataTracker
from .timing import lost_fly_warning

if TYPE_CHECKING:
    from ...middleware.view.run_view import ViewRequest
    from ...middleware.view.server import ViewServer
    from ...runs import RunFolder
    from ...sim.fly_walk import FlyWalkConfig

Say = Callable[[str], None]


def run_flyball(run_folder: RunFolder, *, duration: float = 100.0, seed: int = 0,
                fly: FlyWalkConfig | None = None, say: Say = print,
                show_progress: bool = True, wheel_clamp: str = "scaled",
                rig: RigConfig | None = None,
                record_video: str | Path | None = None,
                view: ViewRequest | None = None) -> dict[str, Any]:
    """Run the closed loop for ``duration`` simulated seconds (see the module docstring);
    returns the summary (the analysis and where the files are). ``wheel_clamp``
    ``"per-wheel"`` drives the robot as Listing 4 does (each wheel clamped on its own; see
    :mod:`servolab.robots.base.config`). ``record_video`` writes every camera frame there
    (:mod:`servolab.vision.frame_writer`: ``.avi``, ``.mp4``, or the thesis's ``.bin``).
    ``view`` serves the run to Foxglove: it waits for the first viewer, then keeps to real
    time (``view.speed`` times it)."""
    from ...middleware.recorder import Recorder
    from ...middleware.view.run_view import serve_run
    from ...sim import Simulation
    from ...sim.fly_camera import SimulatedFlyCamera
    from ...sim.fly_walk import FlyWalkConfig, FlyWalker
    from ..base.config import WHEEL_CLAMPS, shipped_base
    from ..base.config import load as load_base
    from ..base.mobile_base import MobileBase
    from ..base.node import BaseNode
    from .logs import FlyLogWriter

    rig = rig or RigConfig()
    if not (math.isfinite(duration) and duration > 0):
        raise RobotValueError(f"duration {duration!r} must be a number of seconds > 0")
    if wheel_clamp not in WHEEL_CLAMPS:
        raise RobotValueError(f"wheel_clamp {wheel_clamp!r} must be one of "
                              f"{', '.join(WHEEL_CLAMPS)}")
    sim = Simulation()
    aot, world = simulated_treadmill(sim, FlyWalker(fly or FlyWalkConfig(), seed=seed), rig=rig)
    camera = SimulatedFlyCamera(world, seed=seed)
    #: the simulated wheels' start-up delay: a property of the simulation, which the
    #: response delay measured from the logs is to find again, not a measurement
    stiction = float(world.plants[0].delay)
    waffle = replace(load_base(shipped_base("turtlebot3_waffle")), wheel_clamp=wheel_clamp)
    base = MobileBase.emulated(waffle, sim)
    bag = run_folder.file("flyball_bag")
    if bag.exists():
        shutil.rmtree(bag)
    fly_path, encoder_path = run_folder.file("fly_data.bin"), run_folder.file("robot_encoders.bin")
    fictrac_path = run_folder.file(FICTRAC_FILE)
    say(f"the fly walks on the simulated treadmill for {duration:g} s (seed {seed}); "
        "the robot follows the ball")
    node: TreadmillNode | None = None
    tracker: MobrobDataTracker | None = None
    viewer: ViewServer | None = None
    ending = RunEnding(None)
    late = DeferredStop()
    summary: dict[str, Any] = {"duration_asked_s": duration, "seed": seed,
                               "wheel_clamp": wheel_clamp, "rig": rig.source or "the thesis's",
                               "motors_on_stop": ON_STOP,
                               "simulated_wheel_stiction_s": stiction}
    with ExitStack() as way_out:
        with ending.step("closing the logs, the video and the bag"), \
                FlyLogWriter(fly_path) as fly_log, \
                EncoderLogWriter(encoder_path) as encoder_log, \
                _video(record_video, rig) as video, \
                FicTracWriter(fictrac_path, overwrite=True) as fictrac_log, \
                Context.open(clock=sim) as context:
            try:
                start_clock(context)  # simulated time on /clock, as the stamps are
                reader = CameraNode(context, camera, frame_rate=rig.camera.frame_rate,
                                    record=video)
                node = TreadmillNode(context, aot, rig=rig, log=fly_log,
                                     fictrac_log=fictrac_log, camera=reader)
                BaseNode(context, base)
                tracker = MobrobDataTracker(context, encoder_log)
                Recorder(context, str(bag), list(RECORDED))
                if view is not None:  # served from here on, waiting for a viewer
                    viewer = serve_run(context, view, say, name="servolab flyball")
                _spin(context, sim, duration, show_progress)
            except BaseException as error:  # a stop signal, a node's error: keep, analyse
                ending.error = error
            late = way_out.enter_context(stops_deferred())  # the way out is not cut short
            with ending.step("stopping the robot"):
                base.stop()
            with ending.step("stopping the treadmill"):
                stop_wheels(aot)
            if viewer is not None:
                with ending.step("closing the view"):
                    viewer.close()
        with ending.step("analysing"):
            summary.update(analysed_run(run_folder, fly_path, encoder_path, bag, rig))
        summary.update({"frames": node.frames if node is not None else 0,
                        "encoder_records": tracker.records if tracker is not None else 0,
                        "fly_walked_m": world.ground_truth()["fly_walked"]})
        summary["fictrac"] = str(fictrac_path)
        _add_timing(summary, node, rig, say, record_video)
        run_folder.write_summary(summary, interrupted=ending.settle(late, summary))
    ending.raise_if_ended()
    a = summary["analysis"]
    if a is None:
        raise RobotError(f"{summary['frames']} frame(s) in {duration:g} s; the analysis "
                         "needs two")
    say(f"{summary['frames']} frames: mean distance error {a['mean_distance_error_mm']:.3f} mm "
        f"(thesis 1.821), mean angle error {a['mean_angle_error_deg']:.2f}° (thesis 7.039), "
        f"response delay {a['response_delay_s'] * 1000:.0f} ms (measured; the simulated "
        f"wheels start {stiction * 1000:.0f} ms after a command, the thesis "
        f"measured about 110); sphere path {a['sphere_path_length_m'] * 1000:.0f} mm, robot "
        f"path {a['robot_path_length_m']:.2f} m, shape disparity {a['path_disparity']:.2f}; "
        f"plot {summary['plot']}")
    return summary


def run_recorded(run_folder: RunFolder, frames: str | Path | None = None, *,
                 camera: int | str | None = None, port: str | None = None,
                 say: Say = print, show_progress: bool = True, fps: float | None = None,
                 rig: RigConfig | None = None, size: tuple[int, int] | None = None,
                 record_video: str | Path | None = None,
                 view: ViewRequest | None = None) -> dict[str, Any]:
    """Track a recording (``frames``: a folder of images, a video, or the thesis's
    ``Fly_Image.bin``; :class:`~servolab.vision.frame_source.FrameSource`) or a live
    ``camera`` (an OpenCV device index or path) frame by frame, with the treadmill's motors
    emulated or, on ``port``, real. One record per frame in ``fly_data.bin``; no robot, so
    ``robot_encoders.bin`` stays empty. The source is opened and checked before a motor is
    touched.

    A recording is played at the rate it was made at, since the controller divides by the
    time between frames: ``fps`` if given, else the video's own (``CAP_PROP_FPS``, its
    frames stamped by ``CAP_PROP_POS_MSEC``), else the rig camera's (66 frames/s, Listing 3).
    ``summary.json`` says which (``time_base``). A live camera runs in real time (the
    emulated motors too), each frame stamped when it was captured, until a stop signal.
    ``view`` serves the run to Foxglove; a recording on emulated motors waits for the first
    viewer, then keeps to real time (``view.speed`` times it), and a live camera or real
    motors are served as they go, waiting for no one."""
    from ...clock import Clock, WallClock
    from ...dynamixel.bus import Bus
    from ...middleware.recorder import Recorder
    from ...middleware.view.run_view import serve_run
    from ...sim import Simulation
    from ...vision.frame_source import FrameSource
    from .logs import FlyLogWriter

    rig = rig or RigConfig()
    if (frames is None) == (camera is None):
        raise RobotValueError("give a recording (frames) or a live camera, one of them")
    if fps is not None and not (math.isfinite(fps) and fps > 0):
        raise RobotValueError(f"fps {fps!r} must be a number of frames a second > 0")
    size = size or rig.camera.size
    source = (FrameSource.open(frames, size=size) if frames is not None
              else FrameSource.open_camera(camera, size=size))  # type: ignore[arg-type]
    live = camera is not None
    if fps is not None:
        frame_rate, time_base = fps, "given (--fps)"
    elif live:
        frame_rate = source.frame_rate or rig.camera.frame_rate
        time_base = "the camera's capture times"
    elif source.frame_rate is not None:
        frame_rate = source.frame_rate
        time_base = (f"the video's own: {source.stamps}" if source.stamps is not None
                     else "the video's own (CAP_PROP_FPS)")
    else:
        frame_rate = rig.camera.frame_rate
        time_base = "assumed: the rig camera's frame_rate (the recording says none)"
    rig = replace(rig, camera=replace(rig.camera, frame_rate=frame_rate))
    clock: Clock
    sim: Any = None
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
    fictrac_path = run_folder.file(FICTRAC_FILE)
    what = f"camera {camera}" if live else f"{len(source) or 'the'} frames of {frames}"
    say(f"tracking {what} at {frame_rate:g} frames/s ({time_base}) with the treadmill's "
        f"motors {'on ' + port if port else 'emulated'}")
    from tqdm import tqdm

    node: TreadmillNode | None = None
    viewer: ViewServer | None = None
    if view is not None and live:  # a camera does not wait for a laptop
        view = replace(view, wait_for_viewer=False)
    ending = RunEnding(None)
    late = DeferredStop()
    summary: dict[str, Any] = {"frames_source": str(frames) if frames is not None else None,
                               "camera": None if camera is None else str(camera),
                               "port": port or "emulated", "frame_rate_hz": frame_rate,
                               "time_base": time_base, "rig": rig.source or "the thesis's",
                               "motors_on_stop": ON_STOP}
    with ExitStack() as way_out:
        with ending.step("closing the log, the video, the bag and the port"):
            try:
                with FlyLogWriter(fly_path) as fly_log, EncoderLogWriter(encoder_path), \
                        _video(record_video, rig) as video, _real_time(sim if live else None), \
                        FicTracWriter(fictrac_path, overwrite=True) as fictrac_log, \
                        Context.open(clock=clock) as context, \
                        tqdm(total=len(source) or None, unit="frame",
                             disable=not show_progress, leave=False) as bar:
                    try:
                        # stamps (and FicTrac's timestamp, wall-clock ms in
                        # doc/data_header.txt) are ROS time: the epoch's where the run keeps
                        # the wall's time, simulated time (with /clock) otherwise
                        start_clock(context)
                        node = TreadmillNode(context, bus, rig=rig, log=fly_log,
                                             fictrac_log=fictrac_log)
                        reader = CameraNode(context, source, frame_rate=frame_rate, live=live,
                                            record=video, source_stamps=fps is None,
                                            pace=live and Path(str(camera)).is_file())
                        node.camera = reader
                        Recorder(context, str(bag), ["/cmd_vel", "/fly/pose",
                                                     "/treadmill/joint_states"])
                        if view is not None:  # served from here on
                            viewer = serve_run(context, view, say, name="servolab flyball")
                        while not reader.finished:
                            context.spin_until(lambda: reader.finished, timeout=1.0)
                            bar.update(node.frames - bar.n)
                            if not show_progress:  # a log (no terminal): a line a second
                                say(f"tracked {node.frames} of {len(source) or '?'} frames")
                        context.spin_for(2.0 / frame_rate)  # the last frame is handled
                        if reader.error is not None:
                            raise reader.error
                        if reader.camera_stopped:
                            summary.setdefault("warnings", []).append(
                                f"camera {camera} stopped delivering frames after "
                                f"{reader.published}; the run ended there")
                    except BaseException as error:  # a bad frame mid-video, a stop
                        ending.error = error
                    late = way_out.enter_context(stops_deferred())  # not cut short
                    with ending.step("stopping the treadmill"):
                        stop_wheels(bus)  # whether or not the node got to start them
                    if viewer is not None:
                        with ending.step("closing the view"):
                            viewer.close()
            finally:
                source.close()
                bus.close()
        with ending.step("analysing"):
            summary.update(analysed_run(run_folder, fly_path, encoder_path, bag, rig))
        summary["frames"] = node.frames if node is not None else 0
        summary["fictrac"] = str(fictrac_path)
        _add_timing(summary, node, rig, say, record_video)
        run_folder.write_summary(summary, interrupted=ending.settle(late, summary))
    ending.raise_if_ended()
    if summary["analysis"] is None:
        raise RobotError(f"{frames or camera}: {summary['frames']} frame(s) tracked; the "
                         "analysis needs at least two")
    analysis = summary["analysis"]
    say(f"{summary['frames']} frames ({analysis['frames_with_fly']} with the fly): mean "
        f"distance "
        f"error {analysis['mean_distance_error_mm']:.3f} mm, mean angle error "
        f"{analysis['mean_angle_error_deg']:.2f}°; plot {summary['plot']}")
    return summary


@contextmanager
def _video(path: str | Path | None, rig: RigConfig) -> Iterator[Any]:
    """The writer of ``--record-video``, or None."""
    if path is None:
        yield None
        return
    from ...vision.frame_writer import FrameWriter

    with FrameWriter.open(path, rig.camera.size, rig.camera.frame_rate) as writer:
        if writer.note is not None:
            print(f"warning: {writer.note}")
        yield writer


@contextmanager
def _real_time(sim: Any) -> Iterator[None]:
    """The emulated motors in real time, beside a live camera."""
    if sim is None:
        yield
        return
    sim.start_real_time()
    try:
        yield
    finally:
        sim.stop_real_time()


def _add_timing(summary: dict[str, Any], node: TreadmillNode | None, rig: RigConfig,
                say: Say, record_video: str | Path | None) -> None:
    """The frame timing, the fly's share and the lost-fly warning into ``summary``."""
    if node is None:
        return
    timing = node.timing()
    summary["timing"] = timing
    if record_video is not None:
        summary["video"] = str(record_video)
    warning = lost_fly_warning(timing["fly_found_share"], rig.lost_fly_share)
    if warning is not None:
        summary.setdefault("warnings", []).append(warning)
        say(f"warning: {warning}")
    if timing["frames"]:
        say(f"frames: {timing['frames']} handled of {timing['camera_frames']} taken, "
            f"{timing['achieved_fps']:.1f} frames/s, interval p50 "
            f"{timing['interval_ms']['p50']:.1f} ms, p99 {timing['interval_ms']['p99']:.1f} ms, "
            f"max {timing['interval_ms']['max']:.1f} ms; {timing['late_frames']} late, "
            f"{timing['dropped_frames']} dropped")


def _spin(context: Context, sim: Any, duration: float, show_progress: bool) -> None:
    from tqdm import tqdm

    start = sim.now()
    with tqdm(total=round(duration, 1), unit="s", disable=not show_progress, leave=False,
              bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} s") as bar:
        while (elapsed := sim.now() - start) < duration:
            context.spin_for(min(1.0, duration - elapsed))
            bar.update(min(duration, sim.now() - start) - bar.n)
