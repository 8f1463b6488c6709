"""``servolab drive``'s run: one of seed 000's moves on a base, recorded and plotted.

The move runs on the emulated seed-000 robot rolling on the simulated floor by default (or
another base's configuration, or a real base on ``port``). Afterwards the run folder holds:

- ``drive_bag/``: ``/odom`` (the encoders' odometry) and ``/ground_truth`` (the floor's pose,
  emulated bases only), both ``nav_msgs/msg/Odometry``, and ``/wheel_commands``
  (``sensor_msgs/msg/JointState``: the wheel speeds sent, rad/s), stamped in the base's time;
- ``drive.png``: the path, truth against odometry;
- ``summary.json``: the raw wheel commands sent (what each motor's register was given) and the
  path's measured figures (a line's truth length, a circle's truth radius, how far the path
  ended from where it started, odometry's final error against truth).

With ``view`` (``servolab drive --view``) the move is served to Foxglove while it runs
(:func:`~servolab.middleware.view.run_view.serve_run`): the same ``/odom``, ``/ground_truth``
and ``/wheel_commands`` messages as the bag's, same stamps, with ``/tf`` (``odom`` ->
``base_footprint``), published by :class:`DrivePublisher` as the move goes.

A line may be seed 000 A.2's (final.m): at a speed percentage (``percent``, final.m's unit,
turned into m/s by :func:`~.mobile_base.percent_speed`) and stopped by counting encoder counts
(``counts_per_mm``, final.m's 5265/575), as meant or ``as_printed``; the summary's ``counted``
holds final.m's numbers (``h``, ``i``, the reads, the equal reads and the wraps).

Every move is checked before anything is opened: one that would take longer than
:data:`~.mobile_base.MAX_MOVE_SECONDS` is refused in one line (:func:`check_move`).

In a ``namespace`` (``servolab drive --namespace /robot1``) the topics are the robot's, in the
bag and on the view alike (``/robot1/odom``; ``/tf`` is every robot's), and so are the frames
(``robot1/odom`` -> ``robot1/base_footprint``; the floor's ``world`` is every robot's), as
ROS 2 multi-robot setups name them (:mod:`servolab.middleware.names`).
"""

from __future__ import annotations

import dataclasses
import math
import shutil
from collections.abc import Callable
from contextlib import ExitStack
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ...kinematics.diffdrive import (
    DiffDrive,
    a2_target_counts,
    circle_time,
    line_time,
    rotation,
)
from ...middleware.names import BASE_FRAME, ODOM_FRAME, frame_prefix, in_namespace, node_namespace
from ..errors import RobotValueError
from ..lifecycle import Step, Task, run_task
from . import ON_STOP
from .config import BaseConfig
from .config import load as load_base
from .config import resolve as resolve_base
from .mobile_base import (
    ROTATE_WHEEL_SPEED,
    MobileBase,
    check_duration,
    encoder_of,
    open_base,
    percent_speed,
)

if TYPE_CHECKING:
    from ...middleware.context import Context
    from ...middleware.view.run_view import ViewRequest
    from ...runs import RunFolder

Say = Callable[[str], None]
MOVES = ("line", "circle", "eight", "rotate", "rpm", "stop")


def prepare(move: str, base: str | Path | None = None, *, slip: float = 0.0,
            slip_jitter: float = 0.0, encoder_noise: float = 0.0) -> BaseConfig:
    """Everything a drive is given, checked before a run folder is made or a port opened:
    the move, the floor's slip and noise, and the base's file (loaded)."""
    if move not in MOVES:
        raise RobotValueError(f"no move {move!r}; there are {', '.join(MOVES)}")
    for name, value in (("slip", slip), ("slip_jitter", slip_jitter)):
        if not (math.isfinite(value) and 0.0 <= value < 1.0):
            raise RobotValueError(f"{name} must be a fraction in [0, 1), not {value!r}")
    if not (math.isfinite(encoder_noise) and encoder_noise >= 0):
        raise RobotValueError(f"encoder_noise must be 0 or more rad, not {encoder_noise!r}")
    return load_base(resolve_base(base))


def line_speed(config: BaseConfig, speed: float, percent: float | None) -> float:
    """A line's speed (m/s): ``speed``, or final.m's speed ``percent`` converted at the edge
    (:func:`~.mobile_base.percent_speed`)."""
    return speed if percent is None else percent_speed(config, percent)


def planned_duration(config: BaseConfig, move: str, *, distance: float = 1.0,
                     speed: float = 0.1, radius: float = 0.5, turns: float = 1.0,
                     angle_deg: float = 90.0, counts_per_mm: float | None = None) -> float:
    """How long the move should take (s) on ``config``'s base: a line its distance at its
    speed (a counted line the distance its counts roll on this base's wheels), a circle its
    turns (Figure A3's ``t``), an eight two laps, a rotation at
    :data:`~.mobile_base.ROTATE_WHEEL_SPEED`; 0 for rpm and stop. Bad values are
    ValueErrors naming them."""
    drive = DiffDrive(config.wheel_radius, config.wheel_separation)
    if move == "line":
        if counts_per_mm is not None:
            counts = a2_target_counts(distance, counts_per_mm)
            turned = counts / encoder_of(config.model).ticks_per_rev
            distance = turned * 2 * math.pi * config.wheel_radius
        return line_time(distance, speed)
    if move == "circle":
        return circle_time(radius, speed, turns)
    if move == "eight":
        return 2 * circle_time(radius, speed)
    if move == "rotate":
        if not math.isfinite(angle_deg):
            raise RobotValueError(f"angle must be a finite number of degrees, not {angle_deg!r}")
        return rotation(math.radians(angle_deg), ROTATE_WHEEL_SPEED, drive).duration
    return 0.0


def check_move(config: BaseConfig, move: str, *, distance: float = 1.0, speed: float = 0.1,
               percent: float | None = None, radius: float = 0.5, turns: float = 1.0,
               angle_deg: float = 90.0, counts_per_mm: float | None = None) -> float:
    """The move's planned duration (s), checked before a run folder is made or a port opened:
    one that would take longer than :data:`~.mobile_base.MAX_MOVE_SECONDS` is refused in one
    line naming the option's value (``drive rotate --angle 1e9`` would plan two years)."""
    if move == "line":
        speed = line_speed(config, speed, percent)
    seconds = planned_duration(config, move, distance=distance, speed=speed, radius=radius,
                               turns=turns, angle_deg=angle_deg, counts_per_mm=counts_per_mm)
    pace = (f"--percent {percent:g} ({speed:.3g} m/s)" if percent is not None
            else f"--speed {speed:g}")
    what = {"line": f"drive line --distance {distance:g} {pace}"
                    + (f" --counts-per-mm {counts_per_mm:g}" if counts_per_mm else ""),
            "circle": f"drive circle --radius {radius:g} --turns {turns:g} {pace}",
            "eight": f"drive eight --radius {radius:g} {pace}",
            "rotate": f"drive rotate --angle {angle_deg:g} (degrees; the wheels at "
                      f"{ROTATE_WHEEL_SPEED:g} rad/s)"}.get(move, move)
    return check_duration(what, seconds)


def run_drive(run_folder: RunFolder, move: str, *, distance: float = 1.0, speed: float = 0.1,
              radius: float = 0.5, clockwise: bool = False, turns: float = 1.0,
              angle_deg: float = 90.0, base: str | Path | BaseConfig | None = None,
              port: str | None = None, say: Say = print, show_progress: bool = True,
              slip: float = 0.0, slip_jitter: float = 0.0, encoder_noise: float = 0.0,
              real_time: bool = False, percent: float | None = None,
              counts_per_mm: float | None = None, as_printed: bool = False,
              view: ViewRequest | None = None, namespace: str = "/") -> dict[str, Any]:
    """Run one move (see the module docstring); returns the summary. An emulated base runs
    in simulated time, as fast as the computer allows, unless ``real_time``. ``base`` is a
    shipped base's name, a file, or what :func:`prepare` loaded. ``percent``,
    ``counts_per_mm`` and ``as_printed`` make a line final.m's (seed 000 A.2). ``view``
    serves the move to Foxglove while it runs (a simulated one waits for the first viewer,
    then keeps to real time); ``namespace`` names its topics and frames (module docstring)."""
    namespace = node_namespace(namespace)
    config = base if isinstance(base, BaseConfig) else prepare(
        move, base, slip=slip, slip_jitter=slip_jitter, encoder_noise=encoder_noise)
    if as_printed and counts_per_mm is None:
        raise RobotValueError("counting as final.m is printed needs its counts per mm "
                              "(--counts-per-mm 5265/575)")
    check_move(config, move, distance=distance, speed=speed, percent=percent, radius=radius,
               turns=turns, angle_deg=angle_deg, counts_per_mm=counts_per_mm)
    if move == "line":
        speed = line_speed(config, speed, percent)
    asked = Asked(distance=distance, speed=speed, radius=radius, clockwise=clockwise,
                  turns=turns, angle_deg=angle_deg, percent=percent,
                  counts_per_mm=counts_per_mm, as_printed=as_printed)
    task = DriveTask(run_folder, config, move, asked, port=port, say=say,
                     show_progress=show_progress, floor=Floor(slip, slip_jitter, encoder_noise),
                     real_time=real_time, namespace=namespace)
    return run_task(run_folder, task, view=view, say=say)


@dataclasses.dataclass(frozen=True)
class Asked:
    """A move as asked: SI units, a line's speed in m/s (``percent`` converted already);
    ``percent``, ``counts_per_mm`` and ``as_printed`` make a line final.m's."""

    distance: float = 1.0
    speed: float = 0.1
    radius: float = 0.5
    clockwise: bool = False
    turns: float = 1.0
    angle_deg: float = 90.0
    percent: float | None = None
    counts_per_mm: float | None = None
    as_printed: bool = False


@dataclasses.dataclass(frozen=True)
class Floor:
    """The emulated floor's slip (fractions) and encoder noise (rad)."""

    slip: float = 0.0
    slip_jitter: float = 0.0
    encoder_noise: float = 0.0


class DriveTask(Task):
    """A drive's part of the run (:func:`~servolab.robots.lifecycle.run_task`): open the
    base, do the move, stop the wheels; measure, record and plot the path."""

    name = "drive"

    def __init__(self, run_folder: RunFolder, config: BaseConfig, move: str, asked: Asked, *,
                 port: str | None, say: Say, show_progress: bool, floor: Floor,
                 real_time: bool, namespace: str = "/") -> None:
        self.run_folder, self.config, self.move, self.asked = run_folder, config, move, asked
        self.port, self.say, self.show_progress = port, say, show_progress
        self.floor, self.real_time, self.namespace = floor, real_time, namespace
        self.shown: DrivePublisher | None = None
        self.summary = {"move": move, "base": config.name, "port": port or "emulated",
                        "slip": floor.slip, "slip_jitter": floor.slip_jitter,
                        "encoder_noise": floor.encoder_noise, "motors_on_stop": ON_STOP,
                        "namespace": namespace}

    def open(self, opened: ExitStack) -> None:
        self.opened = opened
        self.robot = open_base(self.config, self.port, setup=self.move != "rpm",
                               slip=self.floor.slip, slip_jitter=self.floor.slip_jitter,
                               encoder_noise=self.floor.encoder_noise)
        self.simulation = (self.robot.clock if self.robot.floor is not None and self.real_time
                           else None)
        if self.simulation is not None:
            self.simulation.start_real_time()  # type: ignore[attr-defined]

    def served(self) -> Context:
        from ...middleware.context import Context

        context = self.opened.enter_context(Context.open(clock=self.robot.clock))
        self.shown = DrivePublisher(context, self.robot, self.namespace)
        return context

    def run(self) -> None:
        robot, move, say = self.robot, self.move, self.say
        where = self.port or f"the emulated {self.config.name} base"
        if move == "rpm":
            rpm = robot.rpm()
            self.summary["rpm"] = {str(k): v for k, v in rpm.items()}
            say(f"{where}: " + ", ".join(f"motor {k} {v:+.2f} rpm" for k, v in rpm.items()))
        elif move == "stop":
            robot.stop()
            say(f"{where}: all wheels stopped")
        else:
            _move(robot, move, self.summary, where, say, self.show_progress, self.asked,
                  shown=self.shown)

    def _stop_wheels(self) -> None:
        try:
            if self.move != "rpm":  # reading the wheels' speed leaves them as they are
                self.robot.stop()
                self.summary["wheels_after_stop"] = self.robot.wheel_commands()
        finally:
            if self.simulation is not None:
                self.simulation.stop_real_time()  # type: ignore[attr-defined]
            self.robot.close()

    def stop(self, ended: BaseException | None) -> list[Step]:
        steps = [Step("stopping the wheels", self._stop_wheels)]
        if self.shown is not None:  # the stop's last odometry, if any
            steps.append(Step("showing the stop", self.shown.publish_new))
        return steps

    def way_out(self, ended: BaseException | None) -> list[Step]:
        robot, summary, folder = self.robot, self.summary, self.run_folder
        if self.move in ("rpm", "stop") or not robot.track:  # a refused move drove nothing
            return []

        def measured() -> None:
            summary["wheel_commands"] = raw_commands(robot)
            summary["measured"] = measure(robot, self.move)

        return [Step("measuring", measured),
                Step("recording the bag", lambda: summary.update(
                    bag=str(record(robot, folder.file("drive_bag"), self.namespace)))),
                Step("plotting", lambda: summary.update(
                    plot=str(plot_path(robot, folder.file("drive.png"))))),
                Step("saying what was measured", lambda: self.say(
                    " ".join(f"{k} {v:.4g};" for k, v in summary.get("measured", {}).items())
                    + f" bag {summary.get('bag')}, plot {summary.get('plot')}"))]


def _move(robot: MobileBase, move: str, summary: dict[str, Any], where: str, say: Say,
          show_progress: bool, asked: Asked, *, shown: DrivePublisher | None = None) -> None:
    """One of the moves that drive the wheels, with a progress bar (and, ``shown``, its
    odometry published as it goes)."""
    say(f"{move} on {where}")
    expected = planned_duration(robot.config, move, distance=asked.distance,
                                speed=asked.speed, radius=asked.radius, turns=asked.turns,
                                angle_deg=asked.angle_deg, counts_per_mm=asked.counts_per_mm)
    bar = _progress(expected, robot, show_progress, say,
                    None if shown is None else shown.publish_new)
    try:
        summary["asked"] = _asked_figures(move, asked)
        if move == "line" and asked.counts_per_mm is not None:
            _say_radius(robot, asked.distance, asked.counts_per_mm, say)
            counted = robot.count_line(asked.distance, asked.speed, asked.counts_per_mm,
                                       as_printed=asked.as_printed)
            summary["counted"] = dataclasses.asdict(counted)
            say(f"final.m's count on motor {counted.motor}: i = {counted.counted} of "
                f"h = {counted.target} in {counted.reads} reads ({counted.equal_reads} equal "
                f"to the one before, {counted.wraps} wraps)")
        elif move == "line":
            robot.line(asked.distance, asked.speed)
        elif move == "circle":
            robot.circle(asked.radius, asked.speed, clockwise=asked.clockwise,
                         turns=asked.turns)
        elif move == "eight":
            robot.eight(asked.radius, asked.speed)
        else:
            robot.rotate(math.radians(asked.angle_deg))
        robot.update_odometry()
        if shown is not None:
            shown.publish_new()
    finally:
        bar.close()


def _asked_figures(move: str, asked: Asked) -> dict[str, Any]:
    """The summary's ``asked``: the move's own parameters."""
    if move == "line":
        figures: dict[str, Any] = {"distance_m": asked.distance, "speed_m_s": asked.speed,
                                   "speed_percent": asked.percent}
        if asked.counts_per_mm is not None:
            figures.update(counts_per_mm=asked.counts_per_mm, as_printed=asked.as_printed)
        return figures
    if move == "circle":
        return {"radius_m": asked.radius, "speed_m_s": asked.speed, "turns": asked.turns,
                "clockwise": asked.clockwise}
    if move == "eight":
        return {"radius_m": asked.radius, "speed_m_s": asked.speed}
    return {"angle_deg": asked.angle_deg}


def _say_radius(robot: MobileBase, distance: float, counts_per_mm: float, say: Say) -> None:
    """Warn when the counts per mm do not fit the base's wheels: the line then ends short or
    long in proportion (final.m's 5265/575 on the two-wheel robot's 5.2 cm wheels: 509 mm of
    1 000)."""
    from ...kinematics.diffdrive import radius_from_counts_per_mm

    implied = radius_from_counts_per_mm(counts_per_mm, robot.encoder)
    radius = robot.config.wheel_radius
    if abs(implied / radius - 1) > 0.01:
        say(f"note: {counts_per_mm:g} counts/mm implies a {implied:.4f} m wheel, and the "
            f"{robot.config.name} base's is {radius:g} m: the line will be about "
            f"{abs(distance) * radius / implied:.3f} m, not {abs(distance):g} m")


def _progress(expected: float, robot: MobileBase, show: bool, say: Say,
              also: Callable[[], None] | None = None) -> Any:
    """A tqdm bar over the move's expected seconds, fed by the base's odometry updates
    (each of which calls ``also`` too)."""
    from tqdm import tqdm

    bar = tqdm(total=round(expected, 2), unit="s", disable=not show, leave=False, delay=0.5,
               bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} s")  # a refused move draws none
    start = robot.clock.now()
    said = 0

    def update(_pose: object) -> None:
        nonlocal said
        if also is not None:
            also()
        elapsed = min(expected, robot.clock.now() - start)
        if elapsed > bar.n:
            bar.update(elapsed - bar.n)  # tqdm redraws at most every 0.1 s of wall time
        if not show and int(elapsed) > said:  # a log (no terminal): a line a second
            said = int(elapsed)
            say(f"moving: {said} of {expected:.0f} s")
    robot.on_update = update
    return bar


class DrivePublisher:
    """The move as it goes, for a viewer: each new odometry update of ``robot.track`` on
    ``/odom`` (and the floor's truth on ``/ground_truth``) as ``nav_msgs/msg/Odometry``, with
    ``/tf`` ``odom`` -> ``base_footprint``, and each wheel command sent on
    ``/wheel_commands``: the very messages :func:`record` writes to the bag, stamped alike
    (the base's clock reading), named alike in a ``namespace``. The move spins no executor,
    so each call also runs the context's waiting callbacks (the viewer's subscriptions), never
    moving its clock: a thread spinning it would move a simulated clock under the move's
    feet."""

    def __init__(self, context: Context, robot: MobileBase, namespace: str = "/") -> None:
        from ...middleware.node import Node

        self.robot = robot
        self.node = Node(context, "drive", namespace)
        self.frames = Frames.of(namespace)
        self.odom = self.node.create_publisher(ODOMETRY, "odom", 10)
        self.truth = (self.node.create_publisher(ODOMETRY, "ground_truth", 10)
                      if robot.floor is not None else None)
        self.tf = self.node.create_publisher("tf2_msgs/msg/TFMessage", "/tf", 10)
        self.commands = self.node.create_publisher(JOINT_STATE, "wheel_commands", 10)
        self._tracked = len(robot.track)
        self._sent = len(robot.commands)

    def publish_new(self) -> None:
        """Publish what the base did since the last call."""
        robot, message = self.robot, self.node.message
        track, commands = robot.track, robot.commands
        for i in range(self._sent, len(commands)):
            t, left, right = commands[i]
            self.commands.publish(message(JOINT_STATE, **wheel_command_fields(t, left, right)))
        self._sent = len(commands)
        frames = self.frames
        for i in range(self._tracked, len(track)):
            t, ox, oy, otheta, tx, ty, tyaw = track[i]
            fields = frames.odometry(t, ox, oy, otheta)
            self.odom.publish(message(ODOMETRY, **fields))
            if self.truth is not None:
                self.truth.publish(message(ODOMETRY, **frames.truth(t, tx, ty, tyaw)))
            pose = fields["pose"]["pose"]
            self.tf.publish(message("tf2_msgs/msg/TFMessage", transforms=[{
                "header": fields["header"], "child_frame_id": fields["child_frame_id"],
                "transform": {"translation": pose["position"],
                              "rotation": pose["orientation"]}}]))
        self._tracked = len(track)
        self.deliver()

    def deliver(self) -> None:
        """Run the context's callbacks that wait now (none that a clock must reach)."""
        executor = self.node.context.executor
        while executor.spin_once(0):
            pass


ODOMETRY, JOINT_STATE = "nav_msgs/msg/Odometry", "sensor_msgs/msg/JointState"


@dataclasses.dataclass(frozen=True)
class Frames:
    """The frames a drive's messages name: the odometry's and the base's, prefixed in a
    namespace (:func:`~servolab.middleware.names.frame_prefix`), and the floor's ``world``,
    every robot's."""

    odom: str = ODOM_FRAME
    base: str = BASE_FRAME
    world: str = "world"

    @classmethod
    def of(cls, namespace: str) -> Frames:
        prefix = frame_prefix(namespace)
        return cls(prefix + cls.odom, prefix + cls.base)

    def odometry(self, t: float, x: float, y: float, yaw: float) -> dict[str, Any]:
        """The base's odometry at ``(x, y, yaw)`` at clock reading ``t``."""
        return odometry_fields(self.odom, t, x, y, yaw, child=self.base)

    def truth(self, t: float, x: float, y: float, yaw: float) -> dict[str, Any]:
        """The floor's truth of the base at ``(x, y, yaw)`` at clock reading ``t``."""
        return odometry_fields(self.world, t, x, y, yaw, child=self.base)


def odometry_fields(frame: str, t: float, x: float, y: float, yaw: float, *,
                    child: str = BASE_FRAME) -> dict[str, Any]:
    """An ``Odometry`` of ``child`` at ``(x, y, yaw)`` in ``frame`` at clock reading ``t``, as
    the bag and the view carry it."""
    from ...middleware.messages import time_of

    return {"header": {"stamp": time_of(t), "frame_id": frame},
            "child_frame_id": child,
            "pose": {"pose": {"position": {"x": x, "y": y},
                              "orientation": {"z": math.sin(yaw / 2),
                                              "w": math.cos(yaw / 2)}}}}


def wheel_command_fields(t: float, left: float, right: float) -> dict[str, Any]:
    """A ``JointState`` of the wheel speeds sent (rad/s) at clock reading ``t``."""
    from ...middleware.messages import time_of

    return {"header": {"stamp": time_of(t)},
            "name": ["wheel_left_joint", "wheel_right_joint"], "velocity": [left, right]}


def raw_commands(robot: MobileBase) -> list[dict[str, Any]]:
    """Each distinct wheel command as sent: the time, and each motor's register value (raw,
    as the Dynamixel layer encoded it)."""
    register = "moving_speed" if robot.config.protocol == 1 else "goal_velocity"
    out: list[dict[str, Any]] = []
    previous = None
    for t, left, right in robot.commands:
        if (left, right) == previous:
            continue
        previous = (left, right)
        wheel = {"left": left, "right": right}
        out.append({"t": round(t, 4), "register": register, "raw": {
            str(m.id): robot.bus.from_si(m.id, register, m.direction * wheel[m.side])
            for m in robot.config.motors}})
    return out


def _track(robot: MobileBase) -> np.ndarray:
    return np.array(robot.track, dtype=np.float64).reshape(-1, 7)


def measure(robot: MobileBase, move: str) -> dict[str, float]:
    """The path's figures, from the floor's truth where there is one."""
    track = _track(robot)
    odom, truth = track[:, 1:3], track[:, 4:6]
    figures: dict[str, float] = {}
    if robot.floor is None or not len(track):
        return {"odometry_x_m": robot.pose.x, "odometry_y_m": robot.pose.y}
    end, start = truth[-1], truth[0]
    figures["closure_m"] = float(np.hypot(*(end - start)))
    figures["odometry_error_m"] = float(np.hypot(*(odom[-1] - truth[-1])))
    if move == "line":
        figures["truth_length_m"] = figures["closure_m"]
    if move == "circle":
        centre = truth.mean(axis=0)
        figures["truth_radius_m"] = float(np.mean(np.hypot(*(truth - centre).T)))
    if move == "rotate":
        figures["truth_yaw_deg"] = math.degrees(float(track[-1, 6] - track[0, 6]))
    return figures


def record(robot: MobileBase, path: Path, namespace: str = "/") -> Path:
    """The run's track and commands as an MCAP bag (rosbag2 layout), in the base's time, its
    topics and frames the robot's in ``namespace``."""
    from ...middleware.bag import BagWriter
    from ...middleware.messages import MessageTypes

    if path.exists():  # a run folder's files are replaced (servolab.runs)
        shutil.rmtree(path)
    types = MessageTypes()
    writer = BagWriter(path, types)
    odometry, joints = ODOMETRY, JOINT_STATE
    odom, truth, commands = (in_namespace(topic, namespace) for topic in
                             ("/odom", "/ground_truth", "/wheel_commands"))
    frames = Frames.of(namespace)
    writer.add_topic(odom, odometry)
    writer.add_topic(commands, joints)
    if robot.floor is not None:
        writer.add_topic(truth, odometry)

    def pose(topic: str, fields: dict[str, Any], t: float) -> None:
        writer.write(topic, types.from_value(odometry, fields), round(t * 1e9))

    try:
        for t, ox, oy, otheta, tx, ty, tyaw in robot.track:
            pose(odom, frames.odometry(t, ox, oy, otheta), t)
            if robot.floor is not None:
                pose(truth, frames.truth(t, tx, ty, tyaw), t)
        for t, left, right in robot.commands:
            writer.write(commands, types.from_value(
                joints, wheel_command_fields(t, left, right)), round(t * 1e9))
    finally:
        writer.close()
    return path


def plot_path(robot: MobileBase, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    track = _track(robot)
    figure, ax = plt.subplots(figsize=(6, 6))
    if robot.floor is not None and len(track):
        ax.plot(track[:, 4], track[:, 5], label="truth (simulated floor)")
    if len(track):
        ax.plot(track[:, 1], track[:, 2], linestyle="--", label="odometry (encoders)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, alpha=0.3)
    ax.legend()
    ax.set_title(f"{robot.config.name}: the path")
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)
    return path
