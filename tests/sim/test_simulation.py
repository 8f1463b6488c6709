"""The simulation owns time: fixed physics steps, one clock for nodes, wire and worlds,
worlds' plants read back by the firmware, real time on a thread of its own."""

from __future__ import annotations

import math
import os
import struct
import threading
import time
from pathlib import Path

import pytest

from servolab.dynamixel import Bus, units
from servolab.dynamixel.plant import ServoCommand
from servolab.dynamixel.wire import byte_time
from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.sim import DiffDriveFloor, Simulation, SimulationError, World
from tests.waiting import wait_until

ROOT = Path(__file__).resolve().parents[2]


def test_steps_happen_at_boundaries_that_time_passes() -> None:
    sim = Simulation(0.001)
    sim.advance_to(0.0005)
    assert sim.steps == 0 and sim.now() == 0.0005
    sim.advance_to(0.001)
    assert sim.steps == 1
    for _ in range(3):
        sim.advance(0.1)            # 0.1 + 0.1 + 0.1 is 0.30000000000000004 in floats ...
    assert sim.steps == 301         # ... and still crosses exactly 300 more boundaries
    sim.advance_to(0.2)             # time never goes back
    assert sim.now() == pytest.approx(0.301) and sim.steps == 301
    sim.step(5)
    assert sim.steps == 306


@pytest.mark.parametrize("bad", [0.0, -0.001, math.nan, math.inf])
def test_bad_physics_step_is_refused(bad: float) -> None:
    with pytest.raises(SimulationError, match="physics_step"):
        Simulation(bad)


def test_a_world_cannot_be_added_twice() -> None:
    sim = Simulation()
    world = DiffDriveFloor.example(sim)
    with pytest.raises(SimulationError, match="already"):
        sim.add(world)


class _Turntable(World):
    """A world whose joint turns at a fixed rate whatever the firmware commands: the plant
    owns the state, the firmware can only report it."""

    name = "turntable"

    def __init__(self, rate: float, start: float) -> None:
        self.command = ServoCommand()
        self._position, self._velocity = start, rate
        self.history = [start]  # the position after each step

    # the ServoPlant interface
    @property
    def position(self) -> float:
        return self._position

    @property
    def velocity(self) -> float:
        return self._velocity

    @property
    def effort(self) -> float:
        return -0.25

    @property
    def temperature(self) -> float:
        return 41.0

    def step(self, dt: float) -> None:
        self._position += self._velocity * dt
        self.history.append(self._position)

    def ground_truth(self) -> dict[str, float]:
        return {"angle": self._position}

    @classmethod
    def example(cls, simulation: Simulation) -> _Turntable:
        raise NotImplementedError


@pytest.mark.parametrize(("spec", "baud", "speed_register"), [
    ("xm430-w210:1", 1_000_000, "present_velocity"),
    ("rx28:1", 57142, "present_speed"),
])
@pytest.mark.parametrize("rate", [0.75, -0.75])
def test_a_worlds_plant_is_what_the_firmware_reads_back(spec: str, baud: int,
                                                        speed_register: str,
                                                        rate: float) -> None:
    sim = Simulation()
    bus = Bus.open(f"emu://{spec}", baudrate=baud, simulation=sim)
    motor = bus.emulator.motor(1)
    table = sim.add(_Turntable(rate=rate, start=-0.5 if rate > 0 else 0.5))
    motor.attach_plant(table)  # type: ignore[arg-type]
    attached = sim.steps
    bus.write(1, "torque_enable", 1)
    assert table.command.torque_enabled  # the firmware commands the world's plant
    for wait in (0.2, 0.35, 0.1):
        sim.advance(wait)
        got = bus.read(1, ["present_position", speed_register, "present_temperature"],
                       raw=True)
        m = motor.model
        sampled = table.history[motor.sensed_step - attached]  # where the joint was at the READ
        assert got["present_position"] == round(units.position_ticks(m, sampled))
        expected_speed = units.reading(m, m.register(speed_register), table.velocity)
        assert got[speed_register] == expected_speed
        assert got["present_temperature"] == 41
        assert bus.read(1, speed_register) == pytest.approx(rate, abs=units.velocity_unit(m))


def test_executor_timers_and_wire_time_advance_one_clock_through_its_owner() -> None:
    """A node's 20 Hz timer reads a motor on an emulated bus: the executor moves time to each
    timer, the wire moves it on by each byte, and the floor world steps all the while — one
    clock, one owner."""
    sim = Simulation()
    floor = DiffDriveFloor.example(sim)
    bus = next(iter(sim.emulators))
    reader = Bus.open("emu://rx28:7", baudrate=57142, simulation=sim)
    assert reader.port.clock is sim and bus is not reader.emulator
    reader.declare(7, "RX-28")  # no PING on the first read: every read is the same length
    samples: list[tuple[float, float, int]] = []
    with Context.open(clock=sim) as ctx:
        node = Node(ctx, "reader")

        def tick() -> None:
            before = sim.now()
            reader.read(7, "present_position")
            samples.append((before, sim.now(), floor.steps))

        node.create_timer(0.05, tick)
        start = sim.now()
        ctx.spin_for(1.01)
    assert len(samples) == 20
    for k, (before, after, steps) in enumerate(samples, 1):
        assert before == pytest.approx(start + 0.05 * k)
        # one READ on a 57142 bps wire: 8 + 8 bytes and the 0.5 ms return delay
        assert after - before == pytest.approx(16 * byte_time(57142) + 0.0005, rel=1e-6)
        assert steps == math.floor(after / sim.physics_step + 1e-9)
    assert floor.steps == sim.steps


def _scenario() -> tuple[list[bytes], list[bytes]]:
    """Reads and writes at irregular times on a floor world and an RX-28 bus."""
    sim = Simulation()
    floor = DiffDriveFloor.example(sim)
    bus = Bus.open("emu://rx28:1-3", baudrate=57142, simulation=sim)
    bus.sync_write("torque_enable", {1: 1, 2: 1, 3: 1})
    bus.emulator.motor(2).external_load = 0.4
    answers = []
    for k in range(40):
        if k % 7 == 0:
            bus.sync_write(["goal_position", "moving_speed"],
                           {1: (0.3 * math.sin(k), 2.0), 2: (-0.2, 1.0), 3: (0.1 * k % 1, 0.0)})
        values = bus.read(1 + k % 3, ["present_position", "present_temperature"], raw=True)
        answers.append(repr(values).encode())
        sim.advance(0.013 * (1 + k % 5))
    truth = [struct.pack("<d", v) for v in floor.ground_truth().values()]
    return answers, truth


def test_two_runs_with_the_same_inputs_are_bitwise_identical() -> None:
    assert _scenario() == _scenario()


def test_real_time_steps_on_its_own_thread_and_stops() -> None:
    sim = Simulation()
    floor = DiffDriveFloor.example(sim)
    before = floor.steps
    with sim.real_time():
        assert not sim.virtual
        assert wait_until(lambda: floor.steps >= before + 50, timeout=5.0), floor.steps
        assert any(t.name == "simulation" for t in threading.enumerate())
        t0 = sim.now()
        sim.sleep(0.01)             # waits for the simulation's thread
        assert sim.now() >= t0 + 0.01
    assert sim.virtual
    assert not any(t.name == "simulation" for t in threading.enumerate())
    steps = floor.steps
    time.sleep(0.02)
    assert floor.steps == steps  # stopped: time stands still again


class _Slow(World):
    """A world slower than real time: each 1 ms step takes 2 ms of the host's."""

    name = "slow"

    def __init__(self) -> None:
        self.steps = 0

    def step(self, dt: float) -> None:
        time.sleep(0.002)  # the cost of the physics, not a wait for anything
        self.steps += 1

    def ground_truth(self) -> dict[str, float]:
        return {"steps": float(self.steps)}

    @classmethod
    def example(cls, simulation: Simulation) -> World:
        raise NotImplementedError


def test_real_time_waits_for_the_physics_and_stops_with_every_step_taken() -> None:
    sim = Simulation()
    slow = sim.add(_Slow())
    with sim.real_time():
        sim.advance_to(0.03)          # returns once the steps are taken, not when the wall
        assert slow.steps >= 30       # clock says 30 ms
        with pytest.raises(SimulationError, match="real time"):
            sim.step()
    assert sim.virtual
    assert slow.steps == sim.steps == math.floor(sim.now() / sim.physics_step + 1e-9)


@pytest.mark.slow
def test_runs_in_two_processes_with_different_hash_seeds_are_identical() -> None:
    """Nothing in a run may depend on the interpreter's hash seed (set or dict order of
    strings) or on anything else that differs between processes."""
    import subprocess
    import sys

    code = ("from tests.sim.test_simulation import _scenario\n"
            "answers, truth = _scenario()\nprint(repr(answers), truth)")
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           timeout=120, check=True, env={**os.environ, "PYTHONHASHSEED": seed},
                           cwd=ROOT).stdout
            for seed in ("1", "2")]
    assert runs[0] == runs[1] and len(runs[0]) > 100
