"""Start ``servolab sim --pty`` as a real OS process for tests, and always stop it
(:func:`servolab.sim.pty_process.pty_process`, which the benchmarks use too)."""

from __future__ import annotations

import contextlib
import subprocess
from collections.abc import Iterator
from pathlib import Path

from servolab.sim.pty_process import pty_process


@contextlib.contextmanager
def sim_process(*args: str, out_dir: Path) -> Iterator[tuple[str, subprocess.Popen[str]]]:
    """Run ``servolab sim --pty ARGS``; yield (device path, process). SIGINT stops it."""
    with pty_process(*args, out_dir=out_dir, timeout=20.0) as (device, proc):
        yield device, proc
