"""The control tables of the models added after the first six, row by row, against the ROBOTIS
e-Manual (the first six are in test_tables_emanual.py, which holds the row format and the
checks both files share).

Each table below is typed in from the e-Manual page it cites (the markdown sources of
ROBOTIS-GIT/emanual, at the commit named), never read back from the model files under test. A
row is ``(name, address, size, access, default, minimum, maximum)`` in the page's "Control
Table of EEPROM Area" or "... of RAM Area"; ``default`` None is the page's "-";
``minimum``/``maximum`` None where neither the table nor the item's description gives a range.
Where pages share a table word for word (the AX pages, the RX pages, the X430 and X540 pages),
one function types the shared rows and each model passes what its page says differently.

Where servolab's file departs from a page on purpose, the row says so and why: the checks here
hold the file to the row.
"""

from __future__ import annotations

import math

import pytest

from servolab.dynamixel import model
from tests.dynamixel.test_tables_emanual import (
    Row,
    Table,
    check_no_invented_register,
    check_row,
)

# -- Protocol 1.0: AX, RX, MX ---------------------------------------------------------------


def dx_table(number: int, *, baud: int, temp: int, maxv: int, max_torque: int = 1023,
             margin: int = 1, slope: int = 32, temp_max: int = 100) -> Table:
    """The AX/RX control table (the AX-12A, AX-12W, AX-18A, RX-24F, RX-64 pages: the RX-28's
    of test_tables_emanual.py, which their tables repeat row for row). Ranges from the
    descriptions: ID 0~253, return delay 0~254, angle limits 0~1,023 (Goal Position's),
    temperature 0~100 (control_table_temp_limit.md), voltage 50~250 (the AX-18A page's own
    words; the others include control_table_volt_limit_high.md), compliance margin 0~255 and
    slope 0~254 in seven steps, moving speed 0~2,047 in wheel mode, punch 0x20~0x3FF."""
    return {
        "EEPROM": [
            ("model_number", 0, 2, "R", number, None, None),
            ("firmware_version", 2, 1, "R", None, None, None),
            ("id", 3, 1, "RW", 1, 0, 253),
            ("baud_rate", 4, 1, "RW", baud, None, None),
            ("return_delay_time", 5, 1, "RW", 250, 0, 254),
            ("cw_angle_limit", 6, 2, "RW", 0, 0, 1023),
            ("ccw_angle_limit", 8, 2, "RW", 1023, 0, 1023),
            ("temperature_limit", 11, 1, "RW", temp, 0, temp_max),
            ("min_voltage_limit", 12, 1, "RW", 60, 50, 250),
            ("max_voltage_limit", 13, 1, "RW", maxv, 50, 250),
            ("max_torque", 14, 2, "RW", max_torque, 0, 1023),
            ("status_return_level", 16, 1, "RW", 2, 0, 2),
            ("alarm_led", 17, 1, "RW", 36, 0, 127),
            ("shutdown", 18, 1, "RW", 36, 0, 127),
        ],
        "RAM": [
            ("torque_enable", 24, 1, "RW", 0, 0, 1),
            ("led", 25, 1, "RW", 0, 0, 1),
            ("cw_compliance_margin", 26, 1, "RW", margin, 0, 255),
            ("ccw_compliance_margin", 27, 1, "RW", margin, 0, 255),
            ("cw_compliance_slope", 28, 1, "RW", slope, 0, 254),
            ("ccw_compliance_slope", 29, 1, "RW", slope, 0, 254),
            ("goal_position", 30, 2, "RW", None, 0, 1023),
            ("moving_speed", 32, 2, "RW", None, 0, 2047),
            ("torque_limit", 34, 2, "RW", max_torque, 0, 1023),   # "ADD 14&15"
            ("present_position", 36, 2, "R", None, None, None),
            ("present_speed", 38, 2, "R", None, 0, 2047),
            ("present_load", 40, 2, "R", None, 0, 2047),
            ("present_voltage", 42, 1, "R", None, None, None),
            ("present_temperature", 43, 1, "R", None, None, None),
            ("registered", 44, 1, "R", 0, 0, 1),
            ("moving", 46, 1, "R", 0, 0, 1),
            ("lock", 47, 1, "RW", 0, 0, 1),
            ("punch", 48, 2, "RW", 32, 32, 1023),
        ],
    }


# source: docs/en/dxl/ax/ax-12a.md @486d85b1 (AX-12, AX-12+ and AX-12A share it)
AX_12A = dx_table(12, baud=1, temp=70, maxv=140)
# source: docs/en/dxl/ax/ax-12w.md @07a99125: compliance margin 4, slope 64; its own
# Temperature Limit description gives 0 ~ 99
AX_12W = dx_table(300, baud=1, temp=70, maxv=140, margin=4, slope=64, temp_max=99)
# source: docs/en/dxl/ax/ax-18a.md @07fe860b: temperature 75, Max Torque 983 (so Torque Limit's
# "ADD 14&15" is 983)
AX_18A = dx_table(18, baud=1, temp=75, maxv=140, max_torque=983)
# source: docs/en/dxl/rx/rx-24f.md @0f562b30
RX_24F = dx_table(24, baud=34, temp=80, maxv=190)
# source: docs/en/dxl/rx/rx-64.md @07fe860b. The page includes control_table_volt_limit.md,
# whose range is 50 ~ 160, yet its initial Max Voltage Limit is 190: servolab keeps the RX-28's
# 50 ~ 250, which holds the page's own initial value.
RX_64 = dx_table(64, baud=34, temp=80, maxv=190)


def mx1_table(number: int, *, baud: int, maxv: int, volt_max: int, d: int, p: int, punch: int,
              torque: bool, drive: bool) -> Table:
    """The MX control table in Protocol 1.0 firmware (the MX-12W, MX-64 and MX-106 pages; the
    MX-28's of test_tables_emanual.py plus what each adds). Ranges from the descriptions:
    goal position 0~4,095 in joint mode and -28,672~28,672 in multi-turn mode
    (control_table_mx_goal_position.md; the register takes both), multi-turn offset
    -24,576~24,576, resolution divider 1~4, PID gains 0~254, realtime tick 0~32,767, goal
    acceleration 0~254 (control_table_goal_acceleration.md), goal torque 0~2,047 (the
    page)."""
    eeprom: list[Row] = [
        ("model_number", 0, 2, "R", number, None, None),
        ("firmware_version", 2, 1, "R", None, None, None),
        ("id", 3, 1, "RW", 1, 0, 253),
        ("baud_rate", 4, 1, "RW", baud, None, None),
        ("return_delay_time", 5, 1, "RW", 250, 0, 254),
        ("cw_angle_limit", 6, 2, "RW", 0, 0, 4095),
        ("ccw_angle_limit", 8, 2, "RW", 4095, 0, 4095),
        ("temperature_limit", 11, 1, "RW", 80, 0, 100),
        ("min_voltage_limit", 12, 1, "RW", 60, 50, volt_max),
        ("max_voltage_limit", 13, 1, "RW", maxv, 50, volt_max),
        ("max_torque", 14, 2, "RW", 1023, 0, 1023),
        ("status_return_level", 16, 1, "RW", 2, 0, 2),
        ("alarm_led", 17, 1, "RW", 36, 0, 127),
        ("shutdown", 18, 1, "RW", 36, 0, 127),
        ("multi_turn_offset", 20, 2, "RW", 0, -24576, 24576),
        ("resolution_divider", 22, 1, "RW", 1, 1, 4),
    ]
    if drive:
        # "Dual Mode Setting": bit 0 reverse, bit 1 master/slave (control_table_drivemode.md)
        eeprom.append(("drive_mode", 10, 1, "RW", 0, 0, 3))
    ram: list[Row] = [
        ("torque_enable", 24, 1, "RW", 0, 0, 1),
        ("led", 25, 1, "RW", 0, 0, 1),
        ("d_gain", 26, 1, "RW", d, 0, 254),
        ("i_gain", 27, 1, "RW", 0, 0, 254),
        ("p_gain", 28, 1, "RW", p, 0, 254),
        ("goal_position", 30, 2, "RW", None, -28672, 28672),
        ("moving_speed", 32, 2, "RW", None, 0, 2047),
        ("torque_limit", 34, 2, "RW", 1023, 0, 1023),       # "Max Torque" / "ADD 14&15"
        ("present_position", 36, 2, "R", None, None, None),
        ("present_speed", 38, 2, "R", None, 0, 2047),
        ("present_load", 40, 2, "R", None, 0, 2047),
        ("present_voltage", 42, 1, "R", None, None, None),
        ("present_temperature", 43, 1, "R", None, None, None),
        ("registered", 44, 1, "R", 0, 0, 1),
        ("moving", 46, 1, "R", 0, 0, 1),
        ("lock", 47, 1, "RW", 0, 0, 1),
        # 0x20 ~ 0x3FF by the description; an initial 0 stays writable (see EX-106+)
        ("punch", 48, 2, "RW", punch, punch, 1023),
        ("realtime_tick", 50, 2, "R", 0, 0, 32767),
        ("goal_acceleration", 73, 1, "RW", 0, 0, 254),
    ]
    if torque:
        ram += [("current", 68, 2, "RW", 0, None, None),    # "Consuming Current", as listed
                ("torque_control_mode_enable", 70, 1, "RW", 0, 0, 1),
                ("goal_torque", 71, 2, "RW", 0, 0, 2047)]
    return {"EEPROM": eeprom, "RAM": ram}


# source: docs/en/dxl/mx/mx-12w.md @05231145 (and @4a527086): baud 1 (1 Mbps), D 8, P 8, punch
# 32. Its table says Model Number 104; servolab has 360: see test_mx12w_model_number.
MX_12W = mx1_table(360, baud=1, maxv=160, volt_max=160, d=8, p=8, punch=32, torque=False,
                   drive=False)
# source: docs/en/dxl/mx/mx-64.md @01179568. The page's initial Max Voltage Limit is 240, above
# the 50 ~ 160 of the control_table_volt_limit.md it includes: servolab takes 50 ~ 250, which
# holds it.
MX_64 = mx1_table(310, baud=34, maxv=240, volt_max=250, d=0, p=32, punch=0, torque=True,
                  drive=False)
# source: docs/en/dxl/mx/mx-106.md @01179568
MX_106 = mx1_table(320, baud=34, maxv=160, volt_max=160, d=0, p=32, punch=0, torque=True,
                   drive=True)


# -- Protocol 2.0: XL-320 -------------------------------------------------------------------

# source: docs/en/dxl/x/xl320.md @05aa1bdf: the table has Min and Max columns
XL_320: Table = {
    "EEPROM": [
        ("model_number", 0, 2, "R", 350, None, None),
        ("firmware_version", 2, 1, "R", None, None, None),
        ("id", 3, 1, "RW", 1, 0, 252),
        ("baud_rate", 4, 1, "RW", 3, 0, 3),
        ("return_delay_time", 5, 1, "RW", 250, 0, 254),
        ("cw_angle_limit", 6, 2, "RW", 0, 0, 1023),
        ("ccw_angle_limit", 8, 2, "RW", 1023, 0, 1023),
        ("control_mode", 11, 1, "RW", 2, 1, 2),
        ("temperature_limit", 12, 1, "RW", 65, 0, 150),
        ("min_voltage_limit", 13, 1, "RW", 60, 50, 250),
        ("max_voltage_limit", 14, 1, "RW", 90, 50, 250),
        ("max_torque", 15, 2, "RW", 1023, 0, 1023),
        ("status_return_level", 17, 1, "RW", 2, 0, 2),
        ("shutdown", 18, 1, "RW", 3, 0, 7),
    ],
    "RAM": [
        ("torque_enable", 24, 1, "RW", 0, 0, 1),
        ("led", 25, 1, "RW", 0, 0, 7),
        ("d_gain", 27, 1, "RW", 0, 0, 254),
        ("i_gain", 28, 1, "RW", 0, 0, 254),
        ("p_gain", 29, 1, "RW", 32, 0, 254),
        ("goal_position", 30, 2, "RW", None, 0, 1023),
        ("moving_speed", 32, 2, "RW", None, 0, 2047),
        ("torque_limit", 35, 2, "RW", None, 0, 1023),
        ("present_position", 37, 2, "R", None, None, None),
        ("present_speed", 39, 2, "R", None, None, None),
        ("present_load", 41, 2, "R", None, None, None),
        ("present_voltage", 45, 1, "R", None, None, None),
        ("present_temperature", 46, 1, "R", None, None, None),
        ("registered_instruction", 47, 1, "R", 0, None, None),
        ("moving", 49, 1, "R", 0, None, None),
        ("hardware_error_status", 50, 1, "R", 0, None, None),
        ("punch", 51, 2, "RW", 32, 0, 1023),
    ],
}



def test_xl320_hardware_error_bits() -> None:
    """The XL-320 numbers its hardware errors otherwise than the X-series: Shutdown(18) (and
    Hardware Error Status(50)) bit 0 overload, bit 1 overheating, bit 2 input voltage
    (xl320.md, Shutdown; its Min/Max Voltage Limit text says 0x10, the Shutdown table
    bit 2). The X-series: bit 0 input voltage, 2 overheating, 3 motor encoder, 4 electrical
    shock, 5 overload (control_table_shutdown.md)."""
    assert model("XL-320").hardware_error_bits() == {
        0x01: "overload", 0x02: "overheating", 0x04: "input voltage"}
    assert model("XM540-W270").hardware_error_bits() == {
        0x01: "input voltage", 0x04: "overheating", 0x08: "motor encoder",
        0x10: "electrical shock", 0x20: "overload"}
    assert model("AX-12A").hardware_error_bits() == {
        0x01: "input voltage", 0x04: "overheating", 0x20: "overload"}


# -- Protocol 2.0: MX(2.0) and X ------------------------------------------------------------

def indirect(first: int, count: int, address: int, data: int, top: int) -> list[Row]:
    """Indirect Address n (initial: Indirect Data n's address, range 64 ~ top) and Indirect
    Data n (0 ~ 255, initial 0); the pages print the first and last three of each block."""
    rows: list[Row] = []
    for k in range(count):
        rows.append((f"indirect_address_{first + k}", address + 2 * k, 2, "RW", data + k, 64,
                     top))
        rows.append((f"indirect_data_{first + k}", data + k, 1, "RW", 0, 0, 255))
    return rows


def x2_table(number: int, *, velocity_limit: int, vel_max: int = 1023,
             current: int | None, temp: int = 80, maxv: int = 160, minv: int = 95,
             volt: tuple[int, int] = (95, 160), baud_max: int = 7, gains: tuple[int, ...],
             drive_max: int = 13, protocol: tuple[int, int] = (1, 2), shutdown: int = 52,
             mx2: bool = False, ports: int = 0, pwm_slope: bool = False,
             indirects: tuple[tuple[int, int, int, int, int], ...] = (
                 (1, 28, 168, 224, 661), (29, 28, 578, 634, 661))) -> Table:
    """The X-series and MX(2.0) control table. ``gains`` are the initial velocity I, P and
    position D, I, P gains. Where a page has a Range column it is the range; the MX(2.0) pages
    have none, and their ranges are those of the descriptions they include, which are the X
    pages' items. servolab's departures, the same on every page:

    - Drive Mode(10): the tables say 0 ~ 5; its description (control_table_drivemode.md) adds
      bit 3, Torque On by Goal Update, from firmware V45, and the X models are emulated at 46:
      0 ~ 13. The MX(2.0) pages keep 0 ~ 5 (0 ~ 7 with the MX-106's dual-mode bit 1).
    - Secondary ID(12): the tables say 0 ~ 252 with an initial 255; the description gives
      253 ~ 255 as "off": 0 ~ 255.
    - Bus Watchdog(98): the tables say 1 ~ 127; the description gives 0 (off, clears the
      error): 0 ~ 127 (and -1, set by the motor itself, is why the register is signed).
    - Goal PWM/Current/Velocity: "-Limit ~ Limit" of a limit register a host may raise: the
      register's own range is the limit's range, mirrored.
    - Goal Position(116): Min ~ Max Position Limit in position mode, -1,048,575 ~ 1,048,575
      in the extended modes (control_table_goal_position_2.md): the register takes both.
    - Shutdown(63): the tables give no range; bits 0 ~ 5 are defined: 0 ~ 63.
    """
    vi, vp, pd, pi, pp = gains
    eeprom: list[Row] = [
        ("model_number", 0, 2, "R", number, None, None),
        ("model_information", 2, 4, "R", None, None, None),
        ("firmware_version", 6, 1, "R", None, None, None),
        ("id", 7, 1, "RW", 1, 0, 252),
        ("baud_rate", 8, 1, "RW", 1, 0, baud_max),
        ("return_delay_time", 9, 1, "RW", 250, 0, 254),
        ("drive_mode", 10, 1, "RW", 0, 0, drive_max),
        ("operating_mode", 11, 1, "RW", 3, 0, 16),
        ("secondary_id", 12, 1, "RW", 255, 0, 255),
        ("protocol_type", 13, 1, "RW", 2, *protocol),
        ("homing_offset", 20, 4, "RW", 0, -1_044_479, 1_044_479),
        ("moving_threshold", 24, 4, "RW", 10, 0, 1023),
        ("temperature_limit", 31, 1, "RW", temp, 0, 100),
        ("max_voltage_limit", 32, 2, "RW", maxv, *volt),
        ("min_voltage_limit", 34, 2, "RW", minv, *volt),
        ("pwm_limit", 36, 2, "RW", 885, 0, 885),
        ("velocity_limit", 44, 4, "RW", velocity_limit, 0, vel_max),
        ("max_position_limit", 48, 4, "RW", 4095, 0, 4095),
        ("min_position_limit", 52, 4, "RW", 0, 0, 4095),
        ("shutdown", 63, 1, "RW", shutdown, 0, 63),
    ]
    if current is not None:
        eeprom.append(("current_limit", 38, 2, "RW", current, 0, current))
    if mx2:
        eeprom.append(("acceleration_limit", 40, 4, "RW", 32767, 0, 32767))  # acclimit.md
    else:
        eeprom.append(("startup_configuration", 60, 1, "RW", 0, 0, 3))       # "3": 2 bits
    eeprom += [(f"external_port_mode_{k + 1}", 56 + k, 1, "RW", 3, 0, 3) for k in range(ports)]
    if pwm_slope:
        eeprom.append(("pwm_slope", 62, 1, "RW", 140, 1, 255))
    ram: list[Row] = [
        ("torque_enable", 64, 1, "RW", 0, 0, 1),
        ("led", 65, 1, "RW", 0, 0, 1),
        ("status_return_level", 68, 1, "RW", 2, 0, 2),
        ("registered_instruction", 69, 1, "R", 0, 0, 1),
        ("hardware_error_status", 70, 1, "R", 0, None, None),
        ("velocity_i_gain", 76, 2, "RW", vi, 0, 16383),
        ("velocity_p_gain", 78, 2, "RW", vp, 0, 16383),
        ("position_d_gain", 80, 2, "RW", pd, 0, 16383),
        ("position_i_gain", 82, 2, "RW", pi, 0, 16383),
        ("position_p_gain", 84, 2, "RW", pp, 0, 16383),
        ("feedforward_2nd_gain", 88, 2, "RW", 0, 0, 16383),
        ("feedforward_1st_gain", 90, 2, "RW", 0, 0, 16383),
        ("bus_watchdog", 98, 1, "RW", 0, 0, 127),
        ("goal_pwm", 100, 2, "RW", None, -885, 885),
        ("goal_velocity", 104, 4, "RW", None, -vel_max, vel_max),
        ("profile_acceleration", 108, 4, "RW", 0, 0, 32767),
        ("profile_velocity", 112, 4, "RW", 0, 0, 32767),
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
    ]
    if current is not None:
        ram += [("goal_current", 102, 2, "RW", None, -current, current),
                ("present_current", 126, 2, "R", None, None, None)]
    else:
        ram.append(("present_load", 126, 2, "R", None, -1000, 1000))
    if not mx2:
        ram.append(("backup_ready", 147, 1, "R", None, 0, 1))
    ram += [(f"external_port_data_{k + 1}", 152 + 2 * k, 2, "RW", None, None, None)
            for k in range(ports)]
    for block in indirects:
        ram += indirect(*block)
    return {"EEPROM": eeprom, "RAM": ram}


# source: docs/en/dxl/mx/mx-28-2.md @203f49b5 (no Range column). Velocity Limit 230 (the
# older @07fe860b said 380); no Current Limit: Present Load at 126.
MX_28_2 = x2_table(30, velocity_limit=230, current=None, gains=(1920, 100, 0, 0, 850),
                   drive_max=5, mx2=True)
# source: docs/en/dxl/mx/mx-64-2.md @1b03e234 and @07a99125 (no Range column): Current Limit
# 1,941 (3.36 mA), Velocity Limit 435
MX_64_2 = x2_table(311, velocity_limit=435, current=1941, gains=(1920, 100, 0, 0, 850),
                   drive_max=5, mx2=True)
# source: docs/en/dxl/mx/mx-106-2.md @79c049e3 and @07fe860b (no Range column): Current Limit
# 2,047, Velocity Limit 360; Drive Mode bit 1 dual mode (control_table_dual_drivemode.md)
MX_106_2 = x2_table(321, velocity_limit=360, current=2047, gains=(1920, 100, 0, 0, 850),
                    drive_max=7, mx2=True)
# source: docs/en/dxl/x/xh430-w350.md @028a13d2: Current Limit 648 (2.69 mA), Velocity Limit
# 130, Position P Gain 900
XH430_W350 = x2_table(1000, velocity_limit=130, current=648, gains=(1920, 100, 0, 0, 900))
# source: docs/en/dxl/x/xm540-w270.md @028a13d2: Current Limit 2,047, Velocity Limit 128,
# External Port Mode/Data 1 ~ 3 (56 ~ 58, 152 ~ 156)
XM540_W270 = x2_table(1120, velocity_limit=128, current=2047, gains=(1920, 100, 0, 0, 800),
                      ports=3)
# source: docs/en/dxl/x/xh540-w270.md @01ba9719: as the XM540-W270 but Velocity Limit 167
XH540_W270 = x2_table(1100, velocity_limit=167, current=2047, gains=(1920, 100, 0, 0, 800),
                      ports=3)
# source: docs/en/dxl/x/xl330-m288.md @028a13d2: baud 0 ~ 6, Protocol Type 2 ~ 22, temperature
# 70, voltage 31 ~ 70 (initial 70 and 35), Current Limit 1,750 (1 mA), Velocity Limit 445 of
# 0 ~ 2,047, PWM Slope(62), Shutdown 53, twenty indirect addresses (168 ~ 206, data 208 ~ 227,
# addresses 64 ~ 227)
XL330_M288 = x2_table(1200, velocity_limit=445, vel_max=2047, current=1750, temp=70, maxv=70,
                      minv=35, volt=(31, 70), baud_max=6, gains=(1600, 180, 0, 0, 400),
                      protocol=(2, 22), shutdown=53, pwm_slope=True,
                      indirects=((1, 20, 168, 208, 227),))
# source: docs/en/dxl/x/xc330-m288.md @09317be1: as the XL330 page but Current Limit 2,352,
# Velocity Limit 350, Shutdown 52, gains 1,600 / 50 / 500 / 0 / 1,100. The page prints 0 ~ 225
# for Indirect Data 19 and 20 and 0 ~ 255 for the other eighteen: a byte, 0 ~ 255.
XC330_M288 = x2_table(1240, velocity_limit=350, vel_max=2047, current=2352, temp=70, maxv=70,
                      minv=35, volt=(31, 70), baud_max=6, gains=(1600, 50, 500, 0, 1100),
                      protocol=(2, 22), pwm_slope=True, indirects=((1, 20, 168, 208, 227),))

TABLES: dict[str, Table] = {
    "AX-12A": AX_12A, "AX-12W": AX_12W, "AX-18A": AX_18A, "RX-24F": RX_24F, "RX-64": RX_64,
    "MX-12W": MX_12W, "MX-64": MX_64, "MX-106": MX_106,
    "MX-28(2.0)": MX_28_2, "MX-64(2.0)": MX_64_2, "MX-106(2.0)": MX_106_2, "XL-320": XL_320,
    "XL330-M288": XL330_M288, "XC330-M288": XC330_M288, "XH430-W350": XH430_W350,
    "XM540-W270": XM540_W270, "XH540-W270": XH540_W270,
}

CASES = [pytest.param(name, area, row, id=f"{name}-{row[0]}")
         for name, table in TABLES.items() for area, rows in table.items() for row in rows]


@pytest.mark.parametrize(("name", "area", "row"), CASES)
def test_register_matches_emanual(name: str, area: str, row: Row) -> None:
    """Address, size, area, access, initial value and range of one item, as the page gives
    them: a wrong one is a write to the wrong place, or a value the motor refuses."""
    check_row(name, area, row)


@pytest.mark.parametrize("name", TABLES)
def test_no_register_beyond_emanual(name: str) -> None:
    """The model file has no register the page does not list, and lists none twice."""
    check_no_invented_register(name, TABLES[name])


def test_mx12w_model_number() -> None:
    """The MX-12W page's table says 104; an MX-12W reports 360 (0x0168: 104 is its low byte).
    ROBOTIS agreed (ROBOTIS-GIT/emanual issue #684, "Please modified model number of MX-12W
    from 104 to 360"; dynamixel-workbench issue #226) and its libraries use 360
    (dynamixel-workbench dynamixel_item.h MX_12W, Dynamixel2Arduino actuator.h MX12W)."""
    assert model("MX-12W").number == 360 == 104 + 256


# -- physical figures ------------------------------------------------------------------------

# (model, no-load rpm, at volts, stall torque N·m, stall current A, ticks, angle range in
# degrees, degrees a tick, rpm a speed unit, A a current unit). Sources: the pages'
# Specifications; for the MX and X models the _data/dxl_mx_info.yml (@0ba8ce08) and
# _data/dxl_x_info.yml (@00280385) entries the pages include (the bold, recommended-voltage
# figure); the speed and current units from the control tables and descriptions.
PHYSICAL = [
    # ax-12a.md: 59rpm (at 12V); 1.5 N*m (at 12V, 1.5A); 0.29°, 0° ~ 300°
    ("AX-12A", 59.0, 12.0, 1.5, 1.5, 1024, 300.0, 0.29, 0.111, 0.0),
    # ax-12w.md: 54rpm (at 12.0V, Joint Mode), 470rpm in Wheel Mode; no stall torque given
    ("AX-12W", 54.0, 12.0, 0.0, 0.0, 1024, 300.0, 0.29, 0.111, 0.0),
    # ax-18a.md: 97rpm (at 12V); 1.8 N*m (at 12V, 2.2A)
    ("AX-18A", 97.0, 12.0, 1.8, 2.2, 1024, 300.0, 0.29, 0.111, 0.0),
    # rx-24f.md: 126rpm (at 12V); 2.6 N*m (at 12V, 2.4A)
    ("RX-24F", 126.0, 12.0, 2.6, 2.4, 1024, 300.0, 0.29, 0.111, 0.0),
    # rx-28.md: 85rpm (at 18.5V); 3.7 N*m (at 18.5V, 1.9A)
    ("RX-28", 85.0, 18.5, 3.7, 1.9, 1024, 300.0, 0.29, 0.111, 0.0),
    # rx-64.md: 64rpm (at 18.5V); 5.3 N*m (at 18.5V, 2.6A)
    ("RX-64", 64.0, 18.5, 5.3, 2.6, 1024, 300.0, 0.29, 0.111, 0.0),
    # ex-106+.md: 91rpm (at 18.5V); 10.9 N*m (at 18.5V, 7A); 0.06°, 0° ~ 251°
    ("EX-106+", 91.0, 18.5, 10.9, 7.0, 4096, 251.0, 0.06, 0.111, 0.0),
    # mx-12w.md: 470rpm (at 12V); no stall torque given; 0.916 rpm a unit (Moving Speed)
    ("MX-12W", 470.0, 12.0, 0.0, 0.0, 4096, 360.0, 0.088, 0.916, 0.0),
    # dxl_mx_info.yml mx-28: 55 rev/min @ 12 V; 2.5 Nm @ 12 V, 1.4 A
    ("MX-28", 55.0, 12.0, 2.5, 1.4, 4096, 360.0, 0.088, 0.114, 0.0),
    # mx-64: 63 rev/min @ 12 V; 6.0 Nm @ 12 V, 4.1 A
    ("MX-64", 63.0, 12.0, 6.0, 4.1, 4096, 360.0, 0.088, 0.114, 0.0),
    # mx-106: 45 rev/min @ 12 V; 8.4 Nm @ 12 V, 5.2 A
    ("MX-106", 45.0, 12.0, 8.4, 5.2, 4096, 360.0, 0.088, 0.114, 0.0),
    ("MX-28(2.0)", 55.0, 12.0, 2.5, 1.4, 4096, 360.0, 0.088, 0.229, 0.0),
    # mx-64-2.md / mx-106-2.md: Current Limit "about 3.36[mA]"
    ("MX-64(2.0)", 63.0, 12.0, 6.0, 4.1, 4096, 360.0, 0.088, 0.229, 0.00336),
    ("MX-106(2.0)", 45.0, 12.0, 8.4, 5.2, 4096, 360.0, 0.088, 0.229, 0.00336),
    # xl320.md: 114rpm @ 7.4V, 0.18A; 0.39Nm @ 7.4V, 1.1A; 0.29°, 0 ~ 300°
    ("XL-320", 114.0, 7.4, 0.39, 1.1, 1024, 300.0, 0.29, 0.111, 0.0),
    # dxl_x_info.yml xl330-m288: 103 rev/min (at 5.0 V); 0.52 N.m (at 5.0 V, 1.47 A); 1 mA
    ("XL330-M288", 103.0, 5.0, 0.52, 1.47, 4096, 360.0, 0.088, 0.229, 0.001),
    # xc330-m288: 81 rev/min (at 5.0 V); 0.93 N.m (at 5.0 V, 1.80 A); 1.0 mA
    ("XC330-M288", 81.0, 5.0, 0.93, 1.80, 4096, 360.0, 0.088, 0.229, 0.001),
    # xl430-w250: 57 rev/min (at 11.1 V); 1.4 N.m (at 11.1 V, 1.3 A); no current sensor
    ("XL430-W250", 57.0, 11.1, 1.4, 1.3, 4096, 360.0, 0.088, 0.229, 0.0),
    # xm430-w210: 77 rev/min, 3.0 N.m, 2.3 A (at 12.0 V); 2.69 mA
    ("XM430-W210", 77.0, 12.0, 3.0, 2.3, 4096, 360.0, 0.088, 0.229, 0.00269),
    # xm430-w350: 46 rev/min, 4.1 N.m, 2.3 A (at 12.0 V)
    ("XM430-W350", 46.0, 12.0, 4.1, 2.3, 4096, 360.0, 0.088, 0.229, 0.00269),
    # xh430-w350: 30 rev/min, 3.4 N.m, 1.3 A (at 12.0 V); 2.69 mA (xh430-w350.md)
    ("XH430-W350", 30.0, 12.0, 3.4, 1.3, 4096, 360.0, 0.088, 0.229, 0.00269),
    # xm540-w270: 30 rev/min, 10.6 N.m, 4.4 A (at 12.0 V); 2.69 mA
    ("XM540-W270", 30.0, 12.0, 10.6, 4.4, 4096, 360.0, 0.088, 0.229, 0.00269),
    # xh540-w270: 39 rev/min, 9.9 N.m, 4.9 A (at 12.0 V); 2.69 mA
    ("XH540-W270", 39.0, 12.0, 9.9, 4.9, 4096, 360.0, 0.088, 0.229, 0.00269),
]


@pytest.mark.parametrize(("name", "rpm", "volts", "torque", "amps", "ticks", "degrees",
                          "per_tick", "rpm_unit", "amp_unit"), PHYSICAL,
                         ids=[p[0] for p in PHYSICAL])
def test_physical_figures(name: str, rpm: float, volts: float, torque: float, amps: float,
                          ticks: int, degrees: float, per_tick: float, rpm_unit: float,
                          amp_unit: float) -> None:
    """No-load speed at the voltage the page rates it at (the emulated supply), stall torque
    and current there, resolution, angle range and the units of speed and current."""
    m = model(name)
    assert (m.no_load_speed_rpm, m.nominal_voltage) == (rpm, volts)
    assert (m.stall_torque_nm, m.stall_current_a) == (torque, amps)
    assert m.resolution == ticks
    assert m.angle_range_deg == pytest.approx(degrees, abs=0.1)   # EX-106+: 250.92°
    assert math.degrees(m.rad_per_tick) == pytest.approx(per_tick, rel=0.025)
    assert (m.speed_unit_rpm, m.current_unit_a) == (rpm_unit, amp_unit)


def test_every_model_has_physical_figures() -> None:
    from servolab.dynamixel import MODELS

    assert {p[0] for p in PHYSICAL} == set(MODELS)
