"""How ``make test``'s two workers share the suite: every test marked ``realtime`` on one
worker, one after another, the rest file by file on both, the files with the most tests
marked ``slow`` first.

Two realtime tests never run at once (each holds the wall clock to a deadline or keeps every
core busy; ``tests/conftest.py``'s lock). Sent file by file to both workers, as
``--dist loadfile`` does, they met at that lock: a clean-clone run spent 148 s of its
workers' time waiting there, while a file of quick tests could have run. Here they are one
unit of work, sent first, so that one worker runs them back to back while the other runs
everything else; the lock stays, for any other way of running the suite.

pytest-xdist's controller does not collect, so it cannot read a test's markers: each worker
writes the ids of the tests marked realtime and slow to a file in the run's shared folder as
it collects, and the controller reads it when it splits the collection into units (both come
before the first test). The files are then handed out slowest first, by their count of
``slow`` tests (then of all tests, as xdist orders them): a long file left for the end keeps
one worker busy while the other has nothing to do. (xdist's own ``--dist loadgroup`` would
need an ``xdist_group`` mark on every realtime test, and sends every other test alone rather
than file by file, so that a file's module fixtures are made on both workers.)
"""

from __future__ import annotations

import json
import os
import sys
from collections import Counter
from pathlib import Path

import pytest
from xdist.scheduler import LoadFileScheduling

#: the unit of work that holds every realtime test
REALTIME_UNIT = "realtime"
#: where the workers write the ids of the tests marked realtime and slow, in the run's shared
#: temporary folder
MARKED_IDS = "marked-tests.json"


def shared_folder(config: pytest.Config) -> Path:
    """The folder every process of one pytest run shares: the controller's base temporary
    folder, whose subfolders (``popen-gw0`` …) are the workers'."""
    base: Path = config._tmp_path_factory.getbasetemp()  # type: ignore[attr-defined]
    return base.parent if worker_id(config) else base


def worker_id(config: pytest.Config) -> str | None:
    """This process's xdist worker id (gw0 …), None in the controller or without xdist. From
    the config xdist gives its workers, not from $PYTEST_XDIST_WORKER: a pytest that a test
    starts inherits that variable from the worker it runs on."""
    workerinput = getattr(config, "workerinput", None)
    return None if workerinput is None else str(workerinput["workerid"])


def write_marked_ids(config: pytest.Config, items: list[pytest.Item]) -> None:
    """On a worker: the ids of the collected tests marked ``realtime`` and ``slow``, written
    whole (both workers write the same lists; a reader never sees half of them)."""
    worker = worker_id(config)
    if worker is None:
        return
    marked = {mark: [item.nodeid for item in items if item.get_closest_marker(mark) is not None]
              for mark in ("realtime", "slow")}
    folder = shared_folder(config)
    partial = folder / f"{MARKED_IDS}.{worker}"
    partial.write_text(json.dumps(marked))
    os.replace(partial, folder / MARKED_IDS)


class RealTimeOnOneWorker(LoadFileScheduling):
    """``--dist loadfile``, except that the realtime tests are one unit, assigned first, and
    the files follow by their count of slow tests."""

    def __init__(self, config: pytest.Config, log: object | None = None) -> None:
        super().__init__(config, log)
        self._marked: dict[str, set[str]] | None = None
        self._ordered = False

    def _marked_ids(self, mark: str) -> set[str]:
        if self._marked is None:
            listed = shared_folder(self.config) / MARKED_IDS
            if not listed.exists():  # then file by file, as plain loadfile: said, not hidden
                sys.stderr.write(f"tests/scheduling.py: no {listed} from the workers; the "
                                 "realtime tests go file by file\n")
            lists = json.loads(listed.read_text()) if listed.exists() else {}
            self._marked = {name: set(ids) for name, ids in lists.items()}
        return self._marked.get(mark, set())

    def _split_scope(self, nodeid: str) -> str:
        if nodeid in self._marked_ids("realtime"):
            return REALTIME_UNIT
        return super()._split_scope(nodeid)

    def _assign_work_unit(self, node: object) -> None:
        if not self._ordered:  # once, after schedule() has made the units
            self._ordered = True
            slow = Counter(self._split_scope(nodeid) for nodeid in self._marked_ids("slow"))
            units = sorted(self.workqueue.items(), key=lambda unit: (
                unit[0] != REALTIME_UNIT, -slow[unit[0]], -len(unit[1])))
            self.workqueue.clear()
            self.workqueue.update(units)
        super()._assign_work_unit(node)
