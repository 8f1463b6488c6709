"""``servolab view BAG``: a bag recorded by servolab's own recorder, played back by
:class:`BagPlayer` on a virtual clock that follows the recording, and served by the view server
to a client written from the Foxglove WebSocket spec (a plain ``websockets`` connection).

The bag: a latched ``/robot_description`` String at the start, then a Twist at 20 Hz for 1 s
of virtual time. No test sleeps: each waits on a condition with a bound.
"""

from __future__ import annotations

import contextlib
import json
import math
import signal
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from websockets.sync.client import ClientConnection, connect
from websockets.typing import Subprotocol

from servolab.clock import VirtualClock
from servolab.middleware.bag import BagReader, qos_profile
from servolab.middleware.context import Context
from servolab.middleware.errors import BagError
from servolab.middleware.messages import MessageTypes
from servolab.middleware.node import Node
from servolab.middleware.qos import (
    DurabilityPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_latched,
)
from servolab.middleware.recorder import Recorder
from servolab.middleware.view import SUBPROTOCOLS, ViewConfig, ViewServer
from servolab.middleware.view.player import (
    ENDED,
    PAUSED,
    PLAYING,
    BagPlayer,
    PlaybackClock,
    playback_qos,
    serve_bag,
)
from tests.middleware.conftest import free_port
from tests.waiting import wait_for, wait_for_graph, wait_for_line

STRING, TWIST = "std_msgs/msg/String", "geometry_msgs/msg/Twist"
DESCRIPTION = "<robot name='replayed'/>"
START = 100.0          # s of virtual time the recording starts at
TWISTS = 20            # 20 Hz for 1 s
FAST = 1000.0          # "a high rate": the 1 s bag in about 1 ms


@dataclass(frozen=True)
class Recorded:
    path: Path
    description_ns: int              # the latched String's log time
    twists: list[tuple[int, float]]  # (log time ns, linear.x) of each Twist, in order

    @property
    def start_ns(self) -> int:
        return self.description_ns

    @property
    def end_ns(self) -> int:
        return self.twists[-1][0]


def _record(path: Path, types: MessageTypes) -> None:
    """The run: the description published once at the start, then one Twist every 50 ms of
    virtual time, each recorded (as rosbag2 with use_sim_time) at the time it was taken."""
    clock = VirtualClock(start=START)
    with Context.open(types=types, clock=clock) as ctx:
        talker = Node(ctx, "robot")
        description = talker.create_publisher(STRING, "/robot_description", qos_profile_latched)
        cmd_vel = talker.create_publisher(TWIST, "/cmd_vel", 10)
        recorder = Recorder(ctx, str(path), ["/robot_description", "/cmd_vel"], quiet=True)
        try:
            description.publish(talker.message(STRING, data=DESCRIPTION))
            assert ctx.spin_until(lambda: recorder.counts["/robot_description"] == 1, 5.0)
            for i in range(TWISTS):
                clock.advance_to(START + (i + 1) * 0.05)
                cmd_vel.publish(talker.message(TWIST, linear={"x": float(i), "y": -i / 4},
                                               angular={"z": 0.5}))
                assert ctx.spin_until(lambda i=i: recorder.counts["/cmd_vel"] == i + 1, 5.0)
        finally:
            recorder.destroy()


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Recorded:
    types = MessageTypes()
    path = tmp_path_factory.mktemp("player") / "run"
    _record(path, types)
    reader = BagReader(path, types)
    messages = list(reader.messages())
    [description] = [m for m in messages if m.topic == "/robot_description"]
    twists = [(m.log_time_ns, reader.decode(m).linear.x) for m in messages
              if m.topic == "/cmd_vel"]
    assert len(twists) == TWISTS and description.log_time_ns == round(START * 1e9)
    return Recorded(path, description.log_time_ns, twists)


@dataclass
class Heard:
    """What a subscriber in the player's context got: (ROS time ns when its callback ran,
    message) per message, and a condition to wait on."""

    got: list[tuple[int, Any]]
    cond: threading.Condition

    def wait(self, count: int, timeout: float = 10.0) -> None:
        with self.cond:
            assert self.cond.wait_for(lambda: len(self.got) >= count, timeout), \
                f"{len(self.got)} message(s) of {count} within {timeout:g} s"

    def values(self) -> list[float]:
        return [m.linear.x for _, m in self.got]


def listen(player: BagPlayer, topic: str, type_name: str, qos: QoSProfile | int = 100,
           name: str = "listener") -> Heard:
    heard = Heard([], threading.Condition())
    clock = player.context.clock

    def on_message(msg: Any) -> None:
        with heard.cond:
            heard.got.append((round(clock.ros_time() * 1e9), msg))
            heard.cond.notify_all()

    Node(player.context, name).create_subscription(type_name, topic, on_message, qos)
    return heard


@pytest.fixture
def player(recorded: Recorded) -> Iterator[BagPlayer]:
    with BagPlayer(recorded.path, rate=FAST, paused=True) as p:
        yield p


# -- playing ---------------------------------------------------------------------------------


def test_every_twist_comes_in_order_at_its_recorded_time(player: BagPlayer,
                                                         recorded: Recorded) -> None:
    """At a high rate each Twist arrives once, in order, as recorded; the context's ROS time
    when its callback runs is its recorded log time (the clock started at the first)."""
    assert player.state() == (PAUSED, recorded.start_ns, recorded.start_ns, recorded.end_ns,
                              FAST)
    assert player.context.ros_time() == START and player.clock.virtual
    twists = listen(player, "/cmd_vel", TWIST)
    player.resume()
    assert player.wait(10.0)
    twists.wait(TWISTS)
    assert [(t, m.linear.x) for t, m in twists.got] == recorded.twists
    assert all((m.linear.y, m.angular.z) == (-m.linear.x / 4, 0.5) for _, m in twists.got)
    assert player.state() == (ENDED, recorded.end_ns, recorded.start_ns, recorded.end_ns, FAST)
    assert player.played == TWISTS + 1 and not player.finished


def test_a_subscriber_that_joins_later_gets_the_latched_description(
        player: BagPlayer) -> None:
    """/robot_description was recorded TRANSIENT_LOCAL, so it is played latched: a
    subscriber that joins once it was played (here: at the end) still gets it."""
    assert player.latched_topics == ["/robot_description"]
    assert player.publishers["/robot_description"].qos.transient_local
    assert not player.publishers["/cmd_vel"].qos.transient_local
    player.resume()
    assert player.wait(10.0)
    late = listen(player, "/robot_description", STRING, qos_profile_latched, name="late")
    late.wait(1)
    assert [m.data for _, m in late.got] == [DESCRIPTION]


def test_pause_stops_the_messages_and_resume_goes_on_from_there(player: BagPlayer,
                                                               recorded: Recorded) -> None:
    """Paused from the fifth Twist's own callback: once the state says paused and the player
    has been round its loop (at this rate the rest would be played by then), no Twist more has
    come; resumed, the rest come, each once, still at their recorded times."""
    twists = listen(player, "/cmd_vel", TWIST)

    def pause_at_five(_: Any) -> None:
        if len(twists.got) == 5 and player.state().status == PLAYING:
            player.pause()

    Node(player.context, "pauser").create_subscription(TWIST, "/cmd_vel", pause_at_five, 100)
    player.resume()
    wait_for(lambda: player.state().status == PAUSED, "the player to pause")
    assert player.sync()
    assert player.sync()
    state = player.state()
    assert len(twists.got) == 5 and state.status == PAUSED
    assert state.current_ns == recorded.twists[4][0] == player.clock.ros_time_ns()
    player.resume()
    assert player.wait(10.0)
    twists.wait(TWISTS)
    assert [(t, m.linear.x) for t, m in twists.got] == recorded.twists


def test_seek_to_the_middle_plays_from_there_and_republishes_the_latched_description(
        player: BagPlayer, recorded: Recorded) -> None:
    """After the end, a seek to the middle: the clock goes back there, the description (the
    latched topic's last message before it) comes again, stamped there; resumed, the Twists
    from the middle on are played, at their recorded times, and no earlier one."""
    player.resume()
    assert player.wait(10.0)
    description = listen(player, "/robot_description", STRING, qos_profile_latched, "viewer")
    description.wait(1)
    twists = listen(player, "/cmd_vel", TWIST, name="twists")
    middle = recorded.start_ns + 500_000_000
    player.seek(middle)
    assert player.state() == (PAUSED, middle, recorded.start_ns, recorded.end_ns, FAST)
    assert player.sync()
    description.wait(2)
    assert [m.data for _, m in description.got] == [DESCRIPTION, DESCRIPTION]
    assert description.got[1][0] == middle == player.clock.ros_time_ns()
    assert twists.got == []
    player.resume()
    assert player.wait(10.0)
    after = [(t, x) for t, x in recorded.twists if t >= middle]
    twists.wait(len(after))
    assert [(t, m.linear.x) for t, m in twists.got] == after
    assert player.played == TWISTS + 1 + len(after)
    # a subscriber joining now gets the description once, from the fresh publisher
    late = listen(player, "/robot_description", STRING, qos_profile_latched, "late")
    late.wait(1)
    assert player.sync()
    assert len(late.got) == 1


def test_a_seek_made_while_a_message_plays_is_where_the_player_says_it_is(
        player: BagPlayer, recorded: Recorded) -> None:
    """A seek (and a pause) from inside the callback of a message being played: the state
    and the clock are at the seek, not at the message that was playing (the app's timeline
    would jump back)."""
    middle = recorded.twists[TWISTS // 2][0]

    def seek_on_first(_: Any) -> None:
        if player.state().status == PLAYING and player.played == 1:  # the description was 0
            player.seek(middle)
            player.pause()

    Node(player.context, "seeker").create_subscription(TWIST, "/cmd_vel", seek_on_first, 100)
    player.resume()
    wait_for(lambda: player.state().status == PAUSED, "the player to pause")
    assert player.sync()
    assert player.state().current_ns == middle == player.clock.ros_time_ns()


def test_a_seek_back_before_the_description_forgets_it(player: BagPlayer,
                                                       recorded: Recorded) -> None:
    """Seeking to the very start: no latched message lies before it, so a subscriber joining
    then gets the description only when it is played again."""
    player.resume()
    assert player.wait(10.0)
    player.seek(0)  # clamped to the start
    assert player.sync() and player.state().current_ns == recorded.start_ns
    late = listen(player, "/robot_description", STRING, qos_profile_latched, "late")
    assert player.sync() and late.got == []
    player.resume()
    late.wait(1)
    assert late.got[0][0] == recorded.start_ns


def test_loop_plays_again_from_the_start(recorded: Recorded) -> None:
    with BagPlayer(recorded.path, rate=math.inf, loop=True, paused=True) as player:
        twists = listen(player, "/cmd_vel", TWIST)
        player.resume()
        twists.wait(2 * TWISTS + 1)
        player.stop()
        assert player.loops >= 2 and player.state().status == ENDED and player.finished
    values = twists.values()
    assert values[:2 * TWISTS] == [x for _, x in recorded.twists] * 2
    # the clock went back at each loop: each Twist's ROS time is still its recorded one
    assert [t for t, _ in twists.got[TWISTS:2 * TWISTS]] == [t for t, _ in recorded.twists]


def test_set_rate_paces_to_the_wall_clock(recorded: Recorded) -> None:
    """At rate 1 on a fake wall clock the player waits for the recorded gaps, its clock
    following the wall meanwhile; the wall clock made to jump ahead releases the next message;
    set_rate(inf) plays the rest at once."""
    wall = [0.0]
    with BagPlayer(recorded.path, rate=1.0, paused=True, wall=lambda: wall[0]) as player:
        twists = listen(player, "/cmd_vel", TWIST)
        player.resume()
        assert player.sync() and player.sync()
        assert twists.got == [] and player.played == 1  # the description, at the start
        wall[0] = 0.025                                  # half the first Twist's gap:
        assert player.sync() and player.sync()           # the clock moves, short of it
        assert player.state().current_ns == player.clock.ros_time_ns() == \
            recorded.start_ns + 25_000_000
        assert twists.got == []
        wall[0] = 0.05                                   # the first Twist's gap
        twists.wait(1)
        assert player.sync() and player.sync() and len(twists.got) == 1
        player.set_rate(math.inf)
        assert player.wait(10.0) and player.state().rate == math.inf
        twists.wait(TWISTS)
        assert twists.values() == [x for _, x in recorded.twists]


# -- QoS as recorded -------------------------------------------------------------------------


def test_playback_qos_follows_the_offered_profiles() -> None:
    latched = qos_profile(transient_local=True, depth=1)
    sensor = qos_profile(reliable=False, depth=5)
    one = playback_qos("/map", [latched])
    assert one.transient_local and one.depth == 1 and one.reliable
    three = playback_qos("/tf_static", [latched] * 3)  # three static broadcasters
    assert three.transient_local and three.depth == 3
    mixed = playback_qos("/x", [latched, sensor])
    assert not mixed.transient_local and not mixed.reliable and mixed.depth == 5
    assert playback_qos("/cmd_vel", []) == QoSProfile()
    assert playback_qos("/robot_description", []).durability == DurabilityPolicy.TRANSIENT_LOCAL
    old = {"history": 1, "depth": 1, "reliability": 2, "durability": 1}  # version 8 numbers
    assert playback_qos("/y", [old]) == QoSProfile(
        depth=1, reliability=ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL)


def test_the_clock_can_go_back_and_keeps_whole_nanoseconds() -> None:
    clock = PlaybackClock(1_700_000_000_123_456_789)
    assert clock.ros_time_ns() == 1_700_000_000_123_456_789
    clock.advance_to_ns(1_700_000_000_123_456_889)  # 100 ns on: one float for both
    assert clock.ros_time_ns() == 1_700_000_000_123_456_889
    ticks: list[float] = []
    clock.call_every(1.0, ticks.append)
    clock.jump_to(1_600_000_000_000_000_000)
    assert clock.ros_time_ns() == 1_600_000_000_000_000_000 and clock.now() == 1.6e9
    clock.advance_to_ns(1_600_000_001_000_000_000)
    assert ticks == [1_600_000_001.0]


def test_a_bad_path_is_a_one_line_error_naming_it(tmp_path: Path) -> None:
    missing = tmp_path / "no_such_run"
    for call in (lambda: BagPlayer(missing), lambda: serve_bag(str(missing), port=0)):
        with pytest.raises(BagError) as error:
            call()
        assert str(missing) in str(error.value) and "\n" not in str(error.value)
    with pytest.raises(BagError, match="rate"):
        BagPlayer(missing.parent, rate=-1.0)


# -- served to a viewer ----------------------------------------------------------------------


@dataclass
class Client:
    """A viewer from the spec: JSON ops as text frames, Message Data as binary frames
    (opcode 0x01, u32 subscription id, u64 log time ns, payload)."""

    ws: ClientConnection
    channels: dict[str, dict[str, Any]]
    data: dict[int, list[tuple[int, bytes]]]

    def receive(self, until: Callable[[], bool], what: str, timeout: float = 10.0) -> None:
        deadline = time.monotonic() + timeout
        while not until():
            left = deadline - time.monotonic()
            if left <= 0:
                raise AssertionError(f"no {what} within {timeout:g} s")
            try:
                frame = self.ws.recv(timeout=left)
            except TimeoutError:
                continue
            if isinstance(frame, str):
                op = json.loads(frame)
                if op["op"] == "advertise":
                    self.channels.update({c["topic"]: c for c in op["channels"]})
            elif frame[0] == 0x01:
                subscription, stamp = struct.unpack_from("<IQ", frame, 1)
                self.data.setdefault(subscription, []).append((stamp, bytes(frame[13:])))

    def subscribe(self, *topics: str) -> None:
        self.receive(lambda: all(t in self.channels for t in topics), f"channels {topics}")
        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": i, "channelId": self.channels[t]["id"]} for i, t in enumerate(topics)]}))


@pytest.fixture
def viewer_of() -> Iterator[Callable[[str], Client]]:
    """Opens viewers; each is closed at the end of the test."""
    with contextlib.ExitStack() as opened:
        def open_(url: str) -> Client:
            ws = opened.enter_context(connect(url, subprotocols=[Subprotocol(SUBPROTOCOLS[0])],
                                              open_timeout=5))
            return Client(ws, {}, {})

        yield open_


def test_the_view_server_sends_each_message_at_its_recorded_log_time(
        player: BagPlayer, recorded: Recorded, viewer_of: Callable[[str], Client]) -> None:
    types = player.context.types
    with ViewServer(player.context, ViewConfig(port=0, graph_period=0.05)) as view:
        viewer = viewer_of(view.url)
        viewer.subscribe("/robot_description", "/cmd_vel")
        assert viewer.channels["/cmd_vel"]["schemaName"] == TWIST
        wait_for_graph(player.context, ("MS", "/servolab_view", "/cmd_vel"),
                       ("MS", "/servolab_view", "/robot_description"))
        player.resume()
        viewer.receive(lambda: len(viewer.data.get(1, [])) == TWISTS and 0 in viewer.data,
                       "every Twist and the description")
        [(stamp, payload)] = viewer.data[0]
        assert stamp == recorded.description_ns
        assert types.deserialize(payload, STRING).data == DESCRIPTION
        got = [(stamp, types.deserialize(payload, TWIST).linear.x)
               for stamp, payload in viewer.data[1]]
        assert got == recorded.twists
        assert player.wait(10.0)


def test_serve_bag_waits_for_a_viewer_plays_to_it_and_returns_the_count(
        recorded: Recorded, viewer_of: Callable[[str], Client]) -> None:
    port = free_port()
    said: list[str] = []
    result: list[int] = []
    serving = threading.Event()

    def say(line: str) -> None:
        said.append(line)
        if line.startswith("waiting for a viewer"):
            serving.set()

    def serve() -> None:
        result.append(serve_bag(str(recorded.path), port=port, rate=FAST, say=say))

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        assert serving.wait(10.0), said
        assert any(f"ws://127.0.0.1:{port}" in line for line in said)
        viewer = viewer_of(f"ws://127.0.0.1:{port}")
        viewer.subscribe("/cmd_vel")
        viewer.receive(lambda: len(viewer.data.get(0, [])) == TWISTS, "every Twist")
        assert [stamp for stamp, _ in viewer.data[0]] == [t for t, _ in recorded.twists]
    finally:
        thread.join(15.0)
    assert not thread.is_alive() and result == [TWISTS + 1]
    assert said[-1] == f"played {TWISTS + 1} message(s)"


SERVE = """
import sys
from servolab.middleware.view.player import serve_bag
played = serve_bag(sys.argv[1], port=0, rate=1.0, loop=True, wait_for_viewer=False,
                   say=lambda line: print(line, flush=True))
print("returned", played, flush=True)
"""


@pytest.mark.parametrize("stop", [signal.SIGINT, signal.SIGTERM])
def test_serve_bag_stops_on_a_stop_signal(recorded: Recorded, stop: signal.Signals) -> None:
    """Looping, it plays until SIGINT or SIGTERM, then closes cleanly and returns the count."""
    proc = subprocess.Popen([sys.executable, "-c", SERVE, str(recorded.path)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        lines = wait_for_line(proc, "playing at 1x, looping")
        assert "ws://127.0.0.1:" in lines[0]
        proc.send_signal(stop)
        out, err = proc.communicate(timeout=15)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err
    played = [line for line in out.splitlines() if line.startswith("returned ")]
    assert len(played) == 1 and int(played[0].split()[1]) >= 0


# -- the app's playback controls ---------------------------------------------------------------
#
# The byte layouts below are checked first against foxglove-sdk's own server (its
# ServerListener.on_playback_control_request gets the request decoded; its PlaybackState comes
# back as bytes), so the same bytes then judge servolab's server with an oracle it did not
# write.


def playback_request(command: int, speed: float, seek_ns: int | None, request_id: str) -> bytes:
    """Playback Control Request (client op 0x03) as a test client writes it."""
    rid = request_id.encode()
    return struct.pack("<BBfBQI", 0x03, command, speed, seek_ns is not None, seek_ns or 0,
                       len(rid)) + rid


def read_playback_state(frame: bytes) -> tuple[int, int, float, bool, str]:
    """Playback State (server op 0x05): status, current time ns, speed, did seek, request id."""
    assert frame[0] == 0x05
    status, current, speed, did_seek, length = struct.unpack_from("<BQfBI", frame, 1)
    assert len(frame) == 19 + length
    return status, current, speed, bool(did_seek), frame[19:].decode()


def _next_binary(ws: ClientConnection, opcode: int, timeout: float = 10.0) -> bytes:
    deadline = time.monotonic() + timeout
    while (left := deadline - time.monotonic()) > 0:
        frame = ws.recv(timeout=left)
        if isinstance(frame, bytes) and frame[0] == opcode:
            return frame
    raise AssertionError(f"no binary op 0x{opcode:02x} within {timeout:g} s")


def _server_info(ws: ClientConnection) -> dict[str, Any]:
    while True:
        frame = ws.recv(timeout=10)
        if isinstance(frame, str) and json.loads(frame)["op"] == "serverInfo":
            info: dict[str, Any] = json.loads(frame)
            return info


def test_the_playback_bytes_are_foxglove_sdks() -> None:
    foxglove = pytest.importorskip("foxglove")
    from foxglove.websocket import (
        Capability,
        PlaybackCommand,
        PlaybackState,
        PlaybackStatus,
        ServerListener,
    )

    asked: list[Any] = []

    class Listener(ServerListener):
        def on_playback_control_request(self, request: Any) -> PlaybackState:
            asked.append(request)
            return PlaybackState(PlaybackStatus.Paused, 12_345, 1.5, True, request.request_id)

    server = foxglove.start_server(host="127.0.0.1", port=0, server_listener=Listener(),
                                   capabilities=[Capability.PlaybackControl],
                                   playback_time_range=(100_000_000_123, 101_000_000_000))
    try:
        with connect(f"ws://127.0.0.1:{server.port}", open_timeout=5,
                     subprotocols=[Subprotocol("foxglove.sdk.v1")]) as ws:
            info = _server_info(ws)
            assert "playbackControl" in info["capabilities"]
            assert info["dataStartTime"] == {"sec": 100, "nsec": 123}
            assert info["dataEndTime"] == {"sec": 101, "nsec": 0}
            ws.send(playback_request(1, 1.5, 12_345, "r1"))
            state = read_playback_state(_next_binary(ws, 0x05))
    finally:
        server.stop()
    (request,) = asked
    assert request.playback_command == PlaybackCommand.Pause
    assert (request.playback_speed, request.seek_time, request.request_id) == (1.5, 12_345,
                                                                               "r1")
    assert state == (1, 12_345, 1.5, True, "r1")


def test_the_apps_controls_pause_seek_and_play_the_bag(
        player: BagPlayer, recorded: Recorded, viewer_of: Callable[[str], Client]) -> None:
    with ViewServer(player.context, ViewConfig(port=0), playback=player) as view:
        viewer = viewer_of(view.url)
        info = _server_info(viewer.ws)
        assert "playbackControl" in info["capabilities"]
        assert info["dataStartTime"]["sec"] * 10**9 + info["dataStartTime"]["nsec"] == \
            recorded.start_ns
        assert info["dataEndTime"]["sec"] * 10**9 + info["dataEndTime"]["nsec"] == \
            recorded.end_ns
        middle = recorded.twists[TWISTS // 2][0]
        viewer.ws.send(playback_request(1, 1.0, middle, "seek"))  # pause there
        assert read_playback_state(_next_binary(viewer.ws, 0x05)) == (
            1, middle, 1.0, True, "seek")
        assert player.state().status == "paused" and player.state().current_ns == middle
        viewer.ws.send(playback_request(0, 100.0, None, "play"))  # play fast to the end
        assert read_playback_state(_next_binary(viewer.ws, 0x05))[::4] == (0, "play")
        status, current, _, did_seek, request_id = read_playback_state(
            _next_binary(viewer.ws, 0x05))  # told unasked when it ends
        assert (status, current, did_seek, request_id) == (3, recorded.end_ns, False, "")
    heard_from = [t for t, _ in recorded.twists if t >= middle]
    assert player.played >= len(heard_from)


def test_a_bad_playback_request_is_refused_naming_the_field(
        player: BagPlayer, viewer_of: Callable[[str], Client]) -> None:
    with ViewServer(player.context, ViewConfig(port=0), playback=player) as view:
        viewer = viewer_of(view.url)
        viewer.ws.send(playback_request(7, 1.0, None, "x"))
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            frame = viewer.ws.recv(timeout=10)
            if isinstance(frame, str) and json.loads(frame)["op"] == "status":
                assert "playbackCommand 7" in json.loads(frame)["message"]
                break
        else:
            raise AssertionError("no status")
        assert player.state().status == "paused"  # nothing moved
