"""Run ``servolab`` as a user would and read what it said: in this process (:func:`refusal`),
as a child process (:func:`servolab` to its end, :func:`launched` for a ``with`` block, both
leaving nothing behind), and check that an error says what went wrong in one line
(:func:`one_line`)."""

from __future__ import annotations

import re
import subprocess
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import pytest

from servolab.cli import main
from tests.processes import run_to_end, started
from tests.waiting import wait_for_line

#: ``servolab`` as a child process runs it: this interpreter, this checkout's package.
SERVOLAB = [sys.executable, "-m", "servolab"]


def servolab(*args: str, timeout: float = 120.0,
             env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    """``servolab ARGS`` run to its end as a child process, with nothing on its stdin (a
    command that would ask waits for no one). Its output is returned, whatever its exit
    status; if it has not ended after ``timeout`` s it is stopped with whatever it started
    and the test fails (:func:`tests.processes.run_to_end`), as does a command that exits
    with 0 but leaves processes running."""
    return run_to_end([*SERVOLAB, *args], timeout=timeout, env=env)


@contextmanager
def launched(file: Path, *, timeout: float = 60.0) -> Iterator[tuple[subprocess.Popen[str], str]]:
    """``servolab launch FILE`` for the length of a ``with`` block, once it has said where other
    tools connect (within ``timeout`` s): the launcher (stdout and stderr as one stream) and
    that Zenoh endpoint. The launch is stopped with everything it started when the block
    ends (:func:`tests.processes.started`)."""
    with started([*SERVOLAB, "launch", str(file)], stderr_to_stdout=True) as proc:
        said = wait_for_line(proc, "other tools: --connect", timeout=timeout)[-1]
        endpoint = re.search(r"--connect (tcp/\S+?)\)", said)
        assert endpoint, f"no endpoint in {said!r}"
        yield proc, endpoint[1]


def refusal(argv: Sequence[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    """``servolab ARGV`` expected to refuse: its exit status and its last line on stderr
    (argparse's own refusals exit through SystemExit, servolab's return the status)."""
    try:
        status = main(list(argv))
    except SystemExit as exit_:  # argparse: its usage, then one line of error
        status = exit_.code if isinstance(exit_.code, int) else 1
        err = capsys.readouterr().err.strip().splitlines()
        return status, err[-1] if err else ""
    return status, stderr_line(capsys)


def stderr_line(capsys: pytest.CaptureFixture[str]) -> str:
    """What servolab said on stderr since the last read, which must be one line (ended by
    its newline, nothing before or after it)."""
    err = capsys.readouterr().err
    assert err.endswith("\n") and err.count("\n") == 1, f"servolab did not say one line: {err!r}"
    return err[:-1]


def one_line(error: BaseException | pytest.ExceptionInfo[BaseException], *parts: str) -> str:
    """The message of ``error`` (an exception, or what ``pytest.raises`` caught), which must
    be one line holding every one of ``parts`` (what it should name: a file, a field, a
    value); returned for the test to check further."""
    exc = error.value if isinstance(error, pytest.ExceptionInfo) else error
    message = str(exc)
    assert "\n" not in message, f"not one line: {message!r}"
    for part in parts:
        assert part in message, f"{part!r} not in {message!r}"
    return message
