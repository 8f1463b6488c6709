"""Control tables checked against the ROBOTIS e-Manual.

Every driver, emulator and CLI address comes from these tables, so a wrong number here is a
write to the wrong register on a real motor. The expected figures below are typed in from the
e-Manual pages of each model (the row-by-row checks are test_tables_emanual.py and
test_model_emanual_tables.py), not read back from the tables under test.
"""

from __future__ import annotations

import itertools

import pytest

from servolab.dynamixel import MODELS, ConfigError, model, model_by_number
from servolab.dynamixel.models import Model

# e-Manual: the model number each servo reports at address 0 (and in a 2.0 PING).
MODEL_NUMBERS = {
    "AX-12A": 12, "AX-12W": 300, "AX-18A": 18,
    "RX-24F": 24, "RX-28": 28, "RX-64": 64, "EX-106+": 107,
    "MX-12W": 360,   # the page says 104, its low byte: test_model_emanual_tables.py
    "MX-28": 29, "MX-64": 310, "MX-106": 320,
    "MX-28(2.0)": 30, "MX-64(2.0)": 311, "MX-106(2.0)": 321,
    "XL-320": 350,
    "XL330-M288": 1200, "XC330-M288": 1240,
    "XL430-W250": 1060, "XM430-W210": 1030, "XM430-W350": 1020, "XH430-W350": 1000,
    "XM540-W270": 1120, "XH540-W270": 1100,
}
AX_RX_EX = ["AX-12A", "AX-12W", "AX-18A", "RX-24F", "RX-28", "RX-64", "EX-106+"]
MX1 = ["MX-12W", "MX-28", "MX-64", "MX-106"]
PROTOCOL1_MODELS = AX_RX_EX + MX1
MX2 = ["MX-28(2.0)", "MX-64(2.0)", "MX-106(2.0)"]
X330 = ["XL330-M288", "XC330-M288"]
X_MODELS = ["XL430-W250", "XM430-W210", "XM430-W350", "XH430-W350", "XM540-W270",
            "XH540-W270", *X330]
#: Protocol 2.0 models with the X-series control table layout
X_LAYOUT = X_MODELS + MX2
#: factory baud register value of the 1.0 models (e-Manual): 1 Mbps (1) or 57 142 bps (34)
PROTOCOL1_BAUD = {"AX-12A": 1, "AX-12W": 1, "AX-18A": 1, "MX-12W": 1, "RX-24F": 34,
                  "RX-28": 34, "RX-64": 34, "EX-106+": 34, "MX-28": 34, "MX-64": 34,
                  "MX-106": 34}

# e-Manual, Protocol 1.0 control table (AX/RX/EX/MX share it): name -> (address, size, access)
PROTOCOL1_ADDRESSES = {
    "model_number": (0, 2, "R"),
    "id": (3, 1, "RW"),
    "baud_rate": (4, 1, "RW"),
    "return_delay_time": (5, 1, "RW"),
    "cw_angle_limit": (6, 2, "RW"),
    "ccw_angle_limit": (8, 2, "RW"),
    "status_return_level": (16, 1, "RW"),
    "torque_enable": (24, 1, "RW"),
    "led": (25, 1, "RW"),
    "goal_position": (30, 2, "RW"),
    "moving_speed": (32, 2, "RW"),
    "torque_limit": (34, 2, "RW"),
    "present_position": (36, 2, "R"),
    "present_speed": (38, 2, "R"),
    "present_load": (40, 2, "R"),
    "present_voltage": (42, 1, "R"),
    "present_temperature": (43, 1, "R"),
    "registered": (44, 1, "R"),
    "moving": (46, 1, "R"),
}

# e-Manual, X-series (Protocol 2.0) control table: name -> (address, size, access)
X_ADDRESSES = {
    "model_number": (0, 2, "R"),
    "id": (7, 1, "RW"),
    "baud_rate": (8, 1, "RW"),
    "return_delay_time": (9, 1, "RW"),
    "operating_mode": (11, 1, "RW"),
    "velocity_limit": (44, 4, "RW"),
    "max_position_limit": (48, 4, "RW"),
    "min_position_limit": (52, 4, "RW"),
    "torque_enable": (64, 1, "RW"),
    "led": (65, 1, "RW"),
    "status_return_level": (68, 1, "RW"),
    "hardware_error_status": (70, 1, "R"),
    "goal_velocity": (104, 4, "RW"),
    "profile_acceleration": (108, 4, "RW"),
    "profile_velocity": (112, 4, "RW"),
    "goal_position": (116, 4, "RW"),
    "present_velocity": (128, 4, "R"),
    "present_position": (132, 4, "R"),
    "present_input_voltage": (144, 2, "R"),
    "present_temperature": (146, 1, "R"),
}


def test_every_shipped_model_is_known() -> None:
    """The emulator, the CLI and `scan` enumerate MODELS; a missing model is a motor servolab
    cannot name."""
    assert set(MODELS) == set(MODEL_NUMBERS)
    assert set(MODEL_NUMBERS) == set(PROTOCOL1_MODELS) | set(X_LAYOUT) | {"XL-320"}


@pytest.mark.parametrize(("name", "number"), sorted(MODEL_NUMBERS.items()))
def test_model_number(name: str, number: int) -> None:
    """`scan` identifies a motor only by the number it reports; a wrong number makes a real
    motor 'unknown' or, worse, another model with another control table."""
    m = model(name)
    assert m.number == number
    assert model_by_number(number) is m
    reg = m.register("model_number")
    assert (reg.address, reg.size, reg.default) == (0, 2, number)


def test_unknown_model_number_is_none() -> None:
    """An unknown motor on the bus must come back as 'unknown', not as some other model."""
    assert model_by_number(9999) is None


@pytest.mark.parametrize("name", PROTOCOL1_MODELS)
def test_protocol1_models_speak_protocol1(name: str) -> None:
    """A 1.0 motor addressed with 2.0 packets (or the reverse) never answers."""
    assert model(name).protocol == 1


@pytest.mark.parametrize("name", [*X_LAYOUT, "XL-320"])
def test_x_models_speak_protocol2(name: str) -> None:
    """X-series servos ship with Protocol 2.0, and so do an MX's 2.0 firmware and the XL-320."""
    assert model(name).protocol == 2


@pytest.mark.parametrize(("name", "register"),
                         [(n, r) for n in PROTOCOL1_MODELS for r in PROTOCOL1_ADDRESSES])
def test_protocol1_addresses(name: str, register: str) -> None:
    """Addresses, sizes and access of the 1.0 control table as the e-Manual gives them."""
    reg = model(name).register(register)
    assert (reg.address, reg.size, reg.access) == PROTOCOL1_ADDRESSES[register]


@pytest.mark.parametrize(("name", "register"),
                         [(n, r) for n in X_LAYOUT for r in X_ADDRESSES])
def test_x_series_addresses(name: str, register: str) -> None:
    """Addresses, sizes and access of the X-series control table as the e-Manual gives
    them."""
    reg = model(name).register(register)
    assert (reg.address, reg.size, reg.access) == X_ADDRESSES[register]


@pytest.mark.parametrize(("name", "amps"), [
    ("XM430-W210", 0.00269), ("XM430-W350", 0.00269), ("XH430-W350", 0.00269),
    ("XM540-W270", 0.00269), ("XH540-W270", 0.00269), ("XL330-M288", 0.001),
    ("XC330-M288", 0.001), ("MX-64(2.0)", 0.00336), ("MX-106(2.0)", 0.00336)])
def test_current_sensing_models_have_present_current_at_126(name: str, amps: float) -> None:
    """These measure current at 126 (2 bytes, in the page's unit: 2.69 mA, 1 mA or 3.36 mA),
    not load."""
    m = model(name)
    reg = m.register("present_current")
    assert (reg.address, reg.size, reg.access, reg.signed) == (126, 2, "R", True)
    assert not m.has("present_load")
    assert m.register("goal_current").address == 102
    assert m.register("current_limit").address == 38
    assert m.current_unit_a == amps


@pytest.mark.parametrize("name", ["XL430-W250", "MX-28(2.0)"])
def test_load_sensing_models_have_present_load_at_126(name: str) -> None:
    """XL430 and MX-28(2.0) have no current sensor: 126 is Present Load (0.1 %), and there is
    no goal current or current limit to write."""
    m = model(name)
    reg = m.register("present_load")
    assert (reg.address, reg.size, reg.access, reg.signed) == (126, 2, "R", True)
    assert not m.has("present_current")
    assert not m.has("goal_current")


@pytest.mark.parametrize("name", sorted(MODEL_NUMBERS))
def test_no_two_registers_overlap(name: str) -> None:
    """Overlapping rows would make one WRITE change two registers, and a contiguous READ
    decode garbage."""
    regs = sorted(model(name).registers, key=lambda r: r.address)
    assert len({r.name for r in regs}) == len(regs)
    for a, b in itertools.pairwise(regs):
        assert a.address + a.size <= b.address, f"{a.name} overlaps {b.name}"


@pytest.mark.parametrize("name", sorted(MODEL_NUMBERS))
def test_eeprom_lies_below_ram(name: str) -> None:
    """Every Dynamixel keeps EEPROM (persistent settings) in the low addresses and RAM above;
    the 2.0 emulator locks EEPROM while torque is on by this area flag."""
    regs = model(name).registers
    eeprom = [r.address + r.size for r in regs if r.area == "EEPROM"]
    ram = [r.address for r in regs if r.area == "RAM"]
    assert eeprom and ram
    assert max(eeprom) <= min(ram)
    expected_ram_start = 64 if name in X_LAYOUT else 24   # XL-320: the AX layout
    assert min(ram) == expected_ram_start


@pytest.mark.parametrize("name", sorted(MODEL_NUMBERS))
def test_defaults_are_within_ranges(name: str) -> None:
    """The emulator loads these defaults into its control table; one outside its own range
    would make a factory-fresh motor reject a write-back of its own value."""
    for reg in model(name).registers:
        if reg.default is not None:
            assert reg.raw_min <= reg.default <= reg.raw_max, reg.name


@pytest.mark.parametrize("name", PROTOCOL1_MODELS)
def test_protocol1_factory_defaults(name: str) -> None:
    """e-Manual factory values: ID 1, baud register 34 (57 142 bps) or, on the AX and the
    MX-12W, 1 (1 Mbps), return delay 250 (500 µs), status return level 2, torque off."""
    m = model(name)
    assert m.register("id").default == 1
    assert m.register("baud_rate").default == PROTOCOL1_BAUD[name]
    assert m.register("return_delay_time").default == 250
    assert m.register("status_return_level").default == 2
    assert m.register("torque_enable").default == 0


def test_xl320_factory_defaults() -> None:
    """e-Manual XL-320: ID 1, baud register 3 (1 Mbps), return delay 250, joint mode
    (control_mode 2), status return level 2, torque off."""
    m = model("XL-320")
    defaults = {n: m.register(n).default for n in (
        "id", "baud_rate", "return_delay_time", "control_mode", "status_return_level",
        "torque_enable")}
    assert defaults == {"id": 1, "baud_rate": 3, "return_delay_time": 250, "control_mode": 2,
                        "status_return_level": 2, "torque_enable": 0}
    assert m.baud_from_register(3) == 1_000_000


@pytest.mark.parametrize("name", X_LAYOUT)
def test_x_series_factory_defaults(name: str) -> None:
    """e-Manual factory values: ID 1, baud register 1 (57 600 bps), return delay 250,
    position control mode (3), status return level 2, torque off."""
    m = model(name)
    assert m.register("id").default == 1
    assert m.register("baud_rate").default == 1
    assert m.register("return_delay_time").default == 250
    assert m.register("operating_mode").default == 3
    assert m.register("status_return_level").default == 2
    assert m.register("torque_enable").default == 0


@pytest.mark.parametrize(("name", "rpm", "volts"), [
    ("AX-12A", 59.0, 12.0), ("AX-12W", 54.0, 12.0), ("AX-18A", 97.0, 12.0),
    ("RX-24F", 126.0, 12.0), ("RX-28", 85.0, 18.5), ("RX-64", 64.0, 18.5),
    ("EX-106+", 91.0, 18.5), ("MX-12W", 470.0, 12.0),
    ("MX-28", 55.0, 12.0), ("MX-64", 63.0, 12.0), ("MX-106", 45.0, 12.0),
    ("MX-28(2.0)", 55.0, 12.0), ("MX-64(2.0)", 63.0, 12.0), ("MX-106(2.0)", 45.0, 12.0),
    ("XL-320", 114.0, 7.4), ("XL330-M288", 103.0, 5.0), ("XC330-M288", 81.0, 5.0),
    ("XL430-W250", 57.0, 11.1),  # e-Manual: 57 rpm at the recommended 11.1 V
    ("XM430-W210", 77.0, 12.0), ("XM430-W350", 46.0, 12.0), ("XH430-W350", 30.0, 12.0),
    ("XM540-W270", 30.0, 12.0), ("XH540-W270", 39.0, 12.0),
])
def test_no_load_speed_matches_emanual(name: str, rpm: float, volts: float) -> None:
    """The emulator moves at this speed when told 'as fast as you can'; it must be the
    e-Manual's no-load speed at the model's nominal voltage."""
    m = model(name)
    assert m.nominal_voltage == volts
    assert m.no_load_speed_rpm == pytest.approx(rpm, rel=0.01)


@pytest.mark.parametrize(("name", "per_unit"), [
    *((n, 0.111) for n in AX_RX_EX), ("XL-320", 0.111), ("MX-12W", 0.916),
    ("MX-28", 0.114), ("MX-64", 0.114), ("MX-106", 0.114), *((n, 0.229) for n in X_LAYOUT),
])
def test_speed_unit(name: str, per_unit: float) -> None:
    """rpm per unit of moving speed / goal velocity, from the e-Manual."""
    assert model(name).speed_unit_rpm == per_unit


# -- baud rate register ------------------------------------------------------------------------

@pytest.mark.parametrize("name", PROTOCOL1_MODELS)
@pytest.mark.parametrize(("value", "bps"), [
    (1, 1_000_000), (3, 500_000), (16, 117_647), (34, 57_142), (103, 19_230), (207, 9_615),
])
def test_protocol1_baud_formula(name: str, value: int, bps: int) -> None:
    """1.0: bps = 2 000 000 / (value + 1), truncated as the e-Manual's table lists it
    (34 -> 57 142). A wrong rate makes the driver deaf to the motor."""
    assert model(name).baud_from_register(value) == bps


@pytest.mark.parametrize("name", MX1)
@pytest.mark.parametrize(("value", "bps"), [(250, 2_250_000), (251, 2_500_000),
                                            (252, 3_000_000)])
def test_mx_high_baud_rates(name: str, value: int, bps: int) -> None:
    """The MX (1.0) have three special register values above 1 Mbps ("For BPS over 250
    values"); the AX/RX/EX do not."""
    assert model(name).baud_from_register(value) == bps
    assert model("RX-28").baud_from_register(value) == 2_000_000 // (value + 1)


@pytest.mark.parametrize("name", X_LAYOUT)
@pytest.mark.parametrize(("value", "bps"), [
    (0, 9_600), (1, 57_600), (2, 115_200), (3, 1_000_000), (4, 2_000_000), (5, 3_000_000),
    (6, 4_000_000), (7, 4_500_000),
])
def test_x_series_baud_table(name: str, value: int, bps: int) -> None:
    """X-series and MX(2.0): the baud register is an index into a fixed table (e-Manual,
    control_table_baudrate_2.md); the XL330 and XC330 stop at 6 (4 Mbps)."""
    if name in X330 and value == 7:
        with pytest.raises(ConfigError, match=r"\b7\b"):
            model(name).baud_from_register(value)
        assert model(name).register("baud_rate").raw_max == 6
    else:
        assert model(name).baud_from_register(value) == bps


@pytest.mark.parametrize(("value", "bps"), [(0, 9_600), (1, 57_600), (2, 115_200),
                                            (3, 1_000_000)])
def test_xl320_baud_table(value: int, bps: int) -> None:
    """XL-320: four rates, 1 Mbps the factory's (e-Manual XL-320, Baud Rate)."""
    assert model("XL-320").baud_from_register(value) == bps
    assert model("XL-320").baud_rates == [9_600, 57_600, 115_200, 1_000_000]


def test_x_series_undefined_baud_value_is_config_error() -> None:
    """Register value 8 selects no rate on an X servo; the message names the value."""
    with pytest.raises(ConfigError, match=r"\b8\b"):
        model("XM430-W210").baud_from_register(8)


def test_baud_register_for_57600_on_rx28_is_34() -> None:
    """57 600 is not a 1.0 rate, but 34 (57 142 bps) is within the UART's 3 % tolerance:
    this is what lets a 57 600 adapter talk to a factory-fresh RX-28."""
    m = model("RX-28")
    value = m.baud_register_for(57_600)
    assert value == 34
    assert abs(2_000_000 / (value + 1) - 57_600) <= 0.03 * 57_600


@pytest.mark.parametrize(("name", "bps", "value"), [
    ("RX-28", 1_000_000, 1), ("RX-28", 500_000, 3), ("EX-106+", 57_142, 34),
    ("XM430-W210", 1_000_000, 3), ("XL430-W250", 57_600, 1), ("XM430-W350", 57_142, 1),
])
def test_baud_register_for(name: str, bps: int, value: int) -> None:
    """The inverse of the baud formula, used to set a motor's rate from bps."""
    assert model(name).baud_register_for(bps) == value


@pytest.mark.parametrize(("name", "bps"), [("RX-28", 300), ("XM430-W210", 250_000)])
def test_baud_register_for_unreachable_rate(name: str, bps: int) -> None:
    """A rate no register value reaches within 3 % is refused, naming the rate."""
    with pytest.raises(ConfigError, match=str(bps)):
        model(name).baud_register_for(bps)


# -- lookup ------------------------------------------------------------------------------------

@pytest.mark.parametrize(("text", "name"), [
    ("rx28", "RX-28"), ("RX-28", "RX-28"), ("Rx_28", "RX-28"), ("rx 28", "RX-28"),
    ("ex106+", "EX-106+"), ("EX-106+", "EX-106+"), ("ex106plus", "EX-106+"),
    ("mx28", "MX-28"), ("MX_28", "MX-28"),
    ("xm430-w210", "XM430-W210"), ("XM430W210", "XM430-W210"), ("xm430_w350", "XM430-W350"),
    ("xl430-w250", "XL430-W250"), ("XL430w250", "XL430-W250"),
    ("ax12a", "AX-12A"), ("AX-18A", "AX-18A"), ("rx24f", "RX-24F"), ("mx-12w", "MX-12W"),
    ("mx28(2.0)", "MX-28(2.0)"), ("MX-28(2.0)", "MX-28(2.0)"), ("mx-28-2", "MX-28(2.0)"),
    ("MX_64_2.0", "MX-64(2.0)"), ("mx106 2", "MX-106(2.0)"), ("mx-106(2)", "MX-106(2.0)"),
    ("mx106", "MX-106"), ("xl320", "XL-320"), ("XL-320", "XL-320"),
    ("xl330-m288", "XL330-M288"), ("xc330m288", "XC330-M288"), ("xh430-w350", "XH430-W350"),
    ("xm540-w270", "XM540-W270"), ("XH540_W270", "XH540-W270"),
])
def test_lookup_forgives_case_and_separators(text: str, name: str) -> None:
    """Users type model names on the command line in every spelling."""
    m = model(text)
    assert isinstance(m, Model)
    assert m.name == name


@pytest.mark.parametrize("text", ["rx99", "ax12", "xm430", "", "rx-28x"])
def test_lookup_rejects_unknown_names(text: str) -> None:
    """An unknown name is a ConfigError whose one-line message names it (and the known ones),
    never a silent fallback to some other model."""
    with pytest.raises(ConfigError) as info:
        model(text)
    message = str(info.value)
    assert repr(text) in message
    assert "RX-28" in message
    assert "\n" not in message


def test_lookup_suggests_the_closest_name() -> None:
    """A near miss says which model was likely meant."""
    with pytest.raises(ConfigError, match=r"did you mean 'XM430-W350'\?"):
        model("xm430-w530")


def test_unknown_register_is_config_error_naming_it() -> None:
    """A typo in a register name must be reported by name, before anything is sent."""
    with pytest.raises(ConfigError, match="goal_postion"):
        model("RX-28").register("goal_postion")
    # An X-series name on a 1.0 motor is unknown too.
    with pytest.raises(ConfigError, match="goal_velocity"):
        model("RX-28").register("goal_velocity")


def test_span_is_the_smallest_contiguous_block() -> None:
    """`span` decides what one READ covers; present position..present temperature on a 1.0
    motor is 36..43, i.e. 8 bytes."""
    m = model("RX-28")
    assert m.span(["present_temperature", "present_position"]) == (36, 8)
    assert m.span(["goal_position"]) == (30, 2)
    x = model("XM430-W210")
    assert x.span(["present_velocity", "present_position"]) == (128, 8)
