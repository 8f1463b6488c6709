"""The control table alone (servolab.dynamixel.control_table), against the e-Manual: defaults
at power-up, the byte-level checks of a write, indirect addressing, and the value limits one
register sets for another — with no firmware, plant or bus around it.

Sources (ROBOTIS e-Manual):
- XM430-W350 control table: Operating Mode(11) default 3, Position P Gain(84) 800, Velocity I
  Gain(76) 1 920, Present Position(132) 4 bytes read-only, Goal PWM(100) within PWM
  Limit(36), Indirect Address 1 at 168 (default 224) and Indirect Data 1 at 224;
- Protocol 2.0 error numbers: 0x05 Data Length Error, 0x06 Data Limit Error, 0x07 Access
  Error;
- RX-28: "When the power is turned on, Torque Limit(34) is reset to the value of Max
  Torque(14)"; Moving Speed(32) 0..1023 in joint mode; Protocol 1.0 error bit 3, Range
  Error.
"""

from __future__ import annotations

import pytest

from servolab.dynamixel import protocol1 as p1
from servolab.dynamixel import protocol2 as p2
from servolab.dynamixel.control_table import ControlTable, Write
from servolab.dynamixel.models import model as load_model


def _xm430() -> ControlTable:
    table = ControlTable(load_model("XM430-W350"))
    table.load_defaults()
    return table


def test_power_up_defaults_are_the_e_manuals() -> None:
    table = _xm430()
    assert table.get("operating_mode") == 3
    assert table.get("position_p_gain") == 800
    assert table.get("velocity_i_gain") == 1920
    assert table.get("indirect_address_1") == 224
    rx = ControlTable(load_model("RX-28"))
    rx.data[:] = bytes(len(rx.data))
    rx.load_defaults({"max_torque": 600, "id": 7})
    assert rx.get("torque_limit") == 600       # from Max Torque at power-up
    assert rx.get("id") == 7                   # kept


def test_a_write_is_checked_byte_by_byte_before_anything_changes() -> None:
    table = _xm430()
    before = bytes(table.data)
    assert table.stage(132, b"\x00\x00\x00\x00") == p2.ACCESS      # read-only
    assert table.stage(116, b"\x00\x08") == p2.DATA_LENGTH         # 2 of goal_position's 4
    assert table.stage(len(table.data) - 1, b"\x00\x00") == p2.ACCESS   # past the end
    staged = table.stage(116, (2048).to_bytes(4, "little"))
    assert isinstance(staged, Write) and staged.names == {"goal_position"}
    assert bytes(table.data) == before         # nothing written until commit
    table.commit(staged)
    assert table.get("goal_position") == 2048


def test_a_value_beyond_the_limit_another_register_sets_is_a_data_limit_error() -> None:
    table = _xm430()
    table.put("pwm_limit", 442)
    staged = table.stage(100, (500).to_bytes(2, "little"))           # Goal PWM 500 > 442
    assert isinstance(staged, Write) and table.check(staged) == p2.DATA_LIMIT
    staged = table.stage(100, (400).to_bytes(2, "little"))
    assert isinstance(staged, Write) and table.check(staged) == 0


def test_indirect_data_stands_for_the_address_it_names() -> None:
    table = _xm430()
    staged = table.stage(168, (116).to_bytes(2, "little"))            # Indirect Address 1
    assert isinstance(staged, Write)
    table.commit(staged)
    staged = table.stage(224, b"\x07")          # Indirect Data 1 -> Goal Position's low byte
    assert staged == p2.DATA_LENGTH             # (one byte of a 4-byte item: refused)
    table.put("goal_position", 0x01020304)
    assert table.read(224, 1) == b"\x04"        # reads the byte it points at


def test_protocol1_range_errors() -> None:
    table = ControlTable(load_model("RX-28"))
    table.load_defaults()
    staged = table.stage(32, (1500).to_bytes(2, "little"))            # Moving Speed, joint
    assert isinstance(staged, Write) and table.check(staged) == p1.RANGE
    assert table.stage(36, b"\x00\x00") == p1.RANGE                   # Present Position: R


@pytest.mark.parametrize("model", ["AX-12A", "MX-28", "XL-320", "XM430-W210", "MX-64(2.0)"])
def test_every_register_reads_back_what_was_put(model: str) -> None:
    table = ControlTable(load_model(model))
    table.load_defaults()
    for reg in table.model.registers:
        value = reg.raw_max if reg.raw_max < 2**31 else 1
        table.put(reg.name, value)
        assert table.get(reg.name) == value, reg.name
