"""A simulation's ROS time follows its mode (servolab/sim/simulation.py): simulated seconds in
virtual time (Gazebo with ``use_sim_time``, ``/clock`` published), the epoch's in real time (a
real-time run beside a live camera or a serial port stamps as the wall clock does), and
``call_every`` (what ``/clock`` rides on) only in virtual time."""

from __future__ import annotations

import time

import pytest

from servolab.sim import Simulation
from tests.stamps import TODAY_S
from tests.waiting import wait_for


def test_virtual_time_stamps_simulated_seconds_and_calls_back_as_it_passes() -> None:
    sim = Simulation()
    seen: list[float] = []
    sim.call_every(0.025, seen.append)
    sim.advance_to(0.0601)
    sim.step(15)  # 75 steps of 1 ms: the third tick, 3 * 0.025 s, however floats round
    assert sim.ros_time() == sim.now() and sim.ros_time(0.5) == 0.5
    assert seen == [0.0601, sim.now()]  # 0.025 and 0.05 in one move, once


def test_real_time_stamps_the_epoch_and_back_to_virtual_time_stamps_simulated_seconds() -> None:
    sim = Simulation()
    seen: list[float] = []
    sim.call_every(0.001, seen.append)
    with sim.real_time():
        begun = sim.now()
        assert abs(sim.ros_time() - time.time()) < TODAY_S
        wait_for(lambda: sim.steps >= 5, "five physics steps in real time")
        t = sim.now()
        # the offset is fixed while real time runs: readings map one to one
        assert sim.ros_time(t) - sim.ros_time(begun) == pytest.approx(t - begun, abs=1e-6)
        assert seen == []  # a real-time run publishes no /clock
    assert sim.virtual and sim.ros_time() == sim.now() < 1000.0
