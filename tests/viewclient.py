"""Foxglove's own WebSocket client, run by Node, as a test oracle for ``servolab view``.

``tests/view_client/client.mjs`` connects with ``FoxgloveClient`` from ``@foxglove/ws-protocol``
over the ``ws`` package (Node 20 has no global WebSocket), subscribes to topics and decodes
their ROS 2 CDR messages with ``@foxglove/rosmsg2-serialization`` from the schema text the
server advertises (parsed by ``@foxglove/rosmsg``): none of it written by servolab. It prints
one JSON line per event (``serverInfo``, ``advertise``, ``subscribe``, ``message``,
``parameterValues``, ``serviceResponse``, ``error``, ``close``, ``timeout``, ``done``).

``make view-oracle`` installs its npm packages (``npm ci`` from the lock file) into
``tests/view_client/node_modules``; the tests never reach the network. Where Node or the
packages are missing, the tests that need the client skip saying so (:func:`node_client`).
"""

from __future__ import annotations

import json
import shutil
import subprocess
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import Any

import pytest

from tests.clirun import SERVOLAB

REPO = Path(__file__).resolve().parents[1]
VIEW_CLIENT = REPO / "tests" / "view_client"
CLIENT_SCRIPT = VIEW_CLIENT / "client.mjs"
#: the npm packages client.mjs imports; ``make view-oracle`` installs them.
PACKAGES = ("@foxglove/ws-protocol", "@foxglove/rosmsg2-serialization", "@foxglove/rosmsg", "ws")

#: The subprotocol of the Foxglove WebSocket protocol (ws-protocol's spec) and the one the
#: Foxglove SDK's own server speaks (it answers HTTP 400 to the other).
WEBSOCKET_V1 = "foxglove.websocket.v1"
SDK_V1 = "foxglove.sdk.v1"

Event = dict[str, Any]


def node_client() -> tuple[str, Path]:
    """The ``node`` executable and ``client.mjs``; the test is skipped, saying why, where
    Node is not installed or ``make view-oracle`` did not install the client's packages."""
    node = shutil.which("node")
    if node is None:
        pytest.skip("the Foxglove WebSocket oracle needs Node.js: node not found on PATH "
                    "(install Node 20, then make view-oracle)")
    modules = VIEW_CLIENT / "node_modules"
    missing = [p for p in PACKAGES if not (modules / p / "package.json").exists()]
    if missing:
        pytest.skip(f"make view-oracle did not install the Foxglove client's npm packages "
                    f"({', '.join(missing)} missing from {VIEW_CLIENT / 'node_modules'}; "
                    f"see {VIEW_CLIENT / 'install.log'})")
    return node, CLIENT_SCRIPT


def client_args(url: str, subprotocol: str, topics: Iterable[str] = (), count: int = 1,
                timeout: float = 10.0, *, get_parameters: Iterable[str] | None = None,
                set_parameters: Mapping[str, Any] | None = None,
                call_service: str | None = None, request: Any = None) -> list[str]:
    """The command line of the client (see :func:`started_client`)."""
    node, script = node_client()
    args = [node, str(script), "--url", url, "--subprotocol", subprotocol,
            "--count", str(count), "--timeout", f"{timeout:g}"]
    for topic in topics:
        args += ["--topic", topic]
    if get_parameters is not None:
        args += ["--get-parameters", ",".join(get_parameters)]
    for name, value in (set_parameters or {}).items():
        args += ["--set-parameter", f"{name}={json.dumps(value)}"]
    if call_service is not None:
        args += ["--call-service", call_service,
                 "--request-json", json.dumps({} if request is None else request)]
    return args


class NodeClient:
    """A running client: its events as they arrive (parsed JSON lines; a line that is not
    JSON is kept as ``{"op": "unparsed", "line": ...}``) and its stderr."""

    def __init__(self, args: list[str]) -> None:
        self.args = args
        self.proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                     stdin=subprocess.DEVNULL, text=True, cwd=VIEW_CLIENT)
        self._lock = threading.RLock()
        #: notified on every event and when the client's output ends: waits wake on it
        self._changed = threading.Condition(self._lock)
        self._events: list[Event] = []
        self._stderr: list[str] = []
        self._readers = [threading.Thread(target=self._read_stdout, daemon=True),
                         threading.Thread(target=self._read_stderr, daemon=True)]
        for reader in self._readers:
            reader.start()

    def _read_stdout(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            line = line.strip()
            if not line:
                continue
            try:
                event = json.loads(line)
            except ValueError:
                event = {"op": "unparsed", "line": line}
            if not isinstance(event, dict):
                event = {"op": "unparsed", "line": line}
            with self._changed:
                self._events.append(event)
                self._changed.notify_all()
        with self._changed:  # its output ended: the client is leaving
            self._changed.notify_all()

    def _read_stderr(self) -> None:
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            with self._lock:
                self._stderr.append(line)

    @property
    def events(self) -> list[Event]:
        """A copy of the events so far."""
        with self._lock:
            return list(self._events)

    @property
    def stderr(self) -> str:
        with self._lock:
            return "".join(self._stderr)

    def of(self, op: str, topic: str | None = None) -> list[Event]:
        """The events of kind ``op`` so far (on ``topic`` when given)."""
        return [e for e in self.events if e.get("op") == op
                and (topic is None or e.get("topic") == topic)]

    def messages(self, topic: str) -> list[Any]:
        """The decoded messages received on ``topic`` so far."""
        return [e["message"] for e in self.of("message", topic)]

    @property
    def returncode(self) -> int | None:
        return self.proc.poll()

    def describe(self) -> str:
        """What the client did so far, for a failure message."""
        events = "\n  ".join(json.dumps(e)[:300] for e in self.events[-20:]) or "(none)"
        return (f"client {'running' if self.returncode is None else f'exit {self.returncode}'}"
                f"; last events:\n  {events}\nstderr: {self.stderr.strip()[-2000:] or '(none)'}")

    def _await_change(self, deadline: float) -> None:
        """Wait for the next event or the end of the client's output, at most until
        ``deadline`` (and a moment, so an exit without output is seen too)."""
        with self._changed:
            self._changed.wait(max(0.0, min(deadline - time.monotonic(), 0.2)))

    def wait_until(self, predicate: Callable[[NodeClient], object], what: str,
                   timeout: float = 10.0) -> None:
        """Poll ``predicate(self)`` until true, failing after ``timeout`` s (or as soon as the
        client exited without it) with what the client did instead."""
        deadline = time.monotonic() + timeout
        while not predicate(self):
            if self.returncode is not None:
                self._join_readers()
                if predicate(self):
                    return
                raise AssertionError(f"the Foxglove client ended without {what}: {self.describe()}")
            if time.monotonic() > deadline:
                raise AssertionError(f"timed out after {timeout:g} s waiting for {what}: "
                                     f"{self.describe()}")
            self._await_change(deadline)

    def wait_for_more(self, op: str, timeout: float) -> bool:
        """Wait up to ``timeout`` s for one more event of kind ``op`` than there is now (or for
        the client's end); returns whether one came. For pacing a loop that feeds the client,
        never a failure."""
        seen = len(self.of(op))
        deadline = time.monotonic() + timeout
        while len(self.of(op)) == seen and self.returncode is None:
            if time.monotonic() > deadline:
                return False
            self._await_change(deadline)
        return len(self.of(op)) > seen

    def wait(self, timeout: float) -> int:
        """The client's exit code once it ended by itself (it stops at its own ``--timeout``);
        failing, and stopping it, if it still runs after ``timeout`` s."""
        try:
            code = self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self.stop()
            raise AssertionError(f"the Foxglove client did not end within {timeout:g} s: "
                                 f"{self.describe()}") from None
        self._join_readers()
        return code

    def _join_readers(self) -> None:
        for reader in self._readers:
            reader.join(5.0)

    def stop(self) -> None:
        """End the client (terminate, then kill) if it still runs; it starts no children."""
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(5.0)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self._join_readers()
        for stream in (self.proc.stdout, self.proc.stderr):
            if stream is not None:
                with suppress(OSError):
                    stream.close()


@contextmanager
def started_client(url: str, subprotocol: str, topics: Iterable[str] = (), count: int = 1,
                   timeout: float = 10.0, *, get_parameters: Iterable[str] | None = None,
                   set_parameters: Mapping[str, Any] | None = None,
                   call_service: str | None = None,
                   request: Any = None) -> Iterator[NodeClient]:
    """The client running for the length of a ``with`` block, always stopped at its end.

    It connects to ``url`` with ``subprotocol``, subscribes to each of ``topics`` once the
    server advertises it, and ends by itself (exit 0, a ``done`` event) once each topic gave
    ``count`` messages and the parameter requests and the service call were answered, or at
    ``timeout`` s (exit 2, a ``timeout`` event), or when the connection fails or closes
    (exit 1, ``error``/``close`` events). ``set_parameters`` maps names to JSON values;
    ``request`` is the service request as a JSON value (int64 fields may be numbers)."""
    client = NodeClient(client_args(url, subprotocol, topics, count, timeout,
                                    get_parameters=get_parameters,
                                    set_parameters=set_parameters,
                                    call_service=call_service, request=request))
    try:
        yield client
    finally:
        client.stop()


def run_client(url: str, subprotocol: str, topics: Iterable[str] = (), count: int = 1,
               timeout: float = 10.0, *, get_parameters: Iterable[str] | None = None,
               set_parameters: Mapping[str, Any] | None = None,
               call_service: str | None = None, request: Any = None) -> list[Event]:
    """Run the client to its end (see :func:`started_client`) and return its events; the
    last is ``done``, ``timeout`` or ``close``. It is stopped if it overruns its own
    ``timeout`` by 10 s."""
    with started_client(url, subprotocol, topics, count, timeout,
                        get_parameters=get_parameters, set_parameters=set_parameters,
                        call_service=call_service, request=request) as client:
        client.wait(timeout + 10.0)
        return client.events


@contextmanager
def watched_run(args: list[str], out: Path, *, speed: str = "4") -> Iterator[str]:
    """``servolab ARGS --view PORT --view-speed SPEED --no-progress --out OUT`` started and
    waiting for its first viewer; yields the URL to watch it on. After the block the run must
    end by itself with status 0, having told the student where it was served."""

    from tests.middleware.conftest import free_port
    from tests.processes import started
    from tests.waiting import wait_for

    port = free_port()
    output: list[str] = []
    with started([*SERVOLAB, *args, "--view", str(port),
                  "--view-speed", speed, "--no-progress", "--out", str(out)],
                 stderr_to_stdout=True) as proc:
        reader = threading.Thread(target=lambda: output.extend(proc.stdout or ()),
                                  daemon=True)
        reader.start()
        wait_for(lambda: any("waiting for a viewer" in line for line in output)
                 or proc.poll() is not None, "the run to wait for a viewer", timeout=90)
        assert proc.poll() is None, "".join(output)[-3000:]
        yield f"ws://127.0.0.1:{port}"
        proc.wait(timeout=180)
        reader.join(timeout=10)
    text = "".join(output)
    assert proc.returncode == 0, text[-3000:]
    assert f"serving the run on ws://127.0.0.1:{port}" in text  # the student is told where
