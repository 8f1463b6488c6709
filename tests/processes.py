"""Start a process for a test and always stop it."""

from __future__ import annotations

import os
import signal
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def started(args: list[str], env: dict[str, str] | None = None, *,
            stderr_to_stdout: bool = False) -> Iterator[subprocess.Popen[str]]:
    """A process that is always stopped (SIGINT, then kill) when the block ends; ``env``
    defaults to this process's environment. ``stderr_to_stdout`` reads both as one stream
    (a program that logs to stderr, as rclpy's loggers do)."""
    proc = subprocess.Popen(args, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT if stderr_to_stdout else subprocess.PIPE,
                            text=True,
                            env={**(os.environ if env is None else env),
                                 "PYTHONUNBUFFERED": "1"})
    try:
        yield proc
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(5)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        for stream in (proc.stdout, proc.stderr):
            if stream is not None:
                stream.close()
