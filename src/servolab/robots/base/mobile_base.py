"""A differential-drive base on Dynamixel wheels, and seed 000's moves on it.

The base drives its wheels with one SYNC_WRITE per command (moving speed on Protocol 1.0 wheel
mode, goal velocity on Protocol 2.0 velocity mode), within the motors' no-load speed, scaling
both wheels together so the path's curvature is kept. It reads its wheels' encoders and
integrates odometry (:mod:`servolab.kinematics.diffdrive`), with each model's real encoder
wrap-around.

The moves of seed 000 (Appendix A) are closed loops on that odometry: a straight line stops at
its distance, a circle after its turns (Figure A3's wheel speeds), a figure of eight after one
circle each way (Figure A4), a rotation at its angle. Each ends with the wheels stopped, also
on an error or Ctrl-C (``finally``). A.2's own line (final.m) is there too,
:meth:`MobileBase.count_line`: it counts one motor's encoder up to ``h`` counts, as final.m
does, as meant or as printed (its slips included), at final.m's speed percentage
(:func:`percent_speed`).

Every move is refused before a wheel turns if it would take longer than
:data:`MAX_MOVE_SECONDS`: a typing slip (``--angle 1e9``) must not plan a drive of years.

With no port named the base is emulated: its motors roll on a simulated floor
(:class:`~servolab.sim.floor.DiffDriveFloor`) whose ground truth the tests and plots compare
the odometry with.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ...dynamixel.units import wheel_speed
from ...kinematics.diffdrive import (
    DiffDrive,
    Encoder,
    a2_increment,
    a2_increment_as_printed,
    a2_target_counts,
    circle,
    circle_time,
    clamp_wheel_speeds,
    integrate_odometry,
    limit_wheel_speeds,
    line_time,
    matlab_round,
    radius_from_counts_per_mm,
    rotation,
    tick_delta,
)
from ..errors import RobotError, RobotValueError
from .config import BaseConfig, WheelMotor

if TYPE_CHECKING:
    from ...clock import Clock
    from ...dynamixel.bus import Bus
    from ...dynamixel.models import Model
    from ...sim.floor import DiffDriveFloor
    from ...sim.simulation import Simulation

#: How often the moves' closed loops read the encoders (s of the base's clock).
LOOP_PERIOD = 0.01
#: final.m's ``pause(0.0001)`` between two reads of its counting loop (s; seed 000 A.2).
A2_PAUSE = 0.0001
#: The wheels' speed of a rotation in place (rad/s) when none is given.
ROTATE_WHEEL_SPEED = 1.0
#: The longest a move may be planned to take (s): ten minutes. Seed 000's moves last seconds
#: to a minute (Figure A4's eight as printed, 50 cm at 20 cm/s: 2 x 2t = 63 s; final.m's 1 m
#: at 30 %: 3.4 s), so ten minutes is about ten times the longest, room for slow speeds; a real
#: base meets a wall long before, and an emulated one takes about a minute of computing for
#: ten minutes of driving (a 59.9 m line at 0.1 m/s: 55 s with its bag and plot). Anything
#: longer is a slip of the keyboard (``--angle 1e9`` on seed 000's robot: two years).
MAX_MOVE_SECONDS = 600.0


def check_duration(what: str, seconds: float) -> float:
    """``seconds`` if a move may take that long, else one line naming the move (``what``, with
    its value) and :data:`MAX_MOVE_SECONDS`; checked before any wheel turns."""
    if not (math.isfinite(seconds) and seconds <= MAX_MOVE_SECONDS):
        raise RobotValueError(f"{what} would take {seconds:.3g} s, over the "
                              f"{MAX_MOVE_SECONDS:g} s (10 min) a move may take: ask for "
                              "less, or drive it as several moves")
    return seconds


def percent_speed(config: BaseConfig, percent: float) -> float:
    """final.m's "Speed Percentage" as the base's speed (m/s).

    final.m turns the percentage into ``s = abs(round((s/100)*1023))`` and writes it to moving
    speed (address 32): in wheel mode a share of the motor's full *output*, 0.1 % a unit,
    1023 = 100 % (EX-106+ e-Manual, Moving Speed, Wheel Mode). servolab reads that share as
    the same share of the no-load speed (:func:`servolab.dynamixel.units.wheel_speed`), so the
    speed returned encodes back to final.m's ``s`` on the wire (30 % -> 307). It is a unit of
    the seed, converted here at the edge: the base itself runs in m/s. A motor whose speed
    register is a velocity (Protocol 2.0, or a 1.0 model that regulates speed) has no such
    percentage: refused."""
    model = config.model
    if config.protocol != 1 or not model.wheel_output_ratio:
        raise RobotValueError(f"a speed percentage is final.m's share of a wheel-mode motor's "
                              f"output (moving speed, 0.1 % a unit); the {model.name} is given "
                              "a velocity: ask for a speed in m/s")
    if not (math.isfinite(percent) and 0 < percent <= 100):
        raise RobotValueError(f"a speed percentage must be in (0, 100], not {percent:g}")
    raw = abs(matlab_round(percent / 100 * 1023))
    if raw == 0:
        raise RobotValueError(f"{percent:g} % rounds to a moving speed of 0 (final.m's "
                              "round(s/100*1023)): the wheels would not turn")
    return wheel_speed(model, raw) * config.wheel_radius


def counting_motor(config: BaseConfig, forwards: bool) -> tuple[WheelMotor, int]:
    """The motor whose encoder final.m's line counts, and the sign its count moves with.

    final.m reads motor 4 forwards and motor 1 backwards (``m=4``, ``m=1``): on the 4-motor
    base the motors turning counter-clockwise on that move, whose count goes up (e-Manual,
    Present Position: "increased or decreased by 1 depending on the moving direction"). So:
    forwards the last motor whose count rises, backwards the first; a base with none (both
    sides mounted alike, backwards) counts a falling motor down (sign -1)."""
    sign = 1 if forwards else -1
    rising = [m for m in config.motors if m.direction * sign > 0]
    if rising:
        return (rising[-1] if forwards else rising[0]), 1
    return config.motors[0], -1


@dataclass(frozen=True)
class CountedLine:
    """What :meth:`MobileBase.count_line` did: final.m's numbers, and the slips it met."""

    motor: int            # the motor read (final.m's m)
    counts_per_mm: float
    target: int           # h
    counted: int          # i when the loop ended
    reads: int            # reads of motor m in the loop
    equal_reads: int      # reads equal to the one before (q == p)
    wraps: int            # reads below the one before (q < p) on a rising count: wraps
    as_printed: bool      # counted as final.m is printed (65535 wrap, q == p branch)
    #: the wheel radius (m) counts_per_mm implies on this encoder; the base's is in config
    implied_radius: float
    #: the motor's count read after the stop (final.m's last read)
    final_read: int


def encoder_of(model: Model) -> Encoder:
    """A wheel motor's encoder as odometry needs it, from the model's data (what
    ``present_position`` reads in wheel mode, :attr:`Model.wheel_position`): the EX-106+ counts
    0..65535 and round, an MX-28 the ticks of each turn (0..4095), an X-series motor keeps a
    signed 32-bit multi-turn count. A motor whose position in wheel mode is a potentiometer
    (AX, RX) cannot count a wheel's turns: ValueError."""
    ticks = 2 * math.pi / model.rad_per_tick
    if model.protocol == 2:
        return Encoder(ticks_per_rev=ticks, modulus=2**32, signed=True)
    if model.wheel_position == "encoder16":
        return Encoder(ticks_per_rev=ticks, modulus=65536)
    if model.wheel_position == "turn":
        return Encoder(ticks_per_rev=ticks, modulus=round(ticks))
    raise RobotValueError(f"the {model.name} reads a potentiometer in wheel mode, not an encoder: "
                          "it cannot count a wheel's turns for odometry")


@dataclass
class Pose:
    x: float = 0.0
    y: float = 0.0
    theta: float = 0.0   # not wrapped: a circle's turns are counted in it


class MobileBase:
    """A base (see the module docstring) on ``bus``, timed by ``clock``."""

    def __init__(self, config: BaseConfig, bus: Bus, clock: Clock, *,
                 floor: DiffDriveFloor | None = None, setup: bool = True) -> None:
        self.config = config
        self.bus = bus
        self.clock = clock
        self.floor = floor
        self.drive = DiffDrive(config.wheel_radius, config.wheel_separation)
        self.encoder = encoder_of(config.model)
        self.pose = Pose()
        #: each wheel's rotation since start (rad, positive forwards), from its encoder
        self.wheel_rotation = {"left": 0.0, "right": 0.0}
        self.commands: list[tuple[float, float, float]] = []  # (t, left, right) rad/s sent
        #: (t, odometry x, y, theta, truth x, y, yaw) at every odometry update (truth NaN on
        #: a real base): what a run's plot draws
        self.track: list[tuple[float, ...]] = []
        #: called with each new odometry pose while a move runs (a progress display)
        self.on_update: Callable[[Pose], None] | None = None
        self._ids = [m.id for m in config.motors]
        #: the fastest a wheel may be told to turn (rad/s): the model's no-load speed, and on
        #: Protocol 2.0 the motors' velocity_limit (a goal above it is refused by the motor)
        self.max_wheel_speed = config.max_wheel_speed
        if setup:  # without: a look at the wheels (their rpm) that changes nothing
            self._setup()
        self._ticks = self._read_ticks()

    # -- construction ------------------------------------------------------------------------

    @classmethod
    def emulated(cls, config: BaseConfig, simulation: Simulation | None = None, *,
                 slip: float = 0.0, slip_jitter: float = 0.0,
                 max_acceleration: float | None = None, encoder_noise: float = 0.0,
                 seed: int = 0, start: tuple[float, float, float] = (0.0, 0.0, 0.0)
                 ) -> MobileBase:
        """The base's motors emulated, rolling on a simulated floor in ``simulation``, placed
        at ``start`` ``(x, y, yaw)`` on the floor (m, rad; odometry starts at zero wherever the
        base stands, as a real base's does);
        ``slip`` (a fraction of each wheel's turn that does not move the base, with a seeded
        random ``slip_jitter`` on top), ``max_acceleration`` (rad/s^2 of a wheel) and
        ``encoder_noise`` (rad, standard deviation of each position reading) make the floor
        less kind than odometry assumes."""
        from ...dynamixel.bus import Bus
        from ...dynamixel.emulator import build_emulator
        from ...dynamixel.motorspec import MotorEntry, MotorSpec
        from ...sim.emulated import port_to
        from ...sim.floor import DiffDriveFloor
        from ...sim.simulation import Simulation

        sim = simulation or Simulation()
        spec = MotorSpec(config.protocol, config.baudrate,
                         tuple(MotorEntry(config.model, m.id) for m in config.motors))
        emulator = sim.add_emulator(build_emulator(spec))
        left, right = config.side("left"), config.side("right")
        floor = DiffDriveFloor.for_base(
            sim, emulator, [m.id for m in left], [m.id for m in right],
            wheel_radius=config.wheel_radius, wheel_separation=config.wheel_separation,
            left_forward=tuple(m.mounting for m in left),
            right_forward=tuple(m.mounting for m in right),
            slip=slip, slip_jitter=slip_jitter, max_acceleration=max_acceleration,
            encoder_noise=encoder_noise, seed=seed, x=start[0], y=start[1], yaw=start[2])
        bus = Bus(port_to(emulator, sim, config.baudrate))
        return cls(config, bus, sim, floor=floor)

    def _setup(self) -> None:
        """Wheel mode (1.0: both angle limits 0) or velocity mode (2.0) with each motor's
        Drive Mode direction bit as configured, wheels stopped, torque on."""
        bus = self.bus
        if self.config.protocol == 1:
            for i in self._ids:
                if not bus.wheel_mode(i):
                    bus.write(i, {"cw_angle_limit": 0, "ccw_angle_limit": 0}, raw=True)
            bus.sync_write("moving_speed", dict.fromkeys(self._ids, 0.0))
        else:
            bus.sync_write("torque_enable", dict.fromkeys(self._ids, 0))
            bus.sync_write("operating_mode", dict.fromkeys(self._ids, 1), raw=True)
            for m in self.config.motors:  # Drive Mode bit 0 as configured (EEPROM: torque off)
                mode = int(bus.read(m.id, "drive_mode", raw=True))
                wanted = mode | 0x01 if m.reverse else mode & ~0x01
                if wanted != mode:
                    bus.write(m.id, "drive_mode", wanted, raw=True)
            bus.sync_write("goal_velocity", dict.fromkeys(self._ids, 0.0))
            limits = [float(bus.read(i, "velocity_limit")) for i in self._ids]
            self.max_wheel_speed = min(self.max_wheel_speed, *limits)
        bus.sync_write("torque_enable", dict.fromkeys(self._ids, 1))

    # -- driving -----------------------------------------------------------------------------

    def set_wheel_speeds(self, left: float, right: float) -> tuple[float, float]:
        """Turn the wheels at ``left`` and ``right`` rad/s (positive: forwards), scaled
        together to the motors' no-load speed (the curvature is kept), or with ``wheel_clamp:
        per-wheel`` each clamped to :attr:`wheel_limit` (Listing 4), in one SYNC_WRITE;
        returns the speeds sent. NaN or infinity is refused and nothing is sent."""
        if self.config.wheel_clamp == "per-wheel":  # Listing 4: each wheel on its own
            l_speed, r_speed = clamp_wheel_speeds(left, right, self.wheel_limit)
        else:
            l_speed, r_speed = limit_wheel_speeds(left, right, self.max_wheel_speed)
        wheel = {"left": float(l_speed), "right": float(r_speed)}
        values = {m.id: m.direction * wheel[m.side] for m in self.config.motors}
        register = "moving_speed" if self.config.protocol == 1 else "goal_velocity"
        self.bus.sync_write(register, values)
        self.commands.append((self.clock.now(), wheel["left"], wheel["right"]))
        return wheel["left"], wheel["right"]

    @property
    def wheel_limit(self) -> float:
        """The per-wheel limit of ``wheel_clamp: per-wheel`` (rad/s): ``max_linear_velocity``
        at the wheel's rim (Listing 4's LIMIT_X_MAX_VELOCITY is the TurtleBot3's top speed),
        else the fastest a wheel may turn."""
        linear = self.config.max_linear_velocity
        rim = math.inf if linear is None else linear / self.config.wheel_radius
        return min(rim, self.max_wheel_speed)

    def wheel_commands(self) -> dict[int, int]:
        """Each wheel motor's speed command as its register holds it now (raw), read back
        from the motors: what a summary reports to show that a stop reached them."""
        register = "moving_speed" if self.config.protocol == 1 else "goal_velocity"
        return {i: int(self.bus.read(i, register, raw=True)) for i in self._ids}

    def stop(self) -> None:
        """Both wheels at 0 (one SYNC_WRITE)."""
        self.set_wheel_speeds(0.0, 0.0)

    def close(self) -> None:
        """Close the bus (the wheels keep their last command: :meth:`stop` first)."""
        self.bus.close()

    @contextmanager
    def stopping(self) -> Iterator[MobileBase]:
        """``with base.stopping(): ...`` stops the wheels when the block ends, however."""
        try:
            yield self
        finally:
            self.stop()

    # -- odometry ----------------------------------------------------------------------------

    def _read_ticks(self) -> dict[str, int]:
        """Each side's first motor's raw encoder count (the motors of a side turn together):
        one SYNC_READ of both on Protocol 2.0, a READ each on 1.0 (the EX-106+ has neither
        SYNC_READ nor BULK_READ)."""
        first = {side: self.config.side(side)[0].id for side in ("left", "right")}
        if self.config.protocol == 2:
            counts = self.bus.sync_read("present_position", list(first.values()), raw=True)
            return {side: int(counts[i]) for side, i in first.items()}
        return {side: int(self.bus.read(i, "present_position", raw=True))
                for side, i in first.items()}

    def update_odometry(self) -> Pose:
        """Read the encoders and integrate the increments since the last read."""
        ticks = self._read_ticks()
        deltas = {}
        for side in ("left", "right"):
            direction = self.config.side(side)[0].direction
            deltas[side] = direction * int(tick_delta(self._ticks[side], ticks[side],
                                                      self.encoder))
            self.wheel_rotation[side] += (2 * math.pi * deltas[side]
                                          / self.encoder.ticks_per_rev)
        self._ticks = ticks
        x, y, theta = integrate_odometry((self.pose.x, self.pose.y, self.pose.theta),
                                         deltas["left"], deltas["right"], self.drive,
                                         self.encoder)
        self.pose = Pose(float(x), float(y), float(theta))
        truth = self.floor.ground_truth() if self.floor is not None else {}
        self.track.append((self.clock.now(), self.pose.x, self.pose.y, self.pose.theta,
                           truth.get("x", math.nan), truth.get("y", math.nan),
                           truth.get("yaw", math.nan)))
        return self.pose

    def encoder_counts(self) -> dict[str, int]:
        """Each side's raw encoder count as last read (TurtleBot3's ``sensor_state`` carries
        these): 0..65535 on a 1.0 wheel-mode motor, the signed 32-bit count on 2.0."""
        return dict(self._ticks)

    def wheel_angles(self) -> tuple[float, float]:
        """The left and right wheels' rotation since start (rad), as of the last
        :meth:`update_odometry`."""
        return self.wheel_rotation["left"], self.wheel_rotation["right"]

    def rpm(self) -> dict[int, float]:
        """Each wheel motor's present speed in rpm (000 A.1's "read current speed")."""
        register = "present_speed" if self.config.protocol == 1 else "present_velocity"
        return {i: float(self.bus.read(i, register)) * 60 / (2 * math.pi) for i in self._ids}

    # -- seed 000's moves ------------------------------------------------------------------------

    def _within_limits(self, what: str, left: float, right: float) -> None:
        """Refuse a move whose wheel speeds the motors cannot give (before anything moves):
        a move is geometry, and scaling it down would change its timing, not its shape,
        silently."""
        top = self.max_wheel_speed
        for side, speed in (("left", left), ("right", right)):
            if abs(speed) > top * (1 + 1e-9):
                raise RobotValueError(f"{what} needs the {side} wheel at {abs(speed):.3f} rad/s, "
                                      f"over the {self.config.model.name}'s {top:.3f} rad/s: ask "
                                      "for a lower speed")
        linear = 0.5 * (abs(left) + abs(right)) * self.drive.wheel_radius
        limit = self.config.max_linear_velocity
        if limit is not None and linear > limit * (1 + 1e-9):
            raise RobotValueError(f"{what} drives at {linear:.3f} m/s, over the base's "
                                  f"max_linear_velocity {limit:g} m/s")

    def _loop(self, done: Callable[[Pose], bool], timeout: float) -> None:
        end = self.clock.now() + timeout
        while not done(pose := self.update_odometry()):
            if self.on_update is not None:
                self.on_update(pose)
            if self.clock.now() > end:
                raise RobotError(f"the move did not finish within {timeout:g} s: is a wheel "
                                 "blocked, or the base against something?")
            self.clock.sleep(LOOP_PERIOD)

    def line(self, distance: float, speed: float) -> float:
        """Drive ``distance`` m (negative: backwards) at ``speed`` m/s, stopping when the
        odometry has covered it; returns the distance odometry measured."""
        if not math.isfinite(distance):
            raise RobotValueError(f"distance must be a finite number of metres, not {distance!r}")
        _check("speed", speed)
        sign = 1.0 if distance >= 0 else -1.0
        wheel = sign * speed / self.drive.wheel_radius
        self._within_limits(f"a line at {speed:g} m/s", wheel, wheel)
        check_duration(f"a line of {distance:g} m at {speed:g} m/s",
                       line_time(distance, speed))
        start = (self.update_odometry().x, self.pose.y)
        if distance == 0:
            return 0.0  # nothing to drive: the wheels are not started

        def covered(p: Pose) -> float:
            return math.hypot(p.x - start[0], p.y - start[1])

        with self.stopping():
            self.set_wheel_speeds(wheel, wheel)
            self._loop(lambda p: covered(p) >= abs(distance), 10 * abs(distance) / speed + 5)
        return covered(self.update_odometry())

    def circle(self, radius: float, speed: float, *, clockwise: bool = False,
               turns: float = 1.0) -> None:
        """Figure A3: a circle of ``radius`` m at ``speed`` m/s (the centre's), ``turns``
        times, counter-clockwise unless ``clockwise``; ends when odometry has turned that far."""
        _check("radius", radius)
        _check("speed", speed)
        _check("turns", turns)
        move = circle(radius, speed, self.drive, clockwise=clockwise, turns=turns)
        self._within_limits(f"a circle of {radius:g} m at {speed:g} m/s", move.left,
                            move.right)
        check_duration(f"{turns:g} turn(s) of a circle of {radius:g} m at {speed:g} m/s",
                       move.duration)
        start = self.update_odometry().theta
        target = 2 * math.pi * turns
        with self.stopping():
            self.set_wheel_speeds(move.left, move.right)
            self._loop(lambda p: abs(p.theta - start) >= target, 10 * move.duration + 5)

    def eight(self, radius: float, speed: float) -> None:
        """Figure A4: a circle counter-clockwise, then one clockwise."""
        _check("radius", radius)
        _check("speed", speed)
        move = circle(radius, speed, self.drive)
        self._within_limits(f"an eight of {radius:g} m at {speed:g} m/s", move.left,
                            move.right)
        check_duration(f"an eight of {radius:g} m at {speed:g} m/s",
                       2 * circle_time(radius, speed))
        with self.stopping():
            self.circle(radius, speed)
            self.circle(radius, speed, clockwise=True)

    def rotate(self, angle: float, wheel_speed: float = ROTATE_WHEEL_SPEED) -> None:
        """Turn in place by ``angle`` rad (positive: counter-clockwise) with the wheels at
        ``wheel_speed`` rad/s."""
        if not math.isfinite(angle):
            raise RobotValueError(f"angle must be a finite number of radians, not {angle!r}")
        _check("wheel_speed", wheel_speed)
        if angle == 0:
            return  # nothing to turn: the wheels are not started
        self._within_limits(f"a rotation at {wheel_speed:g} rad/s", wheel_speed, wheel_speed)
        duration = check_duration(
            f"a rotation of {math.degrees(angle):g} deg at {wheel_speed:g} rad/s a wheel",
            rotation(angle, wheel_speed, self.drive).duration)
        start = self.update_odometry().theta
        sign = 1.0 if angle >= 0 else -1.0
        with self.stopping():
            self.set_wheel_speeds(-sign * wheel_speed, sign * wheel_speed)
            self._loop(lambda p: abs(p.theta - start) >= abs(angle), 10 * duration + 5)

    def count_line(self, distance: float, speed: float, counts_per_mm: float, *,
                   as_printed: bool = False) -> CountedLine:
        """Seed 000 A.2's line (final.m): drive ``distance`` m at ``speed`` m/s until one
        motor's encoder has counted ``h = abs(round(counts_per_mm * d_mm))``.

        The loop is final.m's: read motor ``m``'s present position once before the wheels
        start (``p``), then ``q`` again and again with ``pause(0.0001)`` between, adding each
        read's counts to ``i`` until ``i >= h``; then stop, and read ``m`` once more. Counted as
        meant by default (a wrap counts 65536, equal reads nothing); ``as_printed`` counts as
        final.m is printed (``q - p + 65535`` whenever ``q - p`` is not positive), to show
        what its slips do. How far the base gets depends on its real wheel:
        ``counts_per_mm`` implies a radius (:attr:`CountedLine.implied_radius`), and a base of
        another radius drives that much more or less. Odometry and the track are updated every
        :data:`LOOP_PERIOD` beside the count, for the plot and the summary."""
        if not math.isfinite(distance):
            raise RobotValueError(f"distance must be a finite number of metres, not {distance!r}")
        _check("speed", speed)
        _check("counts_per_mm", counts_per_mm)
        forwards = distance >= 0
        wheel = (1.0 if forwards else -1.0) * speed / self.drive.wheel_radius
        self._within_limits(f"a line at {speed:g} m/s", wheel, wheel)
        target = a2_target_counts(distance, counts_per_mm)
        implied = radius_from_counts_per_mm(counts_per_mm, self.encoder)
        travel = target / self.encoder.ticks_per_rev * 2 * math.pi * self.drive.wheel_radius
        duration = check_duration(
            f"a line of {target} counts ({distance:g} m at {counts_per_mm:g} counts/mm) at "
            f"{speed:g} m/s", travel / speed)
        motor, count_sign = counting_motor(self.config, forwards)
        self.update_odometry()

        def read() -> int:
            return int(self.bus.read(motor.id, "present_position", raw=True))

        p = read()
        i = reads = equal = wraps = 0
        if target > 0:
            with self.stopping():
                self.set_wheel_speeds(wheel, wheel)
                timeout = 10 * duration + 5
                end = self.clock.now() + timeout
                next_odometry = self.clock.now() + LOOP_PERIOD
                while i < target:
                    q = read()
                    reads += 1
                    equal += q == p
                    wraps += (q - p) * count_sign < 0
                    i += (a2_increment_as_printed(p, q) if as_printed
                          else count_sign * a2_increment(p, q, self.encoder))
                    p = q
                    if self.clock.now() >= next_odometry:
                        pose = self.update_odometry()
                        if self.on_update is not None:
                            self.on_update(pose)
                        next_odometry += LOOP_PERIOD
                    if self.clock.now() > end:
                        raise RobotError(f"the line did not count {target} counts within "
                                         f"{timeout:g} s (counted {i}): is a wheel blocked?")
                    self.clock.sleep(A2_PAUSE)
        self.update_odometry()
        return CountedLine(motor.id, counts_per_mm, target, i, reads, equal, wraps,
                           as_printed, implied, read())

    def truth(self) -> dict[str, float]:
        """The floor's ground truth (emulated bases only)."""
        if self.floor is None:
            raise RobotError("a real base has no ground truth")
        return self.floor.ground_truth()


def _check(name: str, value: float) -> None:
    if not (math.isfinite(value) and value > 0):
        raise RobotValueError(f"{name} must be a number > 0, not {value!r}")


def open_base(config: BaseConfig, port: str | None, *, setup: bool = True,
              slip: float = 0.0, slip_jitter: float = 0.0,
              encoder_noise: float = 0.0) -> MobileBase:
    """The base: emulated on the simulated floor (with ``slip``, see
    :meth:`MobileBase.emulated`), or the real one on ``port``; without ``setup`` its motors are
    left as they are (to read their speed)."""
    if port is None:
        return MobileBase.emulated(config, slip=slip, slip_jitter=slip_jitter,
                                   encoder_noise=encoder_noise)
    from ...clock import WallClock
    from ...dynamixel.bus import Bus

    return MobileBase(config, Bus.open(port, protocol=config.protocol,
                                       baudrate=config.baudrate), WallClock(), setup=setup)
