"""The emulated RX-28's load and temperature follow its effort, through the bus: a joint held
against its torque limit heats and trips, a load it cannot hold is an overload.

Register facts are the ROBOTIS e-Manual's (ROBOTIS-GIT/emanual): the RX-28 page
docs/en/dxl/rx/rx-28.md (control table: Temperature Limit(11) default 80, Shutdown(18)
default 36 = 0x24, Torque Limit(34), Present Load(40), Present Temperature(43)) and the
descriptions it includes from _includes/en/dxl/: control_table_present_load.md (0.1 % a unit,
bit 10 the direction: 0 CCW, 1 CW; "an inferred value based on the internal output value"),
control_table_temp_limit.md (over the limit: "the Status Packet transmits Overheating Error Bit
(Bit2)"; with overheating set in Shutdown "the motor's output will be 0 [%]") and
control_table_alarm_shutdown.md (bit 5 Overload Error "when the current load cannot be
controlled with the set maximum torque", bit 2 OverHeating Error; a shutdown makes "the motor
output ... 0 % by resetting the value of Torque Limit(34) to 0").

The motors run on a virtual clock; the thermal knobs (``motor.temperature``,
``motor.thermal_time_constant``) put a motor near its limit so that the real model takes it
over in seconds.
"""

from __future__ import annotations

from servolab.dynamixel import Bus, VirtualMotor
from servolab.dynamixel.motor_alarms import OVERLOAD_TIME_S
from servolab.dynamixel.plant import MECHANICAL_TIME_CONSTANT_S

OVERHEATING, OVERLOAD = 0x04, 0x20          # status error bits (e-Manual, Alarm Shutdown)
PRESENT_LOAD, TORQUE_LIMIT = 40, 34          # addresses (e-Manual, RX-28 control table)
CW = 0x400                                   # Present Load bit 10: a CW load


def _rx28() -> tuple[Bus, VirtualMotor]:
    bus = Bus.open("emu://rx28:14", baudrate=57142)
    return bus, bus.emulator.motor(14)


def _load_and_error(bus: Bus) -> tuple[int, int]:
    """One READ of Present Load: (its raw value, the status packet's error byte)."""
    status = bus.transact(bus.proto.read(14, PRESENT_LOAD, 2), {14: 2}, check=False)[14]
    return int.from_bytes(status.params, "little"), status.error


def _ratio(raw: int) -> float:
    """Present Load as a signed ratio: 0.1 % a unit, bit 10 = CW (negative)."""
    return -(raw & 0x3FF) / 1000 if raw & CW else (raw & 0x3FF) / 1000


def test_factory_limits_are_the_e_manuals() -> None:
    """Temperature Limit(11) 80 °C and Shutdown(18) 36 (overheating + overload), Torque
    Limit(34) from Max Torque(14) 1023 (e-Manual, RX-28 control table)."""
    bus, _ = _rx28()
    assert bus.read(14, ["temperature_limit", "shutdown", "torque_limit"], raw=True) == {
        "temperature_limit": 80, "shutdown": 0x24, "torque_limit": 1023}


def test_load_reads_the_torque_that_accelerates_and_brakes_the_horn() -> None:
    """Present Load is inferred from the motor's output: starting a move CCW it reads a CCW
    load (bit 10 clear), large at first and decaying to friction while the horn turns; on
    arrival it brakes (CW, bit 10 set); moving CW the signs are the other way round."""
    bus, motor = _rx28()
    bus.write(14, "torque_enable", 1)
    bus.write(14, "goal_position", 900, raw=True)          # CCW (the count grows CCW)
    start, _ = _load_and_error(bus)
    assert not start & CW and _ratio(start) > 0.5          # accelerating: most of the output
    bus.port.clock.advance(10 * MECHANICAL_TIME_CONSTANT_S)
    cruising, _ = _load_and_error(bus)
    assert motor.plant.velocity > 0
    assert not cruising & CW and 0.04 <= _ratio(cruising) <= 0.17   # friction, CCW
    assert _ratio(cruising) < _ratio(start)
    while motor.plant.velocity:                            # until it arrives
        bus.port.clock.advance(0.001)
    braking, _ = _load_and_error(bus)
    assert braking & CW and _ratio(braking) < -0.1
    bus.port.clock.advance(20 * MECHANICAL_TIME_CONSTANT_S)
    assert _load_and_error(bus)[0] == 0                    # at rest, unloaded: no torque
    bus.write(14, "goal_position", 200, raw=True)          # CW
    back, _ = _load_and_error(bus)
    assert back & CW and _ratio(back) < -0.5


def test_load_reads_the_torque_that_holds_an_external_load() -> None:
    """A load pushing the horn clockwise is held by a counter-clockwise output: Present Load
    30 % CCW (300, bit 10 clear); pushed the other way, 30 % CW (1024 + 300)."""
    bus, motor = _rx28()
    bus.write(14, "torque_enable", 1)
    motor.external_load = -0.3
    bus.port.clock.advance(0.1)
    assert _load_and_error(bus) == (300, 0)
    assert bus.read(14, "present_position", raw=True) == 512   # held where it was
    motor.external_load = 0.3
    bus.port.clock.advance(0.1)
    assert _load_and_error(bus) == (CW | 300, 0)
    bus.write(14, "torque_enable", 0)                      # no output, no load to read
    bus.port.clock.advance(0.1)
    assert _load_and_error(bus) == (0, 0)


def test_a_load_above_the_torque_limit_is_an_overload_and_shuts_the_output_down() -> None:
    """Overload Error "when the current load cannot be controlled with the set maximum
    torque", and with the default Shutdown 0x24 "the motor output becomes 0 % by resetting the
    value of Torque Limit(34) to 0" (e-Manual, Alarm Shutdown) — once the load has lasted
    servolab's OVERLOAD_TIME_S (the e-Manual: a "persistent load"; it names no time). The
    bit stays in every status while the load it could not hold still pushes; gone with the
    load."""
    bus, motor = _rx28()
    bus.write(14, "torque_enable", 1)
    bus.write(14, "torque_limit", 512, raw=True)           # 50 %
    motor.external_load = 0.3                              # within it: held, no error
    bus.port.clock.advance(0.1)
    assert _load_and_error(bus) == (CW | 300, 0)
    motor.external_load = 0.6                              # beyond it: stalled, its
    bus.port.clock.advance(OVERLOAD_TIME_S - 0.1)          # whole limit, and a second of
    assert _load_and_error(bus) == (CW | 500, 0)           # it is an overload: not yet
    bus.port.clock.advance(0.11)
    for _ in range(3):
        load, error = _load_and_error(bus)
        assert error == OVERLOAD
        assert load == 0                                   # output 0 %
        bus.port.clock.advance(0.1)
    assert bus.read(14, ["torque_limit", "torque_enable"], raw=True) == {
        "torque_limit": 0, "torque_enable": 1}             # torque enable stays (1.0)
    assert bus.alerts == {14: OVERLOAD}
    bus.write(14, "torque_limit", 580, raw=True)           # 57 %: still beaten
    bus.port.clock.advance(OVERLOAD_TIME_S - 0.1)
    assert bus.read(14, "torque_limit", raw=True) == 580   # for less than a second
    bus.port.clock.advance(0.11)
    assert bus.read(14, "torque_limit", raw=True) == 0     # shut down again
    motor.external_load = 0.0
    bus.port.clock.advance(0.01)
    assert _load_and_error(bus) == (0, 0)                  # the condition is gone (1.0)
    bus.write(14, "torque_limit", 1023, raw=True)          # and the output back for good
    motor.external_load = 0.6                              # which holds 60 %, once back on
    bus.port.clock.advance(10.0)                           # the goal the load drove it off
    assert _load_and_error(bus) == (CW | 600, 0)


def test_held_against_its_torque_limit_it_heats_and_trips_at_the_temperature_limit() -> None:
    """Shutdown set to overheating only (0x04): a load above the torque limit is reported,
    once it has lasted OVERLOAD_TIME_S, as an overload in every status but does not cut the
    output; the stalled motor gives its full
    torque limit (Present Load 100 %, CCW against a CW push), heats monotonically, and once
    its temperature passes Temperature Limit(11), 80 °C, every status carries the Overheating
    Error bit and Torque Limit(34) is 0 (e-Manual, Temperature Limit and Alarm Shutdown)."""
    bus, motor = _rx28()
    bus.write(14, "shutdown", OVERHEATING, raw=True)
    bus.write(14, "torque_enable", 1)
    motor.temperature = 75.0                               # it has worked all morning
    motor.thermal_time_constant = 10.0                     # and warms in seconds
    motor.external_load = -1.2                             # more than its 100 % holds
    loaded_at = bus.port.clock.now()
    readings: list[int] = []
    tripped_at = None
    for k in range(400):                                   # 10 s at 40 Hz
        bus.port.clock.advance(0.025)
        stalled_for = bus.port.clock.now() - loaded_at
        load, error = _load_and_error(bus)
        temperature = bus.read(14, "present_temperature", raw=True)
        if not error & OVERHEATING:
            # an overload once the stall has lasted a second (the READ's few ms either way)
            if abs(stalled_for - OVERLOAD_TIME_S) > 0.01:
                assert error == (OVERLOAD if stalled_for > OVERLOAD_TIME_S else 0), \
                    (stalled_for, error)
            assert load == 1000                            # the whole torque limit, CCW
            assert temperature <= 80
            readings.append(temperature)
            continue
        tripped_at = k
        assert temperature >= 80                           # passed the limit (rounded)
        break
    assert tripped_at is not None, "never tripped"
    assert readings == sorted(readings) and readings[0] == 75 and readings[-1] == 80
    assert bus.read(14, "torque_limit", raw=True) == 0
    for _ in range(5):                                     # every status while it is hot
        bus.port.clock.advance(0.1)                        # (cooling 4.8 °C/s at tau 10 s)
        load, error = _load_and_error(bus)
        assert error == OVERHEATING | OVERLOAD and load == 0   # no output: cooling
    assert bus.alerts[14] & OVERHEATING


def test_a_joint_starting_warm_and_loaded_trips_through_the_model() -> None:
    """What a robot test needs: "motor 14 starts at 78 °C and is loaded at row 5". With the
    factory Shutdown (0x24), a heavy load within the torque limit (95 %) heats it toward
    32 + 60 x 0.95² = 86 °C; it passes 80 °C, the overheating bit comes and the output goes."""
    bus, motor = _rx28()
    bus.write(14, "torque_enable", 1)
    motor.temperature = 78.0
    motor.thermal_time_constant = 5.0
    assert bus.read(14, "present_temperature", raw=True) == 78
    motor.external_load = 0.95
    previous = motor.temperature
    for _ in range(200):                                   # 10 s at 20 Hz
        bus.port.clock.advance(0.05)
        load, error = _load_and_error(bus)
        if error:
            break
        assert load == CW | 950                            # holding it: 95 % CW
        assert motor.temperature >= previous
        previous = motor.temperature
    assert error == OVERHEATING
    assert bus.read(14, ["torque_limit", "present_temperature"], raw=True) == {
        "torque_limit": 0, "present_temperature": 80}


def test_an_overheated_rx28_reports_it_until_it_has_cooled() -> None:
    """Protocol 1.0 reports overheating as a condition: it stays while the motor is hot and
    goes once it has cooled (5 °C under the limit here, see OVERHEATING_HYSTERESIS_C; the
    e-Manual asks for 20 minutes of cooling after a temperature shutdown)."""
    bus, motor = _rx28()
    bus.write(14, "torque_enable", 1)
    motor.thermal_time_constant = 10.0
    motor.temperature = 85.0                               # over the limit from the next step
    bus.port.clock.advance(0.01)
    assert _load_and_error(bus)[1] == OVERHEATING
    bus.port.clock.advance(1.0)
    assert _load_and_error(bus)[1] == OVERHEATING          # still hot
    bus.port.clock.advance(60.0)
    assert motor.temperature < 75.0
    assert _load_and_error(bus)[1] == 0
