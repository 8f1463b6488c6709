"""The default servo plant: catching up lazily is bit for bit stepping one step at a time,
through the plant alone and through the firmware on the bus."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servolab.dynamixel import Bus
from servolab.dynamixel.plant import (
    AMBIENT_C,
    IDLE_RISE_C,
    MECHANICAL_TIME_CONSTANT_S,
    STALL_HEATING_C,
    KinematicServo,
    ServoCommand,
)
from servolab.sim import Simulation, World

commands = st.builds(
    ServoCommand,
    torque_enabled=st.booleans(),
    velocity_control=st.booleans(),
    goal_position=st.floats(-7, 7),
    profile_velocity=st.sampled_from([0.0, 0.3, 2.0, 50.0]),
    goal_velocity=st.floats(-10, 10),
    torque_limit=st.sampled_from([1.0, 0.5, 0.0]),
)
phases = st.lists(st.tuples(commands, st.sampled_from([0.0, 0.3, -0.95, 1.0]),
                            st.integers(0, 2500)), min_size=1, max_size=6)


def _state(p: KinematicServo) -> tuple[float, float, float, float]:
    return (p.position, p.velocity, p.effort, p.temperature)


@settings(max_examples=150, deadline=None, derandomize=True)
@given(phases)
def test_advancing_n_steps_is_n_single_steps_bit_for_bit(plan: list) -> None:
    lazy, eager = KinematicServo(6.27, 0.2), KinematicServo(6.27, 0.2)
    for command, load, steps in plan:
        for p in (lazy, eager):
            p.command, p.external_load = command, load
        assert lazy.advance(steps, 0.001) == steps
        for _ in range(steps):
            eager.step(0.001)
        assert _state(lazy) == _state(eager)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(st.floats(0.5, 1.0), st.integers(1, 400_000), st.floats(33.0, 91.0))
@pytest.mark.slow
def test_overheating_stop_lands_on_the_first_step_above_the_limit(load: float, steps: int,
                                                                   limit: float) -> None:
    plant = KinematicServo(6.27)
    plant.command = ServoCommand(True, False, 0.0)
    plant.external_load = load  # holding against a load: the motor warms toward its steady
    taken = plant.advance(steps, 0.001, temperature_limit=limit)
    probe = KinematicServo(6.27)
    probe.command, probe.external_load = plant.command, load
    for k in range(1, taken + 1):
        probe.step(0.001)
        if probe.temperature > limit:
            assert k == taken
            break
    else:
        assert taken == steps
    assert _state(probe) == _state(plant)


def test_motion_matches_the_closed_form() -> None:
    """1 rad/s toward +1 rad: at 0.5 s half way, at 1 s there and at rest; load is friction
    while moving (the start's acceleration torque long gone); temperature rises toward its
    steady value, which goes with the square of the load (copper loss), with the 300 s lag."""
    p = KinematicServo(6.27)
    p.command = ServoCommand(True, False, goal_position=1.0, profile_velocity=1.0)
    p.advance(500, 0.001)
    assert (p.position, p.velocity) == (0.5, 1.0)
    assert p.effort == pytest.approx(0.04 + 0.12 / 6.27)
    steady = AMBIENT_C + IDLE_RISE_C + STALL_HEATING_C * p.effort ** 2
    start = AMBIENT_C + IDLE_RISE_C
    assert p.temperature == pytest.approx(steady + (start - steady) * math.exp(-0.5 / 300))
    p.advance(500, 0.001)
    assert (p.position, p.velocity) == (1.0, 0.0)
    # Arrived on step 1000: braking, -dv / no-load speed, one step into its decay.
    braking = -1.0 / 6.27 * math.exp(-0.001 / MECHANICAL_TIME_CONSTANT_S)
    assert p.effort == pytest.approx(braking, rel=1e-9)
    p.advance(500, 0.001)
    assert p.effort == pytest.approx(0.0, abs=1e-10)           # 25 mechanical time constants


def test_a_load_above_the_torque_limit_stalls_the_horn() -> None:
    p = KinematicServo(6.27)
    p.command = ServoCommand(True, True, goal_velocity=3.0, torque_limit=0.3)
    p.external_load = -0.5
    p.advance(1000, 0.001)
    assert (p.position, p.velocity) == (0.0, 0.0)
    p.external_load = -0.2          # within the limit: turns at what the torque-speed line allows
    p.advance(1000, 0.001)
    assert p.velocity == 3.0 and p.position == pytest.approx(3.0)
    p.command = ServoCommand(True, True, goal_velocity=3.0, torque_limit=0.0)
    p.external_load = 0.0           # torque_limit 0: no torque at all, even unloaded
    p.advance(1000, 0.001)
    assert p.velocity == 0.0 and p.position == pytest.approx(3.0)


class _Eager(World):
    """Steps KinematicServo plants every step, as a world would."""

    name = "eager"

    def __init__(self) -> None:
        self.plants: list[KinematicServo] = []

    def step(self, dt: float) -> None:
        for p in self.plants:
            p.step(dt)

    def ground_truth(self) -> dict[str, float]:
        return {}

    @classmethod
    def example(cls, simulation: Simulation) -> World:
        raise NotImplementedError


def _session(eager: bool, spec: str, baud: int) -> list[object]:
    """The same bus session on motors whose plants the emulator catches up lazily, or that a
    world steps every step; returns every answer."""
    sim = Simulation()
    bus = Bus.open(f"emu://{spec}", baudrate=baud, simulation=sim)
    ids = [m.id for m in bus.emulator.motors]
    if eager:
        world = sim.add(_Eager())
        for m in bus.emulator.motors:
            plant = KinematicServo(m.model.no_load_speed, m.plant.position)
            world.plants.append(plant)
            m.attach_plant(plant)
    regs = ["present_position", "present_temperature", "present_load" if spec.startswith("rx")
            else "present_current"]
    answers: list[object] = []
    bus.write(ids[0], "temperature_limit", 40, raw=True)
    bus.sync_write("torque_enable", {i: 1 for i in ids})
    bus.emulator.motor(ids[0]).external_load = 0.9   # heats past 40 °C: overheating shutdown
    for k in range(60):
        if k % 9 == 0:
            bus.sync_write("goal_position", {i: 0.4 * math.sin(k + i) for i in ids})
        if k == 20:     # more than the torque limit holds: an overload a second on, then
            # shutdown (within the 120 s the clock jumps at k = 30)
            bus.emulator.motor(ids[1]).external_load = -1.2
        motor = ids[k % len(ids)]
        answers.append(bus.read(motor, regs, raw=True, check=False))
        answers.append(bus.emulator.motor(motor).hardware_error)
        bus.port.clock.advance(0.011 * (1 + k % 4) + (120.0 if k == 30 else 0.0))
    return answers


@pytest.mark.parametrize(("spec", "baud"), [("rx28:1-3", 57142), ("xm430-w210:1-2", 1_000_000)])
@pytest.mark.slow
def test_lazy_firmware_answers_as_if_stepped_every_step(spec: str, baud: int) -> None:
    lazy, eager = _session(False, spec, baud), _session(True, spec, baud)
    assert lazy == eager
    errors = [a for a in lazy if isinstance(a, int)]
    assert any(a & 0x04 for a in errors), "the session should overheat a motor"
    assert any(a & 0x20 for a in errors), "the session should overload a motor"


def test_set_raw_acts_from_now_not_in_the_past() -> None:
    """A register set by hand after time passed acts from the present step: the horn does not
    jump to where it would be had the change been made when it was last looked at."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    motor = bus.emulator.motor(1)
    bus.write(1, "torque_enable", 1)
    bus.port.clock.advance(1.0)
    motor.set_raw("goal_position", 1023)
    assert motor.position == pytest.approx(0.0)       # nothing moved yet
    bus.port.clock.advance(0.1)
    assert 0.0 < motor.position < 1.0                 # 0.1 s at the no-load speed
    motor.set_raw("status_return_level", 1)           # a setting the firmware keeps decoded
    # level 1: the motor no longer answers a WRITE, at once and not after the next WRITE
    assert bus.emulator.receive(bus.proto.encode_instruction(bus.proto.write(1, 25, b"\x01")),
                                bus.port.clock.now(), 57142) == []


class _Reference:
    """The default plant written the plain way, one step at a time — ``p += travel``, snap on
    arrival, ``T = s + (T - s) a`` — as the emulator's physics was before it was made lazy:
    an independent check of the closed form (which agrees to rounding, and on the step the
    move arrives)."""

    def __init__(self, no_load_speed: float, position: float) -> None:
        self.top, self.position, self.velocity = no_load_speed, position, 0.0
        self.temperature = AMBIENT_C + IDLE_RISE_C

    def step(self, cmd: ServoCommand, load: float, dt: float) -> None:
        top = 0.0 if cmd.torque_limit <= 0 or abs(load) > cmd.torque_limit else \
            self.top * max(0.0, 1 - abs(load))
        if not cmd.torque_enabled:
            # torque off: the load back-drives the horn past the gears' static friction
            # (0.04 of stall), as fast as their viscous friction (0.12 at the no-load speed)
            # lets it, at most the no-load speed
            excess = abs(load) - 0.04
            self.velocity = 0.0 if excess <= 0 else math.copysign(
                self.top * min(1.0, excess / 0.12), load)
            self.position += self.velocity * dt
        elif cmd.torque_limit <= 0:
            # an output of 0: the back-EMF brakes it, w = w0 x load (the torque line, u = 0)
            self.velocity = self.top * max(-1.0, min(1.0, load))
            self.position += self.velocity * dt
        elif cmd.velocity_control:
            self.velocity = max(-top, min(top, cmd.goal_velocity))
            self.position += self.velocity * dt
        else:
            speed = top if cmd.profile_velocity == 0 else min(cmd.profile_velocity, top)
            error = cmd.goal_position - self.position
            if abs(error) <= speed * dt:
                self.velocity, self.position = 0.0, cmd.goal_position
            else:
                self.velocity = math.copysign(speed, error)
                self.position += math.copysign(speed * dt, error)
        effort = 0.0    # the sustained torque the motor gives: friction, holding the load
        if cmd.torque_enabled:
            limit = max(0.0, min(1.0, cmd.torque_limit))
            friction = 0.04 + 0.12 * (abs(self.velocity) / top if top else 0.0)
            effort = max(-limit, min(limit, (math.copysign(friction, self.velocity)
                                             if self.velocity else 0.0) - load))
        steady = AMBIENT_C + IDLE_RISE_C + STALL_HEATING_C * effort ** 2
        self.temperature = steady + (self.temperature - steady) * math.exp(-dt / 300)


@settings(max_examples=100, deadline=None, derandomize=True)
@given(phases)
def test_the_closed_form_agrees_with_plain_stepping(plan: list) -> None:
    plant, ref = KinematicServo(6.27, 0.2), _Reference(6.27, 0.2)
    for command, load, steps in plan:
        plant.command, plant.external_load = command, load
        plant.advance(steps, 0.001)
        for _ in range(steps):
            ref.step(command, load, 0.001)
        if steps:
            assert plant.position == pytest.approx(ref.position, abs=1e-9)
            assert plant.velocity == pytest.approx(ref.velocity, abs=1e-12)
            assert plant.temperature == pytest.approx(ref.temperature, rel=1e-9)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(phases, st.floats(20.0, 95.0), st.sampled_from([300.0, 5.0, 0.5]))
def test_setting_temperature_or_time_constant_keeps_lazy_equal_to_stepping(
        plan: list, celsius: float, tau: float) -> None:
    """The thermal knobs act from the present step, and the closed form goes on from there:
    still bit for bit one step at a time."""
    lazy, eager = KinematicServo(6.27, 0.2), KinematicServo(6.27, 0.2)
    for i, (command, load, steps) in enumerate(plan):
        for p in (lazy, eager):
            p.command, p.external_load = command, load
            if i == 1:
                p.temperature, p.thermal_time_constant = celsius, tau
        lazy.advance(steps, 0.001)
        for _ in range(steps):
            eager.step(0.001)
        assert _state(lazy) == _state(eager)
    if len(plan) > 1:
        assert lazy.thermal_time_constant == tau
