"""Run the rclpy programs of ``tests/rclpy_programs`` under the real rclpy or under servolab.

A *run* is a tuple of programs started together (a listener and a talker, a server and a
client, or one program alone); each must end by itself. What a program says is its stdout
lines and its log lines (rcutils' ``[LEVEL] [stamp] [logger]: text`` on stderr) with the
stamp taken out, so that runs compare line for line.

The transport is a parameter: ``ros`` is the real rclpy (its own venv, Fast DDS, a free ROS
domain, discovery on loopback); ``zenoh`` is servolab with the programs' imports rewritten
(:func:`servolabify`) over Zenoh, the first program listening on a free port and the others
connecting to it. Another servolab transport is one more entry in :func:`servolab_env`.
"""

from __future__ import annotations

import os
import re
import socket
import subprocess
import sys
from pathlib import Path

from tests.processes import started
from tests.rosoracle import free_domain_id, ros_env, ros_python

PROGRAMS = Path(__file__).resolve().parents[1] / "rclpy_programs"
EXPECTED = PROGRAMS / "expected"

#: rcutils' default console format, with the stamp as a group to drop
_LOG_LINE = re.compile(r"^\[(DEBUG|INFO|WARN|ERROR|FATAL)\] \[[0-9.]+\] \[([^\]]*)\]: (.*)$")

_IMPORT_REWRITES = [
    (re.compile(r"^import rclpy$"), "from servolab import rclpy"),
    (re.compile(r"^from rclpy import (.*)$"), r"from servolab.rclpy import \1"),
    (re.compile(r"^from rclpy\.([\w.]+) import (.*)$"), r"from servolab.rclpy.\1 import \2"),
    (re.compile(r"^from (\w+)\.(msg|srv) import (.*)$"),
     r"from servolab.interfaces.\1.\2 import \3"),
]


def servolabify(source: str) -> str:
    """The program with only its import lines changed, as ``docs/from_rclpy.md`` says."""
    out = []
    for line in source.splitlines():
        for pattern, replacement in _IMPORT_REWRITES:
            if pattern.match(line):
                line = pattern.sub(replacement, line)
                break
        out.append(line)
    return "\n".join(out) + "\n"


def said(stdout: str, stderr: str) -> list[str]:
    """A program's stdout lines, then its log lines without their stamps."""
    lines = [f"out: {line}" for line in stdout.splitlines()]
    for line in stderr.splitlines():
        m = _LOG_LINE.match(line)
        if m:
            lines.append(f"log: [{m.group(1)}] [{m.group(2)}]: {m.group(3)}")
    return lines


def expected(program: str) -> list[str]:
    """What ``program`` said under the real rclpy when its expected file was written."""
    return (EXPECTED / f"{program}.txt").read_text().splitlines()


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


def servolab_env(transport: str, index: int, port: int, domain: int) -> dict[str, str]:
    """The environment of the ``index``-th program of a run on a servolab transport."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("SERVOLAB_", "ROS_"))}
    env.update({"SERVOLAB_TRANSPORT": transport, "ROS_DOMAIN_ID": str(domain),
                "SERVOLAB_ZENOH_ROUTER": "", "PYTHONUNBUFFERED": "1"})
    if transport == "zenoh":
        key = "SERVOLAB_LISTEN" if index == 0 else "SERVOLAB_CONNECT"
        env[key] = f"tcp/127.0.0.1:{port}"
    if transport == "dds":
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    src = str(Path(__file__).resolve().parents[2] / "src")
    env["PYTHONPATH"] = os.pathsep.join(p for p in (src, env.get("PYTHONPATH", "")) if p)
    return env


def run(programs: tuple[str, ...], transport: str | tuple[str, ...], tmp: Path,
        timeout: float = 60.0) -> dict[str, list[str]]:
    """Start ``programs`` together (the first first) on ``transport``; what each said.
    Every process is stopped when this returns, and one that fails or does not end within
    ``timeout`` s fails the test with its output."""
    domain = free_domain_id()
    port = free_port()
    commands = []
    for index, name in enumerate(programs):
        source = (PROGRAMS / f"{name}.py").read_text()
        kind = transport[index] if isinstance(transport, tuple) else transport
        if kind == "ros":
            commands.append(([str(ros_python()), str(PROGRAMS / f"{name}.py")],
                             ros_env(domain)))
        else:
            path = tmp / f"{name}.py"
            path.write_text(servolabify(source))
            commands.append(([sys.executable, str(path)],
                             servolab_env(kind, index, port, domain)))
    return _run_all(programs, commands, timeout)


def _run_all(programs: tuple[str, ...], commands: list[tuple[list[str], dict[str, str]]],
             timeout: float) -> dict[str, list[str]]:
    if not commands:
        return {}
    (args, env), rest = commands[0], commands[1:]
    name = programs[0]
    with started(args, env) as proc:
        others = _run_all(programs[1:], rest, timeout)
        try:
            stdout, stderr = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            stdout, stderr = proc.communicate()
            raise AssertionError(f"{name} did not end within {timeout:g} s; it printed "
                                 f"{stdout[-2000:]}{stderr[-2000:]}") from None
    if proc.returncode != 0:
        raise AssertionError(f"{name} exited with {proc.returncode}:\n{stdout[-2000:]}\n"
                             f"{stderr[-3000:]}")
    return {name: said(stdout, stderr), **others}


#: every run: what the test starts together (listener or server first)
RUNS: list[tuple[str, ...]] = [
    ("subscriber_member_function", "publisher_member_function"),
    ("subscriber_old_school", "publisher_old_school"),
    ("subscriber_lambda", "publisher_local_function"),
    ("listener", "talker"),
    ("service_member_function", "client_async_member_function"),
    ("service_member_function", "client_async_callback"),
    ("service_member_function", "client_sync"),
    ("trigger_server", "trigger_client_async"),
    ("parameter_events_listener", "parameter_events_talker"),
    ("param_server", "async_param_client"),
    ("sim_time_listener", "clock_source"),
    ("timer_member_function",),
    ("timer_local_function",),
    ("executors_composed",),
    ("executors_custom_callback_group",),
    ("executors_multithreaded",),
    ("parameters",),
]


def run_id(programs: tuple[str, ...]) -> str:
    return "+".join(programs)
