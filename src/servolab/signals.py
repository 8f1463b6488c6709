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


@contextmanager
def on_stop_signals(handler: SignalHandler) -> Iterator[None]:
    """Call ``handler(signum, frame)`` on a stop signal while inside. Signal handlers belong
    to the main thread, so elsewhere this changes nothing."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.getsignal(s) for s in stop_signals()}
    for s in previous:
        signal.signal(s, handler)
    try:
        yield
    finally:
        for s, old in previous.items():
            signal.signal(s, old if old is not None else signal.SIG_DFL)


def raise_keyboard_interrupt(signum: int, frame: FrameType | None) -> None:
    """A handler that turns any stop signal into the ``KeyboardInterrupt`` of Ctrl-C."""
    raise KeyboardInterrupt
