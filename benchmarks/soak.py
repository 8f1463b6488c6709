"""Whether ``servolab walk`` holds its memory flat over a long walk: the resident set's slope
per row played.

``servolab walk --steps N --no-progress`` runs in a child process on the emulated Armstrong,
in virtual time (the simulation's clock: as fast as the host computes it, about 20 rows a
second). Each time the child says ``step k of N played``, its resident set (``VmRSS`` of
``/proc/PID/status``) is read, so each sample is (rows played, RSS). The slope is the least
squares line through the samples after the first quarter of the walk (imports, the first
plots' fonts and the allocator's first arenas are warm-up, not growth), in kB a row and kB
a step (17 rows).

The anchor, measured in the same run: what the walk writes to its bag per row, in kB (the
bag's size at the end over the rows played). Everything the walk records goes to the bag,
so a process that kept what it records would grow about that much a row (more: Python
objects are larger than CDR); the ratio slope / anchor says what share of it stays in
memory. The MCAP writer's chunk indexes (``mcap.writer``: one record a chunk, with an offset
per channel, kept until the bag is closed to write its summary; the recorder ends a chunk
every second) wait in a file beside the bag (``bag/writer.py``), so nothing is left.

Measured on the development machine (Python 3.11, x86_64, shared with other work: 8 rows
a second), ``benchmarks/soak.py --steps 120`` (2040 rows), the bag 3.6 kB a row in both:

- before (the walk's samples in Python lists: every command, every joint state, every
  motor's temperature and load after each sweep): 14.0 kB a row (238 kB a step; RSS 100 ->
  128 MB), x3.9 of what the bag takes;
- after (:mod:`servolab.robots.armstrong.series`: at most 2048 samples a series, decimated
  evenly; the largest tracking error measured as the states come): 1.2 kB a row (20 kB a
  step; RSS 102 -> 105 MB), x0.33: tracemalloc finds it all in the MCAP writer's chunk
  index, about 5 kB a chunk, one chunk a second;
- with the chunk indexes moved to a file beside the bag as each chunk ends
  (``bag/writer.py``), ``--steps 2000`` (34 000 rows, 22 minutes beside the test suite):
  0.0004 kB a row (RSS 102.1 -> 102.6 MB), x0.0001 of the bag's 3.52 kB a row: flat.

``--pty`` walks the biped that ``servolab sim --pty --robot armstrong`` simulates, over its
pty at the real baud rate, in real time (``--steps 159``: ten minutes), and reads the
simulated robot's RSS beside the walk's.

Run: ``.venv/bin/python benchmarks/soak.py [--quick] [--steps N] [--pty] [--json PATH]``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from servolab.sim.pty_process import pty_process

STEPS = 120
QUICK_STEPS = 6
#: the share of the walk left out of the fit as warm-up
WARM_UP = 0.25
_PLAYED = re.compile(r"step (\d+) of (\d+) played")
_ROWS = re.compile(r"playing (\d+) rows")


def rss_kb(pid: int) -> int | None:
    """The resident set of process ``pid`` in kB, or None once it is gone."""
    try:
        with open(f"/proc/{pid}/status") as status:
            for line in status:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1])
    except OSError:
        return None
    return None


def folder_bytes(folder: Path) -> int:
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file())


@contextmanager
def simulated_robot(out: Path) -> Iterator[tuple[str, subprocess.Popen[str]]]:
    """``servolab sim --pty --robot armstrong``: the biped's bus at its real baud rate
    (57 142 bps, seed 001), in real time; yields (its pty, the process), stopped at the end."""
    out.mkdir(parents=True, exist_ok=True)
    with (out / "sim.log").open("w") as log, \
            pty_process("--robot", "armstrong", out_dir=out, stderr=log) as served:
        yield served


def walk(steps: int, out: Path, port: str | None = None,
         also: subprocess.Popen[str] | None = None) -> dict[str, Any]:
    """``servolab walk --steps N`` in a child, its RSS read at each step played (and the
    RSS of ``also``, the simulated robot, when it walks on a pty)."""
    command = [sys.executable, "-m", "servolab", "walk", "--steps", str(steps), "--out",
               str(out), "--no-progress", *(["--port", port] if port else [])]
    started = time.perf_counter()
    child = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                             text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    samples: list[tuple[int, int]] = []
    robot: list[tuple[int, int]] = []  # the simulated robot's (rows, RSS), on a pty
    rows_per_step = 0
    lines: list[str] = []
    assert child.stdout is not None
    for line in child.stdout:
        lines.append(line.rstrip())
        if not rows_per_step and (match := _ROWS.search(line)):
            rows_per_step = int(match.group(1))
        if (match := _PLAYED.search(line)) and rows_per_step:
            rss = rss_kb(child.pid)
            if rss is not None:
                samples.append((int(match.group(1)) * rows_per_step, rss))
            held = rss_kb(also.pid) if also is not None else None
            if held is not None:
                robot.append((int(match.group(1)) * rows_per_step, held))
    status = child.wait()
    seconds = time.perf_counter() - started
    if status != 0:
        raise SystemExit(f"servolab walk failed ({status}):\n" + "\n".join(lines[-20:]))
    played = samples[-1][0] // rows_per_step if samples else 0
    if played < steps:  # an alarm or a signal ended the gait early: say what, from the run
        summary = json.loads((out / "summary.json").read_text())
        ended = {k: summary.get(k) for k in ("interrupted", "alarms", "reason") if k in summary}
        print(f"  the walk played {played} of {steps} steps; its summary says {ended}")
        said = out.parent / "sim" / "sim.log"
        if said.exists():
            print("  the simulated robot said, last:\n    " + "\n    ".join(
                said.read_text().splitlines()[-8:]))
    rows = played * rows_per_step
    bag = folder_bytes(out / "walk_bag")
    return {"steps": played, "rows_per_step": rows_per_step, "rows": rows,
            "seconds": seconds, "samples": samples, "robot_samples": robot, "bag_bytes": bag}


def slope(samples: Sequence[tuple[int, int]]) -> float:
    """kB a row: the least squares line through the samples after the warm-up."""
    rows = np.array([r for r, _ in samples], dtype=float)
    rss = np.array([kb for _, kb in samples], dtype=float)
    keep = rows >= WARM_UP * rows[-1]
    if keep.sum() < 2:
        keep[:] = True
    return float(np.polyfit(rows[keep], rss[keep], 1)[0])


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true",
                        help=f"{QUICK_STEPS} steps: that it runs")
    parser.add_argument("--steps", type=int, help=f"steps to walk (default {STEPS})")
    parser.add_argument("--pty", action="store_true",
                        help="walk the biped of 'servolab sim --pty --robot armstrong' over "
                        "its pty, in real time (4.5 rows a second: --steps 159 is ten "
                        "minutes), and read the simulated robot's RSS too")
    parser.add_argument("--json", type=Path, metavar="PATH", help="also write the figures here")
    args = parser.parse_args(argv)
    steps = args.steps or (QUICK_STEPS if args.quick else STEPS)
    if steps < 2:
        parser.error("--steps must be at least 2 (a slope needs two samples)")
    how = "over the pty of servolab sim, in real time" if args.pty else "in virtual time"
    print(f"servolab soak benchmark: Python {platform.python_version()}, {platform.machine()}; "
          f"servolab walk --steps {steps} {how}")
    with tempfile.TemporaryDirectory(prefix="servolab-soak-") as folder:
        if args.pty:
            with simulated_robot(Path(folder) / "sim") as (device, sim):
                figures = walk(steps, Path(folder) / "run", device, sim)
        else:
            figures = walk(steps, Path(folder) / "run")
    samples = figures["samples"]
    per_row = slope(samples)
    anchor = figures["bag_bytes"] / 1000 / figures["rows"]
    rows_per_step = figures["rows_per_step"]
    print(f"  {figures['rows']} rows in {figures['seconds']:.1f} s "
          f"({figures['rows'] / figures['seconds']:.1f} rows/s); RSS {samples[0][1] / 1e3:.1f}"
          f" MB after the first step, {samples[-1][1] / 1e3:.1f} MB after the last")
    print(f"  RSS slope: {per_row:.2f} kB a row ({per_row * rows_per_step:.1f} kB a step), "
          f"fitted over rows {WARM_UP * figures['rows']:.0f}..{figures['rows']}")
    print(f"  anchor: the bag grows {anchor:.2f} kB a row; ratio slope / anchor "
          f"x{per_row / anchor:.3f}")
    if figures["robot_samples"]:
        held = figures["robot_samples"]
        robot_slope = slope(held)
        figures["robot_slope_kb_per_row"] = robot_slope
        print(f"  the simulated robot (servolab sim --pty): RSS {held[0][1] / 1e3:.1f} -> "
              f"{held[-1][1] / 1e3:.1f} MB, slope {robot_slope:.2f} kB a row")
    if args.json:
        out = {**figures, "slope_kb_per_row": per_row,
               "slope_kb_per_step": per_row * rows_per_step, "anchor_bag_kb_per_row": anchor,
               "ratio_slope_anchor": per_row / anchor, "warm_up": WARM_UP}
        args.json.write_text(json.dumps(out, indent=2) + "\n")
        print(f"\nfigures written to {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
