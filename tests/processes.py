"""Start a process for a test and always stop it, with whatever it started.

:func:`started` runs a process for the length of a ``with`` block; :func:`run_to_end` runs one
to its end, as ``subprocess.run`` does. Both leave nothing behind: a process such as ``servolab
launch`` starts children that each lead a process group of their own (so that Ctrl-C reaches
only the launcher), and killing the launcher alone would orphan them. So the process's
descendants are recorded (from ``/proc``) while it runs, and once it is stopped whatever is
left of their process groups is killed (:func:`stop_process_tree`, :func:`kill_leftovers`).
"""

from __future__ import annotations

import os
import signal
import subprocess
import threading
import time
from collections.abc import Iterable, Iterator
from contextlib import contextmanager, suppress
from dataclasses import dataclass
from pathlib import Path

from tests.waiting import wait_gone


@contextmanager
def started(args: list[str], env: dict[str, str] | None = None, *,
            stderr_to_stdout: bool = False) -> Iterator[subprocess.Popen[str]]:
    """A process that is always stopped (SIGINT, then kill) when the block ends, and the
    process groups of what it started with it (:func:`kill_leftovers`); ``env`` defaults to
    this process's environment. ``stderr_to_stdout`` reads both as one stream (a program that
    logs to stderr, as rclpy's loggers do)."""
    proc = subprocess.Popen(args, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT if stderr_to_stdout else subprocess.PIPE,
                            text=True,
                            env={**(os.environ if env is None else env),
                                 "PYTHONUNBUFFERED": "1"})
    try:
        yield proc
    finally:
        tracked = descendants(proc.pid) if proc.poll() is None else []
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(5)
            except subprocess.TimeoutExpired:
                tracked += descendants(proc.pid)
                proc.kill()
                proc.wait()
        kill_leftovers(tracked)
        for stream in (proc.stdout, proc.stderr):
            if stream is not None:
                stream.close()


def run_to_end(args: list[str], *, timeout: float, env: dict[str, str] | None = None,
               stop_timeout: float = 20.0) -> subprocess.CompletedProcess[str]:
    """``subprocess.run(args, capture_output=True, text=True, timeout=timeout)`` for a process
    that starts others (``servolab launch``), leaving none of them behind.

    Its descendants are recorded while it runs. If it has not ended after ``timeout`` s it is
    stopped with them (:func:`stop_process_tree`: SIGTERM, on which a launcher stops its
    children itself, SIGKILL ``stop_timeout`` s later, then whatever is left of their process
    groups) and the test fails, with the output so far. A process that exits with 0 but
    leaves processes running fails the test too; one that fails is returned (its leftovers
    killed) for the test to report."""
    proc = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            env={**(os.environ if env is None else env),
                                 "PYTHONUNBUFFERED": "1"})
    output: dict[str, list[str]] = {"stdout": [], "stderr": []}
    readers = [threading.Thread(target=lambda s=stream, lines=output[name]: lines.extend(s),
                                name=f"run_to_end-{name}", daemon=True)
               for name, stream in (("stdout", proc.stdout), ("stderr", proc.stderr))]
    for reader in readers:
        reader.start()
    tracked: dict[int, Tracked] = {}
    deadline = time.monotonic() + timeout
    stopped = ""
    leftovers: list[int] = []
    try:
        while True:
            for t in descendants(proc.pid):
                tracked.setdefault(t.pid, t)
            try:
                proc.wait(timeout=min(0.1, max(0.0, deadline - time.monotonic())))
            except subprocess.TimeoutExpired:
                if time.monotonic() < deadline:
                    continue
                stopped, leftovers = stop_process_tree(proc, stop_timeout=stop_timeout,
                                                       tracked=tracked.values())
            break
    except BaseException:   # Ctrl-C, or anything else: still leave nothing behind
        stop_process_tree(proc, stop_timeout=stop_timeout, tracked=tracked.values())
        raise
    finally:
        leftovers += kill_leftovers(tracked.values())
        for reader in readers:
            reader.join(timeout=10)
        for stream in (proc.stdout, proc.stderr):
            if stream is not None:
                stream.close()
    stdout, stderr = "".join(output["stdout"]), "".join(output["stderr"])
    if stopped:
        raise AssertionError(
            f"{' '.join(args[2:])} did not end within {timeout:g} s; {stopped}, and "
            f"{len(leftovers)} process(es) left of its children's process groups were "
            f"killed. Output:\n{(stdout + stderr)[-3000:]}")
    if proc.returncode == 0 and leftovers:
        raise AssertionError(f"{' '.join(args[2:])} exited with 0 but left processes "
                             f"{leftovers} running (killed). Output:\n"
                             f"{(stdout + stderr)[-3000:]}")
    return subprocess.CompletedProcess(args, proc.returncode, stdout, stderr)


def stop_process_tree(proc: subprocess.Popen[str], *, stop_timeout: float = 20.0,
                      tracked: Iterable[Tracked] = ()) -> tuple[str, list[int]]:
    """Stop ``proc`` and everything it started: SIGTERM (on which ``servolab launch`` stops
    its children itself), SIGKILL if it still runs ``stop_timeout`` s later, then SIGKILL to
    whatever is left of its descendants' process groups (those seen now, just before each
    signal, and ``tracked``, seen earlier), waiting until they are gone. Returns how ``proc``
    ended and the pids killed afterwards."""
    seen = {t.pid: t for t in tracked}

    def record() -> None:
        for t in descendants(proc.pid):
            seen.setdefault(t.pid, t)

    how = "it had ended"
    if proc.poll() is None:
        record()
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(stop_timeout)
            how = "it ended on SIGTERM"
        except subprocess.TimeoutExpired:
            record()
            proc.kill()
            proc.wait()
            how = f"it still ran {stop_timeout:g} s after SIGTERM and was killed"
    return how, kill_leftovers(seen.values())


# -- process trees -----------------------------------------------------------------------------


@dataclass(frozen=True)
class Tracked:
    """A process seen running: its pid, process group and start time (clock ticks after boot,
    which tells it from a later process given the same pid)."""

    pid: int
    pgid: int
    start: int


def _process_table() -> dict[int, tuple[int, int, int]]:
    """Every live process: pid -> (parent pid, process group, start time), from /proc (empty
    where there is none). Zombies are left out: they are gone but for their reaper."""
    table: dict[int, tuple[int, int, int]] = {}
    try:
        names = os.listdir("/proc")
    except OSError:
        return table
    for name in names:
        if not name.isdigit():
            continue
        try:
            stat = Path(f"/proc/{name}/stat").read_text()
        except OSError:
            continue  # ended meanwhile
        fields = stat.rsplit(")", 1)[1].split()  # from field 3 (state) on
        if fields[0] == "Z":
            continue
        table[int(name)] = (int(fields[1]), int(fields[2]), int(fields[19]))
    return table


def descendants(pid: int) -> list[Tracked]:
    """The processes ``pid`` started and those they started, running now."""
    table = _process_table()
    children: dict[int, list[int]] = {}
    for child, (parent, _, _) in table.items():
        children.setdefault(parent, []).append(child)
    found: list[Tracked] = []
    todo = list(children.get(pid, []))
    while todo:
        child = todo.pop()
        _, pgid, start = table[child]
        found.append(Tracked(child, pgid, start))
        todo += children.get(child, [])
    return found


def kill_leftovers(tracked: Iterable[Tracked], timeout: float = 10.0) -> list[int]:
    """SIGKILL what is left of ``tracked`` (processes a test's process started) and wait until
    it is gone; returns the pids killed. A tracked process that leads a process group of its
    own, or sits in one, takes the whole group with it (every member started since the
    first tracked member of that group: what it started, not an unrelated process given a
    reused number); one in the test's own process group goes alone."""
    own = os.getpgrp()
    groups: dict[int, int] = {}
    singles: dict[int, int] = {}
    for t in tracked:
        if t.pgid == own:
            singles[t.pid] = t.start
        else:
            groups[t.pgid] = min(groups.get(t.pgid, t.start), t.start)
    killed: list[int] = []
    for _ in range(3):  # a member may start another while the others die
        victims = [pid for pid, (_, pgid, start) in _process_table().items()
                   if (pgid in groups and start >= groups[pgid])
                   or singles.get(pid) == start]
        victims = [pid for pid in victims if pid != os.getpid()]
        if not victims:
            break
        for pid in victims:
            with suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        for pid in victims:
            wait_gone(pid, timeout)
        killed += victims
    return killed
