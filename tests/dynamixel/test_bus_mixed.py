"""One bus, motors of both protocols (:class:`MixedBus`), as DynamixelSDK's
``protocol_combined`` example drives them: scanned, read and written, each motor in its own
protocol, on an emulated bus that holds both (``Emulator(None)``), on the virtual wire."""

from __future__ import annotations

import pytest

from servolab.dynamixel.errors import ConfigError, NoResponse
from servolab.dynamixel.mixed_bus import MixedBus
from tests.mixedbus import EmulatedMixedBus as Emulated
from tests.mixedbus import mixed_bus

MOTORS = (("XM430-W210", 1), ("XL430-W250", 2), ("RX-28", 11), ("MX-28", 12))


def setup() -> tuple[MixedBus, Emulated]:
    mixed = mixed_bus(MOTORS)
    bus = MixedBus(mixed.port(57600))
    bus.scan(baudrates=[57600])
    return bus, mixed


def counts(mixed: Emulated) -> tuple[int, int]:
    """Instructions each protocol's motors received so far: (2.0, 1.0)."""
    sides = mixed.emulator.sides
    return sides[2].instructions_seen, sides[1].instructions_seen


def test_scan_finds_and_keeps_the_motors_of_both_protocols() -> None:
    bus, mixed = setup()
    assert {i: m.name for i, m in bus.motors.items()} == dict((i, n) for n, i in MOTORS)
    assert bus.versions == {1: 2, 2: 2, 11: 1, 12: 1}
    assert counts(mixed) == (1, 254 + 2)      # one broadcast PING; a PING per 1.0 ID, 2 READs


def test_each_motor_is_read_and_written_in_its_own_protocol() -> None:
    bus, mixed = setup()
    bus.write(1, "goal_position", 0.5)
    bus.write(11, "goal_position", 0.5)
    motor = {m.id: m for m in mixed.emulator.motors}
    assert motor[1].get_raw("goal_position") == 2048 + 326
    assert motor[11].get_raw("goal_position") == 512 + 98
    assert bus.read(11, "goal_position", raw=True) == 610
    assert bus.read(1, ["goal_position", "torque_enable"], raw=True) == {
        "goal_position": 2374, "torque_enable": 0}
    assert bus.read(12, "model_number", raw=True) == 29
    assert bus.stats.timeouts == 252                # the scan's silent 1.0 IDs only


def test_several_motors_go_out_as_one_instruction_per_protocol() -> None:
    bus, mixed = setup()
    before = counts(mixed)
    goals = {1: 0.1, 11: -0.1, 2: 0.2, 12: -0.2}
    bus.sync_write("goal_position", goals)
    assert counts(mixed) == (before[0] + 1, before[1] + 1)     # a SYNC_WRITE in each
    got = bus.sync_read("goal_position", [1, 11, 2, 12])
    assert list(got) == [1, 11, 2, 12]
    assert got == pytest.approx(goals, abs=0.01)
    both = bus.bulk_read({12: ["goal_position", "moving_speed"], 2: "goal_position"}, raw=True)
    assert both == {12: {"goal_position": 2048 - 130, "moving_speed": 0},
                    2: {"goal_position": 2048 + 130}}


def test_a_bad_value_for_one_motor_writes_nothing_to_either_protocol() -> None:
    bus, mixed = setup()
    held = {m.id: m.get_raw("goal_position") for m in mixed.emulator.motors}
    with pytest.raises(ConfigError, match=r"RX-28 goal_position: 9 rad is outside"):
        bus.sync_write("goal_position", {1: 0.1, 2: 0.1, 11: 9.0})
    assert {m.id: m.get_raw("goal_position") for m in mixed.emulator.motors} == held


def test_a_broadcast_write_goes_once_in_each_protocol() -> None:
    bus, mixed = setup()
    before = counts(mixed)
    assert bus.broadcast_write("torque_enable", 1) == [1, 2, 11, 12]
    assert counts(mixed) == (before[0] + 1, before[1] + 1)
    assert all(m.get_raw("torque_enable") == 1 for m in mixed.emulator.motors)


def test_registered_writes_of_both_protocols_act_together() -> None:
    bus, mixed = setup()
    bus.write(2, "goal_position", 1000, raw=True, registered=True)
    bus.write(12, "goal_position", 1000, raw=True, registered=True)
    motor = {m.id: m for m in mixed.emulator.motors}
    assert motor[2].get_raw("goal_position") != 1000
    bus.action()
    assert motor[2].get_raw("goal_position") == motor[12].get_raw("goal_position") == 1000


def test_a_motor_not_met_is_found_in_its_protocol_and_a_declared_one_needs_no_ping() -> None:
    mixed = mixed_bus(MOTORS)
    bus = MixedBus(mixed.port(57600))
    assert bus.read(12, "model_number", raw=True) == 29      # PINGed in 2.0, then in 1.0
    assert bus.versions == {12: 1}
    bus.declare(2, "xl430-w250")
    before = counts(mixed)
    assert bus.read(2, "model_number", raw=True) == 1060
    assert counts(mixed) == (before[0] + 1, before[1])        # the READ alone
    with pytest.raises(NoResponse, match=r"motor 40: no answer to PING in protocol 2\.0 or 1\.0"):
        bus.read(40, "present_position")


def test_an_id_used_in_the_other_protocol_is_refused() -> None:
    bus, mixed = setup()
    with pytest.raises(ConfigError, match=r"ID 1 is taken: motor 1 \(XM430-W210\)"):
        bus.change_id(11, 1)
    assert {m.id for m in mixed.emulator.motors} == {1, 2, 11, 12}
    found = bus.change_id(11, 20)
    assert (found.id, found.model_name, found.protocol) == (20, "RX-28", 1)
    assert bus.versions[20] == 1 and 11 not in bus.versions
    assert bus.read(20, "id", raw=True) == 20


def test_two_motors_at_one_id_in_two_protocols_are_warned_of_and_the_2_0_one_kept(
        caplog: pytest.LogCaptureFixture) -> None:
    """An XM430 and an RX-28 both at ID 5: the scan says so, and the bus speaks to the 2.0
    motor as it says, its model and protocol both (the 1.0 pass comes second and must not
    overwrite them)."""
    mixed = mixed_bus((("XM430-W210", 5), ("RX-28", 5)))
    bus = MixedBus(mixed.port(57600))
    with caplog.at_level("WARNING"):
        bus.scan(baudrates=[57600])
    assert "ID 5 answers in protocol 2.0 and in 1.0" in caplog.text
    assert bus.motors[5].name == "XM430-W210" and bus.version_of(5) == 2
