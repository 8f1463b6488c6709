"""Armstrong, the biped of seed 001, for a student: five lines to stand it up and walk.

::

    from servolab.robots.armstrong.control_node import Armstrong
    from servolab.gait.walking import generate_walk

    with Armstrong() as robot:                     # 20 emulated RX-28; port="/dev/ttyUSB0"
        robot.stand()                              # Table 4.2, over 2 s, never a jump
        robot.move_joint("left_knee", x=-50)       # degrees, as Table 4.1 names the joints
        robot.play(generate_walk().motion(), steps=2)   # 17 rows a step at 4.5 Hz

:class:`BipedNode` is the seed's control node (``node_motor``, 001 chapter 4): it sends joint
angles to the joint controllers' ``/controller_mXX/command`` topics and listens to their
``/state``; it knows nothing of the bus, so it runs the same beside the manager or in another
process. :class:`Armstrong` puts the bus, the
:class:`~servolab.robots.controllers.manager.DynamixelManager` and a :class:`BipedNode` together
in one context, with a :class:`~.supervisor.SafetySupervisor` that ends a walk on an
alarm. It refuses to start without all twelve leg motors (their controllers must run).
:meth:`Armstrong.finish` brings it to double support (the stand pose) after an alarm or a
stop; leaving it stops sending and leaves the motors holding the last pose they were sent:
a biped that loses torque falls.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ...dynamixel.errors import PortError
from ...gait import walking
from ...gait.motionfile import MotionFile
from ...middleware.context import Context
from ...middleware.node import Node
from ..controllers.manager import DynamixelManager
from ..errors import RobotError, RobotValueError
from . import hardware as armstrong
from .poses import MOTORS, POSES, STAND_POSE, Pose, interpolate, joint_pose, radians
from .series import Series
from .supervisor import FINISH_DURATION, SafetySupervisor

if TYPE_CHECKING:
    from ...dynamixel.emulator import Faults
    from ...sim.simulation import Simulation
    from .description import Assumptions
    from .physics import Physics

FLOAT64 = "std_msgs/msg/Float64"
JOINT_STATE = "dynamixel_msgs/msg/JointState"
#: How often an interpolated move sends its intermediate poses (Hz).
MOVE_RATE = 20.0
#: The seed's playback rate: 17 rows a step at 4.5 Hz, 3.78 s a step (001 section 4.2.4);
#: the gait generator derives its t_step from it.
PLAY_RATE = walking.PLAY_RATE


def controller_of(motor: str) -> str:
    """``m14`` -> ``controller_m14``, the seed's naming (Appendix A, Listing 3.4)."""
    return f"controller_{motor}"


class BipedNode(Node):
    """Sends poses (degrees per motor column) to the joint controllers; keeps each joint's
    present angle from its state, and, with ``history``, what it sent and heard when (for
    the run's plot) in bounded :class:`~.series.Series` (``sent[motor]``, ``heard[motor]``:
    a run of any length keeps at most their capacity), and each joint's largest tracking
    error from the first row played on (``tracking[motor]``, degrees: the present angle of
    a state against the last angle sent before it)."""

    def __init__(self, context: Context, motors: Sequence[str] = MOTORS, *,
                 name: str = "biped", namespace: str = "/", history: bool = False,
                 parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        self.motors = tuple(motors)
        self._publishers = {m: self.create_publisher(FLOAT64, f"/{controller_of(m)}/command",
                                                     10) for m in self.motors}
        #: degrees: the last angle sent, and the last present angle heard, per motor
        self.commanded: dict[str, float] = {}
        self.present: dict[str, float] = {}
        self.history = history
        self.sent: dict[str, Series] = {m: Series() for m in self.motors} if history else {}
        self.heard: dict[str, Series] = {m: Series() for m in self.motors} if history else {}
        #: when the tracking errors start to count (the first row played), and the largest
        self.track_from: float | None = None
        self.tracking: dict[str, float] = {}
        for m in self.motors:
            self.create_subscription(JOINT_STATE, f"/{controller_of(m)}/state",
                                     lambda msg, m=m: self._on_state(m, msg), 10)

    def _on_state(self, motor: str, msg: Any) -> None:
        angle = math.degrees(float(msg.current_pos))
        self.present[motor] = angle
        if self.history:
            now = self.now()
            self.heard[motor].append(now, angle)
            sent = self.commanded.get(motor)
            if self.track_from is not None and now >= self.track_from and sent is not None:
                self.tracking[motor] = max(self.tracking.get(motor, 0.0), abs(angle - sent))

    def send(self, pose: Pose) -> None:
        """Send each motor of ``pose`` its angle (degrees) once."""
        now = self.now()
        for motor, degrees in pose.items():
            if motor not in self._publishers:
                raise RobotValueError(f"no motor {motor!r} on this robot (it has "
                                      f"{', '.join(self.motors)})")
            if not math.isfinite(degrees):
                raise RobotValueError(f"motor {motor}: {degrees!r} is not a finite angle")
            self._publishers[motor].publish(self.message(FLOAT64, data=radians(degrees)))
            self.commanded[motor] = float(degrees)
            if self.history:
                self.sent[motor].append(now, float(degrees))

    def where(self) -> dict[str, float]:
        """Each motor's angle now, as best known: the last sent, else the last heard, else 0
        (a motor whose controller does not run, such as Armstrong's m62)."""
        return {m: self.commanded.get(m, self.present.get(m, 0.0)) for m in self.motors}

    def move_to(self, pose: Pose, duration: float = 2.0, *,
                should_stop: Callable[[], bool] = lambda: False) -> bool:
        """Go from where the joints are to ``pose`` over ``duration`` seconds, sending
        interpolated poses at :data:`MOVE_RATE`; False if stopped on the way."""
        if not duration > 0:
            raise RobotValueError(f"a move's duration must be > 0 s, not {duration!r}")
        samples = max(2, round(duration * MOVE_RATE) + 1)
        rows = interpolate(self.where(), pose, samples)
        motors = list(pose)
        rate = self.create_rate(MOVE_RATE)
        for row in rows[1:]:
            if should_stop():
                return False
            self.send(dict(zip(motors, row.tolist(), strict=True)))
            rate.sleep()
        return True

    def play(self, motion: MotionFile, steps: int = 1, rate: float = PLAY_RATE, *,
             should_stop: Callable[[], bool] = lambda: False,
             progress: Callable[[int, int], None] | None = None) -> int:
        """Play ``motion``'s rows ``steps`` times at ``rate`` rows a second (the seed's control
        node); returns the rows sent (fewer if stopped)."""
        if steps < 1:
            raise RobotValueError(f"steps must be >= 1, not {steps}")
        if not (math.isfinite(rate) and rate > 0):
            raise RobotValueError(f"rate must be a number > 0 rows a second, not {rate!r}")
        unknown = [n for n in motion.names if n not in self._publishers]
        if unknown:
            raise RobotValueError(f"the motion moves {', '.join(unknown)}, which this robot has "
                                  "not")
        total = steps * motion.poses
        if self.history and self.track_from is None:
            self.track_from = self.now()
        ticker = self.create_rate(rate)
        sent = 0
        for _ in range(steps):
            for row in motion.angles:
                if should_stop():
                    return sent
                self.send(dict(zip(motion.names, row.tolist(), strict=True)))
                sent += 1
                if progress is not None:
                    progress(sent, total)
                ticker.sleep()
        return sent


class Armstrong:
    """The biped, whole: its bus (emulated unless ``port`` names a serial device), the
    controller manager with its 20 joint controllers, and a :class:`BipedNode`, in one
    context on the simulation's time (emulated) or the wall clock (a real robot).
    ``require_legs`` False lets it start with leg motors missing (to test one joint on the
    bench); walking needs them all. ``faults`` are injected into the emulated robot's
    answers (dropped or corrupted bytes), to see what the supervisor makes of them."""

    def __init__(self, *, port: str | None = None, config: str | Path | None = None,
                 baudrate: int | None = None, history: bool = False,
                 require_legs: bool = True, faults: Faults | None = None,
                 world: str = "kinematic", assumptions: Assumptions | None = None) -> None:
        from ...clock import WallClock
        from ...sim.simulation import DEFAULT_PHYSICS_STEP, Simulation
        from .description import TIMESTEP as PHYSICS_STEP
        from .physics import WORLDS, armstrong_world

        if world not in WORLDS:
            raise RobotValueError(f"no world {world!r} for Armstrong: one of "
                                  f"{', '.join(WORLDS)}")
        if port and world != "kinematic":
            raise RobotValueError(f"world {world!r}: a real robot on {port} stands in the real "
                                  "world; worlds are for the emulated robot (leave out the port)")
        self.config = armstrong.load_config(config)
        self.simulation: Simulation | None = None if port else Simulation(
            PHYSICS_STEP if world == "mujoco" else DEFAULT_PHYSICS_STEP)
        self.bus, self.port = armstrong.open_bus(self.config, port_name=port,
                                                 simulation=self.simulation, baudrate=baudrate,
                                                 faults=faults)
        #: the MuJoCo world the emulated robot stands in (``world="mujoco"``), else None
        self.physics: Physics | None = None
        try:
            if world == "mujoco" and self.simulation is not None:
                self.physics = armstrong_world(self.simulation, self.bus.emulator, self.config,
                                               assumptions)
        except BaseException:
            self.bus.close()
            raise
        try:
            self.context = Context.open(clock=self.simulation or WallClock())
        except BaseException:
            self.bus.close()
            raise
        try:
            self.manager = DynamixelManager(self.context, self.bus, self.port,
                                            self.config.controllers)
            for warning in self.config.warnings:
                self.manager.get_logger().warning(warning)
            missing = [m for m in MOTORS[:12] if controller_of(m) not in
                       self.manager.controllers]
            if missing and require_legs:
                raise RobotValueError(
                    f"cannot walk: leg motor(s) {', '.join(missing)} did not answer on "
                    f"{self.port.port_name} (their controllers could not start; "
                    f"{self.port.ping_retries} pings each); nothing was moved. Check their "
                    "cables and power, then 'servolab scan --port PORT'")
            self.supervisor = SafetySupervisor(
                self.manager, [c.motor_id for c in self.manager.controllers.values()])
            #: how the last walk ended: "stand" (double support) or "hold"
            self.ending: str | None = None
            self.node = BipedNode(self.context, history=history)
            # where each joint is, before anything moves: a move from a guessed pose jumps
            if not self.context.spin_until(self._heard_every_joint, timeout=5.0):
                missing = [m for m in self.node.motors if m not in self.node.present
                           and controller_of(m) in self.manager.controllers]
                raise RobotError(f"no state from the joints of {', '.join(missing)} within "
                                 "5 s: is the bus working? nothing was moved")
        except BaseException:
            self.close()
            raise

    def _heard_every_joint(self) -> bool:
        wanted = {c.name for c in self.manager.controllers.values()}
        return all(m in self.node.present for m in self.node.motors
                   if controller_of(m) in wanted)

    def ok(self) -> bool:
        return self.context.ok()

    def should_stop(self) -> bool:
        """The context ended, the supervisor raised an alarm, or (in the MuJoCo world) the
        robot fell: a fallen biped playing on kicks about on the floor."""
        return not self.context.ok() or self.supervisor.tripped or self.fallen

    @property
    def fallen(self) -> bool:
        """The emulated robot fell in its MuJoCo world (never, in the kinematic one)."""
        return self.physics is not None and self.physics.world.fell_at is not None

    def finish(self, error: BaseException | None = None) -> str:
        """End a walk safely (see :mod:`.supervisor`): "stand", the joints brought to the
        stand pose (double support) over :data:`~.supervisor.FINISH_DURATION` s, or "hold"
        when the bus is gone (``error`` a :class:`PortError`) and nothing can be sent."""
        if isinstance(error, PortError) or not self.context.ok():
            self.ending = "hold"
            return self.ending
        self.node.move_to(STAND_POSE, FINISH_DURATION)
        self.ending = "stand"
        return self.ending

    def stand(self, duration: float = 2.0) -> bool:
        """Table 4.2's stand pose, reached over ``duration`` seconds."""
        return self.pose("stand", duration)

    def pose(self, name: str, duration: float = 2.0) -> bool:
        if name not in POSES:
            raise RobotValueError(f"no pose {name!r}; there are {', '.join(POSES)}")
        return self.node.move_to(POSES[name], duration, should_stop=self.should_stop)

    def move_joint(self, joint: str, duration: float = 1.0, **axes: float) -> bool:
        """Move one joint of Table 4.1 (degrees per axis) over ``duration`` seconds."""
        return self.node.move_to(joint_pose(joint, **axes), duration,
                                 should_stop=self.should_stop)

    def play(self, motion: MotionFile, steps: int = 1, rate: float = PLAY_RATE, *,
             progress: Callable[[int, int], None] | None = None) -> int:
        return self.node.play(motion, steps, rate, should_stop=self.should_stop,
                              progress=progress)

    def close(self) -> None:
        """Stop: the motors keep holding the last pose they were sent."""
        try:
            self.context.close()
        finally:
            self.bus.close()

    def __enter__(self) -> Armstrong:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
