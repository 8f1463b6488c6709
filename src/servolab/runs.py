"""Run folders: every command that runs something leaves one.

``runs/<command>-<YYYYmmdd-HHMMSS>/`` by default, or the folder given with ``--out``. It holds
the run's recording (MCAP, from the middleware), its plots and ``summary.json`` with the key
figures, so any run can be looked at, compared and replayed later. Robots and apps write through
a :class:`RunFolder`; none of them invents its own layout.
"""

from __future__ import annotations

import json
import math
import sys
import time
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

from . import __version__
from .errors import ServolabError

DEFAULT_ROOT = Path("runs")


class RunFolderError(ServolabError, ValueError):
    """A run folder that cannot be made where the user asked."""


@dataclass
class RunFolder:
    """A run's folder. Used as a context manager (``with RunFolder.create(...) as run:``) it
    guarantees the folder its ``summary.json``: a run stopped or failed before its own code
    wrote one (a signal while the robot is still being opened or calibrated) gets one saying
    what ended it."""

    path: Path
    command: str
    started: float = field(default_factory=time.time)
    summary_written: bool = field(default=False, init=False)

    def __enter__(self) -> RunFolder:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: object) -> None:
        if error is not None and not self.summary_written:
            self.write_summary({"stage": "setting up, before the run started"},
                               interrupted=error)

    @classmethod
    def create(cls, command: str, out: str | Path | None = None,
               root: str | Path = DEFAULT_ROOT) -> RunFolder:
        """Make the folder: ``out`` if given (it may exist, files in it are replaced), else a
        new ``root/<command>-<timestamp>`` (with a suffix if that name is taken)."""
        if out is not None:
            path = Path(out)
            if path.exists() and not path.is_dir():
                raise RunFolderError(f"--out {path}: exists and is not a folder; name a "
                                     "folder (it is created if missing)")
        else:
            stamp = datetime.now().strftime("%Y%m%d-%H%M%S")
            path = Path(root) / f"{command}-{stamp}"
            n = 1
            while path.exists():
                n += 1
                path = Path(root) / f"{command}-{stamp}-{n}"
        try:
            path.mkdir(parents=True, exist_ok=True)
        except OSError as exc:  # a file in the way, no permission, a read-only disk
            raise RunFolderError(f"cannot make the run folder {path}: "
                                 f"{exc.strerror or exc}") from None
        return cls(path, command)

    def file(self, name: str) -> Path:
        return self.path / name

    def write_summary(self, figures: dict[str, Any], *,
                      interrupted: BaseException | None = None) -> Path:
        """Write ``summary.json``: what ran, when, for how long, ``figures``, and what ended
        the run early (``"interrupted"``: a signal's name such as ``"SIGTERM"``, an error, or
        null when it finished: :func:`servolab.harness.interruption`)."""
        from .harness import interruption

        summary = {
            "command": self.command,
            "argv": sys.argv[1:],
            "servolab_version": __version__,
            "started": datetime.fromtimestamp(self.started).isoformat(timespec="seconds"),
            "duration_s": round(time.time() - self.started, 3),
            **_jsonable(figures),
            "interrupted": interruption(interrupted),
        }
        target = self.file("summary.json")
        target.write_text(json.dumps(summary, indent=2, sort_keys=False) + "\n")
        self.summary_written = True
        return target

    def save_figure(self, figure: Any, name: str) -> Path:
        """Save a matplotlib figure as PNG in the run folder and close it."""
        import matplotlib.pyplot as plt

        target = self.file(name if name.endswith(".png") else f"{name}.png")
        figure.savefig(target, dpi=110, bbox_inches="tight")
        plt.close(figure)
        return target


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if hasattr(value, "item"):  # numpy scalars
        return value.item()
    if isinstance(value, Path):
        return str(value)
    return value
