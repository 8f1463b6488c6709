"""servolab view against a client written from the published Foxglove WebSocket spec.

The client here is not servolab's: a plain ``websockets`` connection that parses frames as
``foxglove/ws-protocol``'s ``docs/spec.md`` lays them out, and decodes CDR with
``mcap-ros2-support``, an independent implementation of ROS 2's CDR and ``ros2msg`` schemas.
"""

from __future__ import annotations

import itertools
import json
import struct
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import pytest
from mcap_ros2._dynamic import generate_dynamic, serialize_dynamic
from websockets.exceptions import InvalidStatus
from websockets.sync.client import ClientConnection, connect

from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.middleware.qos import qos_profile_latched
from servolab.middleware.transport import TransportOptions
from servolab.middleware.view import SUBPROTOCOLS, ViewConfig, ViewServer
from tests.middleware.conftest import free_port
from tests.waiting import wait_for

STRING, TWIST, SET_BOOL = "std_msgs/msg/String", "geometry_msgs/msg/Twist", "std_srvs/srv/SetBool"
LATCHED_TEXT = "the robot's description, latched"


# -- a client from the spec ------------------------------------------------------------------


@dataclass
class SpecClient:
    """Keeps every frame it receives; ``expect`` waits for the first new one that fits."""

    ws: ClientConnection
    frames: list[str | bytes] = field(default_factory=list)
    seen: int = 0                       # frames[:seen] were handed out by expect()
    channels: dict[str, dict[str, Any]] = field(default_factory=dict)   # by topic
    services: dict[str, dict[str, Any]] = field(default_factory=dict)   # by name

    @classmethod
    @contextmanager
    def open(cls, url: str, subprotocol: str) -> Iterator[SpecClient]:
        with connect(url, subprotocols=[subprotocol], open_timeout=5) as ws:
            yield cls(ws)

    def _receive(self, timeout: float) -> bool:
        try:
            frame = self.ws.recv(timeout=timeout)
        except TimeoutError:
            return False
        self.frames.append(frame)
        if isinstance(frame, str):
            op = json.loads(frame)
            if op["op"] == "advertise":
                self.channels.update({c["topic"]: c for c in op["channels"]})
            elif op["op"] == "unadvertise":
                self.channels = {t: c for t, c in self.channels.items()
                                 if c["id"] not in op["channelIds"]}
            elif op["op"] == "advertiseServices":
                self.services.update({s["name"]: s for s in op["services"]})
        return True

    def expect(self, fits: Callable[[str | bytes], bool], what: str,
               timeout: float = 10.0) -> str | bytes:
        deadline = time.monotonic() + timeout
        while True:
            while self.seen < len(self.frames):
                frame = self.frames[self.seen]
                self.seen += 1
                if fits(frame):
                    return frame
            remaining = deadline - time.monotonic()
            if remaining <= 0 or not self._receive(remaining):
                got = [f if isinstance(f, str) else f[:16] for f in self.frames]
                raise AssertionError(f"no {what} within {timeout:g} s; got {got}")

    def op(self, name: str, timeout: float = 10.0, **fields: Any) -> dict[str, Any]:
        """The next JSON op ``name`` whose fields include ``fields``."""
        def fits(frame: str | bytes) -> bool:
            if not isinstance(frame, str):
                return False
            op = json.loads(frame)
            return op["op"] == name and all(op.get(k) == v for k, v in fields.items())
        return json.loads(self.expect(fits, f"{name} op {fields or ''}", timeout))

    def channel(self, topic: str, timeout: float = 10.0) -> dict[str, Any]:
        wait_until_ = time.monotonic() + timeout
        while topic not in self.channels:
            if time.monotonic() > wait_until_ or not self._receive(wait_until_ - time.monotonic()):
                raise AssertionError(f"{topic} never advertised; channels {list(self.channels)}")
        return self.channels[topic]

    def service(self, name: str, timeout: float = 10.0) -> dict[str, Any]:
        wait_until_ = time.monotonic() + timeout
        while name not in self.services:
            if time.monotonic() > wait_until_ or not self._receive(wait_until_ - time.monotonic()):
                raise AssertionError(f"{name} never advertised; services {list(self.services)}")
        return self.services[name]

    def send(self, op: str, **fields: Any) -> None:
        self.ws.send(json.dumps({"op": op, **fields}))

    def message_data(self, subscription_id: int, timeout: float = 10.0) -> tuple[int, bytes]:
        """(log time ns, payload) of the next Message Data (0x01) of the subscription."""
        def fits(frame: str | bytes) -> bool:
            return (isinstance(frame, bytes) and frame[0] == 0x01
                    and struct.unpack_from("<I", frame, 1)[0] == subscription_id)
        frame = self.expect(fits, f"message data of subscription {subscription_id}", timeout)
        assert isinstance(frame, bytes)
        (stamp,) = struct.unpack_from("<Q", frame, 5)
        return stamp, frame[13:]

    def close(self) -> None:
        self.ws.close()


def decoder(channel: dict[str, Any]) -> Callable[[bytes], Any]:
    assert channel["encoding"] == "cdr" and channel["schemaEncoding"] == "ros2msg"
    return generate_dynamic(channel["schemaName"], channel["schema"])[channel["schemaName"]]


# -- the graph under view --------------------------------------------------------------------


@dataclass
class Graph:
    ctx: Context
    talker: Node
    view: ViewServer
    twists_sent: list[float]

    @property
    def url(self) -> str:
        return self.view.url

    def view_subscriptions(self, topic: str) -> int:
        """The server node's subscriptions on ``topic``, as the graph shows them."""
        return sum(1 for e in self.ctx.transport.graph(0.2)
                   if e.kind == "MS" and e.node == "/servolab_view" and e.name == topic)


@pytest.fixture
def graph(request: pytest.FixtureRequest) -> Iterator[Graph]:
    kind = getattr(request, "param", "local")
    options = (TransportOptions("zenoh", listen=[f"tcp/127.0.0.1:{free_port()}"])
               if kind == "zenoh" else TransportOptions())
    ctx = Context.open(options)
    view: ViewServer | None = None
    thread = None
    try:
        talker = Node(ctx, "talker")
        latched = talker.create_publisher(STRING, "/robot_description", qos_profile_latched)
        latched.publish(talker.message(STRING, data=LATCHED_TEXT))
        twist = talker.create_publisher(TWIST, "/cmd_vel", 10)
        sent: list[float] = []
        counter = itertools.count(1)

        def tick() -> None:
            x = float(next(counter))
            twist.publish(talker.message(TWIST, linear={"x": x, "y": -x / 4},
                                         angular={"z": 0.5}))
            sent.append(x)

        talker.create_timer(0.02, tick)
        talker.declare_parameter("rate", 2.0)
        talker.declare_parameter("label", "left")

        def set_flag(req: Any, resp: Any) -> Any:
            resp.success = bool(req.data)
            resp.message = f"flag {'on' if req.data else 'off'}"
            return resp

        talker.create_service(SET_BOOL, "/talker/set_flag", set_flag)
        thread = ctx.executor.spin_in_thread()
        view = ViewServer(ctx, ViewConfig(port=0, graph_period=0.05))
        yield Graph(ctx, talker, view, sent)
    finally:
        if view is not None:
            view.close()
        ctx.shutdown()
        if thread is not None:
            thread.join()
        ctx.close()


@pytest.fixture
def client(graph: Graph) -> Iterator[SpecClient]:
    with SpecClient.open(graph.url, SUBPROTOCOLS[0]) as c:
        yield c


# -- the tests -------------------------------------------------------------------------------


def _smoke(graph: Graph, subprotocol: str) -> None:
    with SpecClient.open(graph.url, subprotocol) as c:
        assert c.ws.subprotocol == subprotocol
        info = c.op("serverInfo")
        assert c.frames[0] == json.dumps(info, separators=(",", ":"))  # the very first frame
        assert {"parameters", "parametersSubscribe", "services"} <= set(info["capabilities"])
        assert info["supportedEncodings"] == ["cdr"] and info["sessionId"]
        latched, twist = c.channel("/robot_description"), c.channel("/cmd_vel")
        assert (latched["schemaName"], twist["schemaName"]) == (STRING, TWIST)
        assert twist["schema"] == graph.ctx.types.msgdef(TWIST)
        c.send("subscribe", subscriptions=[{"id": 7, "channelId": latched["id"]},
                                           {"id": 8, "channelId": twist["id"]}])
        stamp, payload = c.message_data(7)
        assert decoder(latched)(payload).data == LATCHED_TEXT  # reached a late viewer
        assert abs(stamp / 1e9 - graph.ctx.ros_time()) < 60
        decode = decoder(twist)
        for _ in range(3):
            _, payload = c.message_data(8)
            msg = decode(payload)
            assert msg.linear.x in graph.twists_sent
            assert (msg.linear.y, msg.angular.z) == (-msg.linear.x / 4, 0.5)


@pytest.mark.parametrize("subprotocol", SUBPROTOCOLS)
def test_a_spec_client_sees_and_decodes_the_topics(graph: Graph, subprotocol: str) -> None:
    _smoke(graph, subprotocol)


@pytest.mark.parametrize("graph", ["zenoh"], indirect=True)
def test_the_same_over_zenoh(graph: Graph) -> None:
    _smoke(graph, "foxglove.websocket.v1")


@pytest.mark.parametrize("offered", [["foxglove.websocket.v2"], []])
def test_a_client_offering_neither_subprotocol_is_refused(graph: Graph,
                                                          offered: list[str]) -> None:
    with (pytest.raises(InvalidStatus) as refused,
          connect(graph.url, subprotocols=offered or None, open_timeout=5)):
        pass
    assert refused.value.response.status_code == 400


def test_unsubscribe_stops_messages_and_the_last_viewer_ends_the_subscription(
        graph: Graph, client: SpecClient) -> None:
    with SpecClient.open(graph.url, SUBPROTOCOLS[1]) as other:
        twist = client.channel("/cmd_vel")
        other.channel("/cmd_vel")
        client.send("subscribe", subscriptions=[{"id": 1, "channelId": twist["id"]}])
        other.send("subscribe", subscriptions=[{"id": 2, "channelId": twist["id"]}])
        client.message_data(1)
        other.message_data(2)
        assert graph.view_subscriptions("/cmd_vel") == 1    # one, shared by both viewers
        other.close()                                       # a viewer leaving keeps it ...
        wait_for(lambda: graph.view.viewers == 1, "the server to see the viewer go")
        assert graph.view_subscriptions("/cmd_vel") == 1
        client.send("unsubscribe", subscriptionIds=[1])     # ... the last one ends it
        wait_for(lambda: graph.view_subscriptions("/cmd_vel") == 0,
                 "the server's subscription to go")
        last = len(graph.twists_sent)
        wait_for(lambda: len(graph.twists_sent) >= last + 5, "5 more twists published")
        client.send("getParameters", parameterNames=[], id="barrier")
        client.op("parameterValues", id="barrier")
        decode = decoder(twist)
        after = [decode(f[13:]).linear.x for f in client.frames
                 if isinstance(f, bytes) and f[0] == 1 and decode(f[13:]).linear.x > last]
        assert after == []


def test_a_malformed_op_gets_a_status_error_and_the_connection_survives(
        client: SpecClient) -> None:
    client.op("serverInfo")
    client.ws.send("this is not json")
    assert "not JSON" in client.op("status", level=2)["message"]
    client.send("subscribe", subscriptions=[{"id": "seven", "channelId": 1}])
    assert "subscribe.subscriptions[0].id" in client.op("status", level=2)["message"]
    client.send("teleport")
    assert "teleport" in client.op("status", level=2)["message"]
    client.ws.send(b"\x02\x01\x00")
    assert "serviceCallRequest" in client.op("status", level=2)["message"]
    client.send("getParameters", parameterNames=["/talker.label"], id="alive")
    assert client.op("parameterValues", id="alive")["parameters"] == [
        {"name": "/talker.label", "value": "left"}]


def test_parameters_get_set_and_updates_reach_the_node(graph: Graph, client: SpecClient) -> None:
    client.send("getParameters", parameterNames=["/talker.rate"], id="g1")
    assert client.op("parameterValues", id="g1")["parameters"] == [
        {"name": "/talker.rate", "value": 2.0, "type": "float64"}]
    client.send("getParameters", parameterNames=[], id="all")
    names = {p["name"] for p in client.op("parameterValues", id="all")["parameters"]}
    assert {"/talker.rate", "/talker.label"} <= names
    client.send("setParameters", parameters=[{"name": "/talker.rate", "value": 5.5},
                                             {"name": "/talker.label", "value": "right"}],
                id="s1")
    answer = client.op("parameterValues", id="s1")["parameters"]
    assert {p["name"]: p["value"] for p in answer} == {"/talker.rate": 5.5,
                                                        "/talker.label": "right"}
    assert graph.talker.get_parameter("rate").value == 5.5
    assert graph.talker.get_parameter("label").value == "right"
    client.send("setParameters", parameters=[{"name": "/talker.rate", "value": "fast"}])
    assert "/talker.rate" in client.op("status", level=1)["message"]
    assert graph.talker.get_parameter("rate").value == 5.5

    client.send("subscribeParameterUpdates", parameterNames=["/talker.rate"])
    # the subscription is in place once a request sent after it is answered
    client.send("getParameters", parameterNames=["/talker.rate"], id="g2")
    client.op("parameterValues", id="g2")
    graph.talker.set_parameter("rate", 7.25)
    update = client.op("parameterValues", parameters=[
        {"name": "/talker.rate", "value": 7.25, "type": "float64"}])
    assert "id" not in update


def test_a_service_called_from_the_client_answers(client: SpecClient) -> None:
    service = client.service("/talker/set_flag")
    assert service["type"] == SET_BOOL
    request = service["request"]
    assert (request["encoding"], request["schemaEncoding"]) == ("cdr", "ros2msg")
    encode = serialize_dynamic(request["schemaName"], request["schema"])[request["schemaName"]]
    payload = encode({"data": True})
    client.ws.send(struct.pack("<BIII", 0x02, service["id"], 41, 3) + b"cdr" + payload)
    frame = client.expect(lambda f: isinstance(f, bytes) and f[0] == 0x03, "a service response")
    assert isinstance(frame, bytes)
    service_id, call_id, length = struct.unpack_from("<III", frame, 1)
    assert (service_id, call_id, frame[13:13 + length]) == (service["id"], 41, b"cdr")
    response = service["response"]
    answer = generate_dynamic(response["schemaName"], response["schema"])[
        response["schemaName"]](frame[13 + length:])
    assert (answer.success, answer.message) == (True, "flag on")

    client.ws.send(struct.pack("<BIII", 0x02, 999_999, 42, 3) + b"cdr" + payload)
    failure = client.op("serviceCallFailure", callId=42)
    assert failure["serviceId"] == 999_999 and "not advertised" in failure["message"]


def test_a_virtual_clock_is_sent_as_time_ops() -> None:
    from servolab.clock import VirtualClock

    with Context.open(clock=VirtualClock(start=12.5)) as ctx, \
            ViewServer(ctx, ViewConfig(port=0)) as view, \
            SpecClient.open(view.url, SUBPROTOCOLS[1]) as c:
        assert "time" in c.op("serverInfo")["capabilities"]
        frame = c.expect(lambda f: isinstance(f, bytes) and f[0] == 0x02, "a time op")
        assert isinstance(frame, bytes) and len(frame) == 9
        assert struct.unpack_from("<Q", frame, 1)[0] == round(ctx.ros_time() * 1e9)


@pytest.mark.slow
def test_a_viewer_that_stops_reading_loses_old_frames_not_the_robots_time(graph: Graph) -> None:
    """A viewer that reads nothing fills its queue; the server drops its oldest frames and
    counts them, and the executor keeps running the robot's callbacks meanwhile."""
    graph.view.close()
    big = "x" * 1_000_000   # uncompressed, a few dozen fill the socket buffers (32 MB)
    with ViewServer(graph.ctx, ViewConfig(port=0, send_queue=4, graph_period=0.05)) as view, \
            connect(view.url, subprotocols=[SUBPROTOCOLS[0]], max_size=None,
                    max_queue=1, ping_interval=None, compression=None, close_timeout=1) as ws:
        c = SpecClient(ws)
        pub = graph.talker.create_publisher(STRING, "/flood", 10)
        channel = c.channel("/flood")
        c.send("subscribe", subscriptions=[{"id": 1, "channelId": channel["id"]}])
        wait_for(lambda: graph.view_subscriptions("/flood") == 1, "the server to subscribe")
        ticks = len(graph.twists_sent)

        def flooded() -> bool:
            pub.publish(graph.talker.message(STRING, data=big))
            return view.dropped > 0

        wait_for(flooded, "the server to drop frames the viewer did not read", timeout=30)
        wait_for(lambda: len(graph.twists_sent) > ticks + 3, "the robot's timer to run on")


def test_topics_and_services_are_advertised_as_they_come_and_go(graph: Graph,
                                                                client: SpecClient) -> None:
    client.channel("/cmd_vel")
    pub = graph.talker.create_publisher("std_msgs/msg/Float64", "/late", 10)
    channel = client.channel("/late")
    assert channel["schemaName"] == "std_msgs/msg/Float64"
    server = graph.talker.create_service("std_srvs/srv/Trigger", "/late_trigger",
                                         lambda req, resp: resp)
    service = client.service("/late_trigger")
    graph.talker.destroy_publisher(pub)
    assert client.op("unadvertise")["channelIds"] == [channel["id"]]
    graph.talker.destroy_service(server)
    assert client.op("unadvertiseServices")["serviceIds"] == [service["id"]]


def test_a_tools_topics_are_shown_and_only_hidden_names_are_hidden(graph: Graph,
                                                                   client: SpecClient) -> None:
    """As foxglove_bridge lists a ROS 2 graph (``get_topic_names_and_types``, every node's) and
    ``ros2 topic list`` hides (a name any part of which starts with ``_``): a topic is hidden
    by its own name, never by its node's — ``servolab topic pub`` and ``servolab bag play``
    publish from hidden tool nodes (``_servolab_...``), and what they publish is what the
    user came to watch."""
    tool = Node(graph.ctx, "_servolab_topic_pub_1")
    tool.create_publisher("std_msgs/msg/Float64", "/from_a_tool", 10)
    graph.talker.create_publisher("std_msgs/msg/Float64", "/robot/_internal", 10)
    graph.talker.create_publisher("std_msgs/msg/Float64", "/after", 10)
    assert client.channel("/from_a_tool")["schemaName"] == "std_msgs/msg/Float64"
    client.channel("/after")   # advertised after the hidden one would have been
    assert "/robot/_internal" not in client.channels
    tool.destroy()


def test_a_second_viewer_of_a_latched_topic_gets_what_it_kept(graph: Graph) -> None:
    """Two apps open at once (Foxglove and Lichtblick, two tabs): the view's one subscription
    replays the latched description to the first viewer only; the second gets it too, from
    what the view kept."""
    with SpecClient.open(graph.url, SUBPROTOCOLS[0]) as first, \
            SpecClient.open(graph.url, SUBPROTOCOLS[1]) as second:
        for viewer, sid in ((first, 1), (second, 2)):
            channel = viewer.channel("/robot_description")
            viewer.send("subscribe", subscriptions=[{"id": sid, "channelId": channel["id"]}])
            _, payload = viewer.message_data(sid)
            assert decoder(channel)(payload).data == LATCHED_TEXT
        assert graph.view_subscriptions("/robot_description") == 1  # still one, shared


# -- the history a topic is read with: foxglove_bridge's --------------------------------------


def test_a_topic_is_read_with_the_history_its_publishers_keep_as_foxglove_bridge_reads_it(
) -> None:
    """ros2_foxglove_bridge.cpp: the sum of the publishers' depths, each at least 1, no less
    than min_qos_depth (1) and no more than max_qos_depth (25), which it warns of."""
    from servolab.middleware.qos import HistoryPolicy, QoSProfile
    from servolab.middleware.view.server import subscription_qos

    tf_static = QoSProfile(depth=1, durability=qos_profile_latched.durability)
    qos, wanted = subscription_qos([tf_static] * 3)
    assert (qos.depth, wanted, qos.transient_local) == (3, 3, True)  # three broadcasters
    qos, wanted = subscription_qos([QoSProfile(depth=1000)])
    assert (qos.depth, wanted) == (25, 1000)                          # bounded, and said
    assert subscription_qos([QoSProfile(depth=1000)], max_depth=1000)[0].depth == 1000
    assert subscription_qos([None, None])[0].depth == 2               # unknown: 1 each
    keep_all = QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=0)
    assert subscription_qos([keep_all], max_depth=40)[0].depth == 40
    assert subscription_qos([QoSProfile(depth=1)], min_depth=5)[0].depth == 5


def _burst(graph: Graph, config: ViewConfig, topic: str, count: int) -> tuple[int, ViewServer]:
    """``count`` Strings published back to back by a publisher that keeps them all (depth
    ``count``) to a viewer that reads; how many reached it, and the server (closed)."""
    pub = graph.talker.create_publisher(STRING, topic, count)
    with ViewServer(graph.ctx, config) as view, SpecClient.open(view.url, SUBPROTOCOLS[0]) as c:
        channel = c.channel(topic)
        c.send("subscribe", subscriptions=[{"id": 1, "channelId": channel["id"]}])
        wait_for(lambda: graph.view_subscriptions(topic) == 1, "the server to subscribe")
        for k in range(count):
            pub.publish(graph.talker.message(STRING, data=str(k)))
        got: list[int] = []
        decode = decoder(channel)
        deadline = time.monotonic() + 60
        while len(got) + view.history_dropped + view.dropped < count:
            assert time.monotonic() < deadline, (len(got), view.history_dropped, view.dropped)
            try:
                got.append(int(decode(c.message_data(1, timeout=0.5)[1]).data))
            except AssertionError:  # none for 0.5 s: the rest may be counted as dropped
                continue
        assert got == sorted(got)                   # in order, and no message twice
    return len(got), view


@pytest.mark.slow
def test_a_burst_the_publisher_keeps_reaches_a_viewer_that_keeps_up_whole(
        graph: Graph, caplog: pytest.LogCaptureFixture) -> None:
    """1 000 messages back to back from a publisher of depth 1 000: all 1 000 reach the
    viewer (before, the view read every topic with KEEP_LAST 10 and kept the last 10 of a
    burst). With the bound left at foxglove_bridge's 25, the view says so in one line and
    every message is either delivered or counted as dropped."""
    graph.view.close()
    delivered, view = _burst(graph, ViewConfig(port=0, graph_period=0.05, max_qos_depth=1000),
                             "/burst", 1000)
    assert (delivered, view.history_dropped, view.dropped) == (1000, 0, 0)

    delivered, view = _burst(graph, ViewConfig(port=0, graph_period=0.05), "/bounded", 1000)
    assert delivered + view.history_dropped + view.dropped == 1000
    said = [r.getMessage() for r in caplog.records if "/bounded" in r.getMessage()]
    assert said == ["view: reading /bounded with a history of 25 (its publishers keep 1000): "
                    "a burst of more is cut to its last 25; raise max_qos_depth (servolab "
                    "view --max-qos-depth)"], said


@pytest.mark.slow
def test_images_of_a_megabyte_at_30_hz_reach_a_viewer_that_keeps_up_whole(graph: Graph) -> None:
    """30 Images of 1 MB (a 640 x 480 RGB frame is 0.92 MB) at 30 Hz for a second, from a
    publisher of the default depth 10: every one reaches the viewer, none dropped."""
    image_type = "sensor_msgs/msg/Image"
    pub = graph.talker.create_publisher(image_type, "/camera/image_raw", 10)
    with SpecClient.open(graph.url, SUBPROTOCOLS[0]) as c:
        channel = c.channel("/camera/image_raw")
        c.send("subscribe", subscriptions=[{"id": 1, "channelId": channel["id"]}])
        wait_for(lambda: graph.view_subscriptions("/camera/image_raw") == 1,
                 "the server to subscribe")
        frames = []
        start = time.monotonic()
        for k in range(30):
            time.sleep(max(0.0, start + k / 30 - time.monotonic()))
            pub.publish(graph.talker.message(image_type, height=1000, width=1000,
                                             encoding="mono8", step=1000,
                                             data=bytes([k]) * 1_000_000))
        decode = decoder(channel)
        for _ in range(30):
            image = decode(c.message_data(1, timeout=30)[1])
            frames.append(image.data[0])
        assert frames == list(range(30))
        assert (graph.view.history_dropped, graph.view.dropped) == (0, 0)
