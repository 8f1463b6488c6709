"""Launching: start a robot's nodes from one launch file, in one process or in many.

The format and its checks are in :mod:`.launch_file`.

Why two ways to run: with the local transport every node must share one process (messages
are passed as objects), so such a launch is built here, in one :class:`Context`, and needs no
child process at all. Anything else runs as child processes, one per ``process`` group and
one per ``exec`` entry, under a supervisor that prefixes their output with their name, stops
them all with SIGINT (then SIGTERM, then SIGKILL) on Ctrl-C or when a required one ends, and
leaves none behind.

Over Zenoh with no endpoints given, the children meet on a loopback port picked at run time
(the first listens on it, the others connect to it), so two launches never cross; the
supervisor prints it, and an ``exec`` entry gets it as ``$(zenoh_endpoint)``. Give
``zenoh: {listen: [...]}`` or ``--listen`` for a fixed port that other tools and machines reach.

Machines are not logged in to: each machine runs ``servolab launch FILE`` itself and starts
the entries whose machine address is its own (or those ``--machine NAME`` picks).
"""

from __future__ import annotations

import logging
import os
import signal
import socket
import subprocess
import sys
import threading
import time
import traceback
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from types import FrameType

from servolab.harness import signal_status
from servolab.limits import clip
from servolab.signals import on_stop_signals

from .context import Context
from .errors import LaunchError, MiddlewareError, ParameterError, TransportError
from .launch_file import (
    DEFAULT_PROCESS,
    STOP_TIMEOUT,
    ZENOH_ENDPOINT,
    LaunchFile,
    Machine,
    NodeEntry,
    check_entries,
    import_node_class,
    is_local_address,
    launched_class,
    load_launch,
    node_call,
    one_line,
)
from .node import LOGGER_PREFIX, Node
from .parameters import ParameterOverrides
from .transport import TransportOptions, environment_domain_id

__all__ = ["DEFAULT_PROCESS", "STOP_TIMEOUT", "ZENOH_ENDPOINT", "LaunchFile", "Machine",
           "NodeEntry", "build_node", "check_entries", "child_command", "child_environment",
           "child_transports", "exec_command", "free_loopback_port", "import_node_class",
           "is_local_address", "launch_main", "load_launch", "run_launch", "run_process_group"]


# -- running ---------------------------------------------------------------------------------


def _echo(line: str) -> None:
    """Print and flush: a supervisor's output is often a pipe, read line by line."""
    print(line, flush=True)


def run_launch(launch: LaunchFile, *, machine: str | None = None,
               transport_override: TransportOptions | None = None,
               out: Callable[[str], None] = _echo, stop_timeout: float = STOP_TIMEOUT,
               view: int | None = None) -> int:
    """Run the entries of ``launch`` that belong here; returns the exit code.

    ``view`` (a TCP port) serves the launch's graph to Foxglove (:mod:`.view`): in this
    process beside the nodes, or, when the nodes run in child processes, as one more
    supervised child, ``servolab view`` on the launch's transport.

    With the local transport and a single process group, the nodes are built in this process
    and spun until Ctrl-C or until one of them shuts the context down; otherwise each
    process group and each ``exec`` entry is a supervised child process. ``out`` receives
    every line: ``[launch] ...`` notices, and node and child output prefixed with its name.
    Stopping sends SIGINT, then SIGTERM after ``stop_timeout`` s, then SIGKILL after as long.
    """
    options = launch.transport_options(transport_override)
    entries = launch.entries_for(machine)
    if not entries:
        where = f"machine {machine!r}" if machine else f"this computer ({socket.gethostname()})"
        machines = ", ".join(f"{m.name}={m.address}" for m in launch.machines.values())
        raise LaunchError(f"{launch.path}: nothing runs on {where} (machines: {machines}; "
                          "pick one with --machine)")
    if options.kind == "local" and launch.process_count() > 1:
        raise LaunchError(f"{launch.path}: transport local runs every node in one process; "
                          f"this launch has {launch.process_count()} (use zenoh)")
    check_entries(launch, entries)
    groups = launch.process_groups(entries)
    commands = [e for e in entries if e.is_exec]
    if options.kind == "local" and not commands:
        return _run_nodes(launch, entries, options, out, view=view)
    return _Supervisor(launch, out, stop_timeout).run(groups, commands, options, view=view)


def run_process_group(launch: LaunchFile, group: str, options: TransportOptions, *,
                      out: Callable[[str], None] = _echo) -> int:
    """Run one process group's nodes in this process: what ``servolab launch FILE --process
    GROUP`` does in each child the supervisor starts. Node log records go to ``out`` (the
    child's stdout) as ``[node_fqn] LEVEL message``."""
    groups = launch.process_groups()
    if group not in groups:
        raise LaunchError(f"{launch.path}: no process {group!r} "
                          f"(processes: {', '.join(groups) or 'none'})")
    check_entries(launch, groups[group])
    return _run_nodes(launch, groups[group], options, out)


def launch_main(file: str | Path, *, machine: str | None = None, process: str | None = None,
                transport: str | None = None, listen: Sequence[str] = (),
                connect: Sequence[str] = (), domain_id: int | None = None,
                out: Callable[[str], None] = _echo, view: int | None = None,
                arguments: Mapping[str, str] | None = None) -> int:
    """``servolab launch FILE [--machine M] [--process G] [--transport T] [--listen E]...
    [--connect E]... [--domain-id N]``: what the CLI calls with its parsed arguments.

    ``transport`` None or "" means the file's; ``domain_id`` None means ``$ROS_DOMAIN_ID``
    or 0, resolved here once so that every child is given the same one. ``arguments``: the
    launch arguments (``robots:=3``), passed on to every child."""
    launch = load_launch(file, arguments=arguments)
    if domain_id is None:
        try:
            domain_id = environment_domain_id()
        except TransportError as error:
            raise LaunchError(str(error)) from None
    override = TransportOptions(transport or launch.transport, list(listen), list(connect),
                                domain_id)
    if process is not None:
        if machine is not None:
            raise LaunchError("--machine and --process cannot be combined (a process group "
                              "runs wherever it is started)")
        return run_process_group(launch, process, launch.transport_options(override), out=out)
    return run_launch(launch, machine=machine, transport_override=override, out=out, view=view)


# -- in this process -------------------------------------------------------------------------


class _NodeLogFormatter(logging.Formatter):
    def format(self, record: logging.LogRecord) -> str:
        text = (f"[{record.name.removeprefix(LOGGER_PREFIX)}] {record.levelname} "
                f"{record.getMessage()}")
        if record.exc_info:
            text += "\n" + self.formatException(record.exc_info)
        return text


class _LineHandler(logging.Handler):
    """Hands each formatted record to ``out``: the launch's output, not a global stream."""

    def __init__(self, out: Callable[[str], None]) -> None:
        super().__init__()
        self.out = out
        self.setFormatter(_NodeLogFormatter())

    def emit(self, record: logging.LogRecord) -> None:
        try:
            self.out(self.format(record))
        except Exception:
            self.handleError(record)


@contextmanager
def _node_logging(entries: Sequence[NodeEntry], out: Callable[[str], None]) -> Iterator[None]:
    """Route servolab's loggers — every node's in this process, the entries' and those they
    create (a robot's controller manager), and the driver's — to ``out`` while they run, at
    INFO unless a level was set (``--log-level``), and undo it after."""
    handler = _LineHandler(out)
    top = logging.getLogger(LOGGER_PREFIX.split(".")[0])
    saved = top.level
    top.addHandler(handler)
    if top.level == logging.NOTSET:
        top.setLevel(logging.INFO)
    try:
        yield
    finally:
        top.removeHandler(handler)
        top.setLevel(saved)


def _run_nodes(launch: LaunchFile, entries: Sequence[NodeEntry], options: TransportOptions,
               out: Callable[[str], None], *, view: int | None = None) -> int:
    """Build ``entries`` in one context and spin until Ctrl-C, SIGTERM or a node shuts the
    context down (all of them share it, so any node ending it ends them all)."""
    classes = [(entry, import_node_class(launch, entry)) for entry in entries]
    overrides = ParameterOverrides()
    overrides.merge(launch.parameters)
    started: list[NodeEntry] = []
    viewer = None
    with _node_logging(entries, out):
        context = Context.open(options, parameter_overrides=overrides)
        try:
            with context.stop_on_signals():  # Ctrl-C while building ends the launch cleanly
                for entry, cls in classes:
                    if not context.ok():
                        break
                    try:
                        build_node(launch, entry, cls, context)
                    except MiddlewareError as exc:
                        key = "parameters" if isinstance(exc, ParameterError) else None
                        raise launch.error(entry, key, clip(str(exc), 200)) from None
                    except ArithmeticError as exc:  # 1.0 / rate, with a rate of 0
                        raise launch.error(entry, "parameters" if entry.parameters else None,
                                           f"{entry.node} could not be built: {one_line(exc)} "
                                           "(is a rate or period 0?)") from None
                    started.append(entry)
                    out(f"[launch] started {entry.name} (in process {os.getpid()})")
                if view is not None and context.ok():
                    from .view.server import ViewConfig, ViewServer

                    viewer = ViewServer(context, ViewConfig(port=view, name="servolab launch"))
                    out(f"[launch] serving the graph on {viewer.url} (Foxglove, Lichtblick)")
                try:
                    context.spin()
                except Exception as exc:  # a node's callback failed: stop the rest cleanly
                    out(f"[launch] stopping: a callback raised {one_line(exc)}")
                    for line in traceback.format_exc().rstrip().splitlines():
                        out(f"[launch] {line}")
                    return 1
        finally:
            if viewer is not None:
                viewer.close()
            context.close()
            for entry in started:
                out(f"[launch] stopped {entry.name}")
    # stopped by a signal: 128 + its number, as every servolab command (servolab.harness)
    return 0 if context.stopped_by is None else signal_status(context.stopped_by)


def build_node(launch: LaunchFile, entry: NodeEntry, cls: type[Node], context: Context) -> Node:
    """Build ``entry``'s node on ``context``: a servolab node class as ``cls(context, name,
    namespace, parameter_overrides=..., remappings=...)``, an rclpy-shaped one (whose
    ``__init__`` takes a node name, as rclpy's ``Node(node_name, *, namespace=...,
    parameter_overrides=...)``) through :func:`~.launch_file.launched_class`, which gives
    it the launch's context and the entry's name, namespace, parameters and remappings."""
    call = node_call(launch, entry, cls)
    if not call.rclpy:
        return cls(context, *call.args, **call.kwargs)
    return launched_class(cls, context, entry)(*call.args, **call.kwargs)


# -- child processes -------------------------------------------------------------------------


def free_loopback_port() -> int:
    """A TCP port free on 127.0.0.1 now (the first child listens on it right after)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def child_transports(options: TransportOptions, count: int
                     ) -> tuple[list[TransportOptions], str | None]:
    """Zenoh endpoints for ``count`` process groups, and the endpoint they meet on.

    The first listens (on the given endpoints, or on a free loopback port); the others
    listen on any loopback port, for the direct links Zenoh's gossip finds, and connect to
    the first. Only ``connect`` given (e.g. a router on the robot): all use it as it is.
    """
    if options.listen:
        hub = [_loopback(e) for e in options.listen]
        first = options
    elif options.connect:
        return [options] * count, options.connect[0]
    else:
        hub = [f"tcp/127.0.0.1:{free_loopback_port()}"]
        first = TransportOptions("zenoh", hub, [], options.domain_id)
    rest = TransportOptions("zenoh", ["tcp/127.0.0.1:0"], hub + list(options.connect),
                            options.domain_id)
    return ([first] + [rest] * count)[:count], hub[0]


def _loopback(endpoint: str) -> str:
    """``tcp/0.0.0.0:7447`` listens everywhere; from this computer it is reached on loopback."""
    return (endpoint.replace("/0.0.0.0:", "/127.0.0.1:").replace("/[::]:", "/[::1]:"))


def child_command(launch: LaunchFile, group: str, options: TransportOptions) -> list[str]:
    """The command that runs one process group: ``servolab launch FILE --process GROUP``."""
    argv = [sys.executable, "-m", "servolab", "launch", str(launch.path.resolve()),
            *(f"{name}:={value}" for name, value in launch.given.items()),
            "--process", group, "--transport", options.kind]
    for endpoint in options.listen:
        argv += ["--listen", endpoint]
    for endpoint in options.connect:
        argv += ["--connect", endpoint]
    return [*argv, "--domain-id", str(options.domain_id)]


def view_command(options: TransportOptions, endpoint: str | None, port: int) -> list[str]:
    """``servolab view`` on the launch's transport, joined where its processes meet."""
    joined = _joining(options, endpoint)
    argv = [sys.executable, "-m", "servolab", "view", "--ws-port", str(port),
            "--transport", joined.kind, "--domain-id", str(joined.domain_id)]
    for connect in joined.connect:
        argv += ["--connect", connect]
    return argv


def child_environment(options: TransportOptions) -> dict[str, str]:
    """What a child finds in its environment of the launch's transport: the variables
    servolab's default context reads (``SERVOLAB_TRANSPORT``, ``SERVOLAB_LISTEN``,
    ``SERVOLAB_CONNECT``, as :func:`~.default_context.options_from_environment`) and
    ``ROS_DOMAIN_ID``. An ``exec`` entry's program that opens the default context (rclpy-shaped
    code on :mod:`servolab.rclpy`) so meets the launch's nodes."""
    return {"SERVOLAB_TRANSPORT": options.kind, "SERVOLAB_LISTEN": ",".join(options.listen),
            "SERVOLAB_CONNECT": ",".join(options.connect),
            "ROS_DOMAIN_ID": str(options.domain_id)}


def _joining(options: TransportOptions, endpoint: str | None) -> TransportOptions:
    """The transport a second session in a node group's process (its code opening the
    default context) joins the launch with: connected to where the processes meet, listening
    on nothing, since the group's own session may already listen on that port."""
    if options.kind != "zenoh":
        return options
    connect = list(dict.fromkeys(([endpoint] if endpoint else []) + list(options.connect)))
    return TransportOptions("zenoh", [], connect, options.domain_id)


def _deaf_servolab_command(entry: NodeEntry) -> bool:
    """Whether an ``exec`` entry runs a ``servolab`` command given no endpoint: the CLI takes
    its transport from its options, not from the environment, so it would not meet the
    launch's processes."""
    return entry.command[0] == "servolab" and not any(
        ZENOH_ENDPOINT in arg or arg in ("--connect", "--listen", "--transport")
        or arg.startswith(("--connect=", "--listen=", "--transport="))
        for arg in entry.command[1:])


def exec_command(entry: NodeEntry, endpoint: str | None) -> list[str]:
    """An ``exec`` entry's command; ``servolab`` runs as this interpreter's ``-m servolab``,
    so the child uses the same installation as the launch."""
    argv = [arg.replace(ZENOH_ENDPOINT, endpoint or "") for arg in entry.command]
    if argv[0] == "servolab":
        argv[:1] = [sys.executable, "-m", "servolab"]
    return argv


def _exit_code(returncode: int) -> int:
    return returncode if returncode >= 0 else signal_status(-returncode)


def _describe(returncode: int) -> str:
    if returncode >= 0:
        return f"exited with {returncode}"
    try:
        return f"was ended by {signal.Signals(-returncode).name}"
    except ValueError:
        return f"was ended by signal {-returncode}"


@dataclass
class _Child:
    label: str
    argv: list[str]
    required: bool
    env: dict[str, str]
    proc: subprocess.Popen[str] | None = None
    reader: threading.Thread | None = None
    reported: bool = False


class _Supervisor:
    """Starts the children, relays their output, and stops them all (see the module
    docstring). Each child gets its own process group: Ctrl-C in the terminal then reaches
    only the supervisor, which passes one SIGINT on to every child and its own children."""

    def __init__(self, launch: LaunchFile, out: Callable[[str], None],
                 stop_timeout: float) -> None:
        self.launch = launch
        self.stop_timeout = stop_timeout
        self.children: list[_Child] = []
        self.signals: list[int] = []
        self.stop = threading.Event()
        self._lock = threading.Lock()
        self._out = out

    def emit(self, line: str) -> None:
        with self._lock:  # reader threads and the main thread share out
            self._out(line)

    def run(self, groups: dict[str, list[NodeEntry]], commands: Sequence[NodeEntry],
            options: TransportOptions, *, view: int | None = None) -> int:
        # every child, node group or exec entry, gets its transport: a group on its command
        # line, and each (exec entries too, issue 32 D5) in its environment
        count = len(groups) + len(commands)
        transports = [options] * count
        endpoint = None
        if options.kind == "zenoh":
            transports, endpoint = child_transports(options, count)
        if endpoint and not (options.listen or options.connect):
            self.emit(f"[launch] zenoh: the processes meet on {endpoint} (other tools: "
                      f"--connect {endpoint})")
        labels: set[str] = set()
        for (group, members), transport in zip(groups.items(), transports, strict=False):
            label = members[0].name if len(members) == 1 else group
            self.children.append(_Child(_unique(label, labels),
                                        child_command(self.launch, group, transport),
                                        any(m.required for m in members),
                                        child_environment(_joining(transport, endpoint))))
        for entry, transport in zip(commands, transports[len(groups):], strict=True):
            if (options.kind == "dds" and entry.command[0] == "servolab"
                    and "--transport" not in entry.command):
                self.emit(f"[launch] warning: {entry.name} runs a servolab command without "
                          "--transport dds; it would use its own default (zenoh), not the "
                          "launch's DDS")
            if options.kind == "zenoh" and _deaf_servolab_command(entry):
                self.emit(f"[launch] warning: {entry.name} runs a servolab command with no "
                          f"endpoint; give it --connect {ZENOH_ENDPOINT} to reach the "
                          "launch's processes")
            self.children.append(_Child(_unique(entry.name, labels),
                                        exec_command(entry, endpoint), entry.required,
                                        child_environment(transport)))
        if view is not None:  # the graph served to Foxglove by a child of its own
            self.children.append(_Child("view", view_command(options, endpoint, view), False,
                                        child_environment(_joining(options, endpoint))))
        with on_stop_signals(self._on_signal):
            try:
                for child in self.children:
                    if self.stop.is_set():
                        break
                    self._start(child)
                return self._watch()
            finally:
                self._stop_all()  # also on an exception: never leave a child behind

    def _on_signal(self, signum: int, frame: FrameType | None) -> None:
        self.signals.append(signum)
        self.stop.set()

    def _start(self, child: _Child) -> None:
        try:
            child.proc = subprocess.Popen(
                child.argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                stderr=subprocess.STDOUT, text=True, errors="replace", bufsize=1,
                env={**os.environ, "PYTHONUNBUFFERED": "1", **child.env}, process_group=0)
        except OSError as exc:
            raise LaunchError(f"cannot start {child.label}: {exc}") from None
        self.emit(f"[launch] started {child.label} (pid {child.proc.pid})")
        child.reader = threading.Thread(target=self._relay, args=(child,), daemon=True,
                                        name=f"launch-{child.label}")
        child.reader.start()

    def _relay(self, child: _Child) -> None:
        assert child.proc is not None and child.proc.stdout is not None
        with child.proc.stdout:
            for line in child.proc.stdout:
                self.emit(f"[{child.label}] {line.rstrip()}")

    def _reap(self, child: _Child, note: str = "") -> None:
        assert child.proc is not None
        child.proc.wait()
        if child.reader is not None:
            child.reader.join(timeout=2.0)  # its last lines come before the exit notice
        child.reported = True
        self.emit(f"[launch] {child.label} {_describe(child.proc.returncode)}{note}")

    def _watch(self) -> int:
        """Wait for a signal or for children to exit; returns the launch's exit code."""
        first_failure = 0
        while True:
            if self.stop.is_set():
                name = signal.Signals(self.signals[0]).name if self.signals else "stop"
                self.emit(f"[launch] {name}: stopping everything")
                killed = self._stop_all()
                # stopped by a signal: 128 + its number, as every servolab command
                return signal_status(self.signals[0]) if self.signals else (1 if killed else 0)
            running = False
            for child in self.children:
                if child.proc is None or child.reported:
                    continue
                returncode = child.proc.poll()
                if returncode is None:
                    running = True
                elif child.required:
                    self._reap(child, "; stopping the others (required)")
                    self._stop_all()
                    return _exit_code(returncode)
                else:
                    self._reap(child)
                    first_failure = first_failure or _exit_code(returncode)
            if not running:
                self.emit("[launch] every process has exited")
                return first_failure
            self.stop.wait(0.05)

    def _signal(self, child: _Child, sig: signal.Signals) -> None:
        assert child.proc is not None
        if child.proc.returncode is not None:
            return  # reaped: its pid may already be someone else's
        try:
            os.killpg(child.proc.pid, sig)  # the child and whatever it started
        except ProcessLookupError:
            pass
        except PermissionError:  # macOS refuses a group whose leader is a zombie
            child.proc.send_signal(sig)

    def _stop_all(self) -> bool:
        """SIGINT to every running child; after ``stop_timeout`` SIGTERM, then SIGKILL (or
        at once on another Ctrl-C). Returns whether any needed SIGKILL."""
        alive = [c for c in self.children
                 if c.proc is not None and not c.reported and c.proc.poll() is None]
        killed = False
        previous: signal.Signals | None = None
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGKILL):
            alive = [c for c in alive if c.proc is not None and c.proc.poll() is None]
            if not alive:
                break
            if previous is not None:
                self.emit(f"[launch] {', '.join(c.label for c in alive)} still running after "
                          f"{previous.name}; sending {sig.name}")
            killed = sig == signal.SIGKILL
            for child in alive:
                self._signal(child, sig)
            signals_before = len(self.signals)
            deadline = time.monotonic() + self.stop_timeout
            while alive and time.monotonic() < deadline:
                for child in alive:
                    if child.proc is not None and child.proc.poll() is not None:
                        self._reap(child)
                alive = [c for c in alive if not c.reported]
                if len(self.signals) > signals_before:
                    break  # another Ctrl-C: do not wait out the grace period
                time.sleep(0.02)
            previous = sig
        for child in self.children:
            if child.proc is not None and not child.reported:
                self._reap(child)
        return killed


def _unique(label: str, taken: set[str]) -> str:
    candidate, n = label, 1
    while candidate in taken:
        n += 1
        candidate = f"{label}#{n}"
    taken.add(candidate)
    return candidate
