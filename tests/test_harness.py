"""The run harness: every stop signal raises once, even when SIGINT was ignored at start; the
exit status of a command's end is decided in one place."""

from __future__ import annotations

import os
import signal

import pytest

from servolab.dynamixel.errors import NoResponse
from servolab.errors import ConfigFileError, UsageError
from servolab.harness import (
    StopSignal,
    exit_status,
    interruption,
    stop_signals_raise,
)
from servolab.middleware.errors import BagWriteError, ServiceError
from servolab.robots.errors import RobotError


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_each_stop_signal_raises_stop_signal_with_its_name(sig: signal.Signals) -> None:
    # os.kill runs the handler before it returns (CPython checks signals after kill())
    with pytest.raises(StopSignal) as info, stop_signals_raise():
        os.kill(os.getpid(), sig)
    assert info.value.signum == sig and info.value.name == sig.name
    assert isinstance(info.value, KeyboardInterrupt)  # every Ctrl-C cleanup sees it


def test_sigint_ignored_at_start_still_stops(monkeypatch: pytest.MonkeyPatch) -> None:
    """A shell starts a background job with SIGINT ignored; the harness installs its own."""
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with pytest.raises(StopSignal), stop_signals_raise():
            os.kill(os.getpid(), signal.SIGINT)
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN  # given back afterwards
    finally:
        signal.signal(signal.SIGINT, previous)


def test_a_second_signal_does_not_cut_the_stop_short() -> None:
    """The first signal raises; one that comes while the motors are being stopped is only
    counted, so the stop (in the except/finally) runs to its end."""
    stopped = []
    with stop_signals_raise() as requests:
        try:
            os.kill(os.getpid(), signal.SIGTERM)
        except StopSignal:
            os.kill(os.getpid(), signal.SIGHUP)  # arrives during the cleanup
            stopped.append("wheels at 0")
    assert stopped == ["wheels at 0"]
    assert requests.seen == [signal.SIGTERM, signal.SIGHUP]


@pytest.mark.parametrize(("error", "status"), [
    (None, 0),
    (StopSignal(signal.SIGINT), 130),
    (StopSignal(signal.SIGTERM), 143),
    (StopSignal(signal.SIGHUP), 129),
    (KeyboardInterrupt(), 130),
    (UsageError("--steps 0: must be 1 or more"), 2),
    (ConfigFileError("a.yaml", 3, "rate", "must be a number"), 2),
    (NoResponse("motor 3 did not answer"), 1),
    (ServiceError("/x did not answer"), 1),
    (RobotError("the goal was not reached"), 1),
    (BagWriteError("bag run/x: cannot write: No space left on device"), 1),  # while running
    (IndexError("a bug"), 1),
])
def test_exit_status(error: BaseException | None, status: int) -> None:
    assert exit_status(error) == status


def test_interruption_names_the_signal_or_the_error() -> None:
    assert interruption(None) is None
    assert interruption(StopSignal(signal.SIGTERM)) == "SIGTERM"
    assert interruption(KeyboardInterrupt()) == "SIGINT"
    assert interruption(NoResponse("motor 3 did not answer")) == \
        "NoResponse: motor 3 did not answer"


def test_a_signal_inside_signals_held_comes_when_it_is_left() -> None:
    """A bag's record is appended whole: the stop comes between two writes, never inside."""
    from servolab.signals import signals_held

    steps = []
    with pytest.raises(StopSignal), stop_signals_raise():
        with signals_held():
            os.kill(os.getpid(), signal.SIGTERM)
            steps.append("the rest of the record")  # not cut short
        steps.append("after the write")  # never reached: the stop comes first
    assert steps == ["the rest of the record"]
