"""The C heap keeps what it freed (:mod:`servolab.middleware.heap`), so a camera frame that a
node receives and republishes over Zenoh does not fault its buffers' pages in anew each time.
The page faults are the kernel's count (``getrusage``'s ``ru_minflt``, getrusage(2)); the
thresholds are glibc's ``mallopt`` parameters (mallopt(3): M_TRIM_THRESHOLD is -1,
M_MMAP_THRESHOLD -3, the latter at most 32 MiB on a 64-bit machine)."""

from __future__ import annotations

import os
import sys

import pytest

from servolab.errors import ServolabValueError
from servolab.middleware.heap import (
    DEFAULT_KEEP_MB,
    KEEP_FREED_ENV,
    MAX_KEEP_MB,
    _glibc_mallopt,
    keep_freed_memory,
    keep_mb,
)
from tests.middleware.conftest import free_port
from tests.processes import started
from tests.waiting import wait_for_line

IMAGE = "sensor_msgs/msg/Image"

#: republishes every frame it hears, and says its page faults per frame after a warm-up
ECHO = """
import resource, sys
from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.middleware.transport import TransportOptions
frames, warm_up = int(sys.argv[2]), 20
with Context.open(TransportOptions("zenoh", connect=[sys.argv[1]])) as ctx:
    node = Node(ctx, "echo")
    pong = node.create_publisher("sensor_msgs/msg/Image", "/pong", 0)
    faults = []

    def on_ping(msg):
        pong.publish(msg)
        faults.append(resource.getrusage(resource.RUSAGE_SELF).ru_minflt)

    node.create_subscription("sensor_msgs/msg/Image", "/ping", on_ping, 0)
    print("ready", flush=True)
    ctx.executor.spin_until(lambda: len(faults) >= frames, timeout=120)
    print("faults per frame", (faults[-1] - faults[warm_up]) / (len(faults) - 1 - warm_up),
          flush=True)
"""


def faults_per_frame(keep: str, frames: int = 120) -> float:
    """Page faults per 640x376 mono8 frame in a process that echoes each one back."""
    import numpy as np

    from servolab.middleware.context import Context
    from servolab.middleware.node import Node
    from servolab.middleware.transport import TransportOptions

    endpoint = f"tcp/127.0.0.1:{free_port()}"
    env = {**os.environ, KEEP_FREED_ENV: keep}
    with Context.open(TransportOptions("zenoh", listen=[endpoint])) as ctx:
        node = Node(ctx, "main")
        ping = node.create_publisher(IMAGE, "/ping", 0)
        pongs: list[int] = []
        node.create_subscription(IMAGE, "/pong", lambda m: pongs.append(int(m.data[0])), 0)
        frame = node.message(IMAGE, height=376, width=640, encoding="mono8", step=640,
                             data=np.full(640 * 376, 9, dtype=np.uint8))
        with started([sys.executable, "-c", ECHO, endpoint, str(frames)], env) as echo:
            wait_for_line(echo, "ready", timeout=30)
            assert ping.wait_for_subscription(30)
            for n in range(frames):  # one in flight, as a ping-pong
                ping.publish(frame)
                assert ctx.spin_until(lambda n=n: len(pongs) > n, timeout=30), n
            line = wait_for_line(echo, "faults per frame", timeout=30)
    assert pongs == [9] * frames
    return float(line[-1].split()[-1])


@pytest.mark.slow
@pytest.mark.skipif(_glibc_mallopt() is None, reason="the setting is glibc's mallopt; other "
                    "C libraries are left as they are")
def test_an_echoed_camera_frame_faults_no_page_in() -> None:
    # glibc's own thresholds (0 leaves them): the frame's buffers come back as new memory
    # (86 faults a frame on the project's machine: the frame is 59 pages)
    assert faults_per_frame("0") > 30
    # the heap keeps its freed memory: the buffers are the same memory frame after frame
    assert faults_per_frame("") < 2


def test_the_amount_comes_from_the_environment_and_is_checked() -> None:
    assert keep_mb({}) == DEFAULT_KEEP_MB
    assert keep_mb({KEEP_FREED_ENV: " "}) == DEFAULT_KEEP_MB
    assert keep_mb({KEEP_FREED_ENV: "12.5"}) == 12.5
    assert keep_mb({KEEP_FREED_ENV: "0"}) == 0
    assert keep_mb({KEEP_FREED_ENV: "2147"}) == 2147
    # mallopt takes a C int of bytes: 3000 MB would wrap to a negative, "never trim"
    for bad in ("lots", "-1", "inf", "nan", "3000"):
        with pytest.raises(ServolabValueError, match=f"{KEEP_FREED_ENV}='{bad}': give a "
                           "number of MB from 0 to 2147"):
            keep_mb({KEEP_FREED_ENV: bad})
    assert keep_freed_memory(0) == 0  # nothing asked, nothing changed
    with pytest.raises(ServolabValueError, match="from 0 to 2147"):
        keep_freed_memory(MAX_KEEP_MB + 1)


def test_a_bad_amount_is_said_before_the_graph_is_joined(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from servolab.middleware.context import Context
    from servolab.middleware.transport import TransportOptions

    def no_transport(*_args: object) -> None:
        raise AssertionError("the transport was opened before the variable was checked")

    monkeypatch.setattr("servolab.middleware.context.open_transport", no_transport)
    monkeypatch.setenv(KEEP_FREED_ENV, "much")
    with pytest.raises(ServolabValueError, match=KEEP_FREED_ENV):
        Context.open(TransportOptions("zenoh", listen=[f"tcp/127.0.0.1:{free_port()}"]))
