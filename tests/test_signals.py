"""servolab.signals: every stop signal reaches the handler while inside, and the handlers
that were there before come back afterwards."""

from __future__ import annotations

import os
import signal
import threading

import pytest

from servolab.signals import on_stop_signals, raise_keyboard_interrupt, stop_signals


def test_each_stop_signal_reaches_the_handler_and_the_old_ones_come_back() -> None:
    before = {s: signal.getsignal(s) for s in stop_signals()}
    heard: list[int] = []
    with on_stop_signals(lambda signum, frame: heard.append(signum)):
        for s in stop_signals():
            os.kill(os.getpid(), s)
    assert heard == [int(s) for s in stop_signals()]
    assert {s: signal.getsignal(s) for s in stop_signals()} == before
    assert signal.SIGTERM in stop_signals() and signal.SIGINT in stop_signals()


def test_sigterm_becomes_keyboard_interrupt() -> None:
    with pytest.raises(KeyboardInterrupt), on_stop_signals(raise_keyboard_interrupt):
        os.kill(os.getpid(), signal.SIGTERM)


def test_outside_the_main_thread_nothing_changes() -> None:
    before = signal.getsignal(signal.SIGTERM)
    seen: list[object] = []

    def worker() -> None:
        with on_stop_signals(raise_keyboard_interrupt):
            seen.append(signal.getsignal(signal.SIGTERM))
    thread = threading.Thread(target=worker)
    thread.start()
    thread.join()
    assert seen == [before]
