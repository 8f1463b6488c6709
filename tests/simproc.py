"""Start ``servolab sim --pty`` as a real OS process for tests, and always stop it."""

from __future__ import annotations

import contextlib
import os
import select
import signal
import subprocess
from collections.abc import Iterator
from pathlib import Path

from tests.clirun import SERVOLAB


@contextlib.contextmanager
def sim_process(*args: str, out_dir: Path) -> Iterator[tuple[str, subprocess.Popen[str]]]:
    """Run ``servolab sim --pty ARGS``; yield (device path, process). SIGINT stops it."""
    cmd = [*SERVOLAB, "sim", "--pty", "--out", str(out_dir), *args]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            stdin=subprocess.DEVNULL)
    try:
        ready, _, _ = select.select([proc.stdout], [], [], 20.0)
        if not ready:
            raise RuntimeError("servolab sim printed no device path within 20 s")
        device = proc.stdout.readline().strip()  # type: ignore[union-attr]
        if not device:
            raise RuntimeError(f"servolab sim failed: {proc.stderr.read()}")  # type: ignore[union-attr]
        assert os.path.exists(device), device
        yield device, proc
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        for stream in (proc.stdout, proc.stderr):
            if stream:
                stream.close()

