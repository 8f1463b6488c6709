"""``make test``'s scheduling (tests/scheduling.py) on a suite of its own, run as make runs
the real one (pytest-xdist, two workers, ``--dist loadfile``): every realtime test on one
worker, the files with slow tests handed out first."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

CONFTEST = """
from tests.conftest import (  # noqa: F401  the project's hooks and realtime lock
    _one_real_time_test_at_a_time, pytest_collection_modifyitems, pytest_xdist_make_scheduler)
"""

#: each test writes which worker ran it, and when it started and ended
RECORDING = """
import os, time
import pytest

def record(name):
    start = time.monotonic()
    worker = os.environ["PYTEST_XDIST_WORKER"]
    with open(os.environ["RECORD"], "a") as out:
        out.write(f"{{name}} {{worker}} {{start}} {{time.monotonic()}}\\n")

{tests}
"""


def _file(prefix: str, marks: dict[int, str], count: int) -> str:
    tests = []
    for k in range(count):
        mark = f"@pytest.mark.{marks[k]}\n" if k in marks else ""
        tests.append(f"{mark}def test_{prefix}{k}():\n    record('{prefix}{k}')\n")
    return RECORDING.format(tests="\n".join(tests))


@pytest.mark.slow
def test_realtime_tests_run_on_one_worker_one_after_another(tmp_path: Path) -> None:
    suite = tmp_path / "suite"
    suite.mkdir()
    (suite / "conftest.py").write_text(CONFTEST)
    (suite / "pytest.ini").write_text(
        "[pytest]\nmarkers =\n    realtime: x\n    slow: x\n")
    # realtime tests spread over three files among plain ones; a file of slow tests last
    (suite / "test_a.py").write_text(_file("a", {0: "realtime", 3: "realtime"}, 6))
    (suite / "test_b.py").write_text(_file("b", {2: "realtime"}, 6))
    (suite / "test_c.py").write_text(_file("c", {1: "realtime", 4: "realtime"}, 6))
    (suite / "test_d.py").write_text(_file("d", {}, 12))
    (suite / "test_z.py").write_text(_file("z", {0: "slow", 1: "slow"}, 2))
    record = tmp_path / "record.txt"
    # as a fresh make test sees it: not as a worker of the run this test itself runs in
    env = {**{k: v for k, v in os.environ.items() if not k.startswith("PYTEST_XDIST")},
           "RECORD": str(record), "PYTHONPATH": str(ROOT)}
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-n", "2", "--dist", "loadfile", "-p",
         "no:cacheprovider", "--basetemp", str(tmp_path / "tmp"), str(suite)],
        cwd=suite, env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    runs = {name: (worker, float(start), float(end)) for name, worker, start, end
            in (line.split() for line in record.read_text().splitlines())}
    assert len(runs) == 32, sorted(runs)
    realtime = ["a0", "a3", "b2", "c1", "c4"]
    workers = {runs[name][0] for name in realtime}
    assert len(workers) == 1, {name: runs[name][0] for name in realtime}
    # one after another, and first on their worker: nothing ran there before the last of them
    (worker,) = workers
    last_realtime_end = max(runs[name][2] for name in realtime)
    others_there = [name for name, run in runs.items()
                    if run[0] == worker and name not in realtime]
    assert all(runs[name][1] >= last_realtime_end for name in others_there), others_there
    # the file of slow tests, collected last, is the other worker's first: before any plain one
    slow_worker = runs["z0"][0]
    assert slow_worker != worker and runs["z1"][0] == slow_worker
    plain_there = [run[1] for name, run in runs.items()
                   if run[0] == slow_worker and name[0] in "abcd"]
    assert max(runs["z0"][1], runs["z1"][1]) < min(plain_there), (runs, slow_worker)
