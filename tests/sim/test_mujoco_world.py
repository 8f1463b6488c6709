"""The MuJoCo world: emulated servos' firmware driving hinges of a MuJoCo model.

Facts checked against sources other than this code:

- the RX-28's compliance law (e-Manual, RX-28, Compliance Margin/Slope and Punch: no output
  within the margin, output reduced across the slope): an arm held level by its servo
  settles where the slope's output balances gravity's torque, m g l;
- the RX-28's alarms (e-Manual, RX-28 Alarm Shutdown, default 0x24: overload and
  overheating turn torque off; Present Load bit 10 = clockwise);
- the zero-moment point equals the centre of pressure of coplanar contacts (Vukobratović &
  Borovac 2004, "Zero-moment point — thirty five years of its life"), each computed here from
  different MuJoCo quantities (momentum rates against contact forces).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from servolab.dynamixel.bus import Bus
from servolab.sim import MujocoWorld, ServoJoint, Simulation, SimulationError
from servolab.sim.mujoco_world import support_margin

mujoco = pytest.importorskip("mujoco")

RX28_STALL = 3.7      # N m, e-Manual
TICK = math.radians(300.0) / 1023   # rad per RX-28 position tick

#: A 0.3 kg bar on a horizontal hinge (y axis), its centre of mass 0.1 m from the axis when
#: level, and a block above it that it meets at about +0.22 rad.
ARM = """
<mujoco>
  <compiler angle="radian"/>
  <option timestep="0.001" integrator="implicitfast"/>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.05"/>
    <geom name="wall" type="box" size="0.05 0.05 0.05" pos="0.15 0 0.604"/>
    <body name="bar" pos="0 0 0.5">
      <joint name="hinge" type="hinge" axis="0 -1 0" armature="0.0037"/>
      <geom type="box" size="0.1 0.01 0.01" pos="0.1 0 0" mass="0.3"/>
    </body>
  </worldbody>
</mujoco>
"""


def _arm(**world: object) -> tuple[Simulation, Bus, MujocoWorld]:
    sim = Simulation()
    bus = Bus.open("emu://rx28:1", baudrate=57142, simulation=sim)
    arm = sim.add(MujocoWorld(ARM, [ServoJoint("hinge", bus.emulator.motor(1))],
                              base="bar", **world))  # type: ignore[arg-type]
    return sim, bus, arm


def test_the_compliance_slope_holds_the_arm_where_its_output_balances_gravity() -> None:
    # the oracle is gravity's torque, m g l; the sag it gives follows the law the world
    # states for the e-Manual's words (no output within the margin, rising across the slope)
    sim, bus, _ = _arm()
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_position", 0.0)
    sim.advance(2.0)
    gravity = 0.3 * 9.81 * 0.1                       # N m, the bar level
    # beyond the margin (1 tick) the output rises across the slope (32 ticks) to full
    expected_sag = TICK * 1 + TICK * 32 * gravity / RX28_STALL
    sag = -bus.read(1, "present_position")          # the bar hangs below the goal
    assert sag == pytest.approx(expected_sag, abs=TICK)  # within the encoder's resolution
    load = bus.read(1, "present_load")
    assert load == pytest.approx(gravity / RX28_STALL, abs=0.002)  # load units: 0.1 %
    # a steeper slope (8 ticks) holds it closer
    bus.write(1, {"cw_compliance_slope": 8, "ccw_compliance_slope": 8}, raw=True)
    sim.advance(1.0)
    assert -bus.read(1, "present_position") == pytest.approx(
        TICK * 1 + TICK * 8 * gravity / RX28_STALL, abs=TICK)


def test_moving_speed_limits_how_fast_the_joint_goes() -> None:
    sim, bus, arm = _arm()
    bus.write(1, {"goal_position": 0.0, "moving_speed": 0.5})
    bus.write(1, "torque_enable", 1)
    sim.advance(0.5)
    start = arm.plants[0].position
    bus.write(1, "goal_position", -0.6)
    sim.advance(0.6)
    travelled = start - arm.plants[0].position
    assert travelled == pytest.approx(0.5 * 0.6, abs=0.03)    # 0.5 rad/s for 0.6 s
    assert abs(bus.read(1, "present_speed")) == pytest.approx(0.5, abs=0.05)


def test_a_joint_held_against_a_wall_reads_its_torque_limit_and_heats() -> None:
    sim, bus, arm = _arm()
    plant = arm.plants[0]
    plant.thermal_time_constant = 5.0               # warms in seconds, by the same model
    bus.write(1, "shutdown", 0x04, raw=True)        # overheating only: it keeps pushing
    bus.write(1, "torque_limit", 0.6)
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_position", 1.0)              # through the block
    sim.advance(0.5)
    held = bus.read(1, "present_position")
    assert 0.15 < held < 0.3                        # stopped by the block, far from its goal
    assert bus.read(1, "present_load") == pytest.approx(0.6, abs=0.002)  # at its limit
    first = bus.read(1, "present_temperature")
    sim.advance(3.0)
    assert bus.read(1, "present_temperature") > first + 3
    assert bus.read(1, "present_position") == pytest.approx(held, abs=TICK)
    # at its limit without moving for over a second: the firmware reports overload
    assert plant.stalled
    bus.read(1, "present_load")
    assert "overload" in bus.hardware_errors(1)
    assert bus.read(1, "torque_limit") == pytest.approx(0.6, abs=1e-3)  # not in the mask
    # at full torque the windings pass the 80 °C limit: overheating shuts the output off
    bus.write(1, "torque_limit", 1.0)
    for _ in range(300):
        sim.advance(0.1)
        if plant.command.torque_limit == 0:     # the firmware shut the output off
            break
    assert bus.read(1, "present_temperature") >= 79   # just past 80 °C, cooling now
    assert "overheating" in bus.hardware_errors(1)
    assert bus.read(1, "torque_limit") == 0.0       # RX-28: the shutdown zeroes the limit
    sim.advance(0.1)
    assert bus.read(1, "present_load") == 0.0


def test_the_default_alarm_shutdown_ends_an_overload_with_torque_off() -> None:
    sim, bus, _ = _arm()
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_position", 1.0)
    sim.advance(0.5)
    assert bus.read(1, "present_load") == pytest.approx(1.0, abs=0.002)
    assert bus.read(1, "torque_limit") == 1.0       # a moment at the limit is no overload
    sim.advance(1.0)
    assert bus.read(1, "torque_limit") == 0.0       # 0x24: overload shuts the output off
    sim.advance(0.5)
    assert bus.read(1, "present_load") == 0.0       # output 0 %
    assert bus.read(1, "present_position") < 0.0    # the bar falls
    # the load it could not hold still cannot be: the alarm stays until a host acts
    assert "overload" in bus.hardware_errors(1)


def test_the_torque_limit_caps_the_output_and_the_back_emf_still_brakes() -> None:
    # a limit below what holding the bar level takes (0.08 of stall): it sinks, pushing
    # with exactly its limit; present load is the output, not the torque (e-Manual)
    sim, bus, _ = _arm()
    bus.write(1, "torque_limit", 0.05)
    bus.write(1, {"goal_position": 0.0, "moving_speed": 0.0})
    bus.write(1, "torque_enable", 1)
    sim.advance(2.0)
    assert bus.read(1, "present_position") < -0.3       # sinking (to 0.89 rad, where it holds)
    assert bus.read(1, "present_load") == pytest.approx(0.05, abs=0.002)
    # at an output of 0 the motor still brakes the falling bar; with torque off nothing does
    drops = []
    for torque in (1, 0):
        sim, bus, arm = _arm()
        bus.write(1, "torque_limit", 0.0)
        bus.write(1, "torque_enable", torque)
        sim.advance(0.3)
        drops.append(-arm.plants[0].position)
    braked, free = drops
    assert 0 < braked < 0.5 * free


def test_the_zero_moment_point_is_the_centre_of_pressure_on_a_flat_foot() -> None:
    # a heavy flat foot on the floor with an arm swung by a servo: the ZMP from the
    # momentum's rate of change and the CoP from the contact forces agree, and both move
    robot = """
    <mujoco><compiler angle="radian"/>
      <option timestep="0.001"/>
      <worldbody><geom name="floor" type="plane" size="1 1 0.05"/>
        <body name="foot" pos="0 0 0.01"><freejoint/>
          <geom type="box" size="0.1 0.06 0.01" mass="2"/>
          <body name="arm" pos="0 0 0.15">
            <joint name="swing" type="hinge" axis="0 1 0" armature="0.0037"/>
            <geom type="box" size="0.01 0.01 0.06" pos="0 0 0.06" mass="0.3"/>
          </body></body></worldbody></mujoco>"""
    sim = Simulation()
    bus = Bus.open("emu://rx28:1", baudrate=57142, simulation=sim)
    world = sim.add(MujocoWorld(robot, [ServoJoint("swing", bus.emulator.motor(1))],
                                feet=["foot"], record_period=0.01))
    bus.write(1, {"goal_position": 0.8, "moving_speed": 0.0})
    bus.write(1, "torque_enable", 1)
    sim.advance(1.0)
    samples = world.samples[2:]
    zmp = np.array([s.zmp for s in samples])
    cop = np.array([s.cop for s in samples])
    # the CoP at a sample is instantaneous, the ZMP the mean over the 10 ms before it
    mean_cop = (cop[1:] + cop[:-1]) / 2
    assert np.max(np.abs(zmp[1:] - mean_cop)) < 0.004
    assert np.ptp(zmp[:, 0]) > 0.01                 # the swing moved it
    total = [sum(s.feet) for s in samples[-10:]]
    weight = world.model.body_subtreemass[1] * 9.81
    assert np.mean(total) == pytest.approx(weight, rel=0.01)   # the floor carries it
    assert not any(s.fallen for s in samples)


def test_support_margin_is_signed_distance_to_the_hull() -> None:
    square = [(0.0, 0.0), (0.1, 0.0), (0.1, 0.1), (0.0, 0.1), (0.05, 0.05)]
    assert support_margin((0.05, 0.05), square) == pytest.approx(0.05, abs=1e-6)
    assert support_margin((0.12, 0.05), square) == pytest.approx(-0.02, abs=1e-6)
    assert math.isnan(support_margin((0.0, 0.0), []))
    assert support_margin((0.0, 0.03), [(0.0, 0.0)]) == pytest.approx(-0.03)


def test_bad_models_are_refused_naming_the_fault() -> None:
    sim = Simulation()
    bus = Bus.open("emu://rx28:1", baudrate=57142, simulation=sim)
    motor = bus.emulator.motor(1)
    with pytest.raises(SimulationError, match="no joint 'elbow'"):
        MujocoWorld(ARM, [ServoJoint("elbow", motor)])
    with pytest.raises(SimulationError, match="does not load"):
        MujocoWorld("<mujoco><worldbody><body>", [ServoJoint("hinge", motor)])
    actuated = ARM.replace("</mujoco>", '<actuator><position name="p" joint="hinge"/>'
                           "</actuator></mujoco>")
    with pytest.raises(SimulationError, match="actuator 'p' drives joint 'hinge'"):
        MujocoWorld(actuated, [ServoJoint("hinge", motor)])
    with pytest.raises(SimulationError, match="direction"):
        MujocoWorld(ARM, [ServoJoint("hinge", motor, direction=2)])


def test_a_floor_that_is_not_level_at_zero_is_refused() -> None:
    sim = Simulation()
    bus = Bus.open("emu://rx28:1", baudrate=57142, simulation=sim)
    raised = ARM.replace('<geom name="floor" type="plane" size="1 1 0.05"/>',
                         '<geom name="floor" type="plane" size="1 1 0.05" pos="0 0 0.1"/>')
    with pytest.raises(SimulationError, match="level plane at z = 0"):
        MujocoWorld(raised, [ServoJoint("hinge", bus.emulator.motor(1))])


def test_samples_come_every_period_and_the_oldest_go_when_there_are_too_many() -> None:
    from servolab.middleware.context import Context
    from servolab.middleware.node import Node
    from servolab.sim.mujoco_truth import SampledTruthNode

    sim, bus, arm = _arm(record_period=0.02, max_samples=10)
    bus.write(1, "torque_enable", 1)
    context = Context.open(clock=sim)
    try:
        truth = SampledTruthNode(context, arm)
        heard: list[float] = []
        node = Node(context, "listener")
        node.create_subscription("geometry_msgs/msg/PointStamped", "/ground_truth/com",
                                 lambda m: heard.append(m.header.stamp.sec
                                                        + m.header.stamp.nanosec * 1e-9), 100)
        poses: list[Any] = []
        placed: list[Any] = []
        node.create_subscription("nav_msgs/msg/Odometry", "/ground_truth", poses.append, 100)
        node.create_subscription("tf2_msgs/msg/TFMessage", "/tf", placed.append, 100)
        context.spin_for(0.5)
        truth.publish_new()
        context.spin_for(0.01)
    finally:
        context.close()
    # the base on /tf (world -> base) is the ground truth's pose, sample for sample
    assert len(placed) == len(poses) > 0
    for tf, pose in zip(placed, poses, strict=True):
        (t,) = tf.transforms
        assert (t.header.frame_id, t.child_frame_id) == ("world", pose.child_frame_id)
        assert t.header.stamp == pose.header.stamp
        p, q = pose.pose.pose.position, pose.pose.pose.orientation
        assert (t.transform.translation.x, t.transform.translation.y,
                t.transform.translation.z) == (p.x, p.y, p.z)
        assert (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
                t.transform.rotation.w) == (q.x, q.y, q.z, q.w)
    assert arm.samples_taken >= 25
    assert 10 <= len(arm.samples) <= 11                     # trimmed to the newest
    times = [s.t for s in arm.samples]
    assert times == pytest.approx([round(t / 0.02) * 0.02 for t in times], abs=1e-9)
    assert heard == pytest.approx([k * 0.02 for k in range(len(heard))], abs=1e-9)
    assert len(heard) == arm.samples_taken                  # every sample published once
