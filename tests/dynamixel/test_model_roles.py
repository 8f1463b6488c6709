"""Registers by role (:data:`servolab.dynamixel.models.ROLES`, :meth:`Model.role`): which
register of each control-table family plays each role the dynamixel_motor controllers ask for.

Each expected address is typed from the model's ROBOTIS e-Manual page (the markdown sources of
ROBOTIS-GIT/emanual), never read back from the tables under test:

- docs/en/dxl/rx/rx-28.md (Protocol 1.0, AX/RX/EX family): Torque Enable(24), CW/CCW
  Compliance Margin(26, 27), CW/CCW Compliance Slope(28, 29), Goal Position(30), Moving
  Speed(32), Torque Limit(34), Present Position(36), Present Speed(38), Present Load(40),
  Present Voltage(42), Present Temperature(43), Moving(46), Punch(48);
- docs/en/dxl/mx/mx-28.md (Protocol 1.0 MX): D Gain(26), I Gain(27), P Gain(28) where the RX
  has compliance; the rest as the RX-28;
- docs/en/dxl/x/xl320.md: Torque Enable(24), D/I/P Gain(27, 28, 29), Goal Position(30),
  Moving Speed(32), Torque Limit(35), Present Position(37), Present Speed(39), Present
  Load(41), Present Voltage(45), Present Temperature(46), Moving(49), Punch(51);
- docs/en/dxl/x/xm430-w350.md (Protocol 2.0 X-series): Current Limit(38), Torque Enable(64),
  Position D/I/P Gain(80, 82, 84), Goal PWM(100), Profile Velocity(112), Goal
  Position(116), Moving(122), Present Current(126), Present Velocity(128), Present
  Position(132), Present Input Voltage(144), Present Temperature(146);
- docs/en/dxl/x/xl430-w250.md: as the XM430 but Present Load(126) (0.1 %) for Present Current,
  and no Current Limit.
- _includes/en/dxl/control_table_goal_pwm.md: Goal PWM limits the PWM "in other control modes"
  than PWM control; control_table_goal_current.md: Goal Current limits current only "in
  Current-based Position Control mode" -- hence Goal PWM plays the torque limit on 2.0.
"""

from __future__ import annotations

import pytest

from servolab.dynamixel import MODELS, model
from servolab.dynamixel.errors import ConfigError
from servolab.dynamixel.models import ROLES

P1_STATE = {"goal_position": 30, "moving_speed": 32, "torque_limit": 34,
            "present_position": 36, "present_speed": 38, "present_load": 40,
            "present_voltage": 42, "present_temperature": 43, "moving": 46,
            "torque_enable": 24, "punch": 48}
X_STATE = {"torque_enable": 64, "torque_limit": 100, "moving_speed": 112, "goal_position": 116,
           "moving": 122, "present_load": 126, "present_speed": 128, "present_position": 132,
           "present_voltage": 144, "present_temperature": 146, "d_gain": 80, "i_gain": 82,
           "p_gain": 84}
EXPECTED: dict[str, dict[str, int]] = {
    "RX-28": {**P1_STATE, "cw_compliance_margin": 26, "ccw_compliance_margin": 27,
              "cw_compliance_slope": 28, "ccw_compliance_slope": 29},
    "MX-28": {**P1_STATE, "d_gain": 26, "i_gain": 27, "p_gain": 28},
    "XL-320": {"torque_enable": 24, "d_gain": 27, "i_gain": 28, "p_gain": 29,
               "goal_position": 30, "moving_speed": 32, "torque_limit": 35,
               "present_position": 37, "present_speed": 39, "present_load": 41,
               "present_voltage": 45, "present_temperature": 46, "moving": 49, "punch": 51},
    "XM430-W350": {**X_STATE, "current_limit": 38},
    "XL430-W250": X_STATE,
}
#: The register names the X-series gives the 1.0 roles (e-Manual item names in snake case).
X_NAMES = {"moving_speed": "profile_velocity", "present_speed": "present_velocity",
           "present_load": "present_current", "present_voltage": "present_input_voltage",
           "torque_limit": "goal_pwm", "p_gain": "position_p_gain"}


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_each_role_is_the_register_the_e_manual_puts_there(name: str) -> None:
    m = model(name)
    assert {role: m.role(role).address for role in EXPECTED[name]} == EXPECTED[name]
    assert sorted(r for r in ROLES if m.has_role(r)) == sorted(EXPECTED[name])


def test_the_x_series_names_its_roles_by_its_own_items() -> None:
    xm = model("XM430-W350")
    assert {role: xm.role(role).name for role in X_NAMES} == X_NAMES
    assert model("XL430-W250").role("present_load").name == "present_load"


def test_a_role_the_model_lacks_is_one_line_naming_model_and_register() -> None:
    xm = model("XM430-W350")
    for role, register in (("cw_compliance_slope", "cw_compliance_slope"),
                           ("cw_compliance_margin", "cw_compliance_margin"),
                           ("punch", "punch")):
        assert not xm.has_role(role)
        with pytest.raises(ConfigError) as lacking:
            xm.role(role)
        assert str(lacking.value).startswith(f"XM430-W350 has no {register} register")
        assert "\n" not in str(lacking.value)
    with pytest.raises(ConfigError, match="RX-28 has no current_limit register"):
        model("RX-28").role("current_limit")
    with pytest.raises(ConfigError, match="no register role 'goal_speed'; the roles are"):
        model("RX-28").role("goal_speed")


#: What the dynamixel_motor manager reads of every motor and the joint controllers write.
CONTROLLER_ROLES = ("goal_position", "moving_speed", "torque_limit", "present_position",
                    "present_speed", "present_load", "present_voltage", "present_temperature",
                    "moving", "torque_enable")


@pytest.mark.parametrize("name", sorted(MODELS))
def test_every_shipped_model_plays_every_role_the_controllers_need(name: str) -> None:
    m = MODELS[name]
    registers = [m.role(role) for role in CONTROLLER_ROLES]
    assert len({r.name for r in registers}) == len(CONTROLLER_ROLES)
    # either compliance (AX/RX/EX) or PID gains (MX, XL-320, X-series)
    assert m.has_role("cw_compliance_slope") != m.has_role("p_gain")
    if m.role("present_load").unit == "current":
        assert m.has_role("current_limit") and m.current_unit_a > 0
