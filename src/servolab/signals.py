"""Stop signals: Ctrl-C (SIGINT), SIGTERM and a closing terminal (SIGHUP) all mean "stop
cleanly", so that motors stop and recordings close whichever way a run is ended.

Every command that runs until stopped installs its handler here, for the time it runs, and
gets the previous handlers back afterwards (a test that calls a command in-process leaves the
interpreter as it found it). SIGINT is installed explicitly because a shell starts background
jobs with it ignored.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import FrameType

SignalHandler = Callable[[int, FrameType | None], None]


def stop_signals() -> list[signal.Signals]:
    """The signals that ask a run to stop, on this platform."""
    found = [signal.SIGINT, signal.SIGTERM]
    if hasattr(signal, "SIGHUP"):  # not on Windows
        found.append(signal.SIGHUP)
    return found


class _Held:
    """How deep the main thread is in :func:`signals_held`, and the stop signals that came
    meanwhile. Process-wide, as signal handlers are: there is one main thread."""

    depth = 0
    pending: list[int] = []  # noqa: RUF012 (one instance, never shared by value)


_HELD = _Held()


@contextmanager
def signals_held() -> Iterator[None]:
    """Hold stop signals back for a few statements that must not be cut in half (a message
    half appended to a bag's chunk would corrupt the chunk): a signal that comes while the
    main thread is inside reaches the handler of :func:`on_stop_signals` as it leaves. Costs
    no system call, so it may wrap every message a recorder writes."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _HELD.depth += 1
    try:
        yield
    finally:
        _HELD.depth -= 1
        if _HELD.depth == 0 and _HELD.pending:
            signum = _HELD.pending[0]
            _HELD.pending.clear()
            handler = signal.getsignal(signum)
            if callable(handler):
                handler(signum, None)  # may raise: now, between two whole writes


@contextmanager
def on_stop_signals(handler: SignalHandler) -> Iterator[None]:
    """Call ``handler(signum, frame)`` on a stop signal while inside (once the main thread has
    left any :func:`signals_held` it is in). Signal handlers belong to the main thread, so
    elsewhere this changes nothing."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def held_back(signum: int, frame: FrameType | None) -> None:
        if _HELD.depth:
            _HELD.pending.append(signum)
            return
        handler(signum, frame)

    held_back.__wrapped__ = handler  # type: ignore[attr-defined]
    previous = {s: signal.getsignal(s) for s in stop_signals()}
    for s in previous:
        signal.signal(s, held_back)
    try:
        yield
    finally:
        for s, old in previous.items():
            signal.signal(s, old if old is not None else signal.SIG_DFL)


def raise_keyboard_interrupt(signum: int, frame: FrameType | None) -> None:
    """A handler that turns any stop signal into the ``KeyboardInterrupt`` of Ctrl-C."""
    raise KeyboardInterrupt
