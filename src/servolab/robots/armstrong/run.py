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

import shutil
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ...gait.motionfile import MotionFile
from ...middleware.view.run_view import ViewRequest, serve_run
from ..errors import RobotValueError
from . import ON_STOP
from .control_node import PLAY_RATE, Armstrong, controller_of
from .physics_report import physics_summary, plot_physics, render_walk
from .poses import MOTORS
from .state_publisher import ArmstrongStatePublisher, StatePublisherConfig

if TYPE_CHECKING:
    from ...dynamixel.emulator import Faults
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
    from tqdm import tqdm

    from ...harness import RunEnding, interruption, stops_deferred
    from ...middleware.clock_node import start_clock
    from ...middleware.recorder import Recorder

    bag = run_folder.file("walk_bag")
    if bag.exists():  # a run folder's files are replaced (servolab.runs)
        shutil.rmtree(bag)
    total = steps * motion.poses
    played = 0
    interrupted: BaseException | None = None
    if video is not None and world != "mujoco":
        raise RobotValueError(f"a video of the walk needs the MuJoCo world (--world mujoco), "
                              f"not {world!r}: the {world} world has no bodies to draw")
    with Armstrong(port=port, config=config, history=True, faults=faults, world=world,
                   assumptions=assumptions) as robot:
        where = port or ("the emulated robot" + (" in MuJoCo" if robot.physics else ""))
        say(f"Armstrong on {where}: {len(robot.manager.motors)} motors, "
            f"{len(robot.manager.controllers)} controllers running"
            + (f" ({', '.join(robot.manager.failed)} could not start)"
               if robot.manager.failed else ""))
        start_clock(robot.context)  # the emulated robot's simulated time on /clock
        # the robot for a 3D viewer: /robot_description, /joint_states, /tf, /tf_static;
        # made before the recorder, which then hears the latched topics' publishers
        shown = ArmstrongStatePublisher(robot.context, StatePublisherConfig.armstrong(
            robot.manager.controllers, assumptions, robot.config))
        topics = recorded_topics(robot)
        topics.update(shown.topics)
        truth = None
        if robot.physics is not None:
            from ...sim.mujoco_truth import SampledTruthNode, truth_topics

            if video is not None:  # a video that cannot be made is said before the walk
                from ...sim.mujoco_video import check_video

                check_video(robot.physics.world.model, video)

            truth = SampledTruthNode(robot.context, robot.physics.world)
            topics.update(truth_topics(robot.physics.world))
        recorder = Recorder(robot.context, str(bag), list(topics), types=topics, quiet=True)
        viewer = None
        started = robot.context.clock.now()
        gait_start = gait_end = started
        try:
            if view is not None:  # served from here on, waiting for a viewer if simulated
                viewer = serve_run(robot.context, view, say, name="servolab walk")
                started = gait_start = gait_end = robot.context.clock.now()
            say("standing up (Table 4.2, over 2 s)")
            robot.stand()
            say(f"playing {motion.poses} rows "
                + (f"x {steps} step(s)" if steps > 1 or gait in (None, "seed") else "once")
                + f" at {rate:g} Hz ({motion.poses / rate:.2f} s"
                + (" a step)" if steps > 1 or gait in (None, "seed") else ")"))
            gait_start = robot.context.clock.now()
            with tqdm(total=total, unit="row", disable=not show_progress,
                      leave=False) as bar:
                def progress(done: int, _total: int) -> None:
                    nonlocal played
                    played = done
                    bar.update(done - bar.n)
                    if on_row is not None:
                        on_row(robot, done)
                    if not show_progress and done % motion.poses == 0:
                        say(f"step {done // motion.poses} of {steps} played")
                played = robot.play(motion, steps, rate, progress=progress)
            gait_end = robot.context.clock.now()
            if robot.fallen:
                say(f"fell at {robot.physics.world.fell_at:.2f} s: the gait is stopped"
                    if robot.physics else "fell")
            if robot.supervisor.tripped:
                say("alarm: " + "; ".join(str(a) for a in robot.supervisor.alarms))
        except BaseException as error:  # a stop signal or an error: finish, record, report
            interrupted = error
            gait_end = robot.context.clock.now()   # the gait ended here, before the finish
        ending = RunEnding(interrupted)
        with stops_deferred() as late:  # the way out is not cut short by a signal
            if played < total or interrupted is not None:
                with ending.step("finishing to double support"):
                    robot.finish(interrupted)
            with ending.step("letting the last goals be reached and recorded"):
                robot.context.spin_for(0.5)
                if robot.supervisor.tripped and robot.ending is None:  # an alarm just now
                    robot.finish()
                    robot.context.spin_for(0.5)
            with ending.step("closing the bag"):
                if truth is not None:
                    truth.publish_new()
                    robot.context.spin_for(0.05)
                recorder.destroy()
            if viewer is not None:
                with ending.step("closing the view"):
                    viewer.close()
            manager = robot.manager
            summary: dict[str, Any] = {
                "gait": gait, "rows_played": played, "rows_asked": total, "steps": steps,
                "rate_hz": rate,
                "stopped": played < total, "ending": robot.ending or "walked",
                "alarms": [a.as_dict() for a in robot.supervisor.alarms],
                "motor_errors": {str(i): e for i, e in manager.error_counts().items()},
                "bus": {k: getattr(robot.bus.stats, k)
                        for k in ("transactions", "retries", "timeouts", "corrupt")},
                "state_rate_hz": round(manager.sweep_rate, 2),
                "state_rate_wire_limit_hz": round(1.0 / manager.update_time, 2),
                "goals": {"written": manager.owner.goals_written,
                          "replaced_before_written": manager.owner.goals_replaced},
                "walked_s": robot.context.clock.now() - started, "bag": str(bag),
                "port": port or "emulated", "controllers_failed": manager.failed,
                "motors_on_stop": ON_STOP}
            with ending.step("plotting"):
                summary["plot"] = str(plot_tracking(robot, run_folder.file("walk.png")))
                if robot.supervisor.alarms:
                    summary["alarm_plot"] = str(plot_alarms(robot,
                                                            run_folder.file("alarms.png")))
            with ending.step("measuring"):
                summary["max_tracking_error_deg"] = tracking_errors(robot)
            if robot.physics is not None:
                physics = robot.physics
                with ending.step("judging the physics"):
                    summary["physics"] = physics_summary(physics.world, physics.description,
                                                         gait_start, gait_end)
                    summary["fell"] = summary["physics"]["fell"]
                    summary["fell_at_s"] = summary["physics"]["fell_at_s"]
                    summary["physics_plot"] = str(plot_physics(
                        physics.world, run_folder.file("physics.png"), gait_start))
                    if physics.world.fell_at is not None:
                        say(summary["physics"].get("fall_cause", "it fell"))
                if video is not None:
                    with ending.step("rendering the video"):
                        summary["video"] = str(render_walk(physics.world, video))
            say(("stopped after " if played < total else "played ") + f"{played} of {total} "
                f"rows; recorded to {bag}; plot {summary.get('plot')}")
            run_folder.write_summary(summary, interrupted=ending.settle(late, summary))
    if ending.error is not None:
        say(f"interrupted ({interruption(ending.error)}): "
            + ("the robot is in double support (the stand pose)" if robot.ending == "stand"
               else "the motors hold the last pose"))
    ending.raise_if_ended()
    return summary


def tracking_errors(robot: Armstrong) -> dict[str, float]:
    """Per leg motor: the largest difference (degrees) between the last command sent before a
    state and that state's present angle, over the run's second half (after the stand)."""

    out: dict[str, float] = {}
    node = robot.node
    for motor in MOTORS[:12]:
        sent = [(t, a) for t, m, a in node.sent if m == motor]
        heard = [(t, a) for t, m, a in node.heard if m == motor]
        if not sent or not heard:
            continue
        ts = np.array([t for t, _ in sent])
        half = heard[len(heard) // 2:]
        gaps = [abs(a - sent[int(np.searchsorted(ts, t, side="right")) - 1][1])
                for t, a in half if t >= ts[0]]
        out[motor] = float(max(gaps)) if gaps else 0.0
    return out


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
            sent = [(t, a) for t, m, a in node.sent if m == motor]
            heard = [(t, a) for t, m, a in node.heard if m == motor]
            if sent:
                ax.step(*zip(*sent, strict=True), where="post", color=colour, alpha=0.5,
                        linestyle="--")
            if heard:
                ax.plot(*zip(*heard, strict=True), color=colour, label=motor)
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
        rows = supervisor.history.get(motor, [])
        t = [r[0] for r in rows]
        temp.plot(t, [np.nan if r[1] is None else r[1] for r in rows], color=colour,
                  label=f"motor {motor}")
        load.plot(t, [np.nan if r[2] is None else r[2] for r in rows], color=colour)
        silent.plot(t, [r[3] for r in rows], color=colour)
        name = f"m{motor}"
        sent = [(s - supervisor.started, a) for s, m, a in robot.node.sent if m == name]
        heard = [(s - supervisor.started, a) for s, m, a in robot.node.heard if m == name]
        if sent:
            joint.step(*zip(*sent, strict=True), where="post", color=colour, alpha=0.5,
                       linestyle="--")
        if heard:
            joint.plot(*zip(*heard, strict=True), color=colour, label=name)
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
