"""The X-series and MX feedback laws in MuJoCo: the integral, derivative and feedforward
gains of the position law, and Velocity Control Mode's PI law, each against a figure
computed here by hand from the e-Manual's conversions — not from the model's code.

Sources:

- e-Manual, Position PID Gain(80, 82, 84) and Feedforward 1st/2nd Gain(88, 90): output PWM
  = KPP x error + KPI x the errors' sum + KPD x the error's change + KFF1st x the desired
  velocity + KFF2nd x the desired acceleration, KPP = P / 128, KPI = I / 65 536, KPD = D / 16,
  KFF = FF / 4, "the constant in each equation includes sampling time"; 885 is full PWM;
- e-Manual, Velocity PI Gain(76, 78): KVP = P / 128, KVI = I / 65 536 on Goal Velocity's
  0.229 rpm unit;
- e-Manual, XM430-W350 specifications: stall torque 4.1 N m, no-load speed 46 rpm (12 V);
  MX-28: the P gain's compliance-slope equivalent (slope x P = 1 024) and Ki = I x 1 000 /
  2 048;
- servolab's stated assumption: the X-series controller samples every 1 ms
  (servolab.dynamixel.gains.CONTROL_PERIOD_S), as the e-Manual names no period;
- textbook control: a PI law leaves no steady error against a constant load; a second-order
  system of damping ratio z overshoots a step by exp(-pi z / sqrt(1 - z²)).
"""

from __future__ import annotations

import math

import pytest

from servolab.dynamixel.bus import Bus
from servolab.robots.description import Box, Description, Joint, Link, Motor, mjcf
from servolab.sim import MujocoWorld, ServoJoint, Simulation

from .test_mujoco_arm import HORN_INERTIA, XM430_TICK, _lever

mujoco = pytest.importorskip("mujoco")

STALL_NM = 4.1                          # XM430-W350 at 12 V
NO_LOAD = 46 * 2 * math.pi / 60         # rad/s
PERIOD = 0.001                          # s: the assumed control period
FULL_PWM = 885
VELOCITY_UNIT = 0.229 * 2 * math.pi / 60    # rad/s: Goal Velocity's unit
MASS, REACH, G = 0.3, 0.1, 9.81
#: the lever's inertia about the hinge: the horn's plus the 2 cm block's (m r² + m a² / 6)
LEVER_INERTIA = HORN_INERTIA + MASS * (REACH ** 2 + 0.02 ** 2 / 6)


def _hinge_angle(world: MujocoWorld) -> float:
    return float(world.data.qpos[world.model.joint("hinge").qposadr[0]])


def _p_share_per_rad(p_gain: int) -> float:
    """The P term's output share a radian: (P / 128) PWM a tick over 885."""
    return p_gain / 128 / FULL_PWM / XM430_TICK


def test_the_position_i_gain_takes_the_sag_out_of_a_held_lever() -> None:
    """P alone holds the 0.294 N m lever 10.2 ticks low (0.0717 of stall x 885 / (800 /
    128)); an integral term of any gain goes on adding output until the error is gone."""
    for i_gain, sag in ((0, 0.0717 * FULL_PWM / (800 / 128)), (1000, 0.0)):
        sim, bus, world = _lever(MASS, REACH)
        bus.write(1, "position_p_gain", 800, raw=True)
        bus.write(1, "position_i_gain", i_gain, raw=True)
        bus.write(1, "torque_enable", 1)
        bus.write(1, "goal_position", 0.0)
        sim.advance(5.0)
        assert _hinge_angle(world) / XM430_TICK == pytest.approx(sag, abs=0.5), i_gain


def _overshoot(d_gain: int, p_gain: int, step: float) -> float:
    sim, bus, world = _lever(MASS, REACH)
    bus.write(1, "position_p_gain", p_gain, raw=True)
    bus.write(1, "position_d_gain", d_gain, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_position", 0.0)
    sim.advance(2.0)
    rest = _hinge_angle(world)
    bus.write(1, "goal_position", -step)       # lifting: against gravity's constant torque
    peak = rest
    end = sim.now() + 1.0
    while sim.now() < end:
        sim.advance(0.002)
        peak = min(peak, _hinge_angle(world))
    final = _hinge_angle(world)
    return (final - peak) / (rest - final)


def test_the_position_d_gain_damps_a_step() -> None:
    """A step of 20 ticks (inside the P term's linear range at P 3 000: full output is 37.8
    ticks away). The lever is a second-order system: stiffness k = KPP share x stall, damping
    c = the back-EMF's stall / no-load speed + KPD's share a rad/s x stall, inertia J. Its
    damping ratio c / (2 sqrt(k J)) gives the overshoot (J: the horn's assumed inertia and
    the block's, both stated in the model file, not fitted)."""
    p_gain, step = 3000, 20 * XM430_TICK
    k = _p_share_per_rad(p_gain) * STALL_NM
    for d_gain in (0, 3000):
        c = STALL_NM / NO_LOAD + d_gain / 16 * PERIOD / XM430_TICK / FULL_PWM * STALL_NM
        zeta = c / (2 * math.sqrt(k * LEVER_INERTIA))
        expected = math.exp(-math.pi * zeta / math.sqrt(1 - zeta ** 2))
        assert _overshoot(d_gain, p_gain, step) == pytest.approx(expected, abs=0.03), d_gain


def test_velocity_feedforward_takes_out_the_lag_a_profiled_move_needs() -> None:
    """Cruising at v, the P term alone must drive the back-EMF's v / no-load speed share:
    the horn lags the trajectory by that share over KPP (and gravity moves it by the sag).
    Feedforward 1st Gain FF = 4 x 885 x tick / (1 ms x no-load speed) gives that share from
    the trajectory's velocity itself, and the lag is gone: only the sag is left."""
    p_gain = 800
    ff_exact = 4 * FULL_PWM * XM430_TICK / (PERIOD * NO_LOAD)       # 1 127
    velocity_raw = 40
    v = velocity_raw * VELOCITY_UNIT
    lag = (v / NO_LOAD) / _p_share_per_rad(p_gain) / XM430_TICK      # ticks
    for ff, expected_lag in ((0, lag), (round(ff_exact), 0.0)):
        sim, bus, world = _lever(MASS, REACH)
        bus.write(1, "position_p_gain", p_gain, raw=True)
        bus.write(1, "feedforward_1st_gain", ff, raw=True)
        bus.write(1, {"profile_acceleration": 20, "profile_velocity": velocity_raw}, raw=True)
        bus.write(1, "torque_enable", 1)
        bus.write(1, "goal_position", -0.3)
        sim.advance(2.0)
        began = sim.now()
        bus.write(1, "goal_position", 0.3)
        sim.advance_to(began + 0.3 / v)      # half-way, cruising, the lever about level
        angle = _hinge_angle(world)
        sag = 0.0717 * math.cos(angle) * FULL_PWM / (p_gain / 128)
        # one READ: the trajectory and the horn at the same instant
        seen = bus.read(1, ["present_position", "velocity_trajectory", "position_trajectory"],
                        raw=True)
        behind = seen["position_trajectory"] - seen["present_position"]
        assert behind == pytest.approx(expected_lag - sag, abs=1.5), ff


def _wheel(damping: float) -> tuple[Simulation, Bus, MujocoWorld]:
    """A disc on a vertical axle (no gravity torque), loaded by a viscous brake of
    ``damping`` N m s/rad, on an XM430-W350."""
    description = Description("wheel", "base", (
        Link("base", (Box("base_box", (0.04, 0.04, 0.04), (0.0, 0.0, 0.0), mass=1.0),)),
        Link("disc", (Box("disc_box", (0.05, 0.05, 0.01), (0.0, 0.0, 0.0), mass=0.1),)),
    ), (Joint("axle", "continuous", "base", "disc", (0.0, 0.0, 0.1), (0.0, 0.0, 1.0),
              motor=Motor(1, "XM430-W350"), armature=HORN_INERTIA),))
    # the brake is the test's load, not the servo's: written into the MJCF (a description's
    # joint damping is the servo's own, which the firmware's law gives)
    xml = mjcf(description, "firmware")
    assert xml.count('name="axle"') == 1
    xml = xml.replace('name="axle"', f'name="axle" damping="{damping!r}"')
    sim = Simulation(0.002)
    bus = Bus.open("emu://xm430w350:1", simulation=sim)
    world = sim.add(MujocoWorld(xml,
                                [ServoJoint("axle", bus.emulator.motor(1))], start=sim.now()))
    return sim, bus, world


def test_velocity_mode_holds_its_goal_under_a_load_through_its_pi_law() -> None:
    """Against a brake of c = 2 N m s/rad, P alone (Velocity P Gain 100, I 0) settles where
    its output KVP x error drives the motor's back-EMF and the brake: v = g k / (k + a), with
    k = KVP's share a rad/s and a = 1 / no-load speed + c / stall — 5 % of the goal. With
    the factory I gain (1 920) the integral leaves no error. Either way Present PWM is the
    voltage share that speed takes, a x speed."""
    c = 2.0
    goal_raw = 40
    goal = goal_raw * VELOCITY_UNIT
    k = 100 / 128 / (VELOCITY_UNIT * FULL_PWM)
    a = 1 / NO_LOAD + c / STALL_NM
    for i_gain, expected in ((0, goal * k / (k + a)), (1920, goal)):
        sim, bus, world = _wheel(c)
        bus.write(1, "operating_mode", 1, raw=True)
        bus.write(1, {"velocity_p_gain": 100, "velocity_i_gain": i_gain}, raw=True)
        bus.write(1, "torque_enable", 1)
        bus.write(1, "goal_velocity", goal_raw, raw=True)
        sim.advance(4.0)
        speed = float(world.data.qvel[world.model.joint("axle").dofadr[0]])
        assert speed == pytest.approx(expected, abs=VELOCITY_UNIT), i_gain
        # the voltage it runs on: what the back-EMF and the brake take, a x speed
        assert bus.read(1, "present_pwm", raw=True) == pytest.approx(
            FULL_PWM * a * speed, abs=2), i_gain


def test_an_mx28_i_gain_takes_the_sag_out_too() -> None:
    """MX-28 (1.0): P 32 holds the lever 3.8 ticks low (0.294 / 2.5 N m x 1 024 / 32); its I
    gain (address 27) integrates that away."""
    for i_gain, sag in ((0, 0.294 / 2.5 * 1024 / 32), (20, 0.0)):
        sim, bus, world = _lever(MASS, REACH, "MX-28")
        bus.write(1, "p_gain", 32, raw=True)
        bus.write(1, "i_gain", i_gain, raw=True)
        bus.write(1, "goal_position", 0.0)
        sim.advance(5.0)
        assert _hinge_angle(world) / (2 * math.pi / 4096) == pytest.approx(sag, abs=0.5), \
            i_gain


def test_the_position_integral_takes_the_sag_out_at_the_rate_its_gain_sets() -> None:
    """Held against the lever by P (800) alone, then given I = 300: the law P e + I ∫e +
    the back-EMF's e'/w0 balances the constant load, so the sag decays as exp(-r t) with
    r = ki / (kp + 1 / w0) — 0.70 /s here, a hand calculation from the e-Manual's scalings
    (KPI = I / 65 536 a 1 ms period; the horn's inertia does not enter at this pace)."""
    kp = _p_share_per_rad(800)
    ki = 300 / 65536 / (PERIOD * XM430_TICK * FULL_PWM)
    left, elapsed = _sag_left("XM430-W350", ("position_p_gain", 800),
                              ("position_i_gain", 300), 1.0)
    assert left == pytest.approx(math.exp(-ki / (kp + 1 / NO_LOAD) * elapsed), abs=0.03)


def _sag_left(motor: str, p_gain: tuple[str, int], i_gain: tuple[str, int],
              seconds: float) -> tuple[float, float]:
    """The lever held by P alone until it settles, then given its I gain: (the share of the
    sag left ``seconds`` later, the exact time since the I gain was written)."""
    sim, bus, world = _lever(MASS, REACH, motor)
    bus.write(1, *p_gain, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_position", 0.0)
    sim.advance(3.0)
    sag = _hinge_angle(world)
    bus.write(1, *i_gain, raw=True)
    began = sim.now()
    sim.advance_to(began + seconds)
    return _hinge_angle(world) / sag, sim.now() - began


def test_velocity_mode_reaches_its_goal_at_the_pace_its_pi_gains_set() -> None:
    """A step of Goal Velocity against the brake: the P term answers at once (the speed
    jumps to g k / (k + a)), then the integral closes the rest as exp(-t / T) with
    T = (k + a) / ki — 0.53 s for the factory gains (P 100, I 1 920), by hand from KVP = P /
    128 and KVI = I / 65 536 a 1 ms period on Goal Velocity's units."""
    c = 2.0
    goal_raw = 40
    goal = goal_raw * VELOCITY_UNIT
    k = 100 / 128 / (VELOCITY_UNIT * FULL_PWM)
    ki = 1920 / 65536 / (PERIOD * VELOCITY_UNIT * FULL_PWM)
    a = 1 / NO_LOAD + c / STALL_NM
    pace = (k + a) / ki
    sim, bus, world = _wheel(c)
    bus.write(1, "operating_mode", 1, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_velocity", goal_raw, raw=True)
    began = sim.now()
    for t in (0.25, 0.5, 1.0):
        sim.advance_to(began + t)
        speed = float(world.data.qvel[world.model.joint("axle").dofadr[0]])
        expected = goal - goal * a / (k + a) * math.exp(-(sim.now() - began) / pace)
        assert speed == pytest.approx(expected, abs=0.02 * goal), t


def _step_on_the_wheel(p_gain: int, i_gain: int, d_gain: int, step: float
                       ) -> tuple[float, float]:
    """(the time to 80 % of a ``step`` on the braked wheel, the overshoot past it)."""
    sim, bus, world = _wheel(0.5)
    for name, gain in (("position_p_gain", p_gain), ("position_i_gain", i_gain),
                       ("position_d_gain", d_gain)):
        bus.write(1, name, gain, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_position", -step / 2)
    sim.advance(2.0)
    start = float(world.data.qpos[0])
    bus.write(1, "goal_position", step / 2)
    began, reached, peak = sim.now(), math.nan, start
    while sim.now() < began + 3.0:
        sim.advance(0.002)
        moved = float(world.data.qpos[0]) - start
        peak = max(peak, moved)
        if math.isnan(reached) and moved >= 0.8 * step:
            reached = sim.now() - began
    return reached, peak - step


def test_the_law_is_limited_once_so_d_does_not_brake_a_saturated_move() -> None:
    """A 2 rad step at P 800: far from the goal the P term alone asks far more than full
    output, so adding D (3 000) to it before the one limit leaves the output at full — the
    move is as fast as without D — and near the goal the D term damps it."""
    fast, _ = _step_on_the_wheel(800, 0, 0, 2.0)
    damped, overshoot = _step_on_the_wheel(800, 0, 3000, 2.0)
    assert damped == pytest.approx(fast, rel=0.05)
    assert overshoot < 0.01


def test_the_integral_does_not_wind_up_while_the_output_is_saturated() -> None:
    """The same 2 rad step with I = 300: the integral stops while P + I would pass full
    output the way the error pushes, so the move ends no further past the goal than P
    alone takes it (it overshot by 0.21 rad when the integral ran on)."""
    _, p_only = _step_on_the_wheel(800, 0, 0, 2.0)
    _, with_i = _step_on_the_wheel(800, 300, 0, 2.0)
    assert with_i <= max(p_only, 0.0) + 0.01


def test_present_current_is_the_torques_and_present_pwm_the_voltage_while_spinning() -> None:
    """Spinning freely at Goal Velocity 100 (no brake): the motor gives no torque beyond
    what accelerates nothing, so Present Current reads about 0 — the torque's current,
    torque / Kt — while Present PWM reads the voltage the speed takes, 885 x v / w0 (it read
    the voltage as a current before)."""
    sim, bus, _ = _wheel(0.0)
    bus.write(1, "operating_mode", 1, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_velocity", 100, raw=True)
    sim.advance(4.0)
    seen = bus.read(1, ["present_pwm", "present_current", "present_velocity"], raw=True)
    assert seen["present_velocity"] == pytest.approx(100, abs=1)
    assert abs(seen["present_current"]) <= 3
    assert seen["present_pwm"] == pytest.approx(FULL_PWM * 100 * VELOCITY_UNIT / NO_LOAD,
                                                abs=3)


def test_an_mx28_integral_takes_the_sag_out_at_the_rate_its_gain_sets() -> None:
    """MX-28 (1.0), P 32 then I 20: Ki = I x 1 000 / 2 048 on ticks and seconds, over the
    P gain's full-output scale of 128 (Kp = P / 8 and slope x P = 1 024), so the sag decays
    as exp(-r t), r = ki / (kp + 1 / w0), w0 = 55 rev/min (e-Manual, MX-28 at 12 V)."""
    tick = 2 * math.pi / 4096
    kp = 32 / 1024 / tick
    ki = 20 * 1000 / 2048 / 128 / tick
    rate = ki / (kp + 1 / (55 * 2 * math.pi / 60))
    left, elapsed = _sag_left("MX-28", ("p_gain", 32), ("i_gain", 20), 0.3)
    assert left == pytest.approx(math.exp(-rate * elapsed), abs=0.03)
