"""An emulated XM430-W350 moves along the profile its registers ask for, and reports it as
the e-Manual says: ROBOTIS-GIT/emanual ``control_table_profile_velocity.md`` (the trapezoid,
t1 = 64 x Profile Velocity / Profile Acceleration ms, Velocity Trajectory(136) and Position
Trajectory(140)), ``control_table_profile_acceleration.md`` and ``control_table_drivemode.md``
(Drive Mode bit 2, the time-based profile: Profile Velocity is the span t3, Profile
Acceleration the acceleration time t1, both in ms), ``control_table_moving_status.md`` (bits
0x01 in position, 0x02 profile ongoing, 0x30/0x20/0x10 trapezoidal/triangular/rectangular).

Everything goes over the bus, in raw register values as a ROBOTIS example writes them; the
clock is the emulator's virtual one, stepped at its 1 ms physics step (the control period
the timings are judged to)."""

from __future__ import annotations

import itertools
import math

import pytest

from servolab.dynamixel import Bus

PERIOD = 0.001          # the simulation's physics step (sim.simulation.DEFAULT_PHYSICS_STEP)
POLL = 0.001
CENTRE = 2048


def arm(drive_mode: int = 0, mode: int = 3) -> Bus:
    bus = Bus.open("emu://xm430-w350:1", baudrate=1_000_000, retries=0)
    bus.write(1, "operating_mode", mode, raw=True)
    bus.write(1, "drive_mode", drive_mode, raw=True)
    bus.write(1, "torque_enable", 1)
    return bus


def watch_move(bus: Bus, goal: int, limit: float = 5.0) -> list[tuple[float, int, int, int]]:
    """Write ``goal`` (raw) and read (t, Moving Status, present position, Velocity Trajectory)
    every poll until the in-position bit comes with no profile ongoing and the horn on the
    goal."""
    clock = bus.port.clock  # type: ignore[attr-defined]
    start = clock.now()
    bus.write(1, "goal_position", goal, raw=True)
    seen: list[tuple[float, int, int, int]] = []
    while clock.now() - start < limit:
        clock.advance(POLL)
        raw = bus.read(1, ["moving_status", "present_position", "velocity_trajectory"],
                       raw=True)
        seen.append((clock.now() - start, int(raw["moving_status"]),
                     int(raw["present_position"]), int(raw["velocity_trajectory"])))
        if seen[-1][1] & 0x01 and not seen[-1][1] & 0x02 and seen[-1][2] == goal:
            return seen
    raise AssertionError(f"no In-Position after {limit} s: {seen[-1]}")


def within(seen: list[tuple[float, int, int, int]]) -> float:
    """How closely the arrival is known: the longest gap between two reads (a poll and its
    READ's wire time at 1 Mbps), plus the physics step the motor's state is sampled at."""
    times = [0.0] + [t for t, *_ in seen]
    return max(b - a for a, b in itertools.pairwise(times)) + PERIOD


def nearest(seen: list[tuple[float, int, int, int]], t: float) -> int:
    """The Velocity Trajectory read nearest to ``t``."""
    return min(seen, key=lambda row: abs(row[0] - t))[3]


def test_the_1024_tick_trapezoid_arrives_at_the_e_manuals_time() -> None:
    """Profile Velocity 100 (0.229 rev/min), Acceleration 10 (214.577 rev/min²), 1 024 ticks:
    t1 = 64 x 100 / 10 = 640 ms, t3 = t1 + 1 024 / V = 1.295 s; the emulator arrived in
    0.655 s with no ramp before the profile was emulated."""
    bus = arm()
    bus.write(1, {"profile_acceleration": 10, "profile_velocity": 100}, raw=True)
    seen = watch_move(bus, CENTRE + 1024)
    arrived = seen[-1][0]
    assert arrived == pytest.approx(1.295, abs=0.001 + within(seen))
    assert seen[-1][2] == CENTRE + 1024
    # the profile type all through the move, and Profile Ongoing until t3
    assert {status & 0x30 for _, status, _, _ in seen} == {0x30}
    assert all(status & 0x02 for t, status, _, _ in seen if t < 1.29)
    # the ramp: Velocity Trajectory climbs for 640 ms, at 100 units, then falls
    # (1 024 ticks leave 24 at the profile velocity, 15 ms, between the two ramps)
    assert nearest(seen, 0.32) == pytest.approx(50, abs=2)
    assert nearest(seen, 0.648) == pytest.approx(100, abs=1)
    assert nearest(seen, 0.655 + 0.32) == pytest.approx(50, abs=2)


def test_a_short_move_is_triangular() -> None:
    bus = arm()
    bus.write(1, {"profile_acceleration": 10, "profile_velocity": 100}, raw=True)
    seen = watch_move(bus, CENTRE - 300)
    assert {status & 0x30 for _, status, _, _ in seen} == {0x20}
    assert max(abs(v) for *_, v in seen) < 100
    # from rest over d: 2 sqrt(d / A)
    a = 10 * 214.577 * 2 * math.pi / 3600
    d = 300 * 2 * math.pi / 4096
    assert seen[-1][0] == pytest.approx(2 * math.sqrt(d / a), abs=0.001 + within(seen))


def test_the_time_based_profile_takes_its_span_whatever_the_distance() -> None:
    """Drive Mode 4 (bit 2): Profile Velocity 1 000 ms, Acceleration 300 ms; a move of 200 or
    of 2 000 ticks arrives at 1 000 ms, within one control period (it took 0.327 s for a
    1 000 ms move before)."""
    for distance in (200, 2000):
        bus = arm(drive_mode=4)
        bus.write(1, {"profile_acceleration": 300, "profile_velocity": 1000}, raw=True)
        seen = watch_move(bus, CENTRE + distance)
        assert seen[-1][0] == pytest.approx(1.0, abs=within(seen))
        assert {status & 0x30 for _, status, _, _ in seen} == {0x30}


def test_without_profile_velocity_the_move_is_a_step_with_no_profile_type() -> None:
    """Profile Velocity 0, "Profile not used": the motor goes as fast as it can, its no-load
    speed (XM430-W350: 46 rev/min at 12 V, e-Manual specifications)."""
    bus = arm()
    seen = watch_move(bus, CENTRE + 1024)
    assert {status & 0x30 for _, status, _, _ in seen} == {0x00}
    assert seen[-1][0] == pytest.approx(1024 / (46 / 60 * 4096), abs=within(seen))
    # with no profile, In-Position comes as the horn enters its window (20 ticks), before
    # it stands on the goal
    first_in = next(row for row in seen if row[1] & 0x01)
    assert 0 < CENTRE + 1024 - first_in[2] <= 20


def test_profile_velocity_with_no_acceleration_is_rectangular() -> None:
    bus = arm()
    bus.write(1, "profile_velocity", 100, raw=True)
    seen = watch_move(bus, CENTRE + 1024)
    assert {status & 0x30 for _, status, _, _ in seen} == {0x10}
    v = 100 * 0.229 * 4096 / 60                 # ticks/s
    assert seen[-1][0] == pytest.approx(1024 / v, abs=within(seen))
    assert seen[0][3] == 100                    # at the profile velocity from the first ms


def test_velocity_mode_ramps_to_its_goal_velocity() -> None:
    """Velocity Control Mode: Goal Velocity 200 with Profile Acceleration 50 is reached after
    t1 = 64 x 200 / 50 = 256 ms."""
    bus = arm(mode=1)
    bus.write(1, "profile_acceleration", 50, raw=True)
    clock = bus.port.clock  # type: ignore[attr-defined]
    start = clock.now()
    bus.write(1, "goal_velocity", 200, raw=True)
    clock.advance(0.128)
    raw = bus.read(1, ["present_velocity", "velocity_trajectory"], raw=True)
    elapsed = clock.now() - start       # the write's and the read's wire time included
    assert 100 <= raw["present_velocity"] <= 200 * elapsed / 0.256 + 1
    assert raw["velocity_trajectory"] == raw["present_velocity"]
    clock.advance(0.128 + 2 * PERIOD)
    assert bus.read(1, "present_velocity", raw=True) == 200
    clock.advance(0.5)
    assert bus.read(1, "present_velocity", raw=True) == 200


def test_a_new_goal_mid_move_keeps_the_velocity_continuous() -> None:
    """Velocity Override: a goal written while moving changes the trajectory with no jump in
    its velocity."""
    bus = arm()
    bus.write(1, {"profile_acceleration": 10, "profile_velocity": 100}, raw=True)
    clock = bus.port.clock  # type: ignore[attr-defined]
    bus.write(1, "goal_position", CENTRE + 2000, raw=True)
    clock.advance(0.8)
    before = bus.read(1, "velocity_trajectory", raw=True)
    bus.write(1, "goal_position", CENTRE + 1000, raw=True)
    clock.advance(PERIOD)
    after = bus.read(1, "velocity_trajectory", raw=True)
    assert before == 100 and abs(after - before) <= 1
    seen = watch_move(bus, CENTRE + 1000)
    assert seen[-1][2] == CENTRE + 1000


def test_a_led_written_mid_move_does_not_restart_the_profile() -> None:
    bus = arm(drive_mode=4)
    bus.write(1, {"profile_acceleration": 300, "profile_velocity": 1000}, raw=True)
    clock = bus.port.clock  # type: ignore[attr-defined]
    bus.write(1, "goal_position", CENTRE + 2000, raw=True)
    clock.advance(0.5)
    bus.write(1, "led", 1)
    clock.advance(0.5 + 2 * PERIOD)
    status = bus.read(1, "moving_status", raw=True)
    assert status & 0x01 and not status & 0x02
    assert bus.read(1, "present_position", raw=True) == CENTRE + 2000


def test_a_new_goal_mid_time_based_move_is_reached_within_the_span() -> None:
    """A time-based move is planned again from where the horn is on each new goal, over the
    same span: turned back half-way, the horn arrives on the new goal a span later and never
    runs past the first one."""
    bus = arm(drive_mode=4)
    bus.write(1, {"profile_acceleration": 300, "profile_velocity": 1000}, raw=True)
    clock = bus.port.clock  # type: ignore[attr-defined]
    bus.write(1, "goal_position", CENTRE + 2000, raw=True)
    clock.advance(0.5)
    seen = watch_move(bus, CENTRE + 1000)
    assert seen[-1][0] == pytest.approx(1.0, abs=within(seen))
    assert max(present for _, _, present, _ in seen) <= CENTRE + 2000


def test_only_a_new_goal_makes_a_new_profile() -> None:
    """A profile is made "when Goal Position(116) is updated": writing Goal Velocity or the
    profile registers mid-move changes nothing of it (the new profile registers count from
    the next goal)."""
    bus = arm(drive_mode=4)
    bus.write(1, {"profile_acceleration": 300, "profile_velocity": 1000}, raw=True)
    clock = bus.port.clock  # type: ignore[attr-defined]
    bus.write(1, "goal_position", CENTRE + 2000, raw=True)
    clock.advance(0.5)
    bus.write(1, "goal_velocity", 10, raw=True)
    bus.write(1, {"profile_acceleration": 100, "profile_velocity": 3000}, raw=True)
    clock.advance(0.5 + 2 * PERIOD)
    status = bus.read(1, "moving_status", raw=True)
    assert status == 0x31 and bus.read(1, "present_position", raw=True) == CENTRE + 2000
    seen = watch_move(bus, CENTRE)         # the next goal takes the new span, 3 s
    assert seen[-1][0] == pytest.approx(3.0, abs=within(seen))


def test_a_horn_too_loaded_to_keep_to_its_trajectory_sets_following_error() -> None:
    """"Following Error: Dynamixel fails to reach desired position trajectory" (Moving
    Status bit 0x08): under 0.8 of its stall torque the horn turns at a fifth of the no-load
    speed (the torque-speed line), too slow for a profile at 190 units (43.5 rev/min, nearly
    the no-load 46); it falls behind the Position Trajectory, and still arrives."""
    bus = arm(mode=4)                               # extended position: 3 000 ticks on
    bus.emulator.motor(1).external_load = -0.8      # type: ignore[attr-defined]
    bus.write(1, {"profile_acceleration": 100, "profile_velocity": 190}, raw=True)
    seen = watch_move(bus, CENTRE + 3000, limit=10.0)
    assert any(status & 0x08 for _, status, _, _ in seen)
    assert not seen[-1][1] & 0x08


def test_a_load_changed_mid_ramp_does_not_jolt_the_motor_s_torque() -> None:
    """The torque that accelerates motor and gears along a ramp is a first-order lag toward
    a x tau / no-load speed: a load changed by nothing mid-ramp leaves it where it was."""
    bus = arm()
    bus.write(1, {"profile_acceleration": 10, "profile_velocity": 100}, raw=True)
    bus.write(1, "goal_position", CENTRE + 1024, raw=True)
    motor = bus.emulator.motor(1)                   # type: ignore[attr-defined]
    bus.port.clock.advance(0.3)  # type: ignore[attr-defined]
    before = motor.load
    motor.external_load = 1e-12
    assert motor.load == pytest.approx(before, abs=1e-6)
    bus.port.clock.advance(0.001)  # type: ignore[attr-defined]
    assert motor.load == pytest.approx(before, abs=1e-3)
