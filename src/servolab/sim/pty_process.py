"""``servolab sim --pty`` as a process of its own, for programs that need a serial bus in real
time on another process's CPU: benchmarks and tests that time a driver against it, or a lab's
script that wants a stand-in bus for its own code.

Why a separate process: a pty served from the same interpreter shares its GIL with the client,
so neither the client's timing nor the server's would be what a real wire and real motors give.
"""

from __future__ import annotations

import select
import signal
import subprocess
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO

from .errors import SimError


@contextmanager
def pty_process(*args: str, out_dir: Path, timeout: float = 60.0,
                stderr: IO[str] | None = None) -> Iterator[tuple[str, subprocess.Popen[str]]]:
    """Run ``servolab sim --pty --out OUT_DIR ARGS``; yield (its pty device, the process).
    What it prints after the device is read and dropped (a full pipe would block it); its
    stderr goes to ``stderr`` (None: quoted if it fails to start, then dropped too). SIGINT stops it
    at the end, SIGKILL if it has not stopped 30 s later."""
    command = [sys.executable, "-m", "servolab", "sim", "--pty", "--out", str(out_dir), *args]
    proc = subprocess.Popen(command, stdout=subprocess.PIPE,
                            stderr=stderr if stderr is not None else subprocess.PIPE,
                            stdin=subprocess.DEVNULL, text=True)
    try:
        assert proc.stdout is not None
        ready, _, _ = select.select([proc.stdout], [], [], timeout)
        device = proc.stdout.readline().strip() if ready else ""
        if not device:
            said = proc.stderr.read() if proc.stderr is not None and proc.poll() is not None \
                else ""
            raise SimError(f"servolab sim --pty printed no device within {timeout:g} s"
                           + (f": {said.strip()}" if said else ""))
        # what it says from now on is read and dropped: a full pipe would freeze the bus
        threading.Thread(target=proc.stdout.read, daemon=True).start()
        if proc.stderr is not None:
            threading.Thread(target=proc.stderr.read, daemon=True).start()
        yield device, proc
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        for stream in (proc.stdout, proc.stderr):
            if stream is not None:
                stream.close()
