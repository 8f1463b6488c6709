"""A scan that takes seconds, and broadcast writes.

Scan: Protocol 2.0 by one broadcast PING (every motor answers in its turn, in ID order), 1.0 by
a PING per ID spaced by wire time (PING and status bytes x 10 bits / baud, the longest return
delay and a small margin), an answer that the adapter hands over late taken by the ID it
carries. Everything here runs on a simulation's virtual clock, where every byte takes its wire
time: the figures asserted are instruction counts and simulated time, never wall time.

Broadcast write: one WRITE to ID 254, which no motor answers, checked before it is sent
against the table of every motor the bus knows.
"""

from __future__ import annotations

import pytest

from servolab.dynamixel import Bus, MemoryPort, model
from servolab.dynamixel.bus import MAX_RETURN_DELAY, SCAN_MARGIN
from servolab.dynamixel.emulator import Emulator, Faults, VirtualMotor
from servolab.dynamixel.errors import ConfigError
from servolab.dynamixel.wire import wire_time
from servolab.sim import Simulation
from tests.mixedbus import MIXED, mixed_bus


def bus_on(emulator: Emulator, baudrate: int = 57600) -> tuple[Bus, Simulation]:
    simulation = Simulation()
    simulation.add_emulator(emulator)
    port = MemoryPort(emulator, baudrate, clock=simulation, lock=simulation.lock)
    return Bus(port, emulator.protocol.version), simulation


# -- Protocol 2.0: one broadcast PING ------------------------------------------------------------

def test_broadcast_ping_finds_every_2_0_motor_in_one_instruction() -> None:
    ids = (0, 1, 7, 100, 252)
    emulator = Emulator(2, [VirtualMotor(model("XM430-W210"), i) for i in ids])
    bus, simulation = bus_on(emulator)
    started = simulation.now()
    found = bus.scan()
    assert [(r.id, r.model_name, r.protocol) for r in found] == [
        (i, "XM430-W210", 2) for i in ids]
    assert emulator.instructions_seen == 1 and bus.stats.transactions == 1
    assert sorted(bus.motors) == list(ids)
    # It listens exactly as long as ID 252 may take to answer in its turn, no longer.
    assert simulation.now() - started == pytest.approx(bus.broadcast_ping_wait())
    assert bus.scan_time() == pytest.approx(bus.broadcast_ping_wait())


def test_broadcast_ping_of_a_few_ids_waits_only_for_their_turns() -> None:
    emulator = Emulator(2, [VirtualMotor(model("XM430-W210"), i, baudrate=1_000_000)
                            for i in (1, 2, 30)])
    bus, simulation = bus_on(emulator, 1_000_000)
    started = simulation.now()
    found = bus.scan(range(0, 10), broadcast=True)
    assert [r.id for r in found] == [1, 2]        # 30 answered too, but was not asked
    assert emulator.instructions_seen == 1
    waited = simulation.now() - started
    assert waited == pytest.approx(bus.broadcast_ping_wait(9))
    assert waited < 0.04                          # ten turns, not 253


# -- Protocol 1.0: a PING per ID, spaced by wire time --------------------------------------------

@pytest.mark.parametrize("baud", [57600, 1_000_000])
def test_1_0_pings_are_spaced_by_their_wire_time(baud: int) -> None:
    """254 IDs, 3 motors: one PING per ID and one READ per motor found (its model number),
    in the time the estimate gives: each silent ID its window (PING and status on the wire,
    the longest return delay, the margin), and the margin once more at the end."""
    emulator = Emulator(1, [VirtualMotor(model("RX-28"), i, baudrate=baud) for i in (3, 4, 200)])
    bus, simulation = bus_on(emulator, baud)
    estimate = bus.scan_time()
    window = wire_time(6 + 6, baud) + MAX_RETURN_DELAY + SCAN_MARGIN
    assert bus.ping_window() == pytest.approx(window)
    assert estimate == pytest.approx(254 * window + SCAN_MARGIN)
    started = simulation.now()
    found = bus.scan()
    took = simulation.now() - started
    assert [(r.id, r.model_name) for r in found] == [(3, "RX-28"), (4, "RX-28"), (200, "RX-28")]
    assert emulator.instructions_seen == 254 + 3
    assert (bus.stats.timeouts, bus.stats.corrupt, bus.stats.stale) == (251, 0, 0)
    # A motor that answers takes less than its window, and adds a READ of 10 bytes.
    assert took == pytest.approx(estimate, rel=0.02)
    assert took < (1.25 if baud == 57600 else 0.75)


def test_answers_the_adapter_hands_over_late_are_taken_by_their_id() -> None:
    """An adapter's latency timer holds the answers back (here 10 ms, beyond each PING's
    window): the next PINGs go out meanwhile, and each late answer is taken for the ID it
    carries; after the last PING the scan waits once for what the adapter may still hold."""
    ids = (1, 2, 3, 252, 253)
    emulator = Emulator(1, [VirtualMotor(model("RX-28"), i, baudrate=57600) for i in ids],
                        faults=Faults(delay=0.010))
    bus, _ = bus_on(emulator)
    bus.port.latency = 0.010
    answered = bus._ping_each(range(254), None)     # the PINGs alone (READs are not late-proof)
    assert sorted(answered) == list(ids)
    assert bus.stats.stale == 0 and bus.stats.timeouts == 254 - len(ids)


def test_a_scan_of_both_protocols_keeps_only_the_bus_s_own_motors() -> None:
    mixed = mixed_bus()
    bus = Bus(mixed.port(57600), protocol=1)
    found = bus.scan(baudrates=[57600, 1_000_000], protocols=(1, 2))
    assert {(r.id, r.model_name, r.protocol, r.baudrate) for r in found} == mixed.found()
    assert {i: m.name for i, m in bus.motors.items()} == {
        11: "RX-28", 12: "RX-28", 21: "AX-12A", 30: "MX-28"}
    assert bus.baudrate == 57600 and bus.proto.version == 1


def test_while_a_scan_speaks_the_other_protocol_other_threads_see_the_bus_s_own() -> None:
    """A thread that prepares a transaction during the scan (its plan is built before it
    waits for the bus) prepares it in the bus's protocol, not the one the scan speaks."""
    import threading

    mixed = mixed_bus((("XM430-W210", 1), ("RX-28", 11)))
    bus = Bus(mixed.port(), protocol=2)
    seen: list[tuple[int, int]] = []

    def look(baud: int, motor_id: int) -> None:
        if motor_id == 11:
            other: list[int] = []
            thread = threading.Thread(target=lambda: other.append(bus.proto.version))
            thread.start()
            thread.join()
            seen.append((bus.proto.version, other[0]))

    bus.scan(protocols=(1, 2), progress=look)
    assert seen == [(1, 2)]
    assert bus.proto.version == 2


def test_default_scan_of_a_mixed_bus_at_both_factory_rates() -> None:
    """What ``servolab scan`` does with no options, on a bus that mixes 2.0 (XM430, XL430 at
    57600, XL-320 at 1 Mbps) and 1.0 motors (RX-28, MX-28 at 57142, AX-12A at 1 Mbps): one
    broadcast PING per rate for 2.0, a PING per ID for 1.0 (and a READ per 1.0 motor found),
    all in a few seconds of wire time."""
    mixed = mixed_bus()
    bus = Bus(mixed.port())
    rates = [57600, 1_000_000]
    estimate = bus.scan_time(baudrates=rates, protocols=(1, 2))
    started = mixed.simulation.now()
    found = bus.scan(baudrates=rates, protocols=(1, 2))
    took = mixed.simulation.now() - started
    assert {(r.id, r.model_name, r.protocol, r.baudrate) for r in found} == mixed.found()
    ones = sum(1 for name, _ in MIXED if model(name).protocol == 1)
    sides = mixed.emulator.sides
    assert sides[2].instructions_seen == 2                 # a broadcast PING per rate
    assert sides[1].instructions_seen == 2 * 254 + ones    # a PING per ID and rate, a READ each
    assert took == pytest.approx(estimate, rel=0.03)
    assert took < 4.0


def test_scan_time_is_checked_like_scan() -> None:
    bus, _ = bus_on(Emulator(2, [VirtualMotor(model("XM430-W210"), 1)]))
    with pytest.raises(ConfigError, match="253"):
        bus.scan([1, 253])                              # 2.0 IDs end at 252
    with pytest.raises(ConfigError, match="must be positive"):
        bus.scan_time(baudrates=[0])
    assert bus.emulator.instructions_seen == 0


# -- broadcast write -----------------------------------------------------------------------------

def test_broadcast_write_reaches_every_motor_with_no_status_expected() -> None:
    ids = (1, 2, 3, 7)
    emulator = Emulator(2, [VirtualMotor(model("XM430-W210"), i) for i in ids])
    bus, simulation = bus_on(emulator)
    bus.scan()
    seen, read_before = emulator.instructions_seen, bus.stats.bytes_in
    started = simulation.now()
    assert bus.broadcast_write("led", 1) == list(ids)
    assert [emulator.motor(i).get_raw("led") for i in ids] == [1, 1, 1, 1]
    assert emulator.instructions_seen == seen + 1
    assert bus.stats.bytes_in == read_before and bus.stats.timeouts == 0
    # only the WRITE's own 13 bytes on the wire: no status is waited for
    assert simulation.now() - started == pytest.approx(wire_time(13, 57600))
    bus.broadcast_write("goal_position", 1.0)
    assert {emulator.motor(i).get_raw("goal_position") for i in ids} == {2048 + 652}
    # write() addresses one motor: it points at broadcast_write
    with pytest.raises(ConfigError, match=r"motor ID 254 is the broadcast ID: broadcast_write"):
        bus.write(254, "led", 0)


def test_broadcast_write_of_an_eeprom_register_checks_every_motor_s_torque() -> None:
    emulator = Emulator(2, [VirtualMotor(model("XM430-W210"), i) for i in (1, 2)])
    bus, _ = bus_on(emulator)
    bus.scan()
    emulator.motor(2).set_raw("torque_enable", 1)
    seen = emulator.instructions_seen
    with pytest.raises(ConfigError, match=r"motor 2 .* switch torque off first"):
        bus.broadcast_write("operating_mode", 1)
    bus.broadcast_write("torque_enable", 0)
    bus.broadcast_write("operating_mode", 1)
    assert [emulator.motor(i).get_raw("operating_mode") for i in (1, 2)] == [1, 1]
    assert emulator.instructions_seen > seen


@pytest.mark.parametrize(("spec", "call", "message"), [
    ("xm430-w210:1-3", ("led", 1, None), "knows no motor"),
    ("rx28:1-2;mx28:3", ("goal_position", 0.5, "scan"),
     r"tables disagree \(RX-28 \(motors 1, 2\): address 30, bytes 62 02; MX-28 \(motor 3\)"),
    ("xm430-w210:1-3", ("id", 5, "scan"), "same ID"),
    ("xm430-w210:1-3", ("baud_rate", 3, "scan"), "change_baud"),
    ("xm430-w210:1-3", ("goal_position", 99.0, "scan"), "outside its position limits"),
    ("xm430-w210:1-3", ("goal_positoin", 1.0, "scan"), "did you mean goal_position"),
    ("xm430-w210:1-3", ("operating_mode", 1, "model"), "in EEPROM"),
])
def test_broadcast_write_refused_before_anything_is_sent(spec: str, call: tuple[str, float,
                                                                                str | None],
                                                         message: str) -> None:
    bus = Bus.open(f"emu://{spec}")
    name, value, how = call
    if how == "scan":
        bus.scan(range(5))
    def written() -> list[list[int]]:
        return [[m.get_raw(r) for r in ("id", "baud_rate", "goal_position", "led")
                 + (("operating_mode",) if m.model.protocol == 2 else ())]
                for m in bus.emulator.motors]

    before = written()
    with pytest.raises(ConfigError, match=message) as info:
        bus.broadcast_write(name, value, models=["xm430-w210"] if how == "model" else None)
    assert "\n" not in str(info.value)
    # (a goal beyond what every setting allows is worth a READ of the motor's limits first)
    assert written() == before


def test_broadcast_write_by_model_for_motors_not_met() -> None:
    bus = Bus.open("emu://rx28:1-3")
    assert bus.broadcast_write("torque_enable", 1, models=["rx28"]) == []
    assert [m.get_raw("torque_enable") for m in bus.emulator.motors] == [1, 1, 1]
    with pytest.raises(ConfigError, match=r"speaks protocol 2\.0"):
        bus.broadcast_write("led", 1, models=["xm430-w210"])


# -- the emulator of a mixed bus -----------------------------------------------------------------

def test_a_mixed_emulator_answers_each_protocol_with_its_own_motors() -> None:
    mixed = mixed_bus((("XM430-W210", 1), ("RX-28", 1)))
    v2, v1 = Bus(mixed.port(57600), protocol=2), Bus(mixed.port(57600), protocol=1)
    assert v2.ping(1).model_name == "XM430-W210"
    assert v1.ping(1).model_name == "RX-28"
    v1.write(1, "goal_position", 600, raw=True)
    v2.write(1, "goal_position", 3000, raw=True)
    assert mixed.emulator.sides[1].motor(1).get_raw("goal_position") == 600
    assert mixed.emulator.sides[2].motor(1).get_raw("goal_position") == 3000
    assert mixed.emulator.instructions_seen == sum(
        side.instructions_seen for side in mixed.emulator.sides.values())
    assert mixed.emulator.mixed and len(mixed.emulator.motors) == 2
    steps = mixed.emulator.steps
    mixed.simulation.advance(0.01)
    assert mixed.emulator.steps > steps
    assert all(side.steps == mixed.emulator.steps for side in mixed.emulator.sides.values())
    unplugged = mixed.emulator.unplug(1)
    assert unplugged.model.name == "XM430-W210" and len(mixed.emulator.motors) == 1


# -- benchmarks/bus_cycle.py, section 5 ----------------------------------------------------------

def test_the_benchmark_s_scan_section_runs_on_the_virtual_wire() -> None:
    """Its figures, not their speed: both drivers find the eight motors with the same
    instructions, and servolab's estimate is the wire time it takes."""
    pytest.importorskip("dynamixel_sdk")
    import importlib.util
    import sys
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "benchmarks" / "bus_cycle.py"
    spec = importlib.util.spec_from_file_location("bus_cycle_scan", path)
    assert spec and spec.loader
    bench = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = bench
    try:
        spec.loader.exec_module(bench)
        scan = bench.mixed_scan(pty=False)
        lines = bench.scan_report(scan) + bench.scan_goals(scan)
    finally:
        sys.modules.pop(spec.name, None)
    ours, theirs = scan["ours"], scan["sdk"]
    assert ours["found"] == theirs["found"] == len(bench.SCAN_MOTORS)
    assert ours["instructions"] == theirs["instructions"] == 2 + 2 * 254 + 4
    assert ours["wire_s"] == pytest.approx(ours["estimate_s"], rel=0.01)
    assert 0 < scan["ratio_ours_sdk"] < 1
    assert any(line.startswith("   ratio servolab/SDK ") for line in lines)
    assert lines[-1].startswith("  met: the default scan of a mixed bus takes")
