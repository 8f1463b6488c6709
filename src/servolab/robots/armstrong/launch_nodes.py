"""Armstrong's nodes for launch files: the robot side and the walking side, as the seed's two
launch files split them (``controller_manager.launch`` + ``controller_spawner.launch`` on the
robot, the control node beside them or on another machine).

- :class:`ArmstrongRobot` opens the robot's bus (the emulated robot running in real time, or
  the serial port of parameter ``port``) and runs the :class:`~servolab.robots.controllers.manager.
  DynamixelManager` with the controllers of parameter ``controllers`` (all configured ones by
  default, as the spawner's list in 001 Listing 3.4).
- :class:`Walker` is the control node: when every joint's state has come, it moves to the
  stand pose over ``stand_duration`` s, plays the motion (``file``, or the seed's gait) ``steps``
  times at ``rate`` rows a second, and stops its context, so that a launch whose walker is
  ``required`` ends when the walk does. Timers drive it: it never blocks the executor. It
  listens to ``/diagnostics``: a motor of the robot at level ERROR (silent, overloaded,
  overheating: :mod:`..controllers.diagnostics`) ends the gait and brings the joints to the
  stand pose, as the in-process supervisor does, then stops with the alarm as its error. It
  may run in another process than the robot, so it learns of an alarm at the diagnostics'
  rate (1 Hz by default), not at every sweep.

``configs/armstrong.launch.yaml`` runs both, in one process or, over Zenoh, in two.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from ...middleware.context import Context
from ...middleware.node import Node
from ..controllers.diagnostics import DIAGNOSTIC_ARRAY, ERROR
from ..controllers.manager import DynamixelManager
from ..errors import RobotError, RobotValueError
from . import hardware as armstrong
from .control_node import MOVE_RATE, PLAY_RATE, BipedNode
from .poses import MOTORS, STAND_POSE, interpolate
from .supervisor import FINISH_DURATION

#: How a motor's status is named in /diagnostics (dynamixel_serial_proxy's naming).
_MOTOR_STATUS = "Robotis Dynamixel Motor "


class ArmstrongRobot(Node):
    """The robot side: see the module docstring. Parameters: ``config`` (controller YAML,
    default the shipped armstrong.yaml), ``port`` (a serial device; "" for the emulated robot),
    ``controllers`` (names to start; empty for all)."""

    def __init__(self, context: Context, name: str = "armstrong", namespace: str = "/", *,
                 parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        from ...sim.simulation import Simulation

        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        config_path = self.declare_parameter("config", "", description="controller YAML "
                                             "(empty: the shipped armstrong.yaml)").value
        port = self.declare_parameter("port", "", description="serial device; empty: the "
                                      "emulated robot").value
        wanted = self.declare_parameter("controllers", [""], description="controllers to "
                                        "start (empty: all configured)").value
        config = armstrong.load_config(config_path or None)
        chosen = [c for c in config.controllers if not any(wanted) or c.name in wanted]
        unknown = sorted(set(w for w in wanted if w) - {c.name for c in config.controllers})
        if unknown:
            raise RobotValueError(f"controllers {', '.join(unknown)} are not in {config.path}")
        self.simulation = None if port else Simulation()
        self.bus, used = armstrong.open_bus(config, port_name=port or None,
                                            simulation=self.simulation)
        if self.simulation is not None:
            self.simulation.start_real_time()  # the emulated motors move as time passes
        try:
            self.manager = DynamixelManager(context, self.bus, used, chosen)
        except BaseException:
            self._release()
            raise

    def _release(self) -> None:
        if self.simulation is not None:
            self.simulation.stop_real_time()
        self.bus.close()

    def destroy(self) -> None:
        super().destroy()
        self._release()


class Walker(BipedNode):
    """The walking side: see the module docstring. Parameters: ``steps`` (2), ``rate``
    (4.5 rows a second), ``file`` (a motion CSV; empty for the seed's gait), ``stand_duration``
    (2.0 s), ``wait_for_states`` (10.0 s)."""

    def __init__(self, context: Context, name: str = "walker", namespace: str = "/", *,
                 parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        from .motions import load_motion

        super().__init__(context, name=name, namespace=namespace,
                         parameter_overrides=parameter_overrides, remappings=remappings)
        steps = int(self._param("steps", 2))
        rate = float(self._param("rate", PLAY_RATE))
        path = str(self._param("file", ""))
        config = str(self._param("config", ""))
        self.stand_duration = float(self._param("stand_duration", 2.0))
        self.wait_for_states = float(self._param("wait_for_states", 10.0))
        if steps < 1 or not (math.isfinite(rate) and rate > 0) or not (
                math.isfinite(self.stand_duration) and self.stand_duration > 0):
            raise RobotValueError(f"walker: steps {steps} must be >= 1, rate {rate:g} and "
                                  f"stand_duration {self.stand_duration:g} > 0")
        # checked whole, against the robot's joint limits, before anything moves
        self.motion = load_motion(path or None, config or None)
        self.steps, self.rate = steps, rate
        self.rows_played = 0
        #: the alarms /diagnostics reported ("motor 14: OVERHEATING"); any ends the walk
        self.alarms: list[str] = []
        self._finishing = False
        self._started = self.now()
        self._queue: list[dict[str, float]] = []
        self._rows = 0  # of the gait, to play: steps x the motion's (none are queued)
        self._timer = self.create_timer(0.1, self._wait_for_states)
        self.create_subscription(DIAGNOSTIC_ARRAY, "/diagnostics", self._on_diagnostics, 10)

    def _param(self, name: str, default: Any) -> Any:
        return self.declare_parameter(name, default).value

    def _wait_for_states(self) -> None:
        """Start once the legs' joint states have come, so that the stand move starts where
        the joints are; without them after ``wait_for_states`` s, move nothing and stop (a
        move from a guessed pose would jump)."""
        legs = set(MOTORS[:12])
        heard = legs <= self.present.keys()
        if not heard and self.now() - self._started < self.wait_for_states:
            return
        self._timer.cancel()
        if not heard:
            missing = sorted(legs - self.present.keys())
            raise RobotError(f"walker: no joint state from {', '.join(missing)} within "
                             f"{self.wait_for_states:g} s: is the robot side running? "
                             "nothing was moved")
        self._move_to_stand(self.stand_duration, self._stand)

    def _move_to_stand(self, duration: float, step: Any) -> None:
        """Queue the poses from where the joints are to the stand pose over ``duration`` s,
        and send them one at a time at :data:`MOVE_RATE` from ``step``."""
        samples = max(2, round(duration * MOVE_RATE) + 1)
        rows = interpolate(self.where(), STAND_POSE, samples)[1:]
        self._queue = [dict(zip(STAND_POSE, r.tolist(), strict=True)) for r in rows]
        self._timer = self.create_timer(1.0 / MOVE_RATE, step)

    def _stand(self) -> None:
        if self._queue:
            self.send(self._queue.pop(0))
            return
        self._timer.cancel()
        self._rows = self.steps * self.motion.poses
        self.get_logger().info(f"standing; playing {self._rows} rows at {self.rate:g} Hz")
        self._timer = self.create_timer(1.0 / self.rate, self._play)

    def _play(self) -> None:
        if self.rows_played < self._rows:  # row by row: a long walk queues nothing
            row = self.motion.angles[self.rows_played % self.motion.poses]
            self.send(dict(zip(self.motion.names, row.tolist(), strict=True)))
            self.rows_played += 1
            return
        self._timer.cancel()
        self.get_logger().info(f"walked: {self.rows_played} rows")
        self.context.shutdown()  # a required walker ends the launch

    def _on_diagnostics(self, msg: Any) -> None:
        """A motor of this robot at level ERROR: end the walk in double support."""
        if self._finishing:
            return
        for status in msg.status:
            name = str(status.name)
            if int(status.level) < ERROR or not name.startswith(_MOTOR_STATUS):
                continue
            motor = name.removeprefix(_MOTOR_STATUS).split()[0]
            if f"m{motor}" in self.motors:
                self.alarms.append(f"motor {motor}: {status.message}")
        if self.alarms:
            self._finish()

    def _finish(self) -> None:
        self._finishing = True
        self._timer.cancel()
        self.get_logger().error(f"ALARM {'; '.join(self.alarms)}: ending the walk in double "
                                "support")
        if not self.present:  # nothing moved yet: nothing to bring down
            self._end()
            return
        self._move_to_stand(FINISH_DURATION, self._finish_step)

    def _finish_step(self) -> None:
        if self._queue:
            self.send(self._queue.pop(0))
            return
        self._timer.cancel()
        self._end()

    def _end(self) -> None:
        raise RobotError(f"walker: the walk ended after {self.rows_played} rows on an alarm "
                         f"({'; '.join(self.alarms)}); the robot is in the stand pose")
