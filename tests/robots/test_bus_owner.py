"""The bus owner (servolab.robots.bus_owner) on the executor: commands go out between single
READs of the state sweep, the newest goal per motor, in virtual time on the seed's 57142 bps
bus.

Facts checked, and where they come from:
- issue 27: with the controller manager's old timer, 144 of 1 197 commands reached the
  controllers at 57142 bps (the depth-10 queues overflowed behind 23-25 ms ticks);
- dynamixel_io.py (arebgun/dynamixel_motor): a controller's command is written between two of
  the proxy's reads (the serial mutex), never behind a whole sweep.
"""

from __future__ import annotations

import pytest

from servolab.dynamixel.bus import Bus
from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.robots.bus_owner import BusOwner
from servolab.robots.controllers.motor_state import STATE_REGISTERS
from servolab.sim.simulation import Simulation

IDS = list(range(11, 31))


def _bus() -> tuple[Simulation, Bus, Context]:
    sim = Simulation()
    bus = Bus.open("emu://rx28:11-30", baudrate=57142, simulation=sim)
    for motor_id in IDS:  # as the manager does at start: the bus then knows each model
        bus.ping(motor_id)
    return sim, bus, Context.open(clock=sim)


def test_a_goal_waits_for_at_most_one_read() -> None:
    """A goal given mid-sweep is on the wire after the READ under way and before the next:
    its motor's goal register holds it within one READ's wire time (5.9 ms), while a sweep
    of 20 takes about 120 ms."""
    sim, bus, context = _bus()
    try:
        owner = BusOwner(context, bus, rate=100.0,
                         steps=[lambda i=i: bus.read(i, STATE_REGISTERS, raw=True)
                                for i in IDS])
        context.spin_for(0.05)  # part-way through the first sweep
        assert owner.sweeps == 0
        given = sim.now()
        owner.set_goals("goal_position", {25: 0.3})
        context.spin_until(lambda: not owner.pending, timeout=1.0)
        assert not owner.pending and owner.writes == 1
        assert sim.now() - given < 0.0059 + 0.0019  # a READ under way, the SYNC_WRITE
        raw = int(bus.read(25, "goal_position", raw=True))
        assert raw == int(bus.from_si(25, "goal_position", 0.3))
        context.spin_until(lambda: owner.sweeps >= 2, timeout=2.0)
        assert 0.10 < owner.sweep_time < 0.14
    finally:
        context.close()
        bus.close()


def test_the_newest_goal_per_motor_wins_and_messages_are_never_starved() -> None:
    """Twenty command subscriptions, a row of twenty commands every 50 ms (the stand's 20 Hz)
    while the sweep reads back to back: every command callback runs (none dropped by a full
    queue) and the goals written are the newest."""
    _sim, bus, context = _bus()
    try:
        owner = BusOwner(context, bus, rate=1000.0,
                         steps=[lambda i=i: bus.read(i, STATE_REGISTERS, raw=True)
                                for i in IDS])
        probe = Node(context, "probe")
        received = {i: 0 for i in IDS}

        def on_command(motor_id: int, msg: object) -> None:
            received[motor_id] += 1
            owner.set_goals("goal_position", {motor_id: float(msg.data)})  # type: ignore[attr-defined]

        pubs = {}
        for i in IDS:
            probe.create_subscription("std_msgs/msg/Float64", f"/m{i}/command",
                                      lambda msg, i=i: on_command(i, msg), 10)
            pubs[i] = probe.create_publisher("std_msgs/msg/Float64", f"/m{i}/command", 10)
        rows = 40
        rate = probe.create_rate(20.0)
        for row in range(rows):
            for i in IDS:
                pubs[i].publish(probe.message("std_msgs/msg/Float64", data=0.01 * row))
            rate.sleep()
        context.spin_until(lambda: not owner.pending, timeout=1.0)
        assert received == {i: rows for i in IDS}
        last = int(bus.from_si(11, "goal_position", 0.01 * (rows - 1)))
        assert all(int(bus.read(i, "goal_position", raw=True)) == last for i in IDS)
        assert owner.sweeps > 5  # the sweep went on meanwhile
    finally:
        context.close()
        bus.close()


def test_a_step_that_raises_leaves_the_sweep_whole() -> None:
    """A stop signal (KeyboardInterrupt) in the sweep's last READ goes to whoever spins; the
    owner then goes on from the sweep's first step (a later sweep completes and the goals
    given still go out), never past the sweep's end."""
    _sim, bus, context = _bus()
    try:
        calls: list[int] = []

        def read(motor_id: int) -> None:
            calls.append(motor_id)
            if motor_id == IDS[-1] and calls.count(motor_id) == 1:
                raise KeyboardInterrupt
            bus.read(motor_id, STATE_REGISTERS, raw=True)

        owner = BusOwner(context, bus, rate=1000.0,
                         steps=[lambda i=i: read(i) for i in IDS])
        with pytest.raises(KeyboardInterrupt):
            context.spin_for(1.0)
        assert calls == IDS and owner.sweeps == 0
        owner.set_goals("goal_position", {11: 0.2})
        context.spin_until(lambda: owner.sweeps >= 1, timeout=1.0)
        assert owner.sweeps == 1 and calls[len(IDS)] == IDS[0]
        assert int(bus.read(11, "goal_position", raw=True)) == int(
            bus.from_si(11, "goal_position", 0.2))
    finally:
        context.close()
        bus.close()
