"""Waiting in tests for another process or thread to get somewhere.

Every helper here polls the condition itself (a subscriber is in the graph, a child printed a
line, a bag on disk holds N messages, a process is gone) with a bounded timeout, and fails
naming what never happened and what was seen instead. None of them is a timing assertion: a
slow machine only waits longer. Sleeps that *are* the behaviour under test (a child that sleeps
to be killed, ``Rate.sleep``, a virtual clock) do not belong here.
"""

from __future__ import annotations

import functools
import os
import queue
import select
import subprocess
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import zenoh

    from servolab.middleware.context import Context
    from servolab.middleware.messages import MessageTypes
    from servolab.middleware.transport import Endpoint

#: A graph entity to wait for: (kind, fully qualified node, topic or service); None is any.
Wanted = tuple[str, str | None, str | None]


def wait_until(predicate: Callable[[], object], timeout: float = 5.0,
               step: float = 0.02) -> bool:
    """Poll ``predicate()`` until true or ``timeout`` s; returns whether it became true.
    For conditions on a live process or thread, never a timing assertion."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(step)
    return bool(predicate())


def wait_for(predicate: Callable[[], object], what: str | Callable[[], str], *,
             timeout: float = 5.0, step: float = 0.02) -> None:
    """:func:`wait_until`, failing with "timed out after T s waiting for WHAT" (``what`` may
    be a function, called on failure, to say what was seen instead)."""
    if not wait_until(predicate, timeout, step):
        raise AssertionError(f"timed out after {timeout:g} s waiting for "
                             f"{what() if callable(what) else what}")


# -- processes -------------------------------------------------------------------------------


def alive(pid: int) -> bool:
    """Whether ``pid`` still runs (a zombie waiting for its reaper counts as gone)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
        return stat.rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False
    except OSError:  # no /proc: ask the kernel
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        return True


def wait_gone(pid: int, timeout: float = 5.0) -> bool:
    """Whether ``pid`` is gone within ``timeout`` s."""
    return wait_until(lambda: not alive(pid), timeout)


def wait_for_line(proc: subprocess.Popen[str], text: str, timeout: float = 15.0) -> list[str]:
    """Read ``proc``'s stdout until a line holding ``text``; returns the lines read (without
    their newlines), that one last.

    It reads the pipe's file descriptor a byte at a time, never through the buffered file
    object: the timeout holds even if the process prints nothing, and everything after that
    line is left for a later ``readline`` or ``communicate()``. Call it before anything else
    has read ``proc.stdout`` (a buffered read may already hold the line)."""
    assert proc.stdout is not None, "start the process with stdout=subprocess.PIPE"
    fd = proc.stdout.fileno()
    lines: list[str] = []
    current = bytearray()
    deadline = time.monotonic() + timeout
    while True:
        remaining = deadline - time.monotonic()
        if remaining <= 0 or not select.select([fd], [], [], remaining)[0]:
            partial = [current.decode(errors="replace")] if current else []
            raise AssertionError(f"{text!r} not printed within {timeout:g} s; printed "
                                 f"{lines + partial}")
        byte = os.read(fd, 1)
        if not byte:
            try:
                code: int | None = proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                code = None  # it closed its stdout but runs on
            err = proc.stderr.read()[-2000:] if code is not None and proc.stderr else ""
            raise AssertionError(f"{text!r} never printed: the output ended (exit code "
                                 f"{code}) after {lines}; stderr: {err.strip()}")
        if byte != b"\n":
            current += byte
            continue
        lines.append(current.decode(errors="replace"))
        current.clear()
        if text in lines[-1]:
            return lines


def wait_for_queued_lines(source: queue.Queue[str], seen: list[str], wanted: set[str],
                          timeout: float = 15.0) -> None:
    """Move lines from ``source`` (a reader thread fills it) to ``seen`` until every line of
    ``wanted`` is among them."""
    deadline = time.monotonic() + timeout
    while not wanted <= set(seen):
        remaining = deadline - time.monotonic()
        try:
            if remaining <= 0:
                raise queue.Empty
            seen.append(source.get(timeout=remaining))
        except queue.Empty:
            raise AssertionError(f"{sorted(wanted - set(seen))} not printed within "
                                 f"{timeout:g} s; printed {seen}") from None


# -- the middleware's graph ------------------------------------------------------------------


@functools.cache
def _types() -> MessageTypes:
    from servolab.middleware.messages import MessageTypes
    return MessageTypes()


def _matches(entity: Endpoint, wanted: Wanted) -> bool:
    kind, node, name = wanted
    return entity.kind == kind and node in (None, entity.node) and name in (None, entity.name)


def wait_for_graph(context: Context, *wanted: Wanted, timeout: float = 10.0) -> list[Endpoint]:
    """Until ``context``'s graph (what ``servolab topic list`` sees) shows every entity of
    ``wanted``, e.g. ``("MS", "/listener", "/chatter")``; returns the graph seen last."""
    seen: list[Endpoint] = []

    def present() -> bool:
        seen[:] = context.transport.graph(0.2)
        return all(any(_matches(e, w) for e in seen) for w in wanted)

    wait_for(present, lambda: f"the graph to show {list(wanted)}; it shows "
             f"{[(e.kind, e.node, e.name) for e in sorted(set(seen))]}", timeout=timeout)
    return seen


def wait_for_graph_at(endpoint: str, *wanted: Wanted, timeout: float = 15.0) -> None:
    """:func:`wait_for_graph` from a probe that joins the Zenoh network at ``endpoint`` (the
    ``--listen`` of a process under test; it may not listen yet) and leaves again. The probe
    listens on nothing, so no process under test links to it."""
    from servolab.middleware.context import Context
    from servolab.middleware.transport import TransportOptions

    with Context.open(TransportOptions("zenoh", connect=[endpoint]), types=_types()) as probe:
        wait_for_graph(probe, *wanted, timeout=timeout)


def wait_for_route(session: zenoh.Session, key: str, timeout: float = 10.0) -> None:
    """Until ``session`` knows a subscriber matching ``key`` (Zenoh's matching status of a
    probe publisher on that key): from then on a put on ``key`` from this session is routed to
    it. The exact condition for a put not to be lost; the middleware's own publishers do not
    report it (no subscription count or matched event)."""
    probe = session.declare_publisher(key)
    try:
        wait_for(lambda: probe.matching_status.matching,
                 f"a subscriber matching {key} to be known to session {session.zid()}",
                 timeout=timeout)
    finally:
        probe.undeclare()


def wait_for_subscriber(context: Context, topic: str, type_name: str, node: str | None = None,
                        timeout: float = 10.0) -> None:
    """Until a message published now on ``topic`` from ``context`` reaches a subscription of
    ``node`` (any node if None): the graph shows the subscription and, on Zenoh, the session
    routes the topic's key to a subscriber. (The subscriber is declared before its liveliness
    token, as in rmw_zenoh; the route check stays for a subscription in another process, whose
    routes reach this session on their own path.)"""
    wait_for_graph(context, ("MS", node, topic), timeout=timeout)
    session = getattr(context.transport, "session", None)
    if session is not None:
        from servolab.middleware.rmw_zenoh import topic_keyexpr
        key = topic_keyexpr(getattr(context.transport, "domain_id", 0), topic, type_name,
                            context.types.rihs01(type_name))
        wait_for_route(session, key, timeout)


# -- files -----------------------------------------------------------------------------------


def bag_message_count(bag: Path, types: MessageTypes | None = None) -> int:
    """Messages in the bag ``bag`` as far as it is on disk (a recording still running shows
    its flushed chunks); 0 while there is no readable file yet."""
    from servolab.middleware.bag import BagReader
    from servolab.middleware.errors import BagError

    try:
        return BagReader(bag, types or _types()).info().message_count
    except BagError:
        return 0


def wait_for_bag(bag: Path, count: int, timeout: float = 15.0) -> None:
    """Until the bag a recorder is writing holds ``count`` messages on disk: the recorder has
    received and flushed (it flushes every second) every one of them."""
    seen = [0]

    def reached() -> bool:
        seen[0] = bag_message_count(bag)
        return seen[0] >= count

    wait_for(reached, lambda: f"{count} messages in the bag {bag}; it holds {seen[0]}",
             timeout=timeout, step=0.1)
