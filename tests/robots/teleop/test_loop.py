"""The loop on two emulated arms in virtual time: the follower engages, tracks the leader in
MuJoCo under gravity, every command arrives, the episodes are marked, and on any stop the
follower holds where it is, torque on."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from servolab.robots.teleop.hand import Episodes
from servolab.robots.teleop.loop import LeaderLost, LoopOptions, cycle_wire_s, state_wire_s

from .conftest import FAST, rig

#: the fast loop, and the follower engaged in a fifth of a second (nothing real to hurt)
QUICK = LoopOptions(rate=FAST.rate, state_rate=FAST.state_rate, camera_rate=0.0,
                    engage_speed=5.0)


def test_the_wire_limit_is_the_packets_time() -> None:
    """SYNC_READ 19 bytes + 5 statuses of 15 + SYNC_WRITE 39 bytes = 133 bytes at 1 Mbps;
    the state read: 19 + 5 x 31 bytes."""
    assert cycle_wire_s(5, 5, 1_000_000) == pytest.approx(133e-5)
    assert cycle_wire_s(5, 5, 1_000_000, 0.5e-3) == pytest.approx(133e-5 + 2.5e-3)
    assert state_wire_s(5, 20, 1_000_000) == pytest.approx(174e-5)


def test_the_follower_engages_then_tracks_and_every_command_arrives(tmp_path: Path) -> None:
    with rig(tmp_path, episodes=Episodes(1.5, 1, 0.0)) as task:
        loop, simulation, script = task.loop, task.simulation, task.script
        assert loop is not None and simulation is not None and script is not None
        # the follower starts at its motors' centre, the leader at the hand's home: it is
        # brought there along a ramp, never in one jump
        start = np.array(task.follower.positions())
        engaged = loop.engage()
        assert engaged == pytest.approx(1.0, abs=0.02)   # joint4's 1 rad at 1 rad/s
        goals = np.array(loop.record.goals)
        assert np.abs(np.diff(goals, axis=0)).max() < 0.03  # 10 ms apart: no jump
        assert np.abs(goals[0] - start).max() < 0.01
        loop.run(task.request.episodes, on_begin=script.begin_at)
        figures = loop.figures(task.prepared.follower.linear)
    assert figures["commands_lost"] == 0
    assert figures["commands_sent"] == figures["cycles"] > 240
    assert figures["commands_checked"] >= figures["cycles"] - 2   # a state read each cycle
    assert figures["achieved_hz"] == pytest.approx(100.0, rel=0.02)
    arm = figures["tracking_error_arm_rad"]
    assert isinstance(arm, dict)
    # lagging a hand that moves up to ~1.7 rad/s, under gravity, at 100 commands a second
    assert arm["p50"] < 0.03 and arm["p99"] < 0.15
    assert figures["tracking_error_linear_m"]["p99"] < 0.004
    assert [(e.index, e.complete) for e in loop.record.episodes] == [(0, True)]


def test_after_a_stop_the_follower_holds_where_it_is_torque_on(tmp_path: Path) -> None:
    with rig(tmp_path, episodes=Episodes(3.0, 1, 0.0), options=QUICK) as task:
        loop, simulation, script = task.loop, task.simulation, task.script
        assert loop is not None and simulation is not None and script is not None
        loop.engage()
        script.begin_at(simulation.now())
        end = simulation.now() + 1.2          # mid-episode: the hand is moving
        while simulation.now() < end:
            loop.cycle()
        held = np.array(task.follower.hold())  # what the run's way out does
        stopped = simulation.now()
        for later in (0.1, 0.5, 2.0):          # the leader goes on moving
            simulation.advance_to(stopped + later)
            assert np.abs(np.array(task.follower.positions()) - held).max() < 0.02
        bus = task.follower.bus
        assert [int(bus.read(i, "torque_enable")) for i in task.follower.ids] == [1] * 5


def test_a_leader_that_stops_answering_ends_the_loop_within_its_watchdog(tmp_path: Path
                                                                          ) -> None:
    with rig(tmp_path, options=QUICK) as task:
        loop, simulation = task.loop, task.simulation
        assert loop is not None and simulation is not None
        loop.engage()
        emulator = task.leader_emulator
        for motor_id in task.prepared.leader.system.bus().ids:
            emulator.unplug(motor_id)
        silent = simulation.now()
        with pytest.raises(LeaderLost, match=(
                r"^the leader stopped answering: no reading for 0\.1\d\d s \(watchdog 0\.1 s;"
                r" .*\); the follower holds where it is$")):
            while True:
                loop.cycle()
        assert simulation.now() - silent < 0.15
        assert loop.record.leader_failures >= 2
        sent = loop.record.commands_sent
    assert sent > 0


@pytest.mark.slow
def test_the_loop_runs_as_fast_as_the_wires_allow(tmp_path: Path) -> None:
    """No rate asked: one cycle's wire time apart, less the follower's state reads."""
    options = LoopOptions(state_rate=FAST.state_rate, camera_rate=0.0, engage_speed=20.0)
    with rig(tmp_path, options=options, world="emulated") as task:
        loop, simulation = task.loop, task.simulation
        assert loop is not None and simulation is not None
        loop.engage()
        begin, cycles = simulation.now(), loop.record.cycles
        while simulation.now() < begin + 0.2:
            loop.cycle()
        rate = (loop.record.cycles - cycles) / (simulation.now() - begin)
    wire = task.summary["wire"]
    assert wire["wire_limit_hz"] == pytest.approx(1 / 133e-5)
    # each 10 ms: 10 ms / (cycle + state read / cycles in 10 ms) of the limit
    expected = 1 / (wire["cycle_s"] + wire["state_read_s"] / (0.01 * wire["wire_limit_hz"]))
    assert rate == pytest.approx(expected, rel=0.05)
