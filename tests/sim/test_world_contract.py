"""The contract every registered world keeps, in the style of dm_control's suite test: one
parametrised test over :data:`servolab.sim.WORLDS`, so each new world gets it for free.

- it steps in fixed steps of the simulation's physics step, whether or not the bus is busy;
- the same inputs give bit-for-bit the same run;
- it reports finite ground truth, under the same names every time, that moves while it runs.
"""

from __future__ import annotations

import math
import struct

import pytest

from servolab.sim import WORLDS, Simulation, World


def _bits(truth: dict[str, float]) -> dict[str, bytes]:
    return {k: struct.pack("<d", v) for k, v in truth.items()}


def _run(cls: type[World], seconds: float, physics_step: float = 0.001
         ) -> tuple[Simulation, World, list[dict[str, float]]]:
    sim = Simulation(physics_step)
    world = cls.example(sim)
    trace = []
    for _ in range(round(seconds / 0.05)):
        sim.advance(0.05)
        trace.append(world.ground_truth())
    return sim, world, trace


@pytest.fixture(params=sorted(WORLDS), ids=str)
def world_class(request: pytest.FixtureRequest) -> type[World]:
    return WORLDS[request.param]


def test_registry_names_match(world_class: type[World]) -> None:
    assert WORLDS[world_class.name] is world_class


def test_steps_in_fixed_steps_without_bus_traffic(world_class: type[World]) -> None:
    sim = Simulation(0.002)
    world = world_class.example(sim)
    seen = [e.instructions_seen for e in sim.emulators]
    steps: list[float] = []
    original = world.step

    def counting_step(dt: float) -> None:
        steps.append(dt)
        original(dt)

    world.step = counting_step  # type: ignore[method-assign]
    start = sim.now()
    before = world.ground_truth()
    sim.advance(0.5)
    assert [e.instructions_seen for e in sim.emulators] == seen  # nobody spoke on the bus
    expected = math.floor((start + 0.5) / 0.002 + 1e-9) - math.floor(start / 0.002 + 1e-9)
    assert len(steps) == expected
    assert set(steps) == {0.002}
    assert world.ground_truth() != before, "the example scene must be moving"


def test_same_inputs_same_run_bit_for_bit(world_class: type[World]) -> None:
    _, _, first = _run(world_class, 1.0)
    _, _, second = _run(world_class, 1.0)
    assert [_bits(t) for t in first] == [_bits(t) for t in second]


def test_ground_truth_is_finite_with_stable_names(world_class: type[World]) -> None:
    _, _, trace = _run(world_class, 0.5)
    names = set(trace[0])
    assert names, "a world reports some ground truth"
    for truth in trace:
        assert set(truth) == names
        assert all(isinstance(v, float) and math.isfinite(v) for v in truth.values()), truth
