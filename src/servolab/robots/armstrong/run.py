"""``servolab walk``'s run: what the seed's control node does, recorded and plotted.

As 001's control node: move to the stand pose (Table 4.2), then play a motion sequence N times
at 4.5 rows a second. The motion is the seed's gait generated now, or a motion file checked
whole against the joints' limits *before* anything moves (a bad cell is an error naming its
line and column, never 0 degrees). Every command, every joint state, the motors' states and
``/diagnostics`` go to the run folder's MCAP bag, with what a 3D viewer draws the robot from
(``/robot_description``, ``/joint_states``, ``/tf``, ``/tf_static``: :mod:`.state_publisher`);
a plot compares commanded and present angles of both legs. Stamps and the bag's times are
ROS time: the epoch's on a real robot, the simulation's on the emulated one, which then
publishes it on ``/clock``
(:mod:`servolab.middleware.clock_node`). An alarm of the safety supervisor
(:mod:`.supervisor`), Ctrl-C or SIGTERM end the gait at the next row and bring the robot to
double support (the stand pose); ``summary.json`` lists each alarm and the errors each
motor's reads met.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ...gait.motionfile import MotionFile
from ...middleware.view.run_view import ViewRequest
from ..errors import RobotValueError
from ..lifecycle import Step, Task, replaced, run_task
from . import ON_STOP
from .control_node import PLAY_RATE, Armstrong, controller_of
from .physics_report import physics_summary, plot_physics, render_walk
from .poses import MOTORS
from .state_publisher import ArmstrongStatePublisher, StatePublisherConfig

if TYPE_CHECKING:
    from ...dynamixel.emulator import Faults
    from ...middleware.context import Context
    from ...runs import RunFolder
    from .description import Assumptions

Say = Callable[[str], None]


def recorded_topics(robot: Armstrong) -> dict[str, str]:
    """Topic -> type of what a walk records: every command, every running joint's state,
    and the motors' states."""
    topics = {f"/{controller_of(m)}/command": "std_msgs/msg/Float64" for m in MOTORS}
    for name in robot.manager.controllers:
        topics[f"/{name}/state"] = "dynamixel_msgs/msg/JointState"
    topics[f"/motor_states/{robot.port.name}"] = "dynamixel_msgs/msg/MotorStateList"
    topics["/diagnostics"] = "diagnostic_msgs/msg/DiagnosticArray"
    return topics


def run_walk(run_folder: RunFolder, motion: MotionFile, *, steps: int = 1,
             rate: float = PLAY_RATE, port: str | None = None,
             config: str | Path | None = None, say: Say = print,
             show_progress: bool = True, faults: Faults | None = None,
             on_row: Callable[[Armstrong, int], None] | None = None,
             world: str = "kinematic", assumptions: Assumptions | None = None,
             video: Path | None = None, gait: str | None = None,
             view: ViewRequest | None = None) -> dict[str, Any]:
    """Stand, play ``motion`` ``steps`` times at ``rate``, record; write the summary and
    return it. Ended by an alarm, a signal or an error, the robot finishes to double support
    (or holds, when its bus is gone: :meth:`Armstrong.finish`), the bag is closed and the
    summary written with ``interrupted``, the alarms and the rows played so far, and a
    signal or error goes on to the caller. ``faults`` go to the emulated robot's bus;
    ``on_row(robot, rows_played)`` is called after each row is sent, for scripted
    experiments (a fault made to happen at a given row of the emulated robot).

    ``world="mujoco"`` stands the emulated robot in MuJoCo (:mod:`.physics`, under
    ``assumptions``): the ground truth goes into the bag, and the summary says whether and
    when it fell and why (:mod:`.physics_report`), with a plot of its balance and, given
    ``video``, the run rendered to that file."""
    if video is not None and world != "mujoco":
        raise RobotValueError(f"a video of the walk needs the MuJoCo world (--world mujoco), "
                              f"not {world!r}: the {world} world has no bodies to draw")
    task = WalkTask(run_folder, motion, Walk(steps=steps, rate=rate, gait=gait, port=port,
                                             config=config, world=world,
                                             assumptions=assumptions, video=video),
                    say=say, show_progress=show_progress, faults=faults, on_row=on_row)
    return run_task(run_folder, task, view=view, say=say)


@dataclass(frozen=True)
class Walk:
    """A walk as asked: how often and how fast the motion is played, on which robot (a port,
    or the emulated one in ``world``) with which controllers."""

    steps: int = 1
    rate: float = PLAY_RATE
    gait: str | None = None
    port: str | None = None
    config: str | Path | None = None
    world: str = "kinematic"
    assumptions: Assumptions | None = None
    video: Path | None = None


class WalkTask(Task):
    """A walk's part of the run (:func:`~servolab.robots.lifecycle.run_task`): Armstrong
    opened and recorded, stood up and walked; finished to double support, then measured,
    plotted and judged."""

    name = "walk"

    def __init__(self, run_folder: RunFolder, motion: MotionFile, walk: Walk, *, say: Say,
                 show_progress: bool, faults: Faults | None,
                 on_row: Callable[[Armstrong, int], None] | None) -> None:
        self.run_folder, self.motion, self.walk = run_folder, motion, walk
        self.say, self.show_progress, self.faults, self.on_row = say, show_progress, faults, on_row
        self.total, self.played = walk.steps * motion.poses, 0
        self.summary: dict[str, Any] = {}

    def open(self, opened: ExitStack) -> None:
        from ...middleware.clock_node import start_clock
        from ...middleware.recorder import Recorder

        walk = self.walk
        self.bag = replaced(self.run_folder.file("walk_bag"))
        self.robot = robot = opened.enter_context(Armstrong(
            port=walk.port, config=walk.config, history=True, faults=self.faults,
            world=walk.world, assumptions=walk.assumptions))
        where = walk.port or ("the emulated robot" + (" in MuJoCo" if robot.physics else ""))
        self.say(f"Armstrong on {where}: {len(robot.manager.motors)} motors, "
                 f"{len(robot.manager.controllers)} controllers running"
                 + (f" ({', '.join(robot.manager.failed)} could not start)"
                    if robot.manager.failed else ""))
        start_clock(robot.context)  # the emulated robot's simulated time on /clock
        # the robot for a 3D viewer: /robot_description, /joint_states, /tf, /tf_static;
        # made before the recorder, which then hears the latched topics' publishers
        shown = ArmstrongStatePublisher(robot.context, StatePublisherConfig.armstrong(
            robot.manager.controllers, walk.assumptions, robot.config))
        topics = {**recorded_topics(robot), **shown.topics}
        self.truth = None
        if robot.physics is not None:
            from ...sim.mujoco_truth import SampledTruthNode, truth_topics

            if walk.video is not None:  # a video that cannot be made is said before the walk
                from ...sim.mujoco_video import check_video

                check_video(robot.physics.world.model, walk.video)
            self.truth = SampledTruthNode(robot.context, robot.physics.world)
            topics.update(truth_topics(robot.physics.world))
        self.recorder = Recorder(robot.context, str(self.bag), list(topics), types=topics,
                                 quiet=True)
        self.started = self.gait_start = self.gait_end = robot.context.clock.now()

    def served(self) -> Context:
        return self.robot.context

    def graph(self) -> Context:
        return self.robot.context

    def run(self) -> None:
        robot, motion, walk, say = self.robot, self.motion, self.walk, self.say
        clock = robot.context.clock
        self.started = self.gait_start = self.gait_end = clock.now()  # after the viewer came
        say("standing up (Table 4.2, over 2 s)")
        robot.stand()
        repeated = walk.steps > 1 or walk.gait in (None, "seed")
        say(f"playing {motion.poses} rows " + (f"x {walk.steps} step(s)" if repeated else "once")
            + f" at {walk.rate:g} Hz ({motion.poses / walk.rate:.2f} s"
            + (" a step)" if repeated else ")"))
        self.gait_start = clock.now()
        self.played = self._play()
        self.gait_end = clock.now()
        if robot.fallen:
            say(f"fell at {robot.physics.world.fell_at:.2f} s: the gait is stopped"
                if robot.physics else "fell")
        if robot.supervisor.tripped:
            say("alarm: " + "; ".join(str(a) for a in robot.supervisor.alarms))

    def _play(self) -> int:
        """The motion played with a progress bar; the rows played."""
        from tqdm import tqdm

        robot, poses, steps = self.robot, self.motion.poses, self.walk.steps
        with tqdm(total=self.total, unit="row", disable=not self.show_progress,
                  leave=False) as bar:
            def progress(done: int, _total: int) -> None:
                self.played = done
                bar.update(done - bar.n)
                if self.on_row is not None:
                    self.on_row(robot, done)
                if not self.show_progress and done % poses == 0:
                    self.say(f"step {done // poses} of {steps} played")
            return robot.play(self.motion, steps, self.walk.rate, progress=progress)

    def stop(self, ended: BaseException | None) -> list[Step]:
        robot = self.robot
        if ended is not None:
            self.gait_end = robot.context.clock.now()  # the gait ended here, before the finish
        steps = [Step("finishing to double support", lambda: robot.finish(ended))
                 ] if self.played < self.total or ended is not None else []

        def settle() -> None:
            robot.context.spin_for(0.5)
            if robot.supervisor.tripped and robot.ending is None:  # an alarm just now
                robot.finish()
                robot.context.spin_for(0.5)

        def close_bag() -> None:
            if self.truth is not None:
                self.truth.publish_new()
                robot.context.spin_for(0.05)
            self.recorder.destroy()

        return [*steps, Step("letting the last goals be reached and recorded", settle),
                Step("closing the bag", close_bag)]

    def way_out(self, ended: BaseException | None) -> list[Step]:
        steps = [Step("summarising", self._summarise), Step("plotting", self._plot),
                 Step("measuring", lambda: self.summary.update(
                     max_tracking_error_deg=tracking_errors(self.robot)))]
        if self.robot.physics is not None:
            steps.append(Step("judging the physics", self._judge_physics))
            if self.walk.video is not None:
                physics, video = self.robot.physics, self.walk.video
                steps.append(Step("rendering the video", lambda: self.summary.update(
                    video=str(render_walk(physics.world, video)))))
        steps.append(Step("saying what was played", lambda: self.say(
            ("stopped after " if self.played < self.total else "played ")
            + f"{self.played} of {self.total} rows; recorded to {self.bag}; "
            f"plot {self.summary.get('plot')}")))
        return steps

    def _summarise(self) -> None:
        robot, walk, played, total = self.robot, self.walk, self.played, self.total
        manager = robot.manager
        self.summary.update({
            "gait": walk.gait, "rows_played": played, "rows_asked": total,
            "steps": walk.steps, "rate_hz": walk.rate,
            "stopped": played < total, "ending": robot.ending or "walked",
            "alarms": [a.as_dict() for a in robot.supervisor.alarms],
            "motor_errors": {str(i): e for i, e in manager.error_counts().items()},
            "bus": {k: getattr(robot.bus.stats, k)
                    for k in ("transactions", "retries", "timeouts", "corrupt")},
            "state_rate_hz": round(manager.sweep_rate, 2),
            "state_rate_wire_limit_hz": round(1.0 / manager.update_time, 2),
            "goals": {"written": manager.owner.goals_written,
                      "replaced_before_written": manager.owner.goals_replaced},
            "walked_s": robot.context.clock.now() - self.started, "bag": str(self.bag),
            "port": walk.port or "emulated", "controllers_failed": manager.failed,
            "motors_on_stop": ON_STOP})

    def _plot(self) -> None:
        folder = self.run_folder
        self.summary["plot"] = str(plot_tracking(self.robot, folder.file("walk.png")))
        if self.robot.supervisor.alarms:
            self.summary["alarm_plot"] = str(plot_alarms(self.robot, folder.file("alarms.png")))

    def _judge_physics(self) -> None:
        physics, summary = self.robot.physics, self.summary
        assert physics is not None
        summary["physics"] = physics_summary(physics.world, physics.description,
                                             self.gait_start, self.gait_end)
        summary["fell"] = summary["physics"]["fell"]
        summary["fell_at_s"] = summary["physics"]["fell_at_s"]
        summary["physics_plot"] = str(plot_physics(
            physics.world, self.run_folder.file("physics.png"), self.gait_start))
        if physics.world.fell_at is not None:
            self.say(summary["physics"].get("fall_cause", "it fell"))

    def report(self, ended: BaseException | None) -> None:
        from ...harness import interruption

        if ended is not None:
            self.say(f"interrupted ({interruption(ended)}): "
                     + ("the robot is in double support (the stand pose)"
                        if self.robot.ending == "stand" else "the motors hold the last pose"))


def tracking_errors(robot: Armstrong) -> dict[str, float]:
    """Per leg motor: the largest difference (degrees) between the last command sent before a
    state and that state's present angle, from the gait's first row on (after the stand),
    as :class:`~.control_node.BipedNode` measured it while the states came."""
    tracking = robot.node.tracking
    return {motor: float(tracking[motor]) for motor in MOTORS[:12] if motor in tracking}


def plot_tracking(robot: Armstrong, path: Path) -> Path:
    """Commanded (steps) and present (lines) angles of the twelve leg motors over time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    node = robot.node
    figure, axes = plt.subplots(2, 1, figsize=(10, 7), sharex=True)
    for ax, motors, title in ((axes[0], MOTORS[:6], "Left leg"),
                              (axes[1], MOTORS[6:12], "Right leg")):
        for k, motor in enumerate(motors):
            colour = f"C{k}"
            sent, heard = node.sent.get(motor), node.heard.get(motor)
            if sent:
                ax.step(sent.t, sent.values(), where="post", color=colour, alpha=0.5,
                        linestyle="--")
            if heard:
                ax.plot(heard.t, heard.values(), color=colour, label=motor)
        ax.set_title(f"{title}: commanded (dashed) and present (solid)")
        ax.set_ylabel("angle [deg]")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right", ncol=6, fontsize="small")
    axes[1].set_xlabel("time [s]" + (" (simulated)" if robot.simulation else ""))
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)
    return path


def plot_alarms(robot: Armstrong, path: Path) -> Path:
    """The motors that raised an alarm: temperature against ``warn_level_temp`` and
    ``error_level_temp``, load, and how long each had been silent, with the alarms marked;
    their joints' commanded and present angles below, to show the walk ending in the stand
    pose."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    supervisor, port = robot.supervisor, robot.port
    motors = sorted({a.motor for a in supervisor.alarms})
    figure, axes = plt.subplots(4, 1, figsize=(10, 10), sharex=True)
    temp, load, silent, joint = axes
    for k, motor in enumerate(motors):
        colour = f"C{k}"
        rows = supervisor.history.get(motor)
        if rows:
            temp.plot(rows.t, rows.values(0), color=colour, label=f"motor {motor}")
            load.plot(rows.t, rows.values(1), color=colour)
            silent.plot(rows.t, rows.values(2), color=colour)
        name = f"m{motor}"
        sent, heard = robot.node.sent.get(name), robot.node.heard.get(name)
        if sent:
            joint.step(sent.t - supervisor.started, sent.values(), where="post", color=colour,
                       alpha=0.5, linestyle="--")
        if heard:
            joint.plot(heard.t - supervisor.started, heard.values(), color=colour, label=name)
    temp.axhline(port.warn_level_temp, color="orange", linestyle=":", label="warn_level_temp")
    temp.axhline(port.error_level_temp, color="red", linestyle=":", label="error_level_temp")
    silent.axhline(port.silent_timeout, color="red", linestyle=":", label="silent_timeout")
    for ax in axes:
        for alarm in supervisor.alarms:
            ax.axvline(alarm.time, color="red", alpha=0.6)
        ax.grid(True, alpha=0.3)
    temp.set_title("Alarms: " + "; ".join(f"motor {a.motor} {a.cause} at {a.time:.2f} s"
                                          for a in supervisor.alarms))
    temp.set_ylabel("temperature [deg C]")
    temp.legend(loc="upper left", fontsize="small")
    load.set_ylabel("load [fraction]")
    silent.set_ylabel("silent for [s]")
    silent.legend(loc="upper left", fontsize="small")
    joint.set_ylabel("angle [deg]")
    joint.set_title("commanded (dashed) and present (solid): the walk ends in the stand pose")
    joint.legend(loc="upper left", fontsize="small")
    joint.set_xlabel("time since start [s]" + (" (simulated)" if robot.simulation else ""))
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)
    return path
