"""The floor world: several motors a side, the wheels' acceleration limit, wheel slip, and
building a floor for a base from the IDs of motors already on an emulated bus."""

from __future__ import annotations

import itertools
import math
import struct

import pytest

from servolab.dynamixel import Bus
from servolab.dynamixel.plant import KinematicServo, ServoCommand
from servolab.sim import DiffDriveFloor, DiffDriveGeometry, Simulation, SimulationError
from servolab.sim.floor import RampedWheel

R, SEPARATION = 0.052, 0.38  # seed 000's wheel radius and wheel base, m
IDS = (1, 2, 3, 4)


def _seed000_4motor(sim: Simulation, **floor_options: float) -> tuple[Bus, DiffDriveFloor]:
    """Seed 000's 4-motor base: EX-106+ in wheel mode, motors 1-2 on the left (mirrored:
    forward is clockwise), 3-4 on the right."""
    bus = Bus.open("emu://ex-106+:1-4", baudrate=1_000_000, simulation=sim)
    floor = DiffDriveFloor.for_base(sim, bus.emulator, [1, 2], [3, 4], wheel_radius=R,
                                    wheel_separation=SEPARATION, left_forward=-1,
                                    right_forward=1, **floor_options)  # type: ignore[arg-type]
    bus.sync_write("cw_angle_limit", dict.fromkeys(IDS, 0), raw=True)   # wheel mode
    bus.sync_write("ccw_angle_limit", dict.fromkeys(IDS, 0), raw=True)
    bus.sync_write("torque_enable", dict.fromkeys(IDS, 1))
    return bus, floor


def _forward(bus: Bus, speed: float) -> None:
    """Every wheel forward at ``speed`` rad/s, in one SYNC_WRITE of moving speed."""
    bus.sync_write("moving_speed", {1: -speed, 2: -speed, 3: speed, 4: speed})


def _rotation(bus: Bus, signs: dict[int, int]) -> float:
    """The wheels' forward rotation as their encoders count it, rad, averaged."""
    return float(sum(s * bus.emulator.motor(i).position for i, s in signs.items())) / len(signs)


SIGNS = {1: -1, 2: -1, 3: 1, 4: 1}


def test_four_motor_base_drives_straight_as_far_as_its_wheels_turned() -> None:
    sim = Simulation()
    bus, floor = _seed000_4motor(sim)
    start = _rotation(bus, SIGNS)
    _forward(bus, 2.0)
    sim.advance(1.0)
    truth = floor.ground_truth()
    turned = _rotation(bus, SIGNS) - start
    assert turned == pytest.approx(2.0, rel=0.01)
    assert truth["x"] == pytest.approx(R * turned, rel=1e-9)
    assert truth["y"] == 0.0 and truth["yaw"] == 0.0
    assert truth["linear_velocity"] == pytest.approx(R * 2.0, rel=0.01)
    assert len(floor.left_plants) == len(floor.right_plants) == 2


def test_a_side_turns_at_the_mean_of_its_motors() -> None:
    sim = Simulation()
    bus, floor = _seed000_4motor(sim)
    bus.sync_write("moving_speed", {1: -1.0, 2: -3.0, 3: 2.0, 4: 2.0})
    sim.advance(0.5)
    left, right = floor.wheel_speeds
    motor = bus.emulator.motor
    assert left == pytest.approx(-(motor(1).velocity + motor(2).velocity) / 2, rel=1e-12)
    assert right == pytest.approx(motor(3).velocity, rel=1e-12)
    assert left == pytest.approx(right, rel=0.01)  # (1 + 3) / 2 = 2 on both sides
    truth = floor.ground_truth()
    assert truth["angular_velocity"] == pytest.approx(R * (right - left) / SEPARATION)


def test_per_motor_forward_signs_in_the_geometry() -> None:
    """A tuple of signs, one per motor, when a side's motors are not mounted alike."""
    sim = Simulation()
    bus = Bus.open("emu://xm430-w210:1-4", baudrate=1_000_000, simulation=sim)
    floor = DiffDriveFloor.for_base(sim, bus.emulator, (1, 2), (3, 4), wheel_radius=0.033,
                                    wheel_separation=0.287, left_forward=(1, -1),
                                    right_forward=(-1, 1))
    assert floor.geometry.left_forward == (1, -1)
    bus.sync_write("operating_mode", dict.fromkeys(IDS, 1), raw=True)
    bus.sync_write("torque_enable", dict.fromkeys(IDS, 1))
    bus.sync_write("goal_velocity", {1: 2.0, 2: -2.0, 3: -2.0, 4: 2.0})
    sim.advance(0.5)
    truth = floor.ground_truth()
    assert truth["linear_velocity"] == pytest.approx(0.033 * 2.0, rel=0.01)
    assert truth["angular_velocity"] == 0.0


def test_acceleration_limit_ramps_the_speed_in_virtual_time() -> None:
    accel, speed = 10.0, 4.0  # rad/s^2, rad/s: 0.4 s to full speed
    sim = Simulation()
    bus, floor = _seed000_4motor(sim, max_acceleration=accel)
    assert all(isinstance(p, RampedWheel) for p in floor.left_plants + floor.right_plants)
    _forward(bus, speed)
    trace = []
    for _ in range(12):
        sim.advance(0.05)
        trace.append(floor.ground_truth())
    velocities = [t["linear_velocity"] for t in trace]
    # While ramping, each 50 ms adds exactly accel * 50 ms of wheel speed.
    for before, after in itertools.pairwise(velocities[:7]):
        assert after - before == pytest.approx(R * accel * 0.05, rel=1e-6)
    assert velocities[0] < R * accel * 0.05 + 1e-12   # from standstill, not at once
    assert max(velocities) == pytest.approx(R * min(speed, 4.0), rel=0.01)
    assert velocities[-1] == velocities[-2]            # reached, and held
    # What the firmware reads back is the ramped speed too.
    assert abs(bus.emulator.motor(3).velocity) == pytest.approx(speed, rel=0.01)
    # The distance is the ramp's: v^2 / 2a, then full speed.
    t_ramp, t_end = speed / accel, sim.now()
    ramp_start = t_end - 0.6 + (0.05 - velocities[0] / (R * accel))  # when it started
    expected = R * (speed**2 / (2 * accel) + speed * (t_end - ramp_start - t_ramp))
    assert trace[-1]["distance"] == pytest.approx(expected, rel=0.01)


def test_acceleration_limit_also_slows_the_wheels_down() -> None:
    sim = Simulation()
    bus, floor = _seed000_4motor(sim, max_acceleration=20.0)
    _forward(bus, 4.0)
    sim.advance(0.5)
    _forward(bus, 0.0)
    sim.advance(0.1)
    assert floor.ground_truth()["linear_velocity"] == pytest.approx(R * 2.0, abs=R * 0.03)
    sim.advance(0.2)
    assert floor.ground_truth()["linear_velocity"] == 0.0


def test_ramped_wheel_is_capped_by_the_no_load_speed() -> None:
    wheel = RampedWheel(5.0, max_acceleration=100.0)
    wheel.command = ServoCommand(torque_enabled=True, velocity_control=True, goal_velocity=50.0)
    for _ in range(200):
        wheel.step(0.001)
    assert wheel.velocity == 5.0
    wheel.command = ServoCommand(torque_enabled=False, velocity_control=True)
    wheel.step(0.001)
    assert wheel.velocity == pytest.approx(4.9) and wheel.effort == 0.0  # runs down
    for _ in range(100):
        wheel.step(0.001)
    assert wheel.velocity == 0.0
    with pytest.raises(SimulationError, match="max_acceleration"):
        RampedWheel(5.0, max_acceleration=0.0)


def test_no_acceleration_limit_keeps_the_kinematic_wheels() -> None:
    floor = DiffDriveFloor.example(Simulation())
    assert all(type(p) is KinematicServo for p in floor.left_plants + floor.right_plants)
    assert floor.left is floor.left_plants[0] and floor.right is floor.right_plants[0]


def test_slip_shortens_the_distance_by_the_slip_fraction() -> None:
    runs = {}
    for slip in (0.0, 0.25):
        sim = Simulation()
        bus, floor = _seed000_4motor(sim, slip=slip)
        start = _rotation(bus, SIGNS)
        _forward(bus, 3.0)
        sim.advance(1.0)
        runs[slip] = (floor.ground_truth()["x"], _rotation(bus, SIGNS) - start)
    (x0, turned0), (x1, turned1) = runs[0.0], runs[0.25]
    assert turned1 == turned0                     # the encoders count the slipping rotation
    assert x1 == pytest.approx(0.75 * x0, rel=1e-9)


def test_random_slip_is_seeded_and_deterministic() -> None:
    def run(seed: int) -> list[bytes]:
        sim = Simulation()
        bus, floor = _seed000_4motor(sim, slip=0.1, slip_jitter=0.05, seed=seed)
        _forward(bus, 3.0)
        sim.advance(0.5)
        return [struct.pack("<d", v) for v in floor.ground_truth().values()]

    assert run(7) == run(7)
    assert run(7) != run(8)
    sim = Simulation()
    bus, floor = _seed000_4motor(sim, slip=0.1, slip_jitter=0.05, seed=7)
    start = _rotation(bus, SIGNS)
    _forward(bus, 3.0)
    sim.advance(0.5)
    ratio = floor.ground_truth()["distance"] / (R * (_rotation(bus, SIGNS) - start))
    assert ratio == pytest.approx(0.9, abs=0.01)  # the jitter averages out
    assert math.isfinite(floor.ground_truth()["yaw"])


def test_bad_values_are_refused() -> None:
    sim = Simulation()
    bus = Bus.open("emu://xm430-w210:1-2", baudrate=1_000_000, simulation=sim)
    emulator = bus.emulator
    with pytest.raises(SimulationError, match="motor"):
        DiffDriveFloor.for_base(sim, emulator, [1], [9], wheel_radius=0.03,
                                wheel_separation=0.2)
    with pytest.raises(SimulationError, match="not in the simulation"):
        DiffDriveFloor.for_base(Simulation(), emulator, 1, 2, wheel_radius=0.03,
                                wheel_separation=0.2)
    with pytest.raises(SimulationError, match="2 sign"):
        DiffDriveFloor.for_base(sim, emulator, 1, 2, wheel_radius=0.03,
                                wheel_separation=0.2, left_forward=(1, 1))
    with pytest.raises(SimulationError, match="twice"):
        DiffDriveFloor(emulator.motor(1), [emulator.motor(2), emulator.motor(1)])
    with pytest.raises(SimulationError, match="slip"):
        DiffDriveFloor(emulator.motor(1), emulator.motor(2), slip=1.5)
    with pytest.raises(SimulationError, match="wheel_radius"):
        DiffDriveGeometry(wheel_radius=0.0)
    with pytest.raises(SimulationError, match="left_forward"):
        DiffDriveGeometry(left_forward=(1, 0))
