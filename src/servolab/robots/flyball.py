"""``servolab flyball``'s run: seed 002's closed loop on a simulated fly, ball and robot.

One simulation owns the time of everything (:class:`~servolab.sim.Simulation`): the treadmill
(:class:`~servolab.sim.ball.BallWorld`, three emulated XM430-W210 wheels, IDs 100-102, at
1 Mbps) with a walking fly on it, its camera (:class:`~servolab.sim.fly_camera.
SimulatedFlyCamera`, 640 x 376 at 66 frames/s), and a TurtleBot3 Waffle
(``configs/base_turtlebot3_waffle.yaml``, its own emulated bus) on a floor. The nodes are the
thesis's (Figure 2):

- the camera PC's ``image_converter`` (:class:`~.flyball_node.FlyballNode`): track, control,
  one SYNC_WRITE and one SYNC_READ on the treadmill's bus, ``/cmd_vel`` to the robot, the
  17-value record to ``fly_data.bin``;
- the robot's base node (:class:`~.base_node.BaseNode`): ``/cmd_vel`` to its wheels,
  ``/sensor_state`` with the encoders;
- Listing 2's ``mobrob_data_tracker`` (:class:`MobrobDataTracker`): each ``/sensor_state`` to
  ``robot_encoders.bin``.

The run folder then holds ``fly_data.bin``, ``robot_encoders.bin``, ``flyball_bag/`` (MCAP:
``/cmd_vel``, ``/fly/pose``, ``/aot/joint_states``, ``/sensor_state``, ``/odom``), the
analysis of :mod:`.fly_analysis` in ``summary.json`` and its figures in ``flyball.png``.
"""

from __future__ import annotations

import math
import shutil
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..middleware.context import Context
from ..middleware.node import Node
from . import CONFIGS
from .fly_logs import EncoderLogWriter
from .flyball_node import AOT_BAUDRATE, AOT_IDS, FlyballNode, emulated_aot_bus

if TYPE_CHECKING:
    from ..runs import RunFolder
    from ..sim.fly_walk import FlyWalkConfig

Say = Callable[[str], None]
WAFFLE = CONFIGS / "base_turtlebot3_waffle.yaml"
SENSOR_STATE = "turtlebot3_msgs/msg/SensorState"
RECORDED = ("/cmd_vel", "/fly/pose", "/aot/joint_states", "/sensor_state", "/odom")


class MobrobDataTracker(Node):
    """Listing 2: every ``sensor_state`` message's time (µs) and the left and right encoder
    counts, as three int64, to ``log``."""

    def __init__(self, context: Context, log: EncoderLogWriter, name: str = "mobrob_data_tracker",
                 namespace: str = "/", *, parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        self.log = log
        self.records = 0
        self.create_subscription(SENSOR_STATE, "sensor_state", self._on_state, 1000)

    def _on_state(self, msg: Any) -> None:
        self.log.write(round(self.now() * 1e6), int(msg.left_encoder), int(msg.right_encoder))
        self.records += 1


def run_flyball(run_folder: RunFolder, *, duration: float = 100.0, seed: int = 0,
                fly: FlyWalkConfig | None = None, say: Say = print,
                show_progress: bool = True) -> dict[str, Any]:
    """Run the closed loop for ``duration`` simulated seconds (see the module docstring);
    returns the summary (the analysis and where the files are)."""

    from ..middleware.recorder import Recorder
    from ..sim import Simulation
    from ..sim.fly_camera import SimulatedFlyCamera
    from ..sim.fly_walk import FlyWalkConfig, FlyWalker
    from .base_config import load as load_base
    from .base_node import BaseNode
    from .fly_logs import FlyLogWriter
    from .mobile_base import MobileBase

    if not (math.isfinite(duration) and duration > 0):
        raise ValueError(f"duration {duration!r} must be a number of seconds > 0")
    sim = Simulation()
    aot, world = _treadmill(sim, FlyWalker(fly or FlyWalkConfig(), seed=seed))
    camera = SimulatedFlyCamera(world, seed=seed)
    base = MobileBase.emulated(load_base(WAFFLE), sim)
    bag = run_folder.file("flyball_bag")
    if bag.exists():
        shutil.rmtree(bag)
    fly_path, encoder_path = run_folder.file("fly_data.bin"), run_folder.file("robot_encoders.bin")
    say(f"the fly walks on the simulated treadmill for {duration:g} s (seed {seed}); "
        "the robot follows the ball")
    interrupted: BaseException | None = None
    node: FlyballNode | None = None
    tracker: MobrobDataTracker | None = None
    with FlyLogWriter(fly_path) as fly_log, EncoderLogWriter(encoder_path) as encoder_log, \
            Context.open(clock=sim) as context:
        try:
            node = FlyballNode(context, aot, camera, log=fly_log)
            BaseNode(context, base)
            tracker = MobrobDataTracker(context, encoder_log)
            Recorder(context, str(bag), list(RECORDED))
            _spin(context, sim, duration, show_progress)
        except BaseException as error:  # Ctrl-C, a node's error: keep and analyse the logs
            interrupted = error
        finally:
            try:
                base.stop()
            finally:
                aot.sync_write("goal_velocity", dict.fromkeys(AOT_IDS, 0), raw=True)
                aot.sync_write("torque_enable", dict.fromkeys(AOT_IDS, 0))
    if node is None or tracker is None:
        assert interrupted is not None
        raise interrupted
    summary = _analysed(run_folder, fly_path, encoder_path, bag)
    summary.update({"duration_s": duration, "seed": seed, "frames": node.frames,
                    "encoder_records": tracker.records,
                    "fly_walked_m": world.ground_truth()["fly_walked"]})
    if interrupted is not None:
        summary["interrupted"] = f"{type(interrupted).__name__}: {interrupted}".rstrip(": ")
        run_folder.write_summary(summary)  # the caller will not get to it
        raise interrupted
    a = summary["analysis"]
    if a is None:
        raise ValueError(f"{node.frames} frame(s) in {duration:g} s; the analysis needs two")
    say(f"{node.frames} frames: mean distance error {a['mean_distance_error_mm']:.3f} mm "
        f"(thesis 1.821), mean angle error {a['mean_angle_error_deg']:.2f}° (thesis 7.039), "
        f"response delay {a['response_delay_s'] * 1000:.0f} ms (thesis about 110); "
        f"sphere path {a['sphere_path_length_m'] * 1000:.0f} mm, robot path "
        f"{a['robot_path_length_m']:.2f} m, shape disparity {a['path_disparity']:.2f}; "
        f"plot {summary['plot']}")
    return summary


def run_recorded(run_folder: RunFolder, frames: str | Path, *, port: str | None = None,
                 say: Say = print, show_progress: bool = True) -> dict[str, Any]:
    """Track a recording (a folder of images or a video, :class:`~servolab.vision.
    frame_source.FrameSource`) frame by frame, with the treadmill's motors emulated or, on
    ``port``, real (then at the camera's 66 frames/s by the wall clock). One record per frame
    in ``fly_data.bin``; no robot, so ``robot_encoders.bin`` stays empty. The recording is
    opened and checked before a motor is touched."""
    from ..clock import Clock, WallClock
    from ..dynamixel.bus import Bus
    from ..middleware.recorder import Recorder
    from ..sim import Simulation
    from ..vision.frame_source import FrameSource
    from .fly_logs import FlyLogWriter

    source = FrameSource.open(frames)
    clock: Clock
    if port is None:
        sim = Simulation()
        bus = emulated_aot_bus(sim)
        clock = sim
    else:
        bus = Bus.open(port, protocol=2, baudrate=AOT_BAUDRATE)
        clock = WallClock()
    bag = run_folder.file("flyball_bag")
    if bag.exists():
        shutil.rmtree(bag)
    fly_path, encoder_path = run_folder.file("fly_data.bin"), run_folder.file("robot_encoders.bin")
    say(f"tracking {len(source) or 'the'} frames of {frames} with the treadmill's motors "
        f"{'on ' + port if port else 'emulated'}")
    from tqdm import tqdm

    interrupted: BaseException | None = None
    node: FlyballNode | None = None
    try:
        with FlyLogWriter(fly_path) as fly_log, EncoderLogWriter(encoder_path), \
                Context.open(clock=clock) as context, \
                tqdm(total=len(source) or None, unit="frame", disable=not show_progress,
                     leave=False) as bar:
            try:
                node = FlyballNode(context, bus, source, log=fly_log)
                Recorder(context, str(bag), ["/cmd_vel", "/fly/pose", "/aot/joint_states"])
                while not node.finished:
                    context.spin_until(lambda: node is not None and node.finished,
                                       timeout=1.0)
                    bar.update(node.frames - bar.n)
            except BaseException as error:  # a bad frame mid-video, Ctrl-C: keep the log
                interrupted = error
                if node is not None:
                    node.motor_deinit()
    finally:
        source.close()
        bus.close()
    if node is None:
        assert interrupted is not None
        raise interrupted
    summary = _analysed(run_folder, fly_path, encoder_path, bag)
    summary.update({"frames_source": str(frames), "port": port or "emulated",
                    "frames": node.frames})
    if interrupted is not None:
        summary["interrupted"] = f"{type(interrupted).__name__}: {interrupted}".rstrip(": ")
        run_folder.write_summary(summary)  # the caller will not get to it
        raise interrupted
    if summary["analysis"] is None:
        raise ValueError(f"{frames}: {node.frames} frame(s) tracked; the analysis needs at "
                         "least two")
    analysis = summary["analysis"]
    say(f"{node.frames} frames ({analysis['frames_with_fly']} with the fly): mean distance "
        f"error {analysis['mean_distance_error_mm']:.3f} mm, mean angle error "
        f"{analysis['mean_angle_error_deg']:.2f}°; plot {summary['plot']}")
    return summary


def _treadmill(simulation: Any, walker: Any) -> tuple[Any, Any]:
    """The emulated wheels (:func:`~.flyball_node.emulated_aot_bus`) under a
    :class:`~servolab.sim.ball.BallWorld` with ``walker`` on the ball, in ``simulation``."""
    from ..sim import BallWorld

    bus = emulated_aot_bus(simulation)
    world = simulation.add(BallWorld([bus.emulator.motor(i) for i in AOT_IDS], walker=walker))
    return bus, world


def _analysed(run_folder: RunFolder, fly_path: Path, encoder_path: Path, bag: Path | None
              ) -> dict[str, Any]:
    """The run's logs read back and analysed, the figure drawn: the summary's common part."""
    from .fly_analysis import analyze, plot_analysis
    from .fly_logs import read_encoder_log, read_fly_log

    fly_records, encoders = read_fly_log(fly_path), read_encoder_log(encoder_path)
    files = {"fly_data": str(fly_path), "robot_encoders": str(encoder_path),
             "bag": None if bag is None else str(bag)}
    if len(fly_records) < 2:
        return {"analysis": None, **files, "plot": None}
    result, series = analyze(fly_records, encoders)
    plot = plot_analysis(result, series, fly_records, run_folder.file("flyball.png"))
    return {"analysis": result.summary(), **files, "plot": str(plot)}


def _spin(context: Context, sim: Any, duration: float, show_progress: bool) -> None:
    from tqdm import tqdm

    start = sim.now()
    with tqdm(total=round(duration, 1), unit="s", disable=not show_progress, leave=False,
              bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} s") as bar:
        while (elapsed := sim.now() - start) < duration:
            context.spin_for(min(1.0, duration - elapsed))
            bar.update(min(duration, sim.now() - start) - bar.n)


class FlyballRig(Node):
    """The camera PC of seed 002 for launch files (Figure 2): the simulated fly, ball and
    camera in real time (or the real treadmill on ``port`` -- then frames must come from
    elsewhere, which this node does not do yet, so ``port`` is refused), Listing 1's
    ``image_converter`` and Listing 2's ``mobrob_data_tracker``, writing the run folder
    ``out``. ``duration`` seconds after it first hears the robot (its ``sensor_state``: the
    robot's process may take a while to start) it stops the wheels (torque off), analyses the logs
    into ``out``/summary.json and ``out``/flyball.png, and shuts its process down, so that as
    a ``required`` node it ends the launch. The robot is another node, anywhere on the
    network: it hears ``/cmd_vel`` and answers on ``sensor_state``."""

    def __init__(self, context: Context, name: str = "treadmill", namespace: str = "/", *,
                 parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:

        from ..runs import RunFolder
        from ..sim import Simulation
        from ..sim.fly_camera import SimulatedFlyCamera
        from ..sim.fly_walk import FlyWalker
        from .fly_logs import FlyLogWriter

        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        self.duration = float(self.declare_parameter(
            "duration", 100.0, description="s to run before stopping").value)
        seed = int(self.declare_parameter("seed", 0, description="the fly's walk").value)
        out = str(self.declare_parameter("out", "", description="run folder; empty: "
                                         "runs/flyball-<time>").value)
        port = str(self.declare_parameter("port", "", description="must stay empty: the "
                                          "simulated fly needs the simulated ball").value)
        if port:
            raise ValueError("treadmill: a real treadmill needs a real camera; run "
                             "'servolab flyball --frames ... --port ...' instead")
        if not (math.isfinite(self.duration) and self.duration > 0):
            raise ValueError(f"treadmill: duration {self.duration!r} must be > 0 s")
        self.run = RunFolder.create("flyball", out or None)
        self.simulation = Simulation()
        self.bus, self.world = _treadmill(self.simulation, FlyWalker(seed=seed))
        self.fly_log = FlyLogWriter(self.run.file("fly_data.bin"))
        self.encoder_log = EncoderLogWriter(self.run.file("robot_encoders.bin"))
        self.simulation.start_real_time()
        self.node = FlyballNode(context, self.bus, SimulatedFlyCamera(
            self.world, seed=seed, simulation=self.simulation), log=self.fly_log)
        self.tracker = MobrobDataTracker(context, self.encoder_log)
        self.start: float | None = None  # the robot's first sensor_state: the run starts
        self.summary: dict[str, Any] | None = None
        self.create_timer(0.1, self._check_done)

    def _check_done(self) -> None:
        if self.start is None:
            if self.tracker.records:  # the robot is up and heard: count from here
                self.start = self.now()
            return
        if self.summary is None and self.now() - self.start >= self.duration:
            self.finish()
            self.context.shutdown()  # a required node ends the launch

    def finish(self) -> dict[str, Any]:
        """Stop the wheels, close the logs, analyse them (once)."""
        if self.summary is not None:
            return self.summary
        try:
            self.node.motor_deinit()
        finally:
            self.simulation.stop_real_time()
            self.fly_log.close()
            self.encoder_log.close()
        summary = _analysed(self.run, self.run.file("fly_data.bin"),
                            self.run.file("robot_encoders.bin"), None)
        summary.update({"duration_s": self.duration, "frames": self.node.frames,
                        "encoder_records": self.tracker.records})
        self.summary = summary
        self.run.write_summary(summary)
        analysis = summary["analysis"] or {}
        self.get_logger().info(
            f"{self.node.frames} frames, {self.tracker.records} robot encoder records: mean "
            f"distance error {analysis.get('mean_distance_error_mm', math.nan):.3f} mm, run "
            f"folder {self.run.path}")
        return summary

    def destroy(self) -> None:
        try:
            if self.summary is None:
                self.finish()
        finally:
            super().destroy()
            self.bus.close()
