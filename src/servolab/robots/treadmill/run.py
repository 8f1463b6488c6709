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
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ...middleware.clock_node import start_clock
from ...middleware.context import Context
from ..errors import RobotError, RobotValueError
from ..lifecycle import Step, Task, replaced, run_task
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
    from ...clock import Clock
    from ...middleware.view.run_view import ViewRequest
    from ...runs import RunFolder
    from ...sim import Simulation
    from ...sim.fly_walk import FlyWalkConfig
    from ...vision.frame_source import FrameSource

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
    from ..base.config import WHEEL_CLAMPS

    if not (math.isfinite(duration) and duration > 0):
        raise RobotValueError(f"duration {duration!r} must be a number of seconds > 0")
    if wheel_clamp not in WHEEL_CLAMPS:
        raise RobotValueError(f"wheel_clamp {wheel_clamp!r} must be one of "
                              f"{', '.join(WHEEL_CLAMPS)}")
    task = FlyballTask(run_folder, rig or RigConfig(), duration=duration, seed=seed, fly=fly,
                       wheel_clamp=wheel_clamp, say=say, show_progress=show_progress,
                       record_video=record_video)
    return run_task(run_folder, task, view=view, say=say)


class TreadmillTask(Task):
    """What a treadmill's run does whatever its frames: the logs, the video, FicTrac's file
    and the bag opened around the run's context, then closed, analysed and timed
    (:func:`~servolab.robots.lifecycle.run_task`)."""

    name = "flyball"

    def __init__(self, run_folder: RunFolder, rig: RigConfig, *, say: Say,
                 show_progress: bool, record_video: str | Path | None,
                 summary: dict[str, Any]) -> None:
        self.run_folder, self.rig, self.say = run_folder, rig, say
        self.show_progress, self.record_video = show_progress, record_video
        self.summary = {**summary, "rig": rig.source or "the thesis's", "motors_on_stop": ON_STOP}
        self.bag = run_folder.file("flyball_bag")
        self.fly_path = run_folder.file("fly_data.bin")
        self.encoder_path = run_folder.file("robot_encoders.bin")
        self.fictrac_path = run_folder.file(FICTRAC_FILE)
        self.node: TreadmillNode | None = None

    def open_logs(self, opened: ExitStack, clock: Clock, *,
                  real_time: Simulation | None = None) -> None:
        """The logs, the video, FicTrac's file and the context on ``clock``, closed with
        ``opened`` (``real_time``: a simulation kept to the wall clock while they are open)."""
        from .logs import FlyLogWriter

        replaced(self.bag)
        self.opened = opened
        self.fly_log = opened.enter_context(FlyLogWriter(self.fly_path))
        self.encoder_log = opened.enter_context(EncoderLogWriter(self.encoder_path))
        self.video = opened.enter_context(_video(self.record_video, self.rig))
        opened.enter_context(_real_time(real_time))
        self.fictrac_log = opened.enter_context(FicTracWriter(self.fictrac_path,
                                                              overwrite=True))
        self.context = opened.enter_context(Context.open(clock=clock))

    def served(self) -> Context:
        return self.context

    def graph(self) -> Context:
        return self.context

    def way_out(self, ended: BaseException | None) -> list[Step]:
        return [Step("closing the logs, the video, the bag and the ports", self.opened.close),
                Step("analysing", lambda: self.summary.update(analysed_run(
                    self.run_folder, self.fly_path, self.encoder_path, self.bag, self.rig))),
                Step("counting the frames", self.count)]

    def count(self) -> None:
        """What the run handled, and the frame timing, into the summary."""
        self.summary["frames"] = self.node.frames if self.node is not None else 0
        self.summary["fictrac"] = str(self.fictrac_path)
        _add_timing(self.summary, self.node, self.rig, self.say, self.record_video)


class FlyballTask(TreadmillTask):
    """The closed loop on the simulated fly, ball and robot."""

    def __init__(self, run_folder: RunFolder, rig: RigConfig, *, duration: float, seed: int,
                 fly: FlyWalkConfig | None, wheel_clamp: str, say: Say, show_progress: bool,
                 record_video: str | Path | None) -> None:
        super().__init__(run_folder, rig, say=say, show_progress=show_progress,
                         record_video=record_video, summary={
                             "duration_asked_s": duration, "seed": seed,
                             "wheel_clamp": wheel_clamp})
        self.duration, self.seed, self.fly = duration, seed, fly
        self.tracker: MobrobDataTracker | None = None

    def open(self, opened: ExitStack) -> None:
        from ...sim import Simulation
        from ...sim.fly_camera import SimulatedFlyCamera
        from ...sim.fly_walk import FlyWalkConfig, FlyWalker
        from ..base.config import load as load_base
        from ..base.config import shipped_base
        from ..base.mobile_base import MobileBase

        self.sim = Simulation()
        self.aot, self.world = simulated_treadmill(
            self.sim, FlyWalker(self.fly or FlyWalkConfig(), seed=self.seed), rig=self.rig)
        self.camera = SimulatedFlyCamera(self.world, seed=self.seed)
        #: the simulated wheels' start-up delay: a property of the simulation, which the
        #: response delay measured from the logs is to find again, not a measurement
        self.summary["simulated_wheel_stiction_s"] = float(self.world.plants[0].delay)
        waffle = replace(load_base(shipped_base("turtlebot3_waffle")),
                         wheel_clamp=self.summary["wheel_clamp"])
        self.base = MobileBase.emulated(waffle, self.sim)
        self.say(f"the fly walks on the simulated treadmill for {self.duration:g} s (seed "
                 f"{self.seed}); the robot follows the ball")
        self.open_logs(opened, self.sim)

    def start(self) -> None:
        from ...middleware.recorder import Recorder
        from ..base.node import BaseNode

        context, rig = self.context, self.rig
        start_clock(context)  # simulated time on /clock, as the stamps are
        reader = CameraNode(context, self.camera, frame_rate=rig.camera.frame_rate,
                            record=self.video)
        self.node = TreadmillNode(context, self.aot, rig=rig, log=self.fly_log,
                                  fictrac_log=self.fictrac_log, camera=reader)
        BaseNode(context, self.base)
        self.tracker = MobrobDataTracker(context, self.encoder_log)
        Recorder(context, str(self.bag), list(RECORDED))

    def run(self) -> None:
        _spin(self.context, self.sim, self.duration, self.show_progress)

    def stop(self, ended: BaseException | None) -> list[Step]:
        return [Step("stopping the robot", self.base.stop),
                Step("stopping the treadmill", lambda: stop_wheels(self.aot))]

    def count(self) -> None:
        self.summary.update({"encoder_records": self.tracker.records
                             if self.tracker is not None else 0,
                             "fly_walked_m": self.world.ground_truth()["fly_walked"]})
        super().count()

    def report(self, ended: BaseException | None) -> None:
        if ended is not None:
            return
        summary, a = self.summary, self.summary["analysis"]
        if a is None:
            raise RobotError(f"{summary['frames']} frame(s) in {self.duration:g} s; the "
                             "analysis needs two")
        stiction = summary["simulated_wheel_stiction_s"]
        self.say(f"{summary['frames']} frames: mean distance error "
                 f"{a['mean_distance_error_mm']:.3f} mm (thesis 1.821), mean angle error "
                 f"{a['mean_angle_error_deg']:.2f}° (thesis 7.039), response delay "
                 f"{a['response_delay_s'] * 1000:.0f} ms (measured; the simulated wheels start "
                 f"{stiction * 1000:.0f} ms after a command, the thesis measured about 110); "
                 f"sphere path {a['sphere_path_length_m'] * 1000:.0f} mm, robot path "
                 f"{a['robot_path_length_m']:.2f} m, shape disparity "
                 f"{a['path_disparity']:.2f}; plot {summary['plot']}")


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
    if (frames is None) == (camera is None):
        raise RobotValueError("give a recording (frames) or a live camera, one of them")
    if fps is not None and not (math.isfinite(fps) and fps > 0):
        raise RobotValueError(f"fps {fps!r} must be a number of frames a second > 0")
    if view is not None and camera is not None:  # a camera does not wait for a laptop
        view = replace(view, wait_for_viewer=False)
    task = RecordedTask(run_folder, rig or RigConfig(), frames=frames, camera=camera,
                        port=port, fps=fps, size=size, say=say, show_progress=show_progress,
                        record_video=record_video)
    return run_task(run_folder, task, view=view, say=say)


class RecordedTask(TreadmillTask):
    """A recording or a live camera tracked, the treadmill's motors emulated or real."""

    def __init__(self, run_folder: RunFolder, rig: RigConfig, *, frames: str | Path | None,
                 camera: int | str | None, port: str | None, fps: float | None,
                 size: tuple[int, int] | None, say: Say, show_progress: bool,
                 record_video: str | Path | None) -> None:
        super().__init__(run_folder, rig, say=say, show_progress=show_progress,
                         record_video=record_video, summary={
                             "frames_source": str(frames) if frames is not None else None,
                             "camera": None if camera is None else str(camera),
                             "port": port or "emulated"})
        self.frames, self.camera, self.port, self.fps = frames, camera, port, fps
        self.size = size or rig.camera.size

    def open(self, opened: ExitStack) -> None:
        from ...clock import WallClock
        from ...dynamixel.bus import Bus
        from ...sim import Simulation
        from ...vision.frame_source import FrameSource

        live, frames, camera = self.camera is not None, self.frames, self.camera
        self.source = source = opened.enter_context(
            FrameSource.open(frames, size=self.size) if frames is not None
            else FrameSource.open_camera(camera, size=self.size))  # type: ignore[arg-type]
        frame_rate, time_base = _time_base(source, self.fps, live, self.rig)
        self.rig = replace(self.rig, camera=replace(self.rig.camera, frame_rate=frame_rate))
        self.summary.update(frame_rate_hz=frame_rate, time_base=time_base)
        clock: Clock
        sim: Simulation | None = None
        if self.port is None:
            clock = sim = Simulation()
            self.bus = emulated_treadmill_bus(sim)
        else:
            self.bus = Bus.open(self.port, protocol=2, baudrate=TREADMILL_BAUDRATE)
            clock = WallClock()
        opened.callback(self.bus.close)
        what = f"camera {camera}" if live else f"{len(source) or 'the'} frames of {frames}"
        self.say(f"tracking {what} at {frame_rate:g} frames/s ({time_base}) with the "
                 f"treadmill's motors {'on ' + self.port if self.port else 'emulated'}")
        self.open_logs(opened, clock, real_time=sim if live else None)

    def start(self) -> None:
        from ...middleware.recorder import Recorder

        # stamps (and FicTrac's timestamp, wall-clock ms in doc/data_header.txt) are ROS
        # time: the epoch's where the run keeps the wall's time, simulated time (with
        # /clock) otherwise
        start_clock(self.context)
        self.node = TreadmillNode(self.context, self.bus, rig=self.rig, log=self.fly_log,
                                  fictrac_log=self.fictrac_log)
        live = self.camera is not None
        self.reader = self.node.camera = CameraNode(
            self.context, self.source, frame_rate=self.rig.camera.frame_rate, live=live,
            record=self.video, source_stamps=self.fps is None,
            pace=live and Path(str(self.camera)).is_file())
        Recorder(self.context, str(self.bag), ["/cmd_vel", "/fly/pose",
                                               "/treadmill/joint_states"])

    def run(self) -> None:
        from tqdm import tqdm

        node, reader, source = self.node, self.reader, self.source
        assert node is not None
        with tqdm(total=len(source) or None, unit="frame", disable=not self.show_progress,
                  leave=False) as bar:
            while not reader.finished:
                self.context.spin_until(lambda: reader.finished, timeout=1.0)
                bar.update(node.frames - bar.n)
                if not self.show_progress:  # a log (no terminal): a line a second
                    self.say(f"tracked {node.frames} of {len(source) or '?'} frames")
        self.context.spin_for(2.0 / self.rig.camera.frame_rate)  # the last frame is handled
        if reader.error is not None:
            raise reader.error
        if reader.camera_stopped:
            self.summary.setdefault("warnings", []).append(
                f"camera {self.camera} stopped delivering frames after {reader.published}; "
                "the run ended there")

    def stop(self, ended: BaseException | None) -> list[Step]:
        # whether or not the node got to start them
        return [Step("stopping the treadmill", lambda: stop_wheels(self.bus))]

    def report(self, ended: BaseException | None) -> None:
        if ended is not None:
            return
        summary, analysis = self.summary, self.summary["analysis"]
        if analysis is None:
            raise RobotError(f"{self.frames or self.camera}: {summary['frames']} frame(s) "
                             "tracked; the analysis needs at least two")
        self.say(f"{summary['frames']} frames ({analysis['frames_with_fly']} with the fly): "
                 f"mean distance error {analysis['mean_distance_error_mm']:.3f} mm, mean "
                 f"angle error {analysis['mean_angle_error_deg']:.2f}°; plot {summary['plot']}")


def _time_base(source: FrameSource, fps: float | None, live: bool,
               rig: RigConfig) -> tuple[float, str]:
    """The rate frames are played at, and where it comes from (``summary.json``'s
    ``time_base``)."""
    if fps is not None:
        return fps, "given (--fps)"
    if live:
        return source.frame_rate or rig.camera.frame_rate, "the camera's capture times"
    if source.frame_rate is not None:
        return source.frame_rate, (f"the video's own: {source.stamps}"
                                   if source.stamps is not None
                                   else "the video's own (CAP_PROP_FPS)")
    return rig.camera.frame_rate, "assumed: the rig camera's frame_rate (the recording says none)"


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
