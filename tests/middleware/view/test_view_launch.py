"""``servolab launch FILE --view``: a launch's graph watched by Foxglove's own client, with
the nodes in this process (local transport) and in child processes (Zenoh: the view is one
more supervised child, ``servolab view``, joined where the processes meet)."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest

from tests.clirun import SERVOLAB
from tests.middleware.conftest import free_port
from tests.processes import started
from tests.viewclient import SDK_V1, WEBSOCKET_V1, node_client, run_client
from tests.waiting import wait_for

# each runs a robot or a launch in other processes (and a browser): every core busy, so
# not beside the tests that hold the wall clock to a deadline (tests/conftest.py)
pytestmark = [pytest.mark.slow, pytest.mark.realtime]

LAUNCH = """\
transport: {transport}
nodes:
  - name: talker
    node: servolab.middleware.demo_nodes:Talker
    parameters: {{rate: 20.0, speed: 0.25}}
    process: {talker_process}
  - name: listener
    node: servolab.middleware.demo_nodes:Listener
    process: {listener_process}
"""


@pytest.mark.parametrize(("transport", "subprotocol"), [("local", WEBSOCKET_V1),
                                                        ("zenoh", SDK_V1)])
def test_a_launch_with_view_serves_its_graph(tmp_path: Path, transport: str,
                                              subprotocol: str) -> None:
    node_client()  # skips, saying why, where Node or the npm packages are missing
    file = tmp_path / "talk.launch.yaml"
    file.write_text(LAUNCH.format(
        transport=transport, talker_process="one",
        listener_process="one" if transport == "local" else "two"))
    port = free_port()
    output: list[str] = []
    with started([*SERVOLAB, "launch", str(file), "--view",
                  str(port)], stderr_to_stdout=True) as proc:
        threading.Thread(target=lambda: output.extend(proc.stdout or ()), daemon=True).start()
        serving = f"serving the graph on ws://127.0.0.1:{port}"
        wait_for(lambda: any(serving in line for line in output) or proc.poll() is not None,
                 "the launch to serve its graph", timeout=60)
        assert proc.poll() is None, "".join(output)
        events = run_client(f"ws://127.0.0.1:{port}", subprotocol, ["/cmd_vel"], count=5,
                            timeout=60)
        assert proc.poll() is None  # still running: the view did not end the launch
    twists = [e["message"] for e in events if e.get("op") == "message"]
    assert len(twists) == 5
    assert all(t["linear"]["x"] == 0.25 for t in twists)
