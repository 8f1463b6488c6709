"""``servolab walk --view`` and ``servolab navigate --view`` watched by Foxglove's own client.

The client is ``@foxglove/ws-protocol``'s ``FoxgloveClient`` in Node, decoding CDR with
``@foxglove/rosmsg2-serialization`` (tests/view_client; neither is servolab's code), connected
with each of the protocol's two names: ``foxglove.websocket.v1`` (Lichtblick, older Foxglove)
and ``foxglove.sdk.v1`` (Foxglove now; the same protocol renamed, lichtblick-suite/lichtblick
PR #819). What it decoded must equal what the run's bag recorded, read back with ``mcap`` and
``mcap-ros2-support``: what the view serves is what the run folder holds.
"""

from __future__ import annotations

import json
import signal
import threading
from pathlib import Path
from typing import Any

import pytest

from tests.clirun import SERVOLAB
from tests.middleware.conftest import free_port
from tests.processes import started
from tests.viewclient import SDK_V1, WEBSOCKET_V1, node_client, run_client, watched_run
from tests.waiting import wait_for

# each runs a robot or a launch in other processes (and a browser): every core busy, so
# not beside the tests that hold the wall clock to a deadline (tests/conftest.py)
pytestmark = [pytest.mark.slow, pytest.mark.realtime]

SUBPROTOCOLS = [WEBSOCKET_V1, SDK_V1]
#: the simulated runs play at this many times real time while watched (--view-speed)
SPEED = "4"


def _recorded(bag: Path) -> dict[str, list[Any]]:
    """Topic -> the bag's messages, decoded by mcap-ros2-support."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    found: dict[str, list[Any]] = {}
    (path,) = sorted(bag.glob("*.mcap"))
    with path.open("rb") as f:
        for _, channel, _, msg in make_reader(
                f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            found.setdefault(channel.topic, []).append(msg)
    return found


def _stamp(header: Any) -> tuple[int, int]:
    if isinstance(header, dict):
        return int(header["stamp"]["sec"]), int(header["stamp"]["nanosec"])
    return int(header.stamp.sec), int(header.stamp.nanosec)


def _watch(args: list[str], out: Path, topics: list[str], subprotocol: str,
           count: int) -> list[dict[str, Any]]:
    """Run ``servolab ARGS --view PORT`` to its end with the client watching; the client's
    events."""
    node_client()  # skips, saying why, where Node or the npm packages are missing
    with watched_run(args, out, speed=SPEED) as url:
        return run_client(url, subprotocol, topics, count, timeout=90)


def _messages(events: list[dict[str, Any]], topic: str) -> list[dict[str, Any]]:
    return [e["message"] for e in events if e.get("op") == "message" and e["topic"] == topic]


@pytest.mark.parametrize("subprotocol", SUBPROTOCOLS)
def test_a_watched_walk_shows_the_biped_as_its_bag_recorded_it(tmp_path: Path,
                                                                subprotocol: str) -> None:
    events = _watch(["walk", "--steps", "1"], tmp_path, [
        "/joint_states", "/tf", "/robot_description"], subprotocol, count=5)
    server = next(e for e in events if e.get("op") == "serverInfo")
    assert "time" in server["capabilities"]  # a simulated run: the app follows its clock
    recorded = _recorded(tmp_path / "walk_bag")

    (description,) = recorded["/robot_description"]
    shown = _messages(events, "/robot_description")
    assert shown and shown[0]["data"] == description.data  # latched: reaches the viewer

    joints = {_stamp(m.header): m for m in recorded["/joint_states"]}
    shown = _messages(events, "/joint_states")
    assert len(shown) >= 5
    for msg in shown:
        twin = joints[_stamp(msg["header"])]
        assert msg["name"] == list(twin.name)
        assert msg["position"] == list(twin.position)

    transforms = {_stamp(m.transforms[0].header): m for m in recorded["/tf"]}
    shown = _messages(events, "/tf")
    assert len(shown) >= 5
    for msg in shown:
        twin = transforms[_stamp(msg["transforms"][0]["header"])]
        for got, want in zip(msg["transforms"], twin.transforms, strict=True):
            assert got["child_frame_id"] == want.child_frame_id
            r = got["transform"]["rotation"]
            assert [r["x"], r["y"], r["z"], r["w"]] == [
                want.transform.rotation.x, want.transform.rotation.y,
                want.transform.rotation.z, want.transform.rotation.w]


@pytest.mark.parametrize("subprotocol", SUBPROTOCOLS)
def test_a_watched_navigation_shows_its_costmap_and_path_as_recorded(
        tmp_path: Path, subprotocol: str) -> None:
    events = _watch(["navigate", "--goal", "1.2", "0.9"], tmp_path, [
        "/global_costmap/costmap", "/path", "/plan"], subprotocol, count=1)
    recorded = _recorded(tmp_path / "navigate_bag")

    costmaps = {_stamp(m.header): m for m in recorded["/global_costmap/costmap"]}
    shown = _messages(events, "/global_costmap/costmap")
    assert shown
    for msg in shown:
        twin = costmaps[_stamp(msg["header"])]
        assert msg["info"]["width"] == twin.info.width
        assert msg["info"]["resolution"] == twin.info.resolution
        assert msg["data"] == list(twin.data)

    paths = {_stamp(m.header): m for m in recorded["/path"]}
    shown = _messages(events, "/path")
    assert shown
    for msg in shown:
        twin = paths[_stamp(msg["header"])]
        assert [(p["pose"]["position"]["x"], p["pose"]["position"]["y"])
                for p in msg["poses"]] == [(p.pose.position.x, p.pose.position.y)
                                           for p in twin.poses]
    plans = {_stamp(m.header) for m in recorded["/plan"]}
    assert all(_stamp(msg["header"]) in plans for msg in _messages(events, "/plan"))


@pytest.mark.parametrize(("args", "bag", "stop"), [
    (["walk", "--steps", "1"], "walk_bag", signal.SIGINT),
    (["navigate", "--goal", "1.2", "0.9"], "navigate_bag", signal.SIGTERM),
])
def test_a_stop_while_waiting_for_a_viewer_ends_the_run_cleanly(
        tmp_path: Path, args: list[str], bag: str, stop: signal.Signals) -> None:
    """Ctrl-C (or SIGTERM) while the run waits for its first viewer: the run ends as any
    stopped run does, its summary whole and saying so, its bag closed and readable."""
    port = free_port()
    output: list[str] = []
    with started([*SERVOLAB, *args, "--view", str(port),
                  "--no-progress", "--out", str(tmp_path)], stderr_to_stdout=True) as proc:
        threading.Thread(target=lambda: output.extend(proc.stdout or ()), daemon=True).start()
        wait_for(lambda: any("waiting for a viewer" in line for line in output)
                 or proc.poll() is not None, "the run to wait for a viewer", timeout=90)
        proc.send_signal(stop)
        proc.wait(timeout=60)
    assert proc.returncode == 128 + stop, "".join(output)[-3000:]
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["interrupted"] == stop.name
    assert not summary.get("failures_on_the_way_out"), summary.get("failures_on_the_way_out")
    assert _recorded(tmp_path / bag)  # a bag with its messages so far, readable
