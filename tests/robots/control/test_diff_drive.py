"""diff_drive_controller as ros2_controllers' (Jazzy) behaves, and the TurtleBot3 Waffle driven
through it on the simulated floor.

The reference is ros2_controllers branch ``jazzy`` (diff_drive_controller 4.42.1, commit
ed360c97): ``diff_drive_controller/src/diff_drive_controller.cpp`` is cited as ``.cpp:LINE``,
``src/diff_drive_controller_parameter.yaml`` as ``parameter.yaml``. The unit tests run the
controller under a controller manager on ``mock_components/GenericSystem`` wheels
(``calculate_dynamics``: each wheel's position integrates its velocity command) in virtual
time; the Waffle's run it on emulated XM430-W210s rolling on :class:`servolab.sim.floor.
DiffDriveFloor`, brought up as ``servolab control run turtlebot3_waffle --world robot``
brings it up.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import pytest

from servolab.clock import VirtualClock
from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.middleware.parameters import ParameterOverrides
from servolab.robots.control.bringup import BringUpOptions, ControlSystem
from servolab.robots.control.controller import ControllerInterface
from servolab.robots.control.diff_drive import DiffDriveController
from servolab.robots.control.manager import STRICT, ControllerManager
from servolab.robots.control.mock_system import GenericSystem
from servolab.robots.hardware_info import parse_control_resources

TWIST = "geometry_msgs/msg/TwistStamped"
#: the unit tests' geometry: wheel separation and radius (m)
SEPARATION, RADIUS = 0.5, 0.1
#: the manager's update period (s)
PERIOD = 0.01


def wheels_urdf(per_side: int = 1) -> str:
    """``per_side`` wheels a side on mock_components, each with a velocity command and
    position and velocity state interfaces."""
    joints = [f"{side}_wheel_{i}" for side in ("left", "right") for i in range(per_side)]
    urdf_joints = "".join(
        f'<link name="{j}_link"/><joint name="{j}" type="continuous"><parent link="base_link"/>'
        f'<child link="{j}_link"/><axis xyz="0 1 0"/></joint>' for j in joints)
    block = "".join(
        f'<joint name="{j}"><command_interface name="velocity"/>'
        f'<state_interface name="position"><param name="initial_value">0.0</param>'
        f'</state_interface><state_interface name="velocity">'
        f'<param name="initial_value">0.0</param></state_interface></joint>' for j in joints)
    return (f'<robot name="wheels"><link name="base_link"/>{urdf_joints}'
            f'<ros2_control name="Wheels" type="system"><hardware>'
            f'<plugin>mock_components/GenericSystem</plugin>'
            f'<param name="calculate_dynamics">true</param></hardware>{block}</ros2_control>'
            f'</robot>')


class Rig:
    """A controller manager at 100 Hz on mock wheels in virtual time, the controller
    ``diff_drive_controller`` loaded with ``params`` (a ROS 2 parameter file's text), and a
    probe node that commands it and hears what it publishes."""

    def __init__(self, params: str = "", *, per_side: int = 1, namespace: str = "/",
                 activate: bool = True) -> None:
        left = [f"left_wheel_{i}" for i in range(per_side)]
        right = [f"right_wheel_{i}" for i in range(per_side)]
        ns = "" if namespace == "/" else namespace + "/"
        overrides = ParameterOverrides.from_text(
            f"{ns}controller_manager:\n  ros__parameters:\n    update_rate: 100\n"
            "    diff_drive_controller:\n"
            "      type: diff_drive_controller/DiffDriveController\n"
            f"{ns}diff_drive_controller:\n  ros__parameters:\n"
            f"    left_wheel_names: {left}\n    right_wheel_names: {right}\n"
            f"    wheel_separation: {SEPARATION}\n    wheel_radius: {RADIUS}\n")
        if params:
            overrides.merge(ParameterOverrides.from_text(params))
        self.clock = VirtualClock(10.0)
        self.context = Context.open(clock=self.clock, parameter_overrides=overrides)
        (block,) = parse_control_resources(wheels_urdf(per_side), "wheels.urdf")
        self.manager = ControllerManager(self.context, [GenericSystem(block)],
                                         namespace=namespace)
        self.probe = Node(self.context, "probe")
        prefix = "" if namespace == "/" else namespace
        self.cmd_vel = self.probe.create_publisher(
            TWIST, f"{prefix}/diff_drive_controller/cmd_vel", 10)
        self.odom: list[Any] = []
        self.tf: list[Any] = []
        self.limited: list[Any] = []
        self.probe.create_subscription("nav_msgs/msg/Odometry",
                                       f"{prefix}/diff_drive_controller/odom",
                                       self.odom.append, 1000)
        self.probe.create_subscription("tf2_msgs/msg/TFMessage", "/tf", self.tf.append, 1000)
        self.probe.create_subscription(TWIST, f"{prefix}/diff_drive_controller/cmd_vel_out",
                                       self.limited.append, 1000)
        ok, message = self.manager.load_controller("diff_drive_controller")
        assert ok, message
        self.configured = self.manager.configure_controller("diff_drive_controller")
        if activate:
            assert self.configured[0], self.configured[1]
            self.activate()

    @property
    def controller(self) -> DiffDriveController:
        found: ControllerInterface = self.manager.controllers["diff_drive_controller"]
        assert isinstance(found, DiffDriveController), f"the controller is a {type(found)}"
        return found

    def activate(self) -> None:
        ok, message = self.manager.switch_controller(["diff_drive_controller"], [], STRICT)
        assert ok, message

    def deactivate(self) -> None:
        ok, message = self.manager.switch_controller([], ["diff_drive_controller"], STRICT)
        assert ok, message

    def send(self, linear: float, angular: float, stamp: float | None = None) -> None:
        """A cmd_vel stamped now (``stamp``: that ROS time; 0: a zero stamp)."""
        when = self.probe.stamp() if stamp is None else (
            {"sec": 0, "nanosec": 0} if stamp == 0 else self.probe.stamp(stamp))
        self.cmd_vel.publish(self.probe.message(
            TWIST, header={"stamp": when},
            twist={"linear": {"x": linear}, "angular": {"z": angular}}))

    def spin(self, seconds: float) -> None:
        self.context.spin_for(seconds)

    def hold(self, linear: float, angular: float, seconds: float) -> None:
        """The command sent every 0.1 s for ``seconds`` (within ``cmd_vel_timeout``)."""
        for _ in range(round(seconds / 0.1)):
            self.send(linear, angular)
            self.spin(0.1)

    def commands(self) -> dict[str, float]:
        """Each wheel's velocity command (rad/s), as the hardware holds it."""
        return {n.rpartition("/")[0]: v for n, v in self.manager.interfaces.commands.items()}

    def positions(self) -> dict[str, float]:
        states = self.manager.interfaces.states
        return {n.rpartition("/")[0]: v for n, v in states.items() if n.endswith("/position")}

    def close(self) -> None:
        self.manager.destroy()
        self.context.close()


@pytest.fixture
def rig() -> Iterator[Rig]:
    made = Rig()
    try:
        yield made
    finally:
        made.close()


def rim(linear: float, angular: float, separation: float = SEPARATION,
        left_radius: float = RADIUS, right_radius: float = RADIUS) -> tuple[float, float]:
    """``.cpp:296-300``: each side's wheel velocity from the body twist."""
    return ((linear - angular * separation / 2) / left_radius,
            (linear + angular * separation / 2) / right_radius)


# -- interfaces ---------------------------------------------------------------------------------

@pytest.mark.parametrize(("params", "states"), [
    ("", ["left_wheel_0/position", "left_wheel_1/position", "right_wheel_0/position",
          "right_wheel_1/position"]),
    ("position_feedback: false", ["left_wheel_0/velocity", "left_wheel_1/velocity",
                                  "right_wheel_0/velocity", "right_wheel_1/velocity"]),
    ("open_loop: true", []),
])
def test_it_claims_each_wheels_velocity_and_reads_its_feedback(params: str,
                                                               states: list[str]) -> None:
    """``.cpp:74-105``: ``<wheel>/velocity`` commands of the left then the right wheels;
    ``<wheel>/position`` states (velocity with ``position_feedback: false``; none with
    ``open_loop: true``)."""
    rig = Rig(f"diff_drive_controller:\n  ros__parameters:\n    {params or 'open_loop: false'}\n",
              per_side=2)
    try:
        claimed = rig.manager.interfaces.claimed_by("diff_drive_controller")
        assert claimed == ["left_wheel_0/velocity", "left_wheel_1/velocity",
                           "right_wheel_0/velocity", "right_wheel_1/velocity"], \
            f"claimed {claimed}"
        required = rig.manager.controller_state(rig.controller).required_state_interfaces
        assert list(required) == states, f"state interfaces {list(required)}"
    finally:
        rig.close()


# -- cmd_vel to the wheels ------------------------------------------------------------------------

def test_nothing_is_written_before_a_command() -> None:
    """``.cpp:162-166``: the reference is NaN after configure (``reset_buffers``,
    ``.cpp:642-667``), so the wheels keep what the hardware holds and odometry waits."""
    rig = Rig()
    try:
        rig.spin(0.3)
        assert rig.odom == [], f"{len(rig.odom)} odometry messages before any command"
        commands = rig.commands()
        assert all(math.isnan(v) for v in commands.values()), f"wheel commands {commands}"
    finally:
        rig.close()


def test_a_command_turns_each_wheel_by_its_sides_radius_with_the_multipliers() -> None:
    """``.cpp:179-182`` and ``.cpp:296-310``: separation x wheel_separation_multiplier,
    each side's radius x its multiplier; every wheel of a side gets its side's velocity."""
    rig = Rig("diff_drive_controller:\n  ros__parameters:\n"
              "    wheel_separation_multiplier: 1.2\n    left_wheel_radius_multiplier: 0.9\n"
              "    right_wheel_radius_multiplier: 1.1\n", per_side=2)
    try:
        rig.send(0.3, 0.8)
        rig.spin(0.05)
        left, right = rim(0.3, 0.8, SEPARATION * 1.2, RADIUS * 0.9, RADIUS * 1.1)
        commands = rig.commands()
        assert commands == pytest.approx({"left_wheel_0": left, "left_wheel_1": left,
                                          "right_wheel_0": right, "right_wheel_1": right},
                                         rel=1e-12), f"wheel commands {commands}"
    finally:
        rig.close()


def test_velocity_and_acceleration_limits_apply_and_the_limited_command_is_published() -> None:
    """``.cpp:174-177``: the reference goes through the rate limiter (``linear.x.*``,
    ``angular.z.*`` of parameter.yaml) before the wheels; ``.cpp:284-294``: with
    ``publish_limited_velocity`` the limited twist goes out on ``~/cmd_vel_out`` every
    update."""
    rig = Rig("diff_drive_controller:\n  ros__parameters:\n"
              "    publish_limited_velocity: true\n"
              "    linear.x.max_velocity: 0.4\n    linear.x.max_acceleration: 1.0\n"
              "    angular.z.max_velocity: 1.5\n")
    try:
        rig.send(2.0, -3.0)
        rig.spin(0.05)
        first = rig.limited[0].twist  # the first update with a reference (.cpp:162-166)
        # from rest, 1.0 m/s^2 for one 0.01 s period; angular has no acceleration limit
        assert (first.linear.x, first.angular.z) == pytest.approx((0.01, -1.5)), \
            f"first limited command {first.linear.x}, {first.angular.z}"
        rig.hold(2.0, -3.0, 1.0)
        last = rig.limited[-1].twist
        assert (last.linear.x, last.angular.z) == pytest.approx((0.4, -1.5)), \
            f"limited command {last.linear.x}, {last.angular.z}"
        commands = rig.commands()
        left, right = rim(0.4, -1.5)
        assert commands == pytest.approx({"left_wheel_0": left, "right_wheel_0": right}), \
            f"wheel commands {commands}"
        gaps = {round(b.header.stamp.nanosec - a.header.stamp.nanosec, -3) % 1_000_000_000
                for a, b in zip(rig.limited, rig.limited[1:], strict=False)}
        assert gaps == {10_000_000}, f"cmd_vel_out every update: gaps {gaps} ns"
    finally:
        rig.close()


def test_a_stale_command_brakes_to_zero(rig: Rig) -> None:
    """``.cpp:120-131``: a command older than ``cmd_vel_timeout`` (0.5 s, parameter.yaml) sets
    the reference to zero ("Velocity command timed out. Braking.")."""
    rig.send(0.2, 0.0)
    rig.spin(0.45)
    moving = rig.commands()
    assert moving == pytest.approx({"left_wheel_0": 2.0, "right_wheel_0": 2.0}), \
        f"wheel commands 0.45 s after the command {moving}"
    rig.spin(0.1)
    stopped = rig.commands()
    assert stopped == {"left_wheel_0": 0.0, "right_wheel_0": 0.0}, \
        f"wheel commands 0.55 s after the command {stopped}"


def test_a_timeout_of_zero_keeps_the_last_command() -> None:
    """parameter.yaml: "A value of 0.0 disables the timeout" (``.cpp:121``)."""
    rig = Rig("diff_drive_controller:\n  ros__parameters:\n    cmd_vel_timeout: 0.0\n")
    try:
        rig.send(0.2, 0.0)
        rig.spin(2.0)
        commands = rig.commands()
        assert commands == pytest.approx({"left_wheel_0": 2.0, "right_wheel_0": 2.0}), \
            f"wheel commands 2 s after the command {commands}"
    finally:
        rig.close()


def test_a_message_older_than_the_timeout_is_ignored_and_a_zero_stamp_is_now(rig: Rig) -> None:
    """``.cpp:469-494``: a zero stamp is set to the current time; a message whose stamp is
    older than ``cmd_vel_timeout`` is ignored."""
    rig.send(0.3, 0.0, stamp=rig.context.ros_time() - 0.6)
    rig.spin(0.05)
    ignored = rig.commands()
    assert all(math.isnan(v) for v in ignored.values()), \
        f"wheel commands after a 0.6 s old command {ignored}"
    rig.send(0.3, 0.0, stamp=0)
    rig.spin(0.05)
    taken = rig.commands()
    assert taken == pytest.approx({"left_wheel_0": 3.0, "right_wheel_0": 3.0}), \
        f"wheel commands after a zero-stamped command {taken}"


def test_a_command_holding_nan_leaves_the_reference(rig: Rig) -> None:
    """``.cpp:132-143``: "Command message contains NaNs. Not updating reference
    interfaces."."""
    rig.send(0.1, 0.0)
    rig.spin(0.05)
    rig.send(math.nan, 1.0)
    rig.spin(0.05)
    commands = rig.commands()
    assert commands == pytest.approx({"left_wheel_0": 1.0, "right_wheel_0": 1.0}), \
        f"wheel commands after a NaN command {commands}"


def test_deactivating_sets_the_wheels_to_zero_and_forgets_the_command(rig: Rig) -> None:
    """``.cpp:596-605`` and ``halt`` ``.cpp:669-685``: every wheel's velocity to 0, the
    reference back to NaN (``reset_buffers``); commands are refused while inactive
    (``.cpp:464-468``)."""
    rig.send(0.2, 0.5)
    rig.spin(0.1)
    rig.deactivate()
    stopped = rig.commands()
    assert stopped == {"left_wheel_0": 0.0, "right_wheel_0": 0.0}, \
        f"wheel commands after deactivation {stopped}"
    rig.send(0.3, 0.0)  # refused: inactive
    rig.spin(0.05)
    rig.activate()
    rig.spin(0.2)
    again = rig.commands()
    assert again == {"left_wheel_0": 0.0, "right_wheel_0": 0.0}, \
        f"wheel commands after reactivation with no new command {again}"


# -- odometry ----------------------------------------------------------------------------------

def test_odometry_integrates_the_wheel_positions_along_their_arc(rig: Rig) -> None:
    """``.cpp:190-224`` feeds odometry.cpp's ``update`` the wheel positions; for wheels turning
    at constant speeds the pose is the arc they draw: heading = (r.right - r.left) /
    separation, x = s sin(h) / h, y = s (1 - cos(h)) / h with s the mean travel."""
    rig.hold(0.25, 0.6, 3.0)
    positions = rig.positions()
    travel_l, travel_r = positions["left_wheel_0"] * RADIUS, positions["right_wheel_0"] * RADIUS
    heading = (travel_r - travel_l) / SEPARATION
    s = (travel_l + travel_r) / 2
    odometry = rig.controller.odometry
    assert odometry is not None, "no odometry after configure"
    assert heading == pytest.approx(0.6 * 3.0, abs=0.6 * 0.02), f"heading {heading}"
    pose = odometry.pose
    assert pose == pytest.approx((s * math.sin(heading) / heading,
                                  s * (1 - math.cos(heading)) / heading, heading),
                                 abs=1e-9), f"odometry pose {pose}"
    last = rig.odom[-1]
    assert (last.pose.pose.position.x, last.pose.pose.position.y) == pytest.approx(
        pose[:2], abs=0.25 * 0.02 + 1e-9), f"published pose {last.pose.pose.position}"
    assert 2 * math.atan2(last.pose.pose.orientation.z, last.pose.pose.orientation.w) == \
        pytest.approx(pose[2], abs=0.6 * 0.02), f"published orientation {last.pose.pose}"
    twist = last.twist.twist
    assert (twist.linear.x, twist.angular.z) == pytest.approx((0.25, 0.6), rel=1e-9), \
        f"published twist {twist.linear.x}, {twist.angular.z}"


def test_odometry_is_published_at_publish_rate_with_its_frames_and_covariance() -> None:
    """``.cpp:237-281``: ``~/odom`` and ``/tf`` at most ``publish_rate`` (50 Hz default) a
    second; ``.cpp:504-532``: frames prefixed by the namespace when ``tf_frame_prefix`` is
    empty; ``.cpp:542-549``: the covariance diagonals."""
    rig = Rig("/**:\n  ros__parameters:\n    pose_covariance_diagonal: [1.0, 2.0, 3.0, 4.0, "
              "5.0, 6.0]\n    base_frame_id: base_footprint\n", namespace="/robot1")
    try:
        rig.hold(0.1, 0.0, 1.0)
        count = len(rig.odom)
        assert 49 <= count <= 51, f"{count} odometry messages in 1 s at 50 Hz"
        message = rig.odom[-1]
        frames = (message.header.frame_id, message.child_frame_id)
        assert frames == ("robot1/odom", "robot1/base_footprint"), f"frames {frames}"
        diagonal = [message.pose.covariance[7 * i] for i in range(6)]
        assert diagonal == [1.0, 2.0, 3.0, 4.0, 5.0, 6.0], f"pose covariance {diagonal}"
        (transform,) = rig.tf[-1].transforms
        assert (transform.header.frame_id, transform.child_frame_id) == frames, \
            f"transform {transform.header.frame_id} -> {transform.child_frame_id}"
        assert transform.transform.translation.x == message.pose.pose.position.x, \
            f"transform x {transform.transform.translation.x}"
    finally:
        rig.close()


def test_no_transform_without_enable_odom_tf() -> None:
    """``.cpp:269``: ``/tf`` only with ``enable_odom_tf``."""
    rig = Rig("diff_drive_controller:\n  ros__parameters:\n    enable_odom_tf: false\n")
    try:
        rig.send(0.1, 0.0)
        rig.spin(0.3)
        assert rig.odom and not rig.tf, f"{len(rig.odom)} odom, {len(rig.tf)} tf messages"
    finally:
        rig.close()


# -- refusals ------------------------------------------------------------------------------------

@pytest.mark.parametrize(("params", "words"), [
    ("wheel_separation: 0.0", "parameter 'wheel_separation' is 0.0"),
    ("right_wheel_names: [right_wheel_0, left_wheel_0]",
     "The number of left wheels [1] and the number of right wheels [2] are different"),
    ("left_wheel_radius_multiplier: -1.0", "left_wheel_radius must be positive, got -0.1"),
    ("twist_covariance_diagonal: [0.1, 0.1]", "'twist_covariance_diagonal' is [0.1, 0.1]"),
    ("linear.x.max_velocity: -1.0", "Failed to configure linear speed limiter: "
     "linear.x.max_velocity must be >= 0 or NaN, got -1.0"),
])
def test_a_bad_parameter_is_refused_at_configure_naming_it(params: str, words: str) -> None:
    """parameter.yaml's validation (``gt<>``, ``not_empty<>``, the limits' signs),
    ``.cpp:330-336`` for unequal sides, and servolab's own refusals (a non-positive
    multiplier, a covariance diagonal that is not six numbers)."""
    rig = Rig(f"diff_drive_controller:\n  ros__parameters:\n    {params}\n", activate=False)
    try:
        ok, message = rig.configured
        assert not ok and words in message, f"configure said {ok}, {message!r}"
    finally:
        rig.close()


# -- the TurtleBot3 Waffle on the floor ---------------------------------------------------------

class Waffle:
    """The Waffle brought up as ``servolab control run turtlebot3_waffle --world robot
    --spawn joint_state_broadcaster diff_drive_controller`` does, in virtual time."""

    def __init__(self) -> None:
        from servolab.robots.registry import entry

        plugin = entry("turtlebot3_waffle")
        assert plugin.description is not None, f"{plugin.name} has no URDF"
        (controllers,) = [v for k, v in plugin.shown_files().items()
                          if k.endswith(".controllers")]
        self.system = ControlSystem(
            plugin.description(), "turtlebot3_waffle.urdf",
            ParameterOverrides.from_file(str(controllers)),
            BringUpOptions(world="robot", place=plugin.serve(None).place, real_time=False,
                           spawn=("joint_state_broadcaster", "diff_drive_controller")))
        self.context = self.system.context
        self.floor = self.system.world
        self.probe = Node(self.context, "probe")
        self.cmd_vel = self.probe.create_publisher(TWIST, "/diff_drive_controller/cmd_vel", 10)
        self.odom: list[Any] = []
        self.probe.create_subscription("nav_msgs/msg/Odometry", "/diff_drive_controller/odom",
                                       self.odom.append, 10)
        from servolab.robots.base.config import load, shipped_base

        self.config = load(shipped_base("turtlebot3_waffle"))
        model = self.config.model
        #: one encoder tick of a wheel's travel (m): what odometry resolves
        self.tick = model.rad_per_tick * self.config.wheel_radius

    def drive(self, linear: float, angular: float, done: Any, timeout: float) -> None:
        """cmd_vel at 20 Hz until ``done(odometry message)`` (looked at every 10 ms, as
        ``servolab drive`` looks at its odometry), then a zero command and 0.5 s for the
        wheels to stop."""
        end = self.context.clock.now() + timeout
        steps = 0
        while not (self.odom and done(self.odom[-1])):
            assert self.context.clock.now() < end, f"not done in {timeout} s"
            if steps % 5 == 0:
                self.send(linear, angular)
            self.context.spin_for(0.01)
            steps += 1
        self.send(0.0, 0.0)
        self.context.spin_for(0.5)

    def send(self, linear: float, angular: float) -> None:
        self.cmd_vel.publish(self.probe.message(
            TWIST, header={"stamp": self.probe.stamp()},
            twist={"linear": {"x": linear}, "angular": {"z": angular}}))

    def pose(self) -> tuple[float, float, float]:
        p = self.odom[-1].pose.pose
        return (p.position.x, p.position.y,
                2 * math.atan2(p.orientation.z, p.orientation.w))

    def goal_velocities(self) -> list[int]:
        bus = self.system.buses[0]
        return [int(bus.read(i, "goal_velocity", raw=True)) for i in (1, 2)]


@pytest.fixture
def waffle() -> Iterator[Waffle]:
    made = Waffle()
    try:
        yield made
    finally:
        made.system.close()


def test_the_waffle_drives_a_metre_and_odometry_agrees_with_the_floor(waffle: Waffle) -> None:
    """1 m at 0.2 m/s by cmd_vel, stopped when ``~/odom`` says 1 m. docs/mobile.md: on the
    emulated bases "a 1 m line ends within 1 % of 1 m" (lines 65-67), and with no slip
    "odometry follows the truth to within the encoders' resolution" (lines 97-98): one tick
    of wheel travel, 0.033 m x 2 pi / 4096 = 0.05 mm; the heading within two ticks over the
    separation."""
    waffle.drive(0.2, 0.0, lambda m: m.pose.pose.position.x >= 1.0, timeout=10.0)
    truth = waffle.floor.ground_truth()
    x, y, yaw = waffle.pose()
    assert truth["x"] == pytest.approx(1.0, rel=0.01), f"the base drove {truth['x']} m"
    error = math.hypot(x - truth["x"], y - truth["y"])
    assert error <= waffle.tick, \
        f"odometry ({x}, {y}) is {error * 1e3:.4f} mm from the floor's ({truth['x']}, " \
        f"{truth['y']}), over one tick {waffle.tick * 1e3:.4f} mm"
    assert abs(yaw - truth["yaw"]) <= 2 * waffle.tick / waffle.config.wheel_separation, \
        f"odometry yaw {yaw}, the floor's {truth['yaw']}"
    assert waffle.goal_velocities() == [0, 0], f"goal velocities {waffle.goal_velocities()}"


def test_the_waffle_turns_and_odometry_agrees_with_the_floor(waffle: Waffle) -> None:
    """A quarter turn at 0.1 m/s and 0.5 rad/s (an arc of 0.2 m radius), stopped when
    ``~/odom``'s yaw passes 90 degrees. docs/mobile.md's "to within the encoders' resolution"
    (lines 97-98) for a turn: the heading within two ticks of wheel travel over the
    separation (0.35 mrad), the position within one tick plus that heading error held over
    the whole distance driven."""
    waffle.drive(0.1, 0.5, lambda m: 2 * math.atan2(m.pose.pose.orientation.z,
                                                    m.pose.pose.orientation.w) >= math.pi / 2,
                 timeout=10.0)
    truth = waffle.floor.ground_truth()
    x, y, yaw = waffle.pose()
    heading_resolution = 2 * waffle.tick / waffle.config.wheel_separation
    assert abs(yaw - truth["yaw"]) <= heading_resolution, \
        f"odometry yaw {yaw}, the floor's {truth['yaw']} (resolution {heading_resolution})"
    assert truth["yaw"] == pytest.approx(math.pi / 2, abs=0.05), \
        f"the base turned {math.degrees(truth['yaw'])} deg"
    # an arc of radius 0.2 m: 90 degrees end near (0.2, 0.2)
    assert (truth["x"], truth["y"]) == pytest.approx((0.2, 0.2), abs=0.01), \
        f"the base ended at ({truth['x']}, {truth['y']})"
    error = math.hypot(x - truth["x"], y - truth["y"])
    bound = waffle.tick + heading_resolution * truth["distance"]
    assert error <= bound, \
        f"odometry ({x}, {y}) is {error * 1e3:.4f} mm from the floor's ({truth['x']}, " \
        f"{truth['y']}), over {bound * 1e3:.4f} mm"


def test_deactivating_the_controller_stops_the_waffle(waffle: Waffle) -> None:
    """``.cpp:596-605``: deactivated, the wheels are told 0, which the next write takes to
    the motors (goal velocity 0) and the floor stops."""
    waffle.send(0.2, 0.0)
    waffle.context.spin_for(0.3)
    assert waffle.floor.ground_truth()["linear_velocity"] > 0.19, "the base is not moving"
    ok, message = waffle.system.manager.switch_controller([], ["diff_drive_controller"],
                                                          STRICT)
    assert ok, message
    waffle.context.spin_for(0.1)
    truth = waffle.floor.ground_truth()
    assert truth["linear_velocity"] == 0.0, f"the base still moves at {truth['linear_velocity']}"
    assert waffle.goal_velocities() == [0, 0], f"goal velocities {waffle.goal_velocities()}"


def test_stopping_the_controller_manager_stops_the_wheels(waffle: Waffle) -> None:
    """Ctrl-C on ``servolab control run`` closes the manager while the base drives: the
    motors' goal velocities read 0 afterwards (the controller's zero reaches them in one last
    write, and the hardware's deactivation stops a velocity joint itself), so a real Waffle
    stops. ROBOTIS's and the community plugin leave the last goal in the motor."""
    waffle.send(0.2, 0.0)
    waffle.context.spin_for(0.3)
    assert waffle.goal_velocities() != [0, 0], "the base is not driving"
    waffle.system.manager.close()
    assert waffle.goal_velocities() == [0, 0], f"goal velocities {waffle.goal_velocities()}"


def test_the_waffles_controllers_file_has_its_base_files_figures() -> None:
    """One fact, one place: the controllers file repeats the base file's geometry and
    limits (ROS reads it alone), so they are held equal here."""
    import yaml

    from servolab.robots.base.config import load, shipped_base
    from servolab.robots.base.ros2_control import controllers_file

    config = load(shipped_base("turtlebot3_waffle"))
    path = controllers_file("turtlebot3_waffle")
    assert path is not None, "no turtlebot3_waffle_controllers.yaml beside the base file"
    parameters = yaml.safe_load(path.read_text())["diff_drive_controller"]["ros__parameters"]
    figures = (parameters["wheel_radius"], parameters["wheel_separation"],
               parameters["linear"]["x"]["max_velocity"],
               parameters["angular"]["z"]["max_velocity"])
    assert figures == (config.wheel_radius, config.wheel_separation,
                       config.max_linear_velocity, config.max_angular_velocity), \
        f"controllers file {figures}"
