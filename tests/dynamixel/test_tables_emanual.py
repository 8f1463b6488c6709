"""The first six control tables, row by row, against the ROBOTIS e-Manual (the models added
since are in test_model_emanual_tables.py, which uses this file's row format and checks).

Each model has one table below, typed in from its e-Manual page (the markdown sources in the
public repository ROBOTIS-GIT/emanual), never read back from the tables under test. A row is

    (name, address, size, access, default, minimum, maximum)

in the page's "Control Table of EEPROM Area" or "... of RAM Area" (which fixes the area).
``default`` None is the page's "-" (no initial value). ``minimum``/``maximum`` None: the page
gives no range for the item (a reading, or a bit field given only bit by bit), so none is
checked. Ranges the control table itself does not list come from the item's description on
the same page (or the ``_includes/en/dxl`` file the page includes); a comment says where.

Every register servolab has for a model must be a row of its table: no invented register.
"""

from __future__ import annotations

import math

import pytest

from servolab.dynamixel import MODELS, model
from servolab.dynamixel.models import Register

Row = tuple[str, int, int, str, int | None, int | None, int | None]
Table = dict[str, list[Row]]  # area -> rows

# -- Protocol 1.0 ---------------------------------------------------------------------------

# source: ROBOTIS-GIT/emanual docs/en/dxl/rx/rx-28.md, Control Table of EEPROM/RAM Area
# (ranges: the page's includes control_table_id, _return_delay_time, _dx_goal_position,
# _temp_limit, _volt_limit_rx, _max_torque, _compliance_slope, _moving_speed, _present_speed,
# _present_load, _punch; compliance margin 0~255 as the EX-106+ page words the same item)
RX_28: Table = {
    "EEPROM": [
        ("model_number", 0, 2, "R", 28, None, None),
        ("firmware_version", 2, 1, "R", None, None, None),
        ("id", 3, 1, "RW", 1, 0, 253),
        ("baud_rate", 4, 1, "RW", 34, None, None),
        ("return_delay_time", 5, 1, "RW", 250, 0, 254),
        ("cw_angle_limit", 6, 2, "RW", 0, 0, 1023),
        ("ccw_angle_limit", 8, 2, "RW", 1023, 0, 1023),
        ("temperature_limit", 11, 1, "RW", 80, 0, 100),
        ("min_voltage_limit", 12, 1, "RW", 60, 50, 250),
        ("max_voltage_limit", 13, 1, "RW", 190, 50, 250),
        ("max_torque", 14, 2, "RW", 1023, 0, 1023),
        ("status_return_level", 16, 1, "RW", 2, 0, 2),
        ("alarm_led", 17, 1, "RW", 36, 0, 127),      # bits 0..6; bit 7 is 0
        ("shutdown", 18, 1, "RW", 36, 0, 127),
    ],
    "RAM": [
        ("torque_enable", 24, 1, "RW", 0, 0, 1),
        ("led", 25, 1, "RW", 0, 0, 1),
        ("cw_compliance_margin", 26, 1, "RW", 1, 0, 255),
        ("ccw_compliance_margin", 27, 1, "RW", 1, 0, 255),
        ("cw_compliance_slope", 28, 1, "RW", 32, 0, 254),   # steps from 0(0x00)~3(0x03)
        ("ccw_compliance_slope", 29, 1, "RW", 32, 0, 254),
        ("goal_position", 30, 2, "RW", None, 0, 1023),
        ("moving_speed", 32, 2, "RW", None, 0, 2047),       # wheel mode 0~2,047
        ("torque_limit", 34, 2, "RW", 1023, 0, 1023),       # "ADD 14&15": Max Torque's 1023
        ("present_position", 36, 2, "R", None, None, None),
        ("present_speed", 38, 2, "R", None, 0, 2047),
        ("present_load", 40, 2, "R", None, 0, 2047),
        ("present_voltage", 42, 1, "R", None, None, None),
        ("present_temperature", 43, 1, "R", None, None, None),
        ("registered", 44, 1, "R", 0, 0, 1),
        ("moving", 46, 1, "R", 0, 0, 1),
        ("lock", 47, 1, "RW", 0, 0, 1),
        ("punch", 48, 2, "RW", 32, 32, 1023),               # 0x20 ~ 0x3FF
    ],
}

# source: ROBOTIS-GIT/emanual docs/en/dxl/ex/ex-106+.md, Control Table of EEPROM/RAM Area and
# the item descriptions on the same page
EX_106P: Table = {
    "EEPROM": [
        ("model_number", 0, 2, "R", 107, None, None),
        ("firmware_version", 2, 1, "R", None, None, None),
        # The description says 0~252; the Specifications table (and every other 1.0 page) 0~253.
        ("id", 3, 1, "RW", 1, 0, 253),
        ("baud_rate", 4, 1, "RW", 34, None, None),
        ("return_delay_time", 5, 1, "RW", 250, 0, 254),
        ("cw_angle_limit", 6, 2, "RW", 0, 0, 4095),
        ("ccw_angle_limit", 8, 2, "RW", 4095, 0, 4095),
        ("drive_mode", 10, 1, "RW", 0, 0, 3),              # bit 0 reverse, bit 1 dual (slave)
        ("temperature_limit", 11, 1, "RW", 80, None, None),  # no range on this page
        ("min_voltage_limit", 12, 1, "RW", 60, 50, 250),
        ("max_voltage_limit", 13, 1, "RW", 240, 50, 250),
        ("max_torque", 14, 2, "RW", 1023, 0, 1023),
        ("status_return_level", 16, 1, "RW", 2, 0, 2),
        ("alarm_led", 17, 1, "RW", 36, 0, 127),
        ("shutdown", 18, 1, "RW", 36, 0, 127),
    ],
    "RAM": [
        ("torque_enable", 24, 1, "RW", 0, 0, 1),
        ("led", 25, 1, "RW", 0, 0, 1),
        ("cw_compliance_margin", 26, 1, "RW", 1, 0, 255),
        ("ccw_compliance_margin", 27, 1, "RW", 1, 0, 255),
        ("cw_compliance_slope", 28, 1, "RW", 32, 0, 254),
        ("ccw_compliance_slope", 29, 1, "RW", 32, 0, 254),
        # The page's Goal Position text (0~1023, 0.29°) is the RX-28's; its angle limits go
        # to 4,095: no range checked here.
        ("goal_position", 30, 2, "RW", None, None, None),
        ("moving_speed", 32, 2, "RW", None, 0, 2047),
        ("torque_limit", 34, 2, "RW", 1023, 0, 1023),
        ("present_position", 36, 2, "R", None, None, None),
        ("present_speed", 38, 2, "R", None, 0, 2047),
        ("present_load", 40, 2, "R", None, 0, 2047),
        ("present_voltage", 42, 1, "R", None, None, None),
        ("present_temperature", 43, 1, "R", None, None, None),
        ("registered", 44, 1, "R", 0, 0, 1),
        ("moving", 46, 1, "R", 0, 0, 1),
        ("lock", 47, 1, "RW", 0, 0, 1),
        # Punch: "0x20 to 0x3FF", but the initial value is 0, which must stay writable.
        ("punch", 48, 2, "RW", 0, 0, 1023),
        ("sensed_current", 56, 2, "R", None, 0, 1023),
    ],
}

# source: ROBOTIS-GIT/emanual docs/en/dxl/mx/mx-28.md (MX-28, Protocol 1.0 firmware), Control
# Table of EEPROM/RAM Area (ranges: includes control_table_mx_goal_position, _volt_limit,
# _temp_limit, _multiturn_offset, _resolution_divider, _mx_pid, _realtime_tick,
# _goal_acceleration)
MX_28: Table = {
    "EEPROM": [
        ("model_number", 0, 2, "R", 29, None, None),
        ("firmware_version", 2, 1, "R", None, None, None),
        ("id", 3, 1, "RW", 1, 0, 253),
        ("baud_rate", 4, 1, "RW", 34, None, None),
        ("return_delay_time", 5, 1, "RW", 250, 0, 254),
        ("cw_angle_limit", 6, 2, "RW", 0, 0, 4095),
        ("ccw_angle_limit", 8, 2, "RW", 4095, 0, 4095),
        ("temperature_limit", 11, 1, "RW", 80, 0, 100),
        ("min_voltage_limit", 12, 1, "RW", 60, 50, 160),
        ("max_voltage_limit", 13, 1, "RW", 160, 50, 160),
        ("max_torque", 14, 2, "RW", 1023, 0, 1023),
        ("status_return_level", 16, 1, "RW", 2, 0, 2),
        ("alarm_led", 17, 1, "RW", 36, 0, 127),
        ("shutdown", 18, 1, "RW", 36, 0, 127),
        ("multi_turn_offset", 20, 2, "RW", 0, -24576, 24576),
        ("resolution_divider", 22, 1, "RW", 1, 1, 4),
    ],
    "RAM": [
        ("torque_enable", 24, 1, "RW", 0, 0, 1),
        ("led", 25, 1, "RW", 0, 0, 1),
        ("d_gain", 26, 1, "RW", 0, 0, 254),
        ("i_gain", 27, 1, "RW", 0, 0, 254),
        ("p_gain", 28, 1, "RW", 32, 0, 254),
        # 0~4,095 in joint mode, -28,672~28,672 in multi-turn mode: the register takes both
        ("goal_position", 30, 2, "RW", None, -28672, 28672),
        ("moving_speed", 32, 2, "RW", None, 0, 2047),
        ("torque_limit", 34, 2, "RW", 1023, 0, 1023),       # "Max Torque"
        ("present_position", 36, 2, "R", None, None, None),
        ("present_speed", 38, 2, "R", None, 0, 2047),
        ("present_load", 40, 2, "R", None, 0, 2047),
        ("present_voltage", 42, 1, "R", None, None, None),
        ("present_temperature", 43, 1, "R", None, None, None),
        ("registered", 44, 1, "R", 0, 0, 1),
        ("moving", 46, 1, "R", 0, 0, 1),
        ("lock", 47, 1, "RW", 0, 0, 1),
        ("punch", 48, 2, "RW", 0, 0, 1023),                 # initial 0 (see EX-106+)
        ("realtime_tick", 50, 2, "R", 0, 0, 32767),          # 1 ms units, from firmware v40
        ("goal_acceleration", 73, 1, "RW", 0, 0, 254),
    ],
}

# -- X-series (Protocol 2.0) ----------------------------------------------------------------


def indirect_rows() -> list[Row]:
    """Indirect Address 1..28 at 168..222 (initial 224..251), Indirect Data 1..28 at 224..251,
    Indirect Address 29..56 at 578..632 (initial 634..661), Indirect Data 29..56 at 634..661;
    addresses take 64~661, data 0~255 (the pages list the first and last three of each)."""
    rows: list[Row] = []
    for first, count, address, data in ((1, 28, 168, 224), (29, 28, 578, 634)):
        for k in range(count):
            rows.append((f"indirect_address_{first + k}", address + 2 * k, 2, "RW",
                         data + k, 64, 661))
            rows.append((f"indirect_data_{first + k}", data + k, 1, "RW", 0, 0, 255))
    return rows


def x_table(number: int, velocity_limit: int, *, xl430: bool) -> Table:
    """The X430 control table, with the items where XM430 and XL430 differ."""
    eeprom: list[Row] = [
        ("model_number", 0, 2, "R", number, None, None),
        ("model_information", 2, 4, "R", None, None, None),
        ("firmware_version", 6, 1, "R", None, None, None),
        ("id", 7, 1, "RW", 1, 0, 252),
        ("baud_rate", 8, 1, "RW", 1, 0, 7),
        ("return_delay_time", 9, 1, "RW", 250, 0, 254),
        # XL430 table 0~13; the XM430 table still says 0~5, but its Drive Mode(10) description
        # (control_table_drivemode.md, product group dxl_x430) has bit 3, Torque On by Goal
        # Update, from firmware V45 (the emulated X-series run 46): 0~13.
        ("drive_mode", 10, 1, "RW", 0, 0, 13),
        ("operating_mode", 11, 1, "RW", 3, 0, 16),
        # The table says 0~252, yet its initial value is 255: the description
        # (control_table_shadowid.md) gives 0~252 active, 253~255 off.
        ("secondary_id", 12, 1, "RW", 255, 0, 255),
        ("protocol_type", 13, 1, "RW", 2, 1, 2),
        ("homing_offset", 20, 4, "RW", 0, -1_044_479, 1_044_479),
        ("moving_threshold", 24, 4, "RW", 10, 0, 1023),
        ("temperature_limit", 31, 1, "RW", 72 if xl430 else 80, 0, 100),
        ("max_voltage_limit", 32, 2, "RW", 140, 60, 140) if xl430 else
        ("max_voltage_limit", 32, 2, "RW", 160, 95, 160),
        ("min_voltage_limit", 34, 2, "RW", 60, 60, 140) if xl430 else
        ("min_voltage_limit", 34, 2, "RW", 95, 95, 160),
        ("pwm_limit", 36, 2, "RW", 885, 0, 885),
        ("velocity_limit", 44, 4, "RW", velocity_limit, 0, 1023),
        ("max_position_limit", 48, 4, "RW", 4095, 0, 4095),
        ("min_position_limit", 52, 4, "RW", 0, 0, 4095),
        ("startup_configuration", 60, 1, "RW", 0, 0, 3),   # range column "3": bits 0 and 1
        ("shutdown", 63, 1, "RW", 52, None, None),
    ]
    ram: list[Row] = [
        ("torque_enable", 64, 1, "RW", 0, 0, 1),
        ("led", 65, 1, "RW", 0, 0, 1),
        ("status_return_level", 68, 1, "RW", 2, 0, 2),
        ("registered_instruction", 69, 1, "R", 0, 0, 1),
        ("hardware_error_status", 70, 1, "R", 0, None, None),
        ("velocity_i_gain", 76, 2, "RW", 1000 if xl430 else 1920, 0, 16383),
        ("velocity_p_gain", 78, 2, "RW", 100, 0, 16383),
        ("position_d_gain", 80, 2, "RW", 4000 if xl430 else 0, 0, 16383),
        ("position_i_gain", 82, 2, "RW", 0, 0, 16383),
        ("position_p_gain", 84, 2, "RW", 640 if xl430 else 800, 0, 16383),
        ("feedforward_2nd_gain", 88, 2, "RW", 0, 0, 16383),
        ("feedforward_1st_gain", 90, 2, "RW", 0, 0, 16383),
        # Table 1~127; the description (control_table_buswatchdog.md): 0 switches it off and
        # clears the error, -1 is the error the motor itself sets.
        ("bus_watchdog", 98, 1, "RW", 0, 0, 127),
        ("goal_pwm", 100, 2, "RW", None, -885, 885),          # -PWM Limit ~ PWM Limit
        ("goal_velocity", 104, 4, "RW", None, -1023, 1023),   # -Velocity Limit ~ ..., <= 1023
        ("profile_acceleration", 108, 4, "RW", 0, 0, 32767),
        ("profile_velocity", 112, 4, "RW", 0, 0, 32767),
        # Min~Max Position Limit in position mode; -1,048,575~1,048,575 in extended and
        # current-based position modes (control_table_goal_position_2.md)
        ("goal_position", 116, 4, "RW", None, -1_048_575, 1_048_575),
        ("realtime_tick", 120, 2, "R", None, 0, 32767),
        ("moving", 122, 1, "R", 0, 0, 1),
        ("moving_status", 123, 1, "R", 0, None, None),
        ("present_pwm", 124, 2, "R", None, None, None),
        ("present_velocity", 128, 4, "R", None, None, None),
        ("present_position", 132, 4, "R", None, None, None),
        ("velocity_trajectory", 136, 4, "R", None, None, None),
        ("position_trajectory", 140, 4, "R", None, None, None),
        ("present_input_voltage", 144, 2, "R", None, None, None),
        ("present_temperature", 146, 1, "R", None, None, None),
        ("backup_ready", 147, 1, "R", None, 0, 1),
        *indirect_rows(),
    ]
    if xl430:
        ram.append(("present_load", 126, 2, "R", None, -1000, 1000))
    else:
        eeprom.append(("current_limit", 38, 2, "RW", 1193, 0, 1193))
        ram += [("goal_current", 102, 2, "RW", None, -1193, 1193),
                ("present_current", 126, 2, "R", None, None, None)]
    return {"EEPROM": eeprom, "RAM": ram}


# source: ROBOTIS-GIT/emanual docs/en/dxl/x/xm430-w210.md, Control Table of EEPROM/RAM Area
XM430_W210 = x_table(1030, 330, xl430=False)
# source: ROBOTIS-GIT/emanual docs/en/dxl/x/xm430-w350.md, Control Table of EEPROM/RAM Area
# (model number 1,020, velocity limit 200; the stored versions of this page predate
# Startup Configuration(60) and Backup Ready(147), whose rows are the XM430-W210 page's)
XM430_W350 = x_table(1020, 200, xl430=False)
# source: ROBOTIS-GIT/emanual docs/en/dxl/x/xl430-w250.md, Control Table of EEPROM/RAM Area
XL430_W250 = x_table(1060, 265, xl430=True)

TABLES: dict[str, Table] = {
    "RX-28": RX_28, "EX-106+": EX_106P, "MX-28": MX_28,
    "XM430-W210": XM430_W210, "XM430-W350": XM430_W350, "XL430-W250": XL430_W250,
}

CASES = [pytest.param(name, area, row, id=f"{name}-{row[0]}")
         for name, table in TABLES.items() for area, rows in table.items() for row in rows]


def test_every_model_has_a_table() -> None:
    """Every model servolab ships is checked against its page, here or in
    test_model_emanual_tables.py."""
    from tests.dynamixel.test_model_emanual_tables import TABLES as LATER

    assert not set(TABLES) & set(LATER)
    assert set(TABLES) | set(LATER) == set(MODELS)


def check_row(name: str, area: str, row: Row) -> None:
    """The register ``row`` names in model ``name`` is the row, in ``area``."""
    reg_name, address, size, access, default, minimum, maximum = row
    reg: Register = model(name).register(reg_name)
    assert (reg.address, reg.size, reg.area, reg.access) == (address, size, area, access)
    assert reg.default == default
    if minimum is not None:
        assert reg.raw_min == minimum
    if maximum is not None:
        assert reg.raw_max == maximum
    # A default is a value the motor itself would accept back.
    if reg.default is not None and reg.access == "RW":
        assert reg.raw_min <= reg.default <= reg.raw_max


def check_no_invented_register(name: str, table: Table) -> None:
    """Model ``name`` has no register ``table`` does not list, and ``table`` lists none
    twice."""
    rows = [row for rows in table.values() for row in rows]
    names = [row[0] for row in rows]
    assert len(names) == len(set(names))
    assert {r.name for r in model(name).registers} == set(names)


@pytest.mark.parametrize(("name", "area", "row"), CASES)
def test_register_matches_emanual(name: str, area: str, row: Row) -> None:
    """Address, size, area, access, initial value and range of one item, as the page gives
    them: a wrong one is a write to the wrong place, or a value the motor refuses."""
    check_row(name, area, row)


@pytest.mark.parametrize("name", TABLES)
def test_no_register_beyond_emanual(name: str) -> None:
    """servolab has no register the page does not list, and lists none twice."""
    check_no_invented_register(name, TABLES[name])


def test_x_series_indirect_rows() -> None:
    """Spot checks of the generated indirect rows against the rows the pages print."""
    m = model("XM430-W210")
    for reg_name, address, default in (("indirect_address_1", 168, 224),
                                       ("indirect_address_28", 222, 251),
                                       ("indirect_address_29", 578, 634),
                                       ("indirect_address_56", 632, 661)):
        reg = m.register(reg_name)
        assert (reg.address, reg.default) == (address, default)
    assert m.register("indirect_data_28").address == 251
    assert m.register("indirect_data_29").address == 634
    assert m.table_size == 662


# -- physical figures ------------------------------------------------------------------------

# (model, no-load rpm, at volts, ticks, angle range in degrees, degrees a tick)
# sources (ROBOTIS-GIT/emanual, Specifications):
#   RX-28   docs/en/dxl/rx/rx-28.md: No Load Speed 85rpm (at 18.5V); Resolution 0.29°,
#           Running Degree 0°~300°
#   EX-106+ docs/en/dxl/ex/ex-106+.md: 91rpm (at 18.5V); Resolution 0.06°, 0°~251°
#   MX-28   _data/dxl_mx_info.yml (mx-28, the page's specifications_mx include):
#           55 rev/min @ 12 V; 4096 pulse/rev
#   XM430-W210/-W350, XL430-W250: _data/dxl_x_info.yml (specifications_x include), the bold
#           (recommended-voltage) figure: 77 and 46 rev/min at 12.0 V, 57 rev/min at 11.1 V;
#           4096 pulse/rev
PHYSICAL = [
    ("RX-28", 85.0, 18.5, 1024, 300.0, 0.29),
    ("EX-106+", 91.0, 18.5, 4096, 251.0, 0.06),
    ("MX-28", 55.0, 12.0, 4096, 360.0, 0.088),
    ("XM430-W210", 77.0, 12.0, 4096, 360.0, 0.088),
    ("XM430-W350", 46.0, 12.0, 4096, 360.0, 0.088),
    ("XL430-W250", 57.0, 11.1, 4096, 360.0, 0.088),
]


@pytest.mark.parametrize(("name", "rpm", "volts", "ticks", "degrees", "per_tick"), PHYSICAL)
def test_physical_figures(name: str, rpm: float, volts: float, ticks: int, degrees: float,
                          per_tick: float) -> None:
    """No-load speed at the voltage the page rates it at (the emulated supply), resolution and
    angle range."""
    m = model(name)
    assert m.no_load_speed_rpm == rpm
    assert m.nominal_voltage == volts
    assert m.resolution == ticks
    assert m.angle_range_deg == pytest.approx(degrees, abs=0.1)   # EX-106+: 250.92°
    assert math.degrees(m.rad_per_tick) == pytest.approx(per_tick, rel=0.025)
