"""How fast a simulated robot runs: the real-time factor of emulated buses and a world.

The real-time factor is simulated seconds per second of the host's time: 50 means a minute of
robot time takes 1.2 s. Each scenario runs on one core (the process is pinned to one CPU where
the OS allows), in virtual time, with 1 ms physics steps:

(a) the biped's bus: 20 RX-28 on Protocol 1.0 at 57142 bps (Armstrong, seed 001), the state
    read at 20 Hz — one READ of present_position..present_temperature per motor, since the
    RX-28 has neither SYNC_READ nor BULK_READ — and the goals written at 4.5 Hz, the seed's
    gait rate, as one SYNC_WRITE of goal_position and moving_speed. At 57142 bps the twenty
    READs take longer than 50 ms on the wire (see benchmarks/bus_cycle.py), so the reads run
    back to back and the achieved state rate is printed too;
(b) the same bus at 1 000 000 bps, where the 20 Hz read fits;
(c) the two-wheel floor world: two XM430-W210 at 1 Mbps in velocity mode on a
    ``DiffDriveFloor``, a 50 Hz loop of SYNC_WRITE goal_velocity and SYNC_READ
    present_position + present_velocity;
(d) the floor world alone, nobody on the bus: the cost of the physics steps themselves;
(e) Armstrong in MuJoCo (issue 31): the 20 RX-28 of (a), at 57142 bps, each driving its joint
    of the robot description through the firmware's compliance law, the robot standing on
    the floor, with (a)'s bus traffic — the state read back to back, the goals (the stand
    pose, the arms swinging a little) written at 4.5 Hz; the MuJoCo world steps at 2 ms,
    MuJoCo's default and the description's timestep;
(f) the same robot, nobody on the bus: MuJoCo and the firmware's law alone.

The MuJoCo scenarios split their physics time further: MuJoCo's own step (``mj_step``) and
the rest, the firmware's law and the emulators' per-step duty.

Where the time goes: a second run of each scenario times, with ``time.perf_counter``
accumulators, the physics steps (worlds and the emulators' per-step work), the emulated
firmware answering instructions (``Emulator.receive``, which includes catching the motors'
plants up), and leaves the rest to the driver and the in-memory port. The accumulators cost
time themselves, so the shares come from that second run and the real-time factor from the
first.

Run: ``.venv/bin/python benchmarks/sim.py [--seconds S] [--json PATH]``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from servolab.dynamixel import Bus
from servolab.sim import DiffDriveFloor, Simulation, port_to

RX28_IDS = list(range(1, 21))
STATE = ["present_position", "present_speed", "present_load", "present_voltage",
         "present_temperature"]
GOAL_RATE_HZ = 4.5
STATE_RATE_HZ = 20.0
#: Issue 49's goal for (a): 100x real time with the firmware's motor model in.
TARGET_RTF = 100.0


@dataclass
class Result:
    key: str
    title: str
    simulated_s: float
    host_s: float
    physics_steps: int
    transactions: int
    state_reads: int = 0
    shares: dict[str, float] | None = None
    #: MuJoCo's own step's share of the host time (inside "physics"); 0 for other worlds
    mj_step_share: float = 0.0
    #: the seconds MuJoCo's own step took in the timed run
    mj_step_s: float = 0.0
    physics_step_s: float = 0.001

    @property
    def rtf(self) -> float:
        return self.simulated_s / self.host_s

    @property
    def physics_limit(self) -> float:
        """The real-time factor of MuJoCo's own step alone, as the timed run took it (inf
        outside MuJoCo, or without a timed run): the fastest any firmware could let the
        scenario run."""
        return self.simulated_s / self.mj_step_s if self.mj_step_s else math.inf

    def as_dict(self) -> dict[str, Any]:
        return {"key": self.key, "title": self.title, "simulated_s": self.simulated_s,
                "host_s": self.host_s, "real_time_factor": self.rtf,
                "physics_steps": self.physics_steps, "transactions": self.transactions,
                "state_rate_hz": self.state_reads / self.simulated_s,
                "shares": self.shares or {}, "mj_step_share": self.mj_step_share,
                "physics_limit_rtf": self.physics_limit if self.mj_step_s else None,
                "physics_step_s": self.physics_step_s}


# -- scenarios: each returns a function that runs `seconds` of simulated time ----------------
Scenario = Callable[[], tuple[Simulation, Callable[[float], int], Bus | None]]


def biped_bus(baudrate: int) -> Scenario:
    def build() -> tuple[Simulation, Callable[[float], int], Bus | None]:
        sim = Simulation(0.001)
        bus = Bus.open("emu://rx28:1-20", baudrate=baudrate, simulation=sim)
        for i in RX28_IDS:
            bus.declare(i, "RX-28")
        bus.sync_write("torque_enable", {i: 1 for i in RX28_IDS})
        state = {"k": 0, "next_read": sim.now(), "next_write": sim.now()}

        def run(seconds: float) -> int:
            end, reads = sim.now() + seconds, 0
            while sim.now() < end:
                if sim.now() >= state["next_write"]:
                    state["k"] += 1
                    sign = 1 if state["k"] % 2 else -1
                    bus.sync_write(["goal_position", "moving_speed"],
                                   {i: (sign * 0.02 * i, 1.5) for i in RX28_IDS})
                    state["next_write"] += 1 / GOAL_RATE_HZ
                if sim.now() >= state["next_read"]:
                    for i in RX28_IDS:
                        bus.read(i, STATE)
                    reads += 1
                    state["next_read"] = max(state["next_read"] + 1 / STATE_RATE_HZ,
                                             sim.now())
                sim.advance_to(min(state["next_read"], state["next_write"], end))
            return reads

        return sim, run, bus
    return build


def floor_loop() -> tuple[Simulation, Callable[[float], int], Bus | None]:
    sim = Simulation(0.001)
    world = DiffDriveFloor.example(sim)
    bus = _example_bus(sim)
    g = world.geometry

    def run(seconds: float) -> int:
        end, reads, k = sim.now() + seconds, 0, 0
        while sim.now() < end:
            k += 1
            turn = 0.5 * math.sin(0.05 * k)
            bus.sync_write("goal_velocity", {1: g.left_forward * (2.0 - turn),
                                             2: g.right_forward * (2.0 + turn)})
            bus.sync_read(["present_velocity", "present_position"], [1, 2])
            reads += 1
            sim.advance_to(min(end, sim.now() + 0.02))
        return reads

    return sim, run, bus


def _example_bus(sim: Simulation) -> Bus:
    """A driver on the floor example's own emulated bus (the example keeps no Bus)."""
    return Bus(port_to(sim.emulators[0], sim, 1_000_000))


def floor_alone() -> tuple[Simulation, Callable[[float], int], Bus | None]:
    sim = Simulation(0.001)
    DiffDriveFloor.example(sim)

    def run(seconds: float) -> int:
        sim.advance(seconds)
        return 0

    return sim, run, None


def mujoco_biped(traffic: bool) -> Scenario:
    def build() -> tuple[Simulation, Callable[[float], int], Bus | None]:
        from servolab.robots.armstrong.description import TIMESTEP
        from servolab.robots.armstrong.hardware import load_config, open_bus
        from servolab.robots.armstrong.physics import armstrong_world

        sim = Simulation(TIMESTEP)
        config = load_config()
        bus, _ = open_bus(config, simulation=sim)
        world = armstrong_world(sim, bus.emulator, config).world
        ids = [j.motor.id for j in world.joints]
        standing = {j.motor.id: j.offset for j in world.joints}   # joints at 0: init
        arms = {31, 32, 33, 41, 42, 43}
        for i in ids:
            bus.declare(i, "RX-28")
        bus.sync_write("torque_enable", dict.fromkeys(ids, 1))
        state = {"k": 0, "next_read": sim.now(), "next_write": sim.now()}

        def run(seconds: float) -> int:
            end, reads = sim.now() + seconds, 0
            while sim.now() < end:
                if traffic and sim.now() >= state["next_write"]:
                    state["k"] += 1
                    swing = 0.1 if state["k"] % 2 else -0.1
                    bus.sync_write(["goal_position", "moving_speed"], {
                        i: (standing[i] + (swing if i in arms else 0.0), 1.0) for i in ids})
                    state["next_write"] += 1 / GOAL_RATE_HZ
                if traffic and sim.now() >= state["next_read"]:
                    for i in ids:
                        bus.read(i, STATE)
                    reads += 1
                    state["next_read"] = max(state["next_read"] + 1 / STATE_RATE_HZ,
                                             sim.now())
                if not traffic:
                    sim.advance(seconds)
                    break
                sim.advance_to(min(state["next_read"], state["next_write"], end))
            if world.fell_at is not None:
                raise SystemExit(f"(e)/(f): the standing robot fell at {world.fell_at:.2f} s; "
                                 "the scenario measures a robot that stands")
            return reads

        return sim, run, bus if traffic else None
    return build


SCENARIOS: dict[str, tuple[str, Scenario]] = {
    "a": ("20 RX-28, protocol 1.0, 57142 bps: 20 Hz state read, 4.5 Hz goals",
          biped_bus(57142)),
    "b": ("20 RX-28, protocol 1.0, 1000000 bps: 20 Hz state read, 4.5 Hz goals",
          biped_bus(1_000_000)),
    "c": ("floor world, 2 XM430-W210 at 1 Mbps: 50 Hz SYNC_WRITE + SYNC_READ", floor_loop),
    "d": ("floor world alone, no bus traffic", floor_alone),
    "e": ("Armstrong in MuJoCo, 20 RX-28 at 57142 bps: (a)'s traffic, 2 ms steps",
          mujoco_biped(True)),
    "f": ("Armstrong in MuJoCo alone, no bus traffic, 2 ms steps", mujoco_biped(False)),
}
#: The MuJoCo biped's goal with its bus, on one core (issue 31 asked 20x, issue 49 40x).
TARGET_MUJOCO_RTF = 40.0


# -- timing ------------------------------------------------------------------------------------
class Accumulator:
    """Wraps methods of objects with perf_counter accumulators, outermost calls only."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}
        self._depth = 0

    def wrap(self, obj: object, method: str, bucket: str) -> None:
        original = getattr(obj, method)
        self.seconds.setdefault(bucket, 0.0)

        def timed(*args: Any, **kwargs: Any) -> Any:
            if self._depth:
                return original(*args, **kwargs)
            self._depth += 1
            start = time.perf_counter()
            try:
                return original(*args, **kwargs)
            finally:
                self.seconds[bucket] += time.perf_counter() - start
                self._depth -= 1

        setattr(obj, method, timed)


def measure(key: str, seconds: float, *, breakdown: bool) -> Result:
    title, build = SCENARIOS[key]
    sim, run, bus = build()
    run(min(0.5, seconds))  # warm up: first PINGs, caches
    acc = Accumulator()
    engine = Accumulator()
    if breakdown:
        for world in sim.worlds:
            acc.wrap(world, "step", "physics")
            if hasattr(world, "_mujoco"):  # MuJoCo's own step, inside the world's
                module = world._mujoco
                proxy = type("MujocoTimed", (), {})()
                for name in ("mj_step", "mj_contactForce", "mj_subtreeVel"):
                    setattr(proxy, name, getattr(module, name))
                engine.wrap(proxy, "mj_step", "mj_step")
                world._mujoco = proxy
        for emulator in sim.emulators:
            acc.wrap(emulator, "step", "physics")
            acc.wrap(emulator, "receive", "firmware")
    steps0 = sim.steps
    tx0 = bus.stats.transactions if bus else 0
    t0 = sim.now()
    start = time.perf_counter()
    reads = run(seconds)
    host = time.perf_counter() - start
    result = Result(key, title, sim.now() - t0, host, sim.steps - steps0,
                    (bus.stats.transactions - tx0) if bus else 0, reads)
    if breakdown:
        shares = {k: v / host for k, v in acc.seconds.items()}
        shares["driver_and_port"] = max(0.0, 1.0 - sum(shares.values()))
        result.shares = shares
        result.mj_step_s = engine.seconds.get("mj_step", 0.0)
        result.mj_step_share = result.mj_step_s / host
    result.physics_step_s = sim.physics_step
    return result


def pin_to_one_core() -> str:
    if hasattr(os, "sched_setaffinity"):
        cpu = min(os.sched_getaffinity(0))
        os.sched_setaffinity(0, {cpu})
        return f"pinned to CPU {cpu}"
    return "not pinned (no sched_setaffinity here)"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0,
                        help="simulated seconds per scenario (default 10)")
    parser.add_argument("--json", type=Path, help="write the figures here as JSON")
    args = parser.parse_args(argv)
    if not args.seconds > 0:
        parser.error("--seconds must be positive")
    pinned = pin_to_one_core()
    print(f"servolab simulation speed: {args.seconds:g} simulated s per scenario, 1 ms physics "
          f"steps (2 ms in MuJoCo), one core ({pinned}); Python {platform.python_version()} on "
          f"{platform.machine()}")
    results = []
    for key in SCENARIOS:
        result = measure(key, args.seconds, breakdown=False)
        timed = measure(key, min(args.seconds, 5.0), breakdown=True)
        result.shares, result.mj_step_share = timed.shares, timed.mj_step_share
        # the limit from the timed run alone: MuJoCo's seconds for its simulated seconds
        result.mj_step_s = timed.mj_step_s * result.simulated_s / timed.simulated_s
        results.append(result)
    print()
    print(f"{'':4}{'real-time factor':>17}  {'steps':>7}  {'bus tx/s':>9}  {'state Hz':>8}  "
          f"{'physics':>7}  {'firmware':>8}  {'driver+port':>11}")
    for r in results:
        shares = r.shares or {}
        print(f"({r.key}) {r.rtf:15.1f}x  {r.physics_steps:>7}  "
              f"{r.transactions / r.simulated_s:>9.0f}  {r.state_reads / r.simulated_s:>8.1f}  "
              f"{shares.get('physics', 0):>7.0%}  {shares.get('firmware', 0):>8.0%}  "
              f"{shares.get('driver_and_port', 0):>11.0%}")
    print()
    for r in results:
        print(f"({r.key}) {r.title}: real-time factor = {r.rtf:.1f} "
              f"(simulated {r.simulated_s:.2f} s / host {r.host_s:.3f} s)")
    biped = results[0]
    verdict = "meets" if biped.rtf >= TARGET_RTF else "misses"
    print(f"\nThe biped's bus (a) {verdict} the {TARGET_RTF:.0f}x goal: {biped.rtf:.1f}x.")
    physical = next(r for r in results if r.key == "e")
    engine = physical.mj_step_share
    verdict = "meets" if physical.rtf >= TARGET_MUJOCO_RTF else "misses"
    print(f"Armstrong in MuJoCo with its bus (e) {verdict} the {TARGET_MUJOCO_RTF:.0f}x goal: "
          f"{physical.rtf:.1f}x; MuJoCo's own step takes {engine:.0%} of its time, the "
          f"firmware's law and the emulators' duty "
          f"{(physical.shares or {}).get('physics', 0) - engine:.0%}.")
    print(f"The physics limit: MuJoCo's own step alone, as (e) takes it, would run "
          f"{physical.physics_limit:.0f}x real time; (e) runs at "
          f"{physical.rtf / physical.physics_limit:.2f} of it.")
    if args.json:
        args.json.write_text(json.dumps({
            "seconds": args.seconds, "target_rtf": TARGET_RTF,
            "python": platform.python_version(), "pinned": pinned,
            "scenarios": {r.key: r.as_dict() for r in results}}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
