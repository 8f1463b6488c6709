"""rclpy code runs on servolab with only its imports changed (issue 15, "rclpy's shapes").

The talker and listener below are ROS 2 Jazzy's tutorial nodes as the ROS 2 documentation gives
them ("Writing a simple publisher and subscriber (Python)", from ros2/examples
``rclpy/topics/minimal_publisher/.../publisher_member_function.py`` and
``minimal_subscriber/.../subscriber_member_function.py``), word for word. The test changes their
import lines and nothing else, and checks that it did only that.

The API facts checked against rclpy's sources (ros2/rclpy, ``rclpy/node.py``, ``qos.py``,
``impl/rcutils_logger.py``, ``client.py``) are named at each test.
"""

from __future__ import annotations

import difflib
import logging
import os
import sys
from pathlib import Path

import pytest

from servolab.middleware.context import Context
from servolab.middleware.errors import MessageError
from servolab.middleware.node import Node
from servolab.middleware.parameters import SetParametersResult
from servolab.middleware.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
    as_profile,
)
from tests.middleware.conftest import free_port
from tests.processes import started
from tests.waiting import wait_for_line, wait_until

TALKER = '''\
import rclpy
from rclpy.node import Node

from std_msgs.msg import String


class MinimalPublisher(Node):

    def __init__(self):
        super().__init__('minimal_publisher')
        self.publisher_ = self.create_publisher(String, 'topic', 10)
        timer_period = 0.5  # seconds
        self.timer = self.create_timer(timer_period, self.timer_callback)
        self.i = 0

    def timer_callback(self):
        msg = String()
        msg.data = 'Hello World: %d' % self.i
        self.publisher_.publish(msg)
        self.get_logger().info('Publishing: "%s"' % msg.data)
        self.i += 1


def main(args=None):
    rclpy.init(args=args)

    minimal_publisher = MinimalPublisher()

    rclpy.spin(minimal_publisher)

    # Destroy the node explicitly
    # (optional - otherwise it will be done automatically
    # when the garbage collector destroys the node object)
    minimal_publisher.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
'''

LISTENER = '''\
import rclpy
from rclpy.node import Node

from std_msgs.msg import String


class MinimalSubscriber(Node):

    def __init__(self):
        super().__init__('minimal_subscriber')
        self.subscription = self.create_subscription(
            String,
            'topic',
            self.listener_callback,
            10)
        self.subscription  # prevent unused variable warning

    def listener_callback(self, msg):
        self.get_logger().info('I heard: "%s"' % msg.data)


def main(args=None):
    rclpy.init(args=args)

    minimal_subscriber = MinimalSubscriber()

    rclpy.spin(minimal_subscriber)

    # Destroy the node explicitly
    # (optional - otherwise it will be done automatically
    # when the garbage collector destroys the node object)
    minimal_subscriber.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
'''

#: The only change a port needs: rclpy's imports for servolab's.
IMPORTS = {
    "import rclpy": "from servolab import rclpy",
    "from rclpy.node import Node": "from servolab.rclpy.node import Node",
    "from std_msgs.msg import String": "from servolab.interfaces.std_msgs.msg import String",
}


def ported(source: str) -> str:
    """``source`` with its rclpy imports swapped, and a check that nothing else changed."""
    lines = [IMPORTS.get(line, line) for line in source.splitlines()]
    changed = [d for d in difflib.unified_diff(source.splitlines(), lines, lineterm="", n=0)
               if d.startswith(("+", "-")) and not d.startswith(("+++", "---"))]
    assert changed and all(d[1:].startswith(("import ", "from ")) for d in changed), changed
    return "\n".join(lines) + "\n"


def _env(**extra: str) -> dict[str, str]:
    env = dict(os.environ)
    env.update(extra)
    env["PYTHONUNBUFFERED"] = "1"
    return env


@pytest.mark.slow
def test_the_tutorial_talker_and_listener_talk_across_processes(tmp_path: Path) -> None:
    """The two tutorial scripts, ported by their imports only, run as two processes over
    Zenoh (the transport chosen by environment, as ROS chooses its rmw), and the listener
    logs what the talker sent in rclpy's console format."""
    (tmp_path / "talker.py").write_text(ported(TALKER))
    (tmp_path / "listener.py").write_text(ported(LISTENER))
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    listener_env = _env(SERVOLAB_TRANSPORT="zenoh", SERVOLAB_LISTEN=endpoint)
    talker_env = _env(SERVOLAB_TRANSPORT="zenoh", SERVOLAB_CONNECT=endpoint)
    with started([sys.executable, str(tmp_path / "listener.py")], env=listener_env,
                 stderr_to_stdout=True) as listener, \
         started([sys.executable, str(tmp_path / "talker.py")], env=talker_env,
                 stderr_to_stdout=True) as talker:
        wait_for_line(talker, 'Publishing: "Hello World: 0"', timeout=30)
        line = wait_for_line(listener, 'I heard: "Hello World: 2"', timeout=30)[-1]
        # rcutils' console format: [INFO] [<seconds>] [<logger>]: <message>
        assert line.startswith("[INFO] [") and "] [minimal_subscriber]: I heard:" in line


@pytest.mark.slow
def test_the_tutorial_nodes_in_one_process_on_the_default_context(
        caplog: pytest.LogCaptureFixture) -> None:
    """Both tutorial classes in one process share the default context (in-process
    transport): rclpy's ``Node("name")`` with no context given."""
    talker_ns: dict[str, object] = {"__name__": "talker"}
    exec(compile(ported(TALKER), "talker.py", "exec"), talker_ns)
    listener_ns: dict[str, object] = {"__name__": "listener"}
    exec(compile(ported(LISTENER), "listener.py", "exec"), listener_ns)
    from servolab import rclpy
    caplog.set_level(logging.INFO)

    def heard() -> list[str]:
        return [r.getMessage() for r in caplog.records if "I heard" in r.getMessage()]

    with rclpy.init():
        talker = talker_ns["MinimalPublisher"]()  # type: ignore[operator]
        listener = listener_ns["MinimalSubscriber"]()  # type: ignore[operator]
        assert talker.context is listener.context is rclpy.get_default_context()
        assert rclpy.get_default_context().spin_until(lambda: len(heard()) >= 2, timeout=5.0)
        assert heard()[:2] == ['I heard: "Hello World: 0"', 'I heard: "Hello World: 1"']
    assert not rclpy.ok()
    with pytest.raises(RuntimeError, match="not initialized"):
        rclpy.shutdown()  # as rclpy's: shutting down twice is an error; try_shutdown is not
    rclpy.try_shutdown()


def test_a_message_reused_after_publish_does_not_change_what_subscribers_got(
        ctx: Context) -> None:
    """rclpy's value semantics: publish() serializes (or copies) the message, so a talker
    that reuses one object and changes it between publishes sends each value once."""
    node = Node(ctx, "n")
    got: list[object] = []
    node.create_subscription("geometry_msgs/msg/Twist", "/cmd_vel", got.append)
    pub = node.create_publisher("geometry_msgs/msg/Twist", "/cmd_vel", 10)
    msg = node.message("geometry_msgs/msg/Twist")
    for k in range(3):
        msg.linear.x = float(k)
        pub.publish(msg)
    msg.linear.x = 99.0
    ctx.spin_until(lambda: len(got) == 3, timeout=2.0)
    assert [m.linear.x for m in got] == [0.0, 1.0, 2.0]  # type: ignore[attr-defined]
    assert all(m is not msg for m in got)


def test_message_classes_build_with_no_arguments_and_check_fields() -> None:
    """rclpy's generated classes take no arguments (every field at its default) or keyword
    fields; a wrong field value is refused naming the field."""
    from servolab.interfaces.geometry_msgs.msg import Twist
    from servolab.interfaces.std_srvs.srv import SetBool
    twist = Twist()
    twist.linear.x = 0.5
    assert twist.angular.z == 0.0 and isinstance(twist, Twist)
    assert Twist(linear={"x": 1.0}).linear.x == 1.0
    assert SetBool.Request(data=True).data is True and SetBool.Response().success is False
    with pytest.raises(MessageError, match="linear"):
        Twist(linear={"x": "fast"})
    with pytest.raises(ImportError, match="NoSuchType"):
        from servolab.interfaces.std_msgs.msg import NoSuchType  # noqa: F401


def test_qos_profiles_and_depths_as_rclpy_takes_them(ctx: Context) -> None:
    """rclpy/qos.py: policy values are rmw's (RELIABLE 1, BEST_EFFORT 2, TRANSIENT_LOCAL 1,
    VOLATILE 2, KEEP_LAST 1, KEEP_ALL 2); an int is KEEP_LAST(depth)."""
    assert (ReliabilityPolicy.RELIABLE, ReliabilityPolicy.BEST_EFFORT) == (1, 2)
    assert (DurabilityPolicy.TRANSIENT_LOCAL, DurabilityPolicy.VOLATILE) == (1, 2)
    assert (HistoryPolicy.KEEP_LAST, HistoryPolicy.KEEP_ALL) == (1, 2)
    assert as_profile(7) == QoSProfile(depth=7)
    assert as_profile(0).keep_all
    node = Node(ctx, "n")
    sensor = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)
    pub = node.create_publisher("std_msgs/msg/String", "/s", qos_profile=sensor)
    assert pub.qos == sensor and not pub.qos.reliable
    with pytest.raises(ValueError, match="depth"):
        QoSProfile(depth=-1)
    with pytest.raises(TypeError, match="QoSProfile or a depth"):
        node.create_publisher("std_msgs/msg/String", "/s", qos_profile="10")  # type: ignore


def test_callbacks_say_their_signature(ctx: Context) -> None:
    """A callback's arguments are said (with_info=True), not guessed; one that does not fit
    is refused when the subscription is made."""
    node = Node(ctx, "n")
    with pytest.raises(TypeError, match="with_info=True"):
        node.create_subscription("std_msgs/msg/String", "/s", lambda msg, info: None)
    with pytest.raises(TypeError, match="2 argument"):
        node.create_subscription("std_msgs/msg/String", "/s", lambda msg: None, with_info=True)
    got: list[tuple[str, int]] = []
    node.create_subscription("std_msgs/msg/String", "/s",
                             lambda msg, info: got.append((msg.data, info.sequence_number)),
                             with_info=True)
    # a callback with a defaulted second argument is called with the message only
    plain: list[str] = []
    node.create_subscription("std_msgs/msg/String", "/s",
                             lambda msg, extra=None: plain.append(msg.data))
    node.create_publisher("std_msgs/msg/String", "/s").publish(
        node.message("std_msgs/msg/String", data="a"))
    ctx.spin_until(lambda: got and plain, timeout=2.0)
    assert got == [("a", 1)] and plain == ["a"]


def test_parameters_and_services_in_rclpys_shape(ctx: Context) -> None:
    """rclpy/node.py: declare_parameter / get_parameter return a Parameter (``.value``);
    add_on_set_parameters_callback's result refuses a change; client.py:
    wait_for_service(timeout_sec=...) returns False when no server came."""
    node = Node(ctx, "n")
    assert node.declare_parameter("gain", 2.0).value == 2.0
    assert node.get_parameter("gain").value == 2.0 and node.get_parameter("gain").name == "gain"
    node.add_on_set_parameters_callback(
        lambda params: SetParametersResult(all(p.value < 10 for p in params), "too high"))
    assert not node.set_parameters({"gain": 12.0})[0].successful
    assert node.get_parameter("gain").value == 2.0
    client = node.create_client("std_srvs/srv/Trigger", "/nobody")
    assert client.wait_for_service(timeout_sec=0.2) is False
    node.create_service("std_srvs/srv/Trigger", "/somebody",
                        lambda req, resp: (setattr(resp, "success", True), resp)[1])
    client = node.create_client("std_srvs/srv/Trigger", "/somebody")
    assert client.wait_for_service(timeout_sec=2.0)
    assert client.call(client.request(), timeout=2.0).success is True
    # service classes, as rclpy code names them
    from servolab.interfaces.std_srvs.srv import SetBool
    node.create_service(SetBool, "/switch",
                        lambda req, resp: (setattr(resp, "success", req.data), resp)[1])
    switch = node.create_client(SetBool, "/switch")
    future = switch.call_async(SetBool.Request(data=True))
    assert ctx.spin_until(future.done, timeout=2.0) and future.result().success is True


def test_logger_throttle_once_and_skip_first(ctx: Context,
                                             caplog: pytest.LogCaptureFixture) -> None:
    """rclpy/impl/rcutils_logger.py: ``once`` logs a call site the first time only,
    ``skip_first`` all but the first time, ``throttle_duration_sec`` at most once per
    period (rcutils' steady clock); each condition belongs to its call site."""
    logger = Node(ctx, "n").get_logger()
    caplog.set_level(logging.INFO)
    for k in range(5):
        logger.info(f"once {k}", once=True)
        logger.info(f"skip {k}", skip_first=True)
        logger.info(f"throttled {k}", throttle_duration_sec=3600.0)
    logger.info("once again", once=True)  # another call site: its own first time
    texts = [r.getMessage() for r in caplog.records]
    assert [t for t in texts if t.startswith("once")] == ["once 0", "once again"]
    assert [t for t in texts if t.startswith("skip")] == ["skip 1", "skip 2", "skip 3", "skip 4"]
    assert [t for t in texts if t.startswith("throttled")] == ["throttled 0"]
    # throttling lets a call site through again once its period has passed
    passed: list[bool] = []
    assert wait_until(lambda: passed.append(logger.info("tick", throttle_duration_sec=0.05))
                      or passed.count(True) >= 2, timeout=5.0)
    assert caplog.records[-1].filename == Path(__file__).name  # the caller, not logger.py


def test_rclpy_init_joins_the_domain_ros_domain_id_names(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Issue 32, D3: rclpy reads ``ROS_DOMAIN_ID`` (docs.ros.org, "The ROS_DOMAIN_ID"), and
    so must ``servolab.rclpy.init``; over Zenoh the domain is the first part of every
    liveliness token (rmw_zenoh's ``@ros2_lv/<domain>/...``)."""
    from servolab import rclpy
    from servolab.middleware.default_context import options_from_environment
    from servolab.middleware.errors import TransportError
    from tests.middleware.conftest import free_port

    monkeypatch.setenv("ROS_DOMAIN_ID", "7")
    assert options_from_environment().domain_id == 7
    monkeypatch.setenv("SERVOLAB_TRANSPORT", "zenoh")
    monkeypatch.setenv("SERVOLAB_LISTEN", f"tcp/127.0.0.1:{free_port()}")
    with rclpy.init():
        node = rclpy.create_node("in_domain_seven")
        tokens = [str(r.ok.key_expr) for r in node.context.transport.session.liveliness()
                  .get("@ros2_lv/**", timeout=1.0) if r.ok is not None]
        assert tokens and all(t.startswith("@ros2_lv/7/") for t in tokens), tokens
    for bad in ("seven", "233", "-1"):
        monkeypatch.setenv("ROS_DOMAIN_ID", bad)
        with pytest.raises(TransportError, match=f"ROS_DOMAIN_ID='{bad}': a ROS domain"):
            options_from_environment()
