"""The Bus driver: how many packets it sends, and that bad input never reaches a motor.

A robot's control loop is bounded by bus time, so reading several registers of one motor must
cost one READ, not one per register. And a typo or an out-of-range value must stop in the
driver with a one-line message, before a single byte is written: a half-applied SYNC_WRITE
moves some joints of a robot and not others.
"""

from __future__ import annotations

import math

import pytest

from servolab.dynamixel import Bus, ConfigError
from tests.clirun import one_line as assert_one_line_naming

RX28_TICK = math.radians(300.0) / 1023
X_TICK = 2 * math.pi / 4096


def rx_bus(ids: str = "1-3") -> Bus:
    """RX-28s at the factory rate, each already pinged, and its mode known (which the SI
    units of moving_speed depend on), so that later counts are exact."""
    bus = Bus.open(f"emu://rx28:{ids}", baudrate=57142)
    for m in bus.emulator.motors:
        bus.ping(m.id)
        assert not bus.wheel_mode(m.id)
    return bus


def x_bus(ids: str = "1-3") -> Bus:
    bus = Bus.open(f"emu://xm430-w210:{ids}", baudrate=1_000_000)
    for m in bus.emulator.motors:
        bus.ping(m.id)
    return bus


def tables(bus: Bus) -> list[bytes]:
    return [bytes(m.table) for m in bus.emulator.motors]


# -- packet economy ------------------------------------------------------------------------------

def test_several_registers_of_one_motor_are_one_contiguous_read() -> None:
    """present_position..present_temperature (36..43) go out as one 8-byte READ: an 8-byte
    instruction packet (FF FF ID LEN INST ADDR N CHK) and a 6 + 8 byte status."""
    bus = rx_bus("1")
    bus.write(1, "torque_enable", 1)
    bus.emulator.motor(1).external_load = -0.3     # something pushes the horn clockwise
    bus.port.clock.advance(0.1)                    # the motor holds against it
    seen, stats = bus.emulator.instructions_seen, (bus.stats.transactions,
                                                    bus.stats.bytes_out, bus.stats.bytes_in)
    names = ["present_position", "present_speed", "present_load", "present_voltage",
             "present_temperature"]
    got = bus.read(1, names, raw=True)
    assert bus.emulator.instructions_seen - seen == 1
    assert bus.stats.transactions - stats[0] == 1
    assert bus.stats.bytes_out - stats[1] == 8
    assert bus.stats.bytes_in - stats[2] == 6 + 8
    motor = bus.emulator.motor(1)
    assert got == {n: motor.get_raw(n) for n in names}
    assert got["present_position"] == 512
    assert got["present_speed"] == 0
    assert got["present_load"] == 300  # 30 %: the motor holds a clockwise push with a CCW torque
    # the emulated supply is the model's nominal voltage (RX-28: 18.5 V, e-Manual)
    assert got["present_voltage"] == pytest.approx(10 * motor.model.nominal_voltage, abs=5)


def test_read_of_distant_registers_spans_the_gap_in_one_read() -> None:
    """goal_position (30) and present_temperature (43): one READ of 14 bytes, not two."""
    bus = rx_bus("1")
    seen, bytes_in = bus.emulator.instructions_seen, bus.stats.bytes_in
    got = bus.read(1, ["present_temperature", "goal_position"], raw=True)
    assert bus.emulator.instructions_seen - seen == 1
    assert bus.stats.bytes_in - bytes_in == 6 + 14
    assert got["goal_position"] == 512
    assert 20 <= got["present_temperature"] <= 80


def test_protocol2_multi_register_read_is_one_read() -> None:
    """X-series: present velocity and position (128..135) in one READ; 2.0 READ instruction
    is 14 bytes, its status 11 + 8."""
    bus = x_bus("1")
    seen, out, inn = (bus.emulator.instructions_seen, bus.stats.bytes_out,
                      bus.stats.bytes_in)
    got = bus.read(1, ["present_position", "present_velocity"])
    assert bus.emulator.instructions_seen - seen == 1
    assert (bus.stats.bytes_out - out, bus.stats.bytes_in - inn) == (14, 11 + 8)
    assert got == {"present_position": 0.0, "present_velocity": 0.0}


def test_adjacent_registers_are_one_write() -> None:
    """goal_position + moving_speed (30..33) in one WRITE (6 + 1 address + 4 data bytes)."""
    bus = rx_bus("1")
    seen, out = bus.emulator.instructions_seen, bus.stats.bytes_out
    bus.write(1, {"goal_position": 0.25, "moving_speed": 2.0})
    assert bus.emulator.instructions_seen - seen == 1
    assert bus.stats.bytes_out - out == 11
    motor = bus.emulator.motor(1)
    assert motor.get_raw("goal_position") == 512 + round(0.25 / RX28_TICK)
    assert motor.get_raw("moving_speed") == round(2.0 / (0.111 * 2 * math.pi / 60))


def test_sync_write_is_one_packet_for_all_motors() -> None:
    """SYNC_WRITE: one broadcast packet sets each motor's own goal."""
    bus = rx_bus()
    seen = bus.emulator.instructions_seen
    bus.sync_write("goal_position", {1: -0.5, 2: 0.0, 3: 0.5})
    assert bus.emulator.instructions_seen - seen == 1
    assert [bus.emulator.motor(i).get_raw("goal_position") for i in (1, 2, 3)] == [
        512 - round(0.5 / RX28_TICK), 512, 512 + round(0.5 / RX28_TICK)]


def test_model_is_learnt_once() -> None:
    """The first access to an undeclared motor pings it; later ones do not."""
    bus = Bus.open("emu://xm430-w210:4", baudrate=1_000_000)
    bus.read(4, "present_position")
    seen = bus.emulator.instructions_seen
    bus.read(4, "present_position")
    assert bus.emulator.instructions_seen - seen == 1
    assert bus.motors[4].name == "XM430-W210"


# -- bad input writes nothing ------------------------------------------------------------------

def test_unknown_model_in_spec() -> None:
    with pytest.raises(ConfigError) as info:
        Bus.open("emu://rx99:1-3", baudrate=1_000_000)
    assert_one_line_naming(info.value, "rx99")


@pytest.mark.parametrize("do", [
    lambda bus: bus.read(1, "goal_postion"),
    lambda bus: bus.write(1, "goal_postion", 0.0),
    lambda bus: bus.write(1, {"goal_position": 0.0, "goal_postion": 0.0}),
    lambda bus: bus.sync_write("goal_postion", {1: 0.0, 2: 0.0}),
    lambda bus: bus.sync_read("goal_postion", [1, 2]),
    lambda bus: bus.bulk_read({1: "present_position", 2: "goal_postion"}),
], ids=["read", "write", "write-dict", "sync_write", "sync_read", "bulk_read"])
def test_unknown_register_name(do) -> None:
    """A misspelt register is named in the error and nothing goes on the wire."""
    bus = rx_bus()
    seen, before = bus.emulator.instructions_seen, tables(bus)
    with pytest.raises(ConfigError) as info:
        do(bus)
    assert_one_line_naming(info.value, "goal_postion")
    assert bus.emulator.instructions_seen == seen
    assert tables(bus) == before


@pytest.mark.parametrize(("name", "value"), [
    ("goal_position", 3.0),            # beyond +150°
    ("goal_position", -3.0),
    ("goal_position", "abc"),
    ("goal_position", math.nan),
    ("goal_position", None),
    ("moving_speed", 20.0),            # beyond 1023 × 0.111 rpm: must not become clockwise
    ("torque_enable", 2),
    ("return_delay_time", 1.0),
])
def test_out_of_range_or_non_numeric_value(name: str, value) -> None:
    """The value is refused by the driver, naming the register; the motor never sees it."""
    bus = rx_bus("1")
    seen, before = bus.emulator.instructions_seen, tables(bus)
    with pytest.raises(ConfigError) as info:
        bus.write(1, name, value)
    assert_one_line_naming(info.value, name)
    assert bus.emulator.instructions_seen == seen
    assert tables(bus) == before


@pytest.mark.parametrize(("name", "value"), [("goal_position", 1024), ("goal_position", -1),
                                             ("goal_position", 1.5), ("led", True)])
def test_out_of_range_raw_value(name: str, value) -> None:
    bus = rx_bus("1")
    seen, before = bus.emulator.instructions_seen, tables(bus)
    with pytest.raises(ConfigError) as info:
        bus.write(1, name, value, raw=True)
    assert_one_line_naming(info.value, name)
    assert bus.emulator.instructions_seen == seen
    assert tables(bus) == before


def test_read_only_register_is_refused_by_the_driver() -> None:
    """Writing present_position cannot work; the driver says so instead of asking the
    motor."""
    bus = rx_bus("1")
    seen = bus.emulator.instructions_seen
    with pytest.raises(ConfigError) as info:
        bus.write(1, "present_position", 0.0)
    assert_one_line_naming(info.value, "present_position")
    assert bus.emulator.instructions_seen == seen


def test_non_adjacent_registers_in_one_write_are_refused() -> None:
    bus = rx_bus("1")
    seen, before = bus.emulator.instructions_seen, tables(bus)
    with pytest.raises(ConfigError) as info:
        bus.write(1, {"goal_position": 0.0, "led": 1})
    assert_one_line_naming(info.value, "goal_position", "led")
    assert bus.emulator.instructions_seen == seen
    assert tables(bus) == before


@pytest.mark.parametrize(("spec", "baud", "bad_id"), [
    ("rx28:1", 57142, 254), ("rx28:1", 57142, 300), ("rx28:1", 57142, -1),
    ("xm430-w210:1", 1_000_000, 253), ("xm430-w210:1", 1_000_000, 254),
])
def test_id_outside_protocol_range(spec: str, baud: int, bad_id: int) -> None:
    """1.0 IDs are 0..253 and 2.0 IDs 0..252 (254 is broadcast, which cannot be READ);
    a bad ID is refused, naming it, before anything is sent."""
    bus = Bus.open(f"emu://{spec}", baudrate=baud)
    bus.ping(1)
    seen, before = bus.emulator.instructions_seen, tables(bus)
    for do in (lambda: bus.read(bad_id, "present_position"),
               lambda: bus.write(bad_id, "led", 1),
               lambda: bus.ping(bad_id),
               lambda: bus.sync_write("led", {1: 1, bad_id: 1}),
               lambda: bus.scan([1, bad_id])):
        with pytest.raises(ConfigError) as info:
            do()
        assert_one_line_naming(info.value, str(bad_id))
    assert bus.emulator.instructions_seen == seen
    assert tables(bus) == before


def test_serial_port_that_does_not_exist() -> None:
    with pytest.raises(ConfigError) as info:
        Bus.open("/dev/does-not-exist")
    assert_one_line_naming(info.value, "/dev/does-not-exist")


def test_sync_write_with_one_bad_value_writes_nothing() -> None:
    """All or nothing: the two good goals must not be applied when the third is bad."""
    bus = rx_bus()
    seen, before = bus.emulator.instructions_seen, tables(bus)
    with pytest.raises(ConfigError) as info:
        bus.sync_write("goal_position", {1: 0.1, 2: 9.0, 3: 0.2})
    assert_one_line_naming(info.value, "goal_position")
    assert bus.emulator.instructions_seen == seen
    assert tables(bus) == before
    with pytest.raises(ConfigError):
        bus.sync_write("goal_position", {1: 0.1, 2: 0.2, 3: "abc"})
    with pytest.raises(ConfigError):
        bus.sync_write(["goal_position", "moving_speed"], {1: (0.1, 1.0), 2: (0.2,)})
    assert bus.emulator.instructions_seen == seen
    assert tables(bus) == before


def test_bulk_write_with_one_bad_value_writes_nothing() -> None:
    bus = x_bus()
    seen, before = bus.emulator.instructions_seen, tables(bus)
    with pytest.raises(ConfigError) as info:
        bus.bulk_write({1: {"goal_position": 0.5}, 2: {"led": 1},
                        3: {"profile_velocity": -1.0}})
    assert_one_line_naming(info.value, "profile_velocity")
    assert bus.emulator.instructions_seen == seen
    assert tables(bus) == before


def test_bad_bus_settings() -> None:
    """Negative retries, a zero timeout or an unknown protocol version are refused."""
    with pytest.raises(ConfigError, match="retries"):
        Bus.open("emu://rx28:1", baudrate=57142, retries=-1)
    with pytest.raises(ConfigError, match="timeout"):
        Bus.open("emu://rx28:1", baudrate=57142, timeout=0.0)
    with pytest.raises(ConfigError, match="3"):
        Bus(Bus.open("emu://rx28:1", baudrate=1_000_000).port, 3)


def test_scan_rejects_bad_baud_rate() -> None:
    bus = rx_bus("1")
    seen = bus.emulator.instructions_seen
    with pytest.raises(ConfigError, match="0"):
        bus.scan([1], [57142, 0])
    assert bus.emulator.instructions_seen == seen


# The e-Manual's Status Return Level table (ROBOTIS-GIT/emanual,
# _includes/en/dxl/control_table_status_return_lv.md, included by the RX-28 and X-series
# pages): 0 returns a status for PING only, 1 for PING and READ, 2 for all instructions.
@pytest.mark.parametrize(("spec", "baud"), [("rx28:1-2", 57142), ("xm430-w210:1-2", 1_000_000)])
def test_writing_status_return_level_updates_what_the_bus_waits_for(spec: str,
                                                                     baud: int) -> None:
    bus = Bus.open(f"emu://{spec}", baudrate=baud, retries=0)
    bus.write(1, "status_return_level", 1)          # no need to tell the bus first
    assert bus.status_return_level[1] == 1
    bus.write(1, "led", 1)                          # level 1: no status to WRITE, none awaited
    assert bus.read(1, "led", raw=True) == 1        # ... READ still answered
    assert bus.stats.timeouts == 0
    bus.sync_write("status_return_level", {1: 0, 2: 0})
    assert bus.status_return_level == {1: 0, 2: 0}
    with pytest.raises(ConfigError, match="motor 1: status return level 0 answers PING only"):
        bus.read(1, "present_position")             # refused before anything is sent
    seen = bus.emulator.instructions_seen
    with pytest.raises(ConfigError, match="status return level 0"):
        bus.sync_read("present_position", [1, 2])
    assert bus.emulator.instructions_seen == seen
    bus.write(2, "status_return_level", 2)          # back to 2: that WRITE is answered
    assert bus.read(2, "status_return_level", raw=True) == 2
    assert bus.stats.timeouts == 0


def test_scan_holds_the_bus_while_it_changes_the_baud_rate() -> None:
    """While scan() has the port at another rate, no other thread can start a transaction
    (which would go out at the wrong baud rate)."""
    import threading

    bus = Bus.open("emu://rx28:1", baudrate=57142)
    free_during_scan: list[bool] = []

    def other_thread_tries() -> None:
        def attempt() -> None:
            got = bus._lock.acquire(blocking=False)
            if got:
                bus._lock.release()
            free_during_scan.append(got)
        thread = threading.Thread(target=attempt)
        thread.start()
        thread.join()

    bus.scan([1], [1_000_000, 57142], progress=lambda baud, motor_id: other_thread_tries())
    assert free_during_scan == [False, False]
    assert bus.baudrate == 57142
