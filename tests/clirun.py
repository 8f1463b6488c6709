"""Run ``servolab`` in-process as a user would and read what it said."""

from __future__ import annotations

from collections.abc import Sequence

import pytest

from servolab.cli import main


def refusal(argv: Sequence[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    """``servolab ARGV`` expected to refuse: its exit status and its last line on stderr
    (argparse's own refusals exit through SystemExit, servolab's return the status)."""
    try:
        status = main(list(argv))
    except SystemExit as exit_:  # argparse: its usage, then one line of error
        status = exit_.code if isinstance(exit_.code, int) else 1
        err = capsys.readouterr().err.strip().splitlines()
        return status, err[-1] if err else ""
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, f"servolab said more than one line: {err}"
    return status, err[0]
