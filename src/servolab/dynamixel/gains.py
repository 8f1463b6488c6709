"""The firmware's feedback laws, read from a control table into SI: what each family's gains
and compliance registers mean, in one place.

Each function takes the model and a way to read a register's raw value (``get``) and returns
the law the joint's plant runs (:mod:`.plant`'s :class:`~.plant.Compliance`,
:class:`~.plant.PositionPid`, :class:`~.plant.VelocityPi`), or None where the model has no
such law. Every law gives an *output share* (1.0 = full output: Goal PWM's 885 on the
X-series, the torque limit's 1023 on the AX/RX/MX); errors are in radians and seconds.

**What ROBOTIS publish and what is assumed.** The e-Manual gives the X-series conversions
(Position PID Gain: KPP = P/128, KPI = I/65 536, KPD = D/16, KFF1st = FF1/4, KFF2nd = FF2/4;
Velocity PI Gain: KVP = P/128, KVI = I/65 536) and says "the constant in each equation
includes sampling time", with the controller's output in PWM units and the error in the
table's own units (pulses; Goal Velocity's 0.229 rpm). It names no sampling time:
:data:`CONTROL_PERIOD_S` states the one assumed. The MX (1.0) page gives Kp = P/8,
Ki = I x 1 000 / 2 048, Kd = D x 4 / 1 000 (e-Manual, MX-28 PID Gain) and an equivalence
with the compliance slope (slope 8, 16, 32, 64, 128 = P 128, 64, 32, 16, 8: full output at
1 024 / P ticks), which fixes the output's scale: full output is Kp x error = 128.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from . import units
from .models import Model
from .plant import Compliance, PositionPid, VelocityPi

#: The X-series controller's sampling period, s. ROBOTIS publish none; the millisecond is the
#: unit of the motor's own clock (Realtime Tick(120)). With it the factory velocity gains
#: (P 100, I 1 920 on an XM430) close a speed error with a time constant of about 0.2 s on a
#: free horn (0.5 s against a brake of 2 N m s/rad: tests/sim/test_mujoco_gains.py).
CONTROL_PERIOD_S = 0.001
#: The MX (1.0) output at which the law gives full output, in its Kp x ticks units (see the
#: module docstring: P x slope = 1 024 and Kp = P / 8).
_MX_FULL_OUTPUT = 128.0

#: Reads a register's raw value by name.
Getter = Callable[[str], int]

#: Every register the laws below read: the firmware keeps its laws decoded until one of
#: these changes (:mod:`.virtual_motor`).
REGISTERS = frozenset({
    "cw_compliance_margin", "ccw_compliance_margin", "cw_compliance_slope",
    "ccw_compliance_slope", "punch", "p_gain", "i_gain", "d_gain", "position_p_gain",
    "position_i_gain", "position_d_gain", "feedforward_1st_gain", "feedforward_2nd_gain",
    "velocity_p_gain", "velocity_i_gain"})


def compliance(model: Model, get: Getter) -> Compliance | None:
    """The position law's proportional part as a compliance law: the AX/RX/EX's own registers
    (Compliance Margin, Slope, Punch: margins and slopes in ticks, punch on the torque
    limit's 1023 scale), the MX's P gain as its equivalent slope, the X-series' Position P
    Gain as the error at which KPP x error reaches full PWM (885 x 128 / P ticks)."""
    if model.has("p_gain"):
        return _proportional(model, 8.0 * _MX_FULL_OUTPUT, get("p_gain"))
    if model.has("position_p_gain") and model.has("goal_pwm"):
        return _proportional(model, _pwm_full(model) * 128.0, get("position_p_gain"))
    if not model.has("cw_compliance_slope"):
        return None
    return Compliance(
        cw_margin=units.tick_span(model, get("cw_compliance_margin")),
        ccw_margin=units.tick_span(model, get("ccw_compliance_margin")),
        cw_slope=units.tick_span(model, get("cw_compliance_slope")),
        ccw_slope=units.tick_span(model, get("ccw_compliance_slope")),
        punch=get("punch") / 1023.0)


def position_pid(model: Model, get: Getter) -> PositionPid | None:
    """The position law's integral, derivative and feedforward parts in SI (None where the
    model has none, or all are 0).

    X-series: output(PWM) = KPI x sum of errors (pulses, one a period) + KPD x change of error
    a period + KFF1st x the trajectory's velocity (pulses a period) + KFF2nd x its
    acceleration (pulses a period²); so per second and radian the gains are KPI / (T x tick),
    KPD x T / tick, KFF1st x T / tick, KFF2nd x T² / tick, over 885 for a share.
    MX (1.0): Ki = I x 1 000 / 2 048 and Kd = D x 4 / 1 000 on ticks and seconds, over 128."""
    tick = model.rad_per_tick
    if model.has("position_i_gain") and model.has("goal_pwm"):
        full, t = _pwm_full(model), CONTROL_PERIOD_S
        pid = PositionPid(
            integral=get("position_i_gain") / 65536.0 / (t * tick * full),
            derivative=get("position_d_gain") / 16.0 * t / (tick * full),
            velocity_feedforward=_ff(model, get, "feedforward_1st_gain") * t / (tick * full),
            acceleration_feedforward=_ff(model, get, "feedforward_2nd_gain") * t * t
            / (tick * full))
    elif model.has("i_gain") and model.has("d_gain"):
        pid = PositionPid(integral=get("i_gain") * 1000.0 / 2048.0 / (tick * _MX_FULL_OUTPUT),
                          derivative=get("d_gain") * 4.0 / 1000.0 / (tick * _MX_FULL_OUTPUT))
    else:
        return None
    return pid if pid.active else None


def velocity_pi(model: Model, get: Getter) -> VelocityPi | None:
    """Velocity Control Mode's PI law in SI: output(PWM) = KVP x error + KVI x sum of errors
    (one a period), the error in Goal Velocity's units; per rad/s that is KVP / unit and
    KVI / (T x unit), over 885 for a share. None on a model without the gains."""
    if not (model.has("velocity_p_gain") and model.has("goal_pwm")):
        return None
    unit = units.velocity_unit(model)
    full = _pwm_full(model)
    return VelocityPi(proportional=get("velocity_p_gain") / 128.0 / (unit * full),
                      integral=get("velocity_i_gain") / 65536.0
                      / (CONTROL_PERIOD_S * unit * full))


def _pwm_full(model: Model) -> float:
    """Full output in Goal PWM's units (885 on the X-series)."""
    return float(model.register("goal_pwm").raw_max)


def _ff(model: Model, get: Getter, name: str) -> float:
    return get(name) / 4.0 if model.has(name) else 0.0


def _proportional(model: Model, full_output_at: float, gain: int) -> Compliance:
    """A proportional position law as the compliance law: full output ``full_output_at /
    gain`` ticks from the goal (a gain of 0: no output at all)."""
    slope = units.tick_span(model, full_output_at / gain) if gain else math.inf
    return Compliance(cw_slope=slope, ccw_slope=slope)
