"""Many robots in one graph: every robot command takes ``--namespace``, as ROS 2 multi-robot
setups run a fleet. Two emulated TurtleBot3 Waffles under ``/robot1`` and ``/robot2`` in one
process and in two processes over Zenoh: a command to one moves that one only, each one's
topics are in its namespace and its tf frames carry its prefix, and nothing of one arrives
under the other; a bad namespace is refused in one line; no namespace gives a robot alone's
names.

The ROS facts checked, and where they come from:

- a relative name (``cmd_vel``) resolves in the node's namespace (``/robot1/cmd_vel``), an
  absolute one (``/tf``) ignores it: the ROS 2 design article "Topic and Service names"
  (design.ros2.org/articles/topic_and_service_names.html) and rcl's
  ``rcl/src/rcl/expand_topic_name.c``; ``/clock``, ``/parameter_events`` and ``/rosout`` are
  created absolute by rclcpp and rclpy, ``/tf`` and ``/tf_static`` by tf2_ros' broadcasters;
- a namespaced robot's frames are ``<namespace without its leading />/<frame>``:
  robot_state_publisher's ``frame_prefix`` parameter (``robot_state_publisher.cpp`` declares
  it, empty by default, and puts it before every frame it publishes on the absolute ``/tf``
  and ``/tf_static`` its README names), set to ``namespace + '/'`` by
  ROBOTIS-GIT/turtlebot3's ``turtlebot3_bringup/launch/turtlebot3_state_publisher.launch.py``
  and to ``TB3_n/`` beside ``PushRosNamespace('TB3_n')`` (and the diff-drive plugin's
  ``odometry_frame`` ``TB3_n/odom``) by turtlebot3_simulations'
  ``turtlebot3_gazebo/launch/multi_robot.launch.py``, every robot on the one global ``/tf``;
  diff_drive_controller's ``tf_frame_prefix`` defaults to its node's namespace that way
  (ros2_controllers ``diff_drive_controller.cpp``, jazzy). nav2_bringup's multi-robot launch
  (``navigation_launch.py``) takes the other convention, remapping ``/tf`` to ``tf`` so each
  robot has a tree of its own: servolab follows TurtleBot3's, which keeps one tree a viewer
  can show whole;
- joint_state_broadcaster publishes ``joint_states`` relative (``joint_state_broadcaster.cpp``:
  ``topic_name_prefix`` is ``"~/"`` or ``""``), so a namespaced controller manager's is the
  robot's;
- a parameter file's node name without a leading ``/`` is the root's (rclcpp's
  ``parameter_map.cpp`` prepends one), so one robot's file is rewritten for each robot of a
  fleet: nav2_bringup's ``RewrittenYaml(root_key=namespace)``.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from mcap_ros2.reader import read_ros2_messages

from servolab.middleware.context import Context
from servolab.middleware.names import GLOBAL_TOPICS, frame_prefix, in_namespace
from servolab.middleware.node import Node
from servolab.middleware.parameters import ParameterOverrides
from servolab.middleware.qos import DurabilityPolicy, QoSProfile
from servolab.middleware.transport import TransportOptions
from tests.clirun import SERVOLAB, refusal, servolab
from tests.middleware.conftest import free_port
from tests.processes import started
from tests.waiting import wait_for, wait_for_line

TWIST, TWIST_STAMPED = "geometry_msgs/msg/Twist", "geometry_msgs/msg/TwistStamped"
ODOMETRY, TF = "nav_msgs/msg/Odometry", "tf2_msgs/msg/TFMessage"
ROBOTS = ("/robot1", "/robot2")
#: tf2_ros' StaticListenerQoS: TRANSIENT_LOCAL, depth 100, so every robot's latched
#: /tf_static is kept, not only the last to arrive
STATIC_LISTENER = QoSProfile(depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL)


# -- the names ------------------------------------------------------------------------------

def test_a_namespace_prefixes_frames_and_keeps_the_global_topics() -> None:
    """robot_state_publisher's frame_prefix as turtlebot3_bringup sets it (namespace + '/');
    diff_drive_controller's default tf_frame_prefix (namespace, leading / removed, trailing /
    added); rcl's expansion of a relative name; the topics rclcpp and tf2_ros create
    absolute."""
    assert [frame_prefix(ns) for ns in ("/", "", "/robot1", "robot1", "/fleet/robot1")] == \
        ["", "", "robot1/", "robot1/", "fleet/robot1/"]
    assert in_namespace("/odom", "/robot1") == "/robot1/odom"
    assert in_namespace("/navigate_to_pose/_action/status", "robot2") == \
        "/robot2/navigate_to_pose/_action/status"
    assert [in_namespace(topic, "/robot1") for topic in GLOBAL_TOPICS] == list(GLOBAL_TOPICS)
    assert in_namespace("/odom", "/") == "/odom"
    assert set(GLOBAL_TOPICS) == {"/clock", "/parameter_events", "/rosout", "/tf", "/tf_static"}


def test_one_robots_parameter_file_applies_in_its_namespace() -> None:
    """rclcpp reads a file's ``controller_manager:`` as ``/controller_manager``; the file is
    rewritten for the robot's namespace as nav2_bringup's RewrittenYaml(root_key=namespace)
    does; ``/**`` stays every node's, and a node already named in the namespace is kept."""
    overrides = ParameterOverrides.from_text(
        "controller_manager:\n  ros__parameters:\n    update_rate: 50\n"
        "/**:\n  ros__parameters:\n    use_sim_time: false\n"
        "/robot1/diff_drive_controller:\n  ros__parameters:\n    wheel_radius: 0.033\n")
    moved = overrides.in_namespace("/robot1")
    assert moved.by_node == {"/robot1/controller_manager": {"update_rate": 50},
                             "/**": {"use_sim_time": False},
                             "/robot1/diff_drive_controller": {"wheel_radius": 0.033}}
    assert moved.for_node("/robot1/controller_manager") == {"update_rate": 50,
                                                            "use_sim_time": False}
    assert overrides.in_namespace("/").by_node == overrides.by_node
    # the robot's own entry wins over the general one, whichever the file writes first
    both = ParameterOverrides.from_text(
        "/robot1/controller_manager:\n  ros__parameters:\n    update_rate: 100\n"
        "controller_manager:\n  ros__parameters:\n    update_rate: 50\n    x: 1\n")
    assert both.in_namespace("/robot1").by_node == {
        "/robot1/controller_manager": {"update_rate": 100, "x": 1}}


# -- a bad namespace, and none -----------------------------------------------------------------

@pytest.mark.parametrize("argv", [
    ["drive", "line", "--distance", "0.1"],
    ["navigate", "--goal", "3.3", "2.3"],
    ["control", "run", "turtlebot3_waffle"],
    ["control", "list_controllers"],
], ids=["drive", "navigate", "control run", "control list_controllers"])
@pytest.mark.parametrize("bad", ["robot-1", "/1robot", "/robot1/"])
def test_a_bad_namespace_is_refused_in_one_line(argv: list[str], bad: str,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    """rmw's namespace rules (validate_namespace.c): one line naming the value, the rule, and
    what to give; nothing is run (argparse refuses it before the command starts)."""
    status, line = refusal([*argv, "--namespace", bad], capsys)
    assert status == 2, line
    assert f"argument --namespace: '{bad}': namespace must not" in line, line
    assert line.endswith("give one such as /robot1"), line


def test_no_namespace_gives_a_robot_alones_names() -> None:
    """Without --namespace nothing moves: the base node's /cmd_vel, /odom and /tf with
    TurtleBot3's frames odom -> base_footprint, as turtlebot3_node names them."""
    from servolab.robots.base.config import load, resolve
    from servolab.robots.base.mobile_base import MobileBase
    from servolab.robots.base.node import BaseNode

    base = MobileBase.emulated(load(resolve("turtlebot3_waffle")))
    with Context.open(clock=base.clock) as ctx:
        node = BaseNode(ctx, base)
        odom: list[Any] = []
        probe = Node(ctx, "probe")
        probe.create_subscription(ODOMETRY, "/odom", odom.append, 0)
        ctx.spin_until(lambda: bool(odom), timeout=5.0)
        names = {e.name for e in ctx.transport.graph() if e.node == node.fully_qualified_name
                 and e.kind in ("MP", "MS")}
        assert {"/cmd_vel", "/odom", "/tf", "/joint_states", "/sensor_state"} <= names, names
        assert (odom[-1].header.frame_id, odom[-1].child_frame_id) == ("odom", "base_footprint")


# -- two robots in one process -----------------------------------------------------------------

@pytest.fixture
def two_waffles() -> Iterator[Context]:
    """Two emulated Waffles on their floors in real time, each a launch's base_robot in its
    namespace, in one process on one (in-process) graph."""
    from servolab.robots.base.node import BaseRobot

    with Context.open() as ctx:
        for namespace in ROBOTS:
            BaseRobot(ctx, "base_robot", namespace,
                      parameter_overrides={"base": "turtlebot3_waffle"})
        yield ctx


def _own_topics_only(ctx: Context) -> None:
    """Every publisher and subscription of a robot's node is on a topic of its namespace or a
    global one: nothing one robot publishes can reach the other."""
    seen = dict.fromkeys(ROBOTS, 0)
    for endpoint in ctx.transport.graph():
        for namespace in ROBOTS:
            if endpoint.kind in ("MP", "MS") and endpoint.node.startswith(namespace + "/"):
                seen[namespace] += 1
                assert endpoint.name.startswith(namespace + "/") or \
                    endpoint.name in GLOBAL_TOPICS, \
                    f"{endpoint.node}'s {endpoint.kind} on {endpoint.name}"
    assert all(seen.values()), f"the graph shows no topic of a robot: {seen}"


def test_a_cmd_vel_to_robot1_moves_robot1_only_in_one_process(two_waffles: Context) -> None:
    ctx = two_waffles
    probe = Node(ctx, "probe")
    odom: dict[str, list[Any]] = {ns: [] for ns in ROBOTS}
    truth: dict[str, list[Any]] = {ns: [] for ns in ROBOTS}
    tf: list[Any] = []
    for ns in ROBOTS:
        probe.create_subscription(ODOMETRY, f"{ns}/odom", odom[ns].append, 0)
        probe.create_subscription(ODOMETRY, f"{ns}/ground_truth", truth[ns].append, 0)
    probe.create_subscription(TF, "/tf", tf.append, 0)
    cmd_vel = probe.create_publisher(TWIST, "/robot1/cmd_vel", 10)
    probe.create_timer(0.1, lambda: cmd_vel.publish(probe.message(TWIST, linear={"x": 0.2})))
    assert ctx.spin_until(lambda: bool(odom["/robot1"]) and
                          odom["/robot1"][-1].pose.pose.position.x > 0.05, timeout=20.0), \
        odom["/robot1"][-1:] or "no odometry from /robot1"
    assert truth["/robot1"][-1].pose.pose.position.x > 0.03, "robot1 did not move on its floor"
    assert odom["/robot2"] and truth["/robot2"], "robot2 published nothing"
    assert all(m.pose.pose.position.x == 0.0 and m.twist.twist.linear.x == 0.0
               for m in odom["/robot2"]), "robot2's odometry moved"
    assert all(m.pose.pose.position.x == 0.0 for m in truth["/robot2"]), "robot2 moved"
    for ns in ROBOTS:
        prefix = frame_prefix(ns)
        assert {(m.header.frame_id, m.child_frame_id) for m in odom[ns]} == \
            {(f"{prefix}odom", f"{prefix}base_footprint")}
        assert {m.child_frame_id for m in truth[ns]} == {f"{prefix}base_footprint"}
    frames = {(t.header.frame_id, t.child_frame_id) for m in tf for t in m.transforms}
    assert frames == {("robot1/odom", "robot1/base_footprint"),
                      ("robot2/odom", "robot2/base_footprint")}, frames
    # the graph API lists both namespaces, each robot on its own topics
    nodes = {e.node for e in ctx.transport.graph() if e.kind == "NN"}
    assert {"/robot1/base", "/robot2/base", "/robot1/base_robot", "/robot2/base_robot",
            "/robot1/ground_truth", "/robot2/ground_truth"} <= nodes, nodes
    _own_topics_only(ctx)


# -- servolab drive, navigate and control run in a namespace ------------------------------------

def _bag(folder: Path) -> dict[str, list[Any]]:
    (mcap,) = folder.glob("*.mcap")
    topics: dict[str, list[Any]] = {}
    for message in read_ros2_messages(str(mcap)):
        topics.setdefault(message.channel.topic, []).append(message.ros_msg)
    return topics


def test_drive_records_and_shows_the_robots_names(tmp_path: Path) -> None:
    """``servolab drive --namespace /robot1``: the bag and the view name the robot's topics
    and frames alike."""
    from servolab.robots.base.config import load, resolve
    from servolab.robots.base.mobile_base import MobileBase
    from servolab.robots.base.run import DrivePublisher, run_drive
    from servolab.runs import RunFolder

    summary = run_drive(RunFolder.create("drive", tmp_path / "run"), "line", distance=0.1,
                        base="turtlebot3_waffle", namespace="robot1", say=lambda _: None,
                        show_progress=False)
    assert summary["namespace"] == "/robot1"
    topics = _bag(Path(str(summary["bag"])))
    assert set(topics) == {"/robot1/odom", "/robot1/ground_truth", "/robot1/wheel_commands"}
    assert {(m.header.frame_id, m.child_frame_id) for m in topics["/robot1/odom"]} == \
        {("robot1/odom", "robot1/base_footprint")}
    assert {(m.header.frame_id, m.child_frame_id) for m in topics["/robot1/ground_truth"]} == \
        {("world", "robot1/base_footprint")}

    robot = MobileBase.emulated(load(resolve("turtlebot3_waffle")))
    with Context.open(clock=robot.clock) as ctx:
        shown = DrivePublisher(ctx, robot, "/robot1")
        heard: dict[str, list[Any]] = {"/robot1/odom": [], "/tf": []}
        probe = Node(ctx, "probe")
        for topic, kind in (("/robot1/odom", ODOMETRY), ("/tf", TF)):
            probe.create_subscription(kind, topic, heard[topic].append, 0)
        robot.line(0.05, 0.1)
        robot.update_odometry()
        shown.publish_new()
        assert heard["/robot1/odom"][-1].header.frame_id == "robot1/odom"
        (transform,) = heard["/tf"][-1].transforms
        assert (transform.header.frame_id, transform.child_frame_id) == \
            ("robot1/odom", "robot1/base_footprint")
        robot.bus.close()


@pytest.mark.slow
def test_navigate_runs_every_node_in_the_namespace(tmp_path: Path) -> None:
    """``servolab navigate --namespace /robot1``: the six nodes there, the bag's topics the
    robot's but /tf and /clock, the robot's frames prefixed, the map's not."""
    from servolab.robots.navigation.run import RECORDED, prepare, run_navigate
    from servolab.runs import RunFolder

    summary = run_navigate(RunFolder.create("navigate", tmp_path / "run"),
                           prepare((3.3, 2.3), namespace="/robot1"), say=lambda _: None,
                           show_progress=False)
    assert summary["status"] == "SUCCEEDED", summary.get("reason")
    topics = _bag(Path(str(summary["bag"])))
    assert set(topics) <= {in_namespace(topic, "/robot1") for topic in RECORDED}
    assert {"/robot1/cmd_vel", "/robot1/odom", "/robot1/map", "/robot1/fused_pose", "/tf",
            "/clock"} <= set(topics), sorted(topics)
    frames = {(t.header.frame_id, t.child_frame_id) for m in topics["/tf"]
              for t in m.transforms}
    assert frames == {("map", "robot1/odom"), ("robot1/odom", "robot1/base_footprint")}, frames
    assert topics["/robot1/odometry/filtered"][-1].child_frame_id == "robot1/base_footprint"
    assert topics["/robot1/map"][-1].header.frame_id == "map"


def test_control_run_puts_every_node_in_the_namespace() -> None:
    """``servolab control run turtlebot3_waffle --namespace /robot1``, in process on emulated
    wheels in virtual time: the controller manager, both controllers and
    robot_state_publisher in /robot1 with the robot's own controllers file, the robot's
    topics there, its frames prefixed on the global /tf and /tf_static."""
    from servolab.apps.control import robot_files
    from servolab.robots.control.bringup import BringUpOptions, ControlSystem

    urdf, source, controllers, plugin = robot_files("turtlebot3_waffle", None)
    assert controllers is not None and plugin is not None
    options = BringUpOptions(world="robot", place=plugin.serve(None).place, real_time=False,
                             spawn=("joint_state_broadcaster", "diff_drive_controller"),
                             namespace="/robot1")
    with ControlSystem(urdf, source, ParameterOverrides.from_file(controllers),
                       options) as system:
        ctx = system.context
        probe = Node(ctx, "probe")
        odom: list[Any] = []
        static: list[Any] = []
        probe.create_subscription(ODOMETRY, "/robot1/diff_drive_controller/odom", odom.append, 0)
        probe.create_subscription(TF, "/tf_static", static.append, STATIC_LISTENER)
        cmd_vel = probe.create_publisher(TWIST_STAMPED, "/robot1/diff_drive_controller/cmd_vel")
        for _ in range(10):
            cmd_vel.publish(probe.message(TWIST_STAMPED, header={"stamp": probe.stamp()},
                                          twist={"linear": {"x": 0.2}}))
            ctx.spin_for(0.1)
        assert odom and odom[-1].pose.pose.position.x > 0.05, odom[-1:]
        assert (odom[-1].header.frame_id, odom[-1].child_frame_id) == \
            ("robot1/odom", "robot1/base_footprint")
        fixed = {(t.header.frame_id, t.child_frame_id) for m in static for t in m.transforms}
        assert ("robot1/base_footprint", "robot1/base_link") in fixed, fixed
        assert all(f.startswith("robot1/") for pair in fixed for f in pair), fixed
        graph = ctx.transport.graph()
        nodes = {e.node for e in graph if e.kind == "NN"} - {"/probe"}
        assert nodes == {"/robot1/controller_manager", "/robot1/joint_state_broadcaster",
                         "/robot1/diff_drive_controller", "/robot1/robot_state_publisher"}
        published = {e.name for e in graph if e.kind == "MP" and e.node != "/probe"}
        assert {"/robot1/joint_states", "/robot1/dynamic_joint_states",
                "/robot1/robot_description", "/robot1/diff_drive_controller/odom", "/tf",
                "/tf_static"} <= published, published
        assert all(name.startswith("/robot1/") or name in GLOBAL_TOPICS
                   for name in published), published


# -- two robots in two processes over Zenoh ----------------------------------------------------

def _control_run(namespace: str, port: int, connect: int | None) -> list[str]:
    """``servolab control run`` of an emulated Waffle on its floor in ``namespace``,
    listening on ``port`` of loopback (and connecting to ``connect``'s)."""
    return [*SERVOLAB, "control", "run", "turtlebot3_waffle", "--world", "robot",
            "--namespace", namespace, "--spawn", "joint_state_broadcaster",
            "diff_drive_controller", "--listen", f"tcp/127.0.0.1:{port}",
            *(["--connect", f"tcp/127.0.0.1:{connect}"] if connect else [])]


@pytest.mark.slow
def test_two_waffles_in_two_processes_over_zenoh() -> None:
    """Two ``servolab control run turtlebot3_waffle --namespace`` processes, peer to peer on
    loopback, heard from a third (this test): a cmd_vel to /robot1 moves robot1 only,
    ``servolab topic list`` shows both namespaces and no robot topic outside them, each
    robot's frames are prefixed on the shared /tf and /tf_static, and
    ``control list_controllers --namespace`` reaches each manager."""
    first, second = free_port(), free_port()
    endpoints = [f"tcp/127.0.0.1:{first}", f"tcp/127.0.0.1:{second}"]
    connect = [arg for endpoint in endpoints for arg in ("--connect", endpoint)]
    with started(_control_run("/robot1", first, None), stderr_to_stdout=True) as robot1, \
            started(_control_run("/robot2", second, first), stderr_to_stdout=True) as robot2:
        for proc, namespace in ((robot1, "/robot1"), (robot2, "/robot2")):
            wait_for_line(proc, f"controller manager {namespace}/controller_manager",
                          timeout=60)
            wait_for_line(proc, "running; Ctrl-C stops it", timeout=60)
        with Context.open(TransportOptions("zenoh", connect=endpoints)) as ctx:
            probe = Node(ctx, "probe")
            odom: dict[str, list[Any]] = {ns: [] for ns in ROBOTS}
            tf: list[Any] = []
            static: list[Any] = []
            for ns in ROBOTS:
                probe.create_subscription(ODOMETRY, f"{ns}/diff_drive_controller/odom",
                                          odom[ns].append, 0)
            probe.create_subscription(TF, "/tf", tf.append, 0)
            probe.create_subscription(TF, "/tf_static", static.append, STATIC_LISTENER)
            cmd_vel = probe.create_publisher(TWIST_STAMPED,
                                             "/robot1/diff_drive_controller/cmd_vel", 10)
            assert cmd_vel.wait_for_subscription(30.0), "robot1's cmd_vel never subscribed"
            probe.create_timer(0.1, lambda: cmd_vel.publish(probe.message(
                TWIST_STAMPED, header={"stamp": probe.stamp()}, twist={"linear": {"x": 0.1}})))
            assert ctx.spin_until(lambda: bool(odom["/robot1"]) and
                                  odom["/robot1"][-1].pose.pose.position.x > 0.05,
                                  timeout=30.0), odom["/robot1"][-1:] or "no odometry"
            assert ctx.spin_until(lambda: len(odom["/robot2"]) > 10, timeout=10.0), \
                "no odometry from robot2"
            assert all(m.pose.pose.position.x == 0.0 for m in odom["/robot2"]), \
                "robot2 moved on robot1's command"
            for ns in ROBOTS:
                prefix = frame_prefix(ns)
                assert {(m.header.frame_id, m.child_frame_id) for m in odom[ns]} == \
                    {(f"{prefix}odom", f"{prefix}base_footprint")}
            moving = {(t.header.frame_id, t.child_frame_id) for m in tf for t in m.transforms}
            assert {("robot1/odom", "robot1/base_footprint"),
                    ("robot2/odom", "robot2/base_footprint")} <= moving, moving
            assert all(parent.split("/")[0] == child.split("/")[0] in ("robot1", "robot2")
                       for parent, child in moving), moving
            assert ctx.spin_until(lambda: {t.child_frame_id for m in static
                                           for t in m.transforms} >=
                                  {"robot1/base_link", "robot2/base_link"}, timeout=10.0), static
            _own_topics_only(ctx)

        def listed() -> set[str]:
            out = servolab("topic", "list", *connect, timeout=60).stdout
            return set(out.split())

        robots_topics = {f"{ns}/{topic}" for ns in ROBOTS for topic in (
            "joint_states", "dynamic_joint_states", "robot_description",
            "diff_drive_controller/odom", "diff_drive_controller/cmd_vel")}
        wait_for(lambda: robots_topics <= listed(),
                 lambda: f"both robots' topics in 'topic list'; listed {sorted(listed())}",
                 timeout=30, step=0.5)
        outside = {t for t in listed() if not re.match(r"/robot[12]/", t)}
        assert outside <= set(GLOBAL_TOPICS), outside
        for ns in ROBOTS:
            out = servolab("control", "list_controllers", "--namespace", ns, *connect,
                           timeout=60)
            assert out.returncode == 0, out.stderr
            rows = {line.split()[0]: line.split()[-1] for line in out.stdout.splitlines()}
            assert rows == {"joint_state_broadcaster": "active",
                            "diff_drive_controller": "active"}, out.stdout
