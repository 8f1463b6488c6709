"""The run harness: how every command ends, whichever way it is ended.

A robot command is stopped by Ctrl-C (SIGINT), by ``kill`` or a supervisor (SIGTERM), or by
its terminal closing (SIGHUP); a shell starts a background job with SIGINT ignored, and Python
then never raises ``KeyboardInterrupt`` for it. :func:`stop_signals_raise`, which the
``servolab`` command wraps around every command, makes all three mean the same: the first one
raises :class:`StopSignal` (a ``KeyboardInterrupt``, so every ``finally`` and every
``except KeyboardInterrupt`` that already stops motors sees it) wherever the main thread is.
Later signals are counted, not raised, so that the stop they interrupt (the motors' last
SYNC_WRITE, the bag's last chunk, ``summary.json``) is not itself cut short; SIGKILL remains
for a stop that hangs. Standard output and error survive their reader going away (a
terminal that closed, the usual source of SIGHUP, fails every write with EIO): a write that
fails so is dropped, or it would fail the stop in the middle (:class:`HangupSafeStream`).

Every robot command's run then does the same three things on its way out, ended or not,
written once in :func:`servolab.robots.lifecycle.run_task` on :func:`stops_deferred` and
:class:`RunEnding`: it stops its motors (or holds them, where that is safer: each robot's
``ON_STOP`` says which), closes its bag, and writes ``summary.json`` with what it measured so
far and ``"interrupted"``: the signal's name, the error, or ``null`` for a run that finished
(:meth:`servolab.runs.RunFolder.write_summary`). The exit status is decided in one place,
:func:`exit_status`:

====  ==========================================================================
0     done
1     failed while running (a motor that stopped answering, a goal not reached)
2     bad input, refused before anything moved (a value, an argument, a file)
128+N stopped by signal N: 130 SIGINT, 143 SIGTERM, 129 SIGHUP
====  ==========================================================================
"""

from __future__ import annotations

import errno
import os
import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from types import FrameType
from typing import Any, TextIO

from .errors import ServolabError
from .signals import on_stop_signals


class StopSignal(KeyboardInterrupt):
    """A stop signal arrived while a command ran; ``signum`` says which."""

    def __init__(self, signum: int) -> None:
        self.signum = int(signum)
        super().__init__(self.name)

    @property
    def name(self) -> str:
        """``"SIGTERM"``, as ``kill -l`` names it."""
        try:
            return signal.Signals(self.signum).name
        except ValueError:
            return f"signal {self.signum}"


@dataclass
class StopRequests:
    """The stop signals seen while :func:`stop_signals_raise` was in force, in order."""

    seen: list[int] = field(default_factory=list)

    def handler(self, signum: int, frame: FrameType | None) -> None:
        self.seen.append(signum)
        if len(self.seen) == 1:
            raise StopSignal(signum)
        # a second signal while the first one's stop runs: let that stop finish


@dataclass
class DeferredStop:
    """A stop signal that came while :func:`stops_deferred` held it back."""

    signum: int | None = None

    def handler(self, signum: int, frame: FrameType | None) -> None:
        if self.signum is None:
            self.signum = signum

    def error(self) -> StopSignal | None:
        """The :class:`StopSignal` to raise for it, if one came."""
        return None if self.signum is None else StopSignal(self.signum)


@contextmanager
def stops_deferred() -> Iterator[DeferredStop]:
    """Hold stop signals back while inside: what a run does on its way out (stop the motors,
    close the bag, measure, plot, write ``summary.json``) must not itself be cut short by the
    signal that ended the run, or by the first one when the run ended on its own. The caller
    asks :meth:`DeferredStop.error` at the end and raises it."""
    deferred = DeferredStop()
    if threading.current_thread() is not threading.main_thread():
        yield deferred
        return
    with on_stop_signals(deferred.handler):
        yield deferred


class RunEnding:
    """How a run ends: what ended it (``error``: a stop signal, an error, or None), and what
    went wrong on its way out. Each step of the way out (stop the motors, write the bag, plot)
    runs in :meth:`step`, so one that fails is recorded in the summary and the next still
    runs; the first cause wins, and is what the caller raises after the summary is written::

        ending = RunEnding(interrupted)
        with stops_deferred() as late:
            with ending.step("stopping the wheels"):
                robot.stop()
            ...
            run_folder.write_summary(summary, interrupted=ending.settle(late, summary))
        ending.raise_if_ended()
    """

    def __init__(self, error: BaseException | None) -> None:
        self.error = error
        self.failures: list[str] = []

    @contextmanager
    def step(self, name: str) -> Iterator[None]:
        try:
            yield
        except Exception as exc:
            self.failures.append(f"{name}: {interruption(exc)}")
            if self.error is None:
                self.error = exc

    def settle(self, deferred: DeferredStop, summary: dict[str, Any]) -> BaseException | None:
        """The run's end once the way out is done (a signal held back counts when nothing
        else ended the run); the failures on the way out go into ``summary``."""
        if self.error is None:
            self.error = deferred.error()
        if self.failures:
            summary["failures_on_the_way_out"] = list(self.failures)
        return self.error

    def raise_if_ended(self) -> None:
        if self.error is not None:
            raise self.error


def signal_status(signum: int) -> int:
    """The exit status of a process a signal stopped, as a shell reports it: 128 + N."""
    return 128 + int(signum)


class HangupSafeStream:
    """A standard stream whose reader may go away: a terminal that closed (EIO, with a SIGHUP
    that may come just after) or a pipe whose reader ended (EPIPE). Its first failed write
    points the stream's descriptor at /dev/null and drops the text, so a stop under way (the
    motors, the bag, ``summary.json``) does not fail on a line nobody can read any more."""

    def __init__(self, stream: TextIO) -> None:
        self.stream = stream

    def _gone(self) -> None:
        null = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(null, self.stream.fileno())
        finally:
            os.close(null)

    def write(self, text: str) -> int:
        try:
            return self.stream.write(text)
        except OSError as exc:
            if exc.errno not in (errno.EIO, errno.EPIPE):
                raise
            self._gone()
            return len(text)

    def flush(self) -> None:
        try:
            self.stream.flush()
        except OSError as exc:
            if exc.errno not in (errno.EIO, errno.EPIPE):
                raise
            self._gone()

    def __getattr__(self, name: str) -> Any:
        return getattr(self.stream, name)


@contextmanager
def hangup_safe_output() -> Iterator[None]:
    """:class:`HangupSafeStream` around ``sys.stdout`` and ``sys.stderr`` while inside (those
    with a descriptor of their own; a test's captured streams are left as they are)."""
    saved = sys.stdout, sys.stderr
    try:
        sys.stdout, sys.stderr = (_safe(s) for s in saved)
        yield
    finally:
        sys.stdout, sys.stderr = saved


def _safe(stream: TextIO) -> TextIO | HangupSafeStream:
    try:
        stream.fileno()
    except (OSError, ValueError, AttributeError):
        return stream
    return HangupSafeStream(stream)


@contextmanager
def stop_signals_raise() -> Iterator[StopRequests]:
    """While inside, SIGINT, SIGTERM and SIGHUP raise :class:`StopSignal` once (also when
    SIGINT was ignored at start, as in a background job). Outside the main thread, where
    Python delivers no signals, this changes nothing."""
    requests = StopRequests()
    if threading.current_thread() is not threading.main_thread():
        yield requests
        return
    with on_stop_signals(requests.handler):
        yield requests


def interruption(error: BaseException | None) -> str | None:
    """What ``summary.json`` says ended a run: ``None`` for a run that finished, the signal's
    name (``"SIGTERM"``; a bare ``KeyboardInterrupt`` is Ctrl-C, ``"SIGINT"``), else the
    error's class and message."""
    if error is None:
        return None
    if isinstance(error, StopSignal):
        return error.name
    if isinstance(error, KeyboardInterrupt):
        return "SIGINT"
    text = str(error)
    return f"{type(error).__name__}: {text}" if text else type(error).__name__


def is_bad_input(error: ServolabError) -> bool:
    """Errors in what the user gave (a value, an argument, a file, a name, an endpoint) are
    the value errors: each layer's bad-input classes derive from ``ValueError`` too, so this
    core module needs to know none of them."""
    return isinstance(error, ValueError)


def exit_status(error: BaseException | None) -> int:
    """The exit status of a command that ended with ``error`` (``None``: done). Errors not
    raised on purpose (not :class:`~servolab.errors.ServolabError`) are bugs: 1, and the
    caller keeps their traceback."""
    if error is None:
        return 0
    if isinstance(error, StopSignal):
        return signal_status(error.signum)
    if isinstance(error, KeyboardInterrupt):
        return signal_status(signal.SIGINT)
    if isinstance(error, ServolabError):
        return 2 if is_bad_input(error) else 1
    return 1
