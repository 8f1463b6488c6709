"""A fixed arm in the MuJoCo world: a hinge and a rack-and-pinion slide, each driven by an
emulated XM430-W350 through the servo firmware, described with the generic description model
(robots/description.py) and written to MJCF with no floor and no floating base.

Facts checked against sources other than this code:

- the XM430-W350's position unit: 4096 ticks a turn, 0.088 degrees a tick (ROBOTIS e-Manual,
  XM430-W350, Goal Position), so a joint settles within a few ticks of its goal;
- a rack and pinion of pitch radius r moves the rack r x theta for a pinion turn of theta
  (the arc length), so the slide's gear ratio is 1 / r radians a metre.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from servolab.dynamixel.bus import Bus
from servolab.robots.description import Box, Description, Joint, Link, Mimic, Motor, mjcf
from servolab.sim import MujocoWorld, ServoJoint, Simulation

mujoco = pytest.importorskip("mujoco")

XM430_TICK = 2 * math.pi / 4096       # rad, e-Manual: 0.088 degrees a tick
PINION_RADIUS = 0.01                  # m: the gripper's pinion (a choice of this test)
#: the horn-side inertia of an XM430 (rotor x gear ratio²; a guess, the e-Manual gives none)
HORN_INERTIA = 0.01


def arm() -> Description:
    """A base on a table, a shoulder turning about the vertical, an upper arm, and a gripper
    finger sliding along the arm on a rack."""
    slide_ratio = 1.0 / PINION_RADIUS
    links = (
        Link("base", (Box("base_box", (0.06, 0.06, 0.04), (0.0, 0.0, 0.02), mass=0.5),)),
        Link("upper_arm", (Box("upper_box", (0.2, 0.03, 0.03), (0.1, 0.0, 0.0), mass=0.15),)),
        Link("finger", (Box("finger_box", (0.02, 0.01, 0.04), (0.0, 0.0, -0.02),
                            mass=0.02),)),
        Link("tool"),
        Link("other_finger", (Box("other_box", (0.02, 0.01, 0.04), (0.0, 0.0, -0.02),
                                  mass=0.02),)),
    )
    joints = (
        Joint("shoulder", "revolute", "base", "upper_arm", (0.0, 0.0, 0.06), (0.0, 0.0, 1.0),
              -2.0, 2.0, Motor(1, "XM430-W350", direction=-1), armature=HORN_INERTIA),
        Joint("finger_slide", "prismatic", "upper_arm", "finger", (0.15, 0.0, 0.0),
              (1.0, 0.0, 0.0), 0.0, 0.03, Motor(2, "XM430-W350", gear_ratio=slide_ratio),
              armature=HORN_INERTIA * slide_ratio ** 2),
        Joint("tool_joint", "fixed", "finger", "tool", (0.0, 0.0, -0.04)),
        # the second finger on the same pinion, the other side of it: it moves the other way
        Joint("other_finger_slide", "prismatic", "upper_arm", "other_finger",
              (0.15, 0.0, 0.0), (1.0, 0.0, 0.0), -0.03, 0.0,
              armature=HORN_INERTIA * slide_ratio ** 2, mimic=Mimic("finger_slide", -1.0)),
    )
    return Description("gripper_arm", "base", links, joints)


def _world() -> tuple[Simulation, Bus, MujocoWorld, Description]:
    description = arm()
    sim = Simulation(0.002)
    bus = Bus.open("emu://xm430-w350:1-2", simulation=sim)
    joints = [ServoJoint(j.name, bus.emulator.motor(m.id), direction=m.direction,
                         gear_ratio=m.gear_ratio) for j, m in description.motors]
    world = sim.add(MujocoWorld(mjcf(description, "firmware"), joints, start=sim.now()))
    return sim, bus, world, description


def test_a_hinge_and_a_geared_slide_reach_their_commanded_positions() -> None:
    sim, bus, world, description = _world()
    targets = {"shoulder": 0.7, "finger_slide": 0.02}      # rad, m
    for joint, motor in description.motors:
        bus.write(motor.id, "torque_enable", 1)
        bus.write(motor.id, "goal_position", motor.reduction * targets[joint.name])
    sim.advance(3.0)
    for joint, motor in description.motors:
        qpos = float(world.data.qpos[world.model.joint(joint.name).qposadr[0]])
        horn = bus.read(motor.id, "present_position")
        # the joint is where the horn says, through the transmission
        assert horn == pytest.approx(motor.reduction * qpos, abs=1e-9)
        # and the horn within a few ticks of its goal: the slide within 4 ticks / 100 rad/m
        assert horn == pytest.approx(motor.reduction * targets[joint.name],
                                     abs=4 * XM430_TICK)
    # the rack moved the finger along the arm by r x the pinion's turn
    slide = world.model.joint("finger_slide").qposadr[0]
    turn = bus.read(2, "present_position")
    assert world.data.qpos[slide] == pytest.approx(PINION_RADIUS * turn, abs=1e-9)
    # and the mimic finger the other way (URDF <mimic multiplier="-1">, MuJoCo's soft
    # joint equality: within a tenth of a millimetre)
    other = world.model.joint("other_finger_slide").qposadr[0]
    assert world.data.qpos[other] == pytest.approx(-world.data.qpos[slide], abs=1e-4)
    # the tool frame (a site) went with it: shoulder turned 0.7 rad about z
    tool = world.data.site("tool").xpos
    reach = 0.15 + 0.02
    np.testing.assert_allclose(tool, [reach * math.cos(0.7), reach * math.sin(0.7), 0.02],
                               atol=4 * XM430_TICK * reach)


def test_an_arm_without_a_floor_has_no_floor_and_never_falls() -> None:
    sim, bus, world, _ = _world()
    assert world.floor == -1
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_position", -2.0)         # the shoulder swings far past 45 degrees
    sim.advance(1.0)
    assert world.samples and not any(s.fallen for s in world.samples)
    assert all(math.isnan(s.zmp[0]) for s in world.samples)
    assert world.ground_truth()["fallen"] == 0.0


def test_a_gear_ratio_that_is_not_a_positive_number_is_refused() -> None:
    from servolab.sim import SimulationError

    description = arm()
    sim = Simulation(0.002)
    bus = Bus.open("emu://xm430-w350:1-2", simulation=sim)
    with pytest.raises(SimulationError, match="gear_ratio 0 must be a positive number"):
        MujocoWorld(mjcf(description, "firmware"),
                    [ServoJoint("finger_slide", bus.emulator.motor(2), gear_ratio=0)])



def test_the_shoulder_follows_a_time_based_profile_in_mujoco() -> None:
    """The same X-series profile in MuJoCo as on the default plant (e-Manual, Drive Mode(10)
    bit 2: Profile Velocity is the span, 1 000 ms; Profile Acceleration the acceleration time,
    300 ms). A move of d over that trapezoid cruises at v = d / (1 - 0.3): a quarter-second
    in, the ramp has covered v t² / (2 x 0.3); half-way through the span the shoulder is
    half-way (the trapezoid is symmetric); after the span it stands on its goal."""
    sim, bus, _, _ = _world()
    bus.write(1, "drive_mode", 4 | 1, raw=True)     # time-based, and the shoulder's reverse
    # the stiffest P gain, so that the horn keeps within a few ticks of the trajectory (at
    # the default 800 it lags by the error its P term needs against the back-EMF)
    bus.write(1, "position_p_gain", 16383, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.write(1, {"profile_acceleration": 300, "profile_velocity": 1000}, raw=True)
    start = bus.read(1, "present_position")
    distance = 1.2
    began = sim.now()
    bus.write(1, "goal_position", start + distance)
    cruise = distance / 0.7
    expected = {0.25: cruise * 0.25 ** 2 / (2 * 0.3), 0.5: distance / 2, 1.01: distance}
    for t, moved in expected.items():
        sim.advance_to(began + t)
        assert bus.read(1, "present_position") - start == pytest.approx(
            moved, abs=4 * XM430_TICK), t
    assert bus.read(1, "moving_status", raw=True) == 0x31    # trapezoidal, in position


def _lever(mass: float, reach: float, motor: str = "XM430-W350"
           ) -> tuple[Simulation, Bus, MujocoWorld]:
    """A block of ``mass`` kg whose centre is ``reach`` m out from a horizontal hinge (about
    y: a positive angle lowers it), on an emulated ``motor``."""
    description = Description("lever", "base", (
        Link("base", (Box("base_box", (0.04, 0.04, 0.04), (0.0, 0.0, 0.0), mass=1.0),)),
        Link("lever", (Box("lever_box", (0.02, 0.02, 0.02), (reach, 0.0, 0.0), mass=mass),)),
    ), (Joint("hinge", "revolute", "base", "lever", (0.0, 0.0, 0.1), (0.0, 1.0, 0.0),
              -2.0, 2.0, Motor(1, motor), armature=HORN_INERTIA),))
    sim = Simulation(0.002)
    bus = Bus.open(f"emu://{motor.lower().replace('-', '')}:1", simulation=sim)
    world = sim.add(MujocoWorld(mjcf(description, "firmware"),
                                [ServoJoint("hinge", bus.emulator.motor(1))], start=sim.now()))
    return sim, bus, world


@pytest.mark.parametrize("p_gain", [400, 800, 1600])
def test_a_held_lever_sags_by_its_p_gain_and_draws_its_torques_current(p_gain: int) -> None:
    """A 0.3 kg block whose centre is 0.1 m out from a horizontal hinge, held level in
    position mode: gravity asks m g r = 0.3 x 9.81 x 0.1 = 0.294 N m of the horn, 0.0717 of
    the XM430-W350's 4.1 N m stall torque. Computed here by hand, not by the model:

    - the P term gives PWM = KPP x error, KPP = P / 128, full output 885 (e-Manual,
      Position PID Gain; Goal PWM's range), so the lever sags until 885 x 0.0717 = KPP x
      error: 20.3, 10.2 and 5.1 ticks at P 400, 800, 1 600 (within a tick);
    - the motor draws torque / Kt, Kt = 4.1 N m / 2.3 A: 0.165 A, 61 units of 2.69 mA
      (within 5 %)."""
    mass, reach, g = 0.3, 0.1, 9.81
    sim, bus, world = _lever(mass, reach)
    bus.write(1, "position_p_gain", p_gain, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_position", 0.0)
    sim.advance(3.0)
    angle = float(world.data.qpos[world.model.joint("hinge").qposadr[0]])
    torque_nm = mass * g * reach * math.cos(angle)
    sag_ticks = 885 * (torque_nm / 4.1) / (p_gain / 128)
    assert abs(angle) / XM430_TICK == pytest.approx(sag_ticks, abs=1.0)
    amps = torque_nm / (4.1 / 2.3)
    current = bus.read(1, "present_current", raw=True)
    assert abs(current) == pytest.approx(amps / 0.00269, rel=0.05)


@pytest.mark.parametrize("p_gain", [16, 32, 64])
def test_an_mx28_lever_sags_by_its_p_gain(p_gain: int) -> None:
    """The MX-28 (Protocol 1.0) P gain as the e-Manual's table makes it the compliance
    slope's equal (slope 8/16/32/64/128 is P 128/64/32/16/8: slope = 1 024 / P ticks), so
    the 0.294 N m lever sags share x 1 024 / P ticks, share = 0.294 / 2.5 N m stall (MX-28,
    e-Manual specifications at 12 V): 7.5, 3.8, 1.9 ticks (within a tick). It held the same
    at every P gain before."""
    mass, reach, g = 0.3, 0.1, 9.81
    sim, bus, world = _lever(mass, reach, "MX-28")
    bus.write(1, "p_gain", p_gain, raw=True)
    bus.write(1, "goal_position", 0.0)               # (Protocol 1.0: torque on with the goal)
    sim.advance(3.0)
    angle = float(world.data.qpos[world.model.joint("hinge").qposadr[0]])
    share = mass * g * reach * math.cos(angle) / 2.5
    tick = 2 * math.pi / 4096                       # MX-28: 4096 ticks a turn
    assert abs(angle) / tick == pytest.approx(share * 1024 / p_gain, abs=1.0)


@pytest.mark.slow
def test_a_lever_held_by_goal_current_comes_to_rest_where_gravity_equals_it() -> None:
    """Current Control Mode is a torque demand: Goal Current 50 (0.1345 A, x Kt = 0.240 N m)
    under a lever whose gravity torque is m g r cos(angle) = 0.294 cos(angle) N m lets it
    sink to rest at acos(0.240 / 0.294) = 35.4 degrees below level, and stay there: the
    angle a hand calculation gives, not the model. (The current loop makes up for the
    back-EMF, so it is the gears' viscous friction that damps the swing.)"""
    mass, reach, g = 0.3, 0.1, 9.81
    sim, bus, world = _lever(mass, reach)
    bus.write(1, "operating_mode", 0, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_current", -50, raw=True)     # lifting: against a positive angle
    sim.advance(40.0)
    qpos = world.model.joint("hinge").qposadr[0]
    held = math.degrees(math.acos(50 * 0.00269 * (4.1 / 2.3) / (mass * g * reach)))
    assert math.degrees(float(world.data.qpos[qpos])) == pytest.approx(held, abs=1.0)
    assert bus.read(1, "present_velocity", raw=True) == 0
    assert bus.read(1, "present_current", raw=True) == pytest.approx(-50, abs=1)
