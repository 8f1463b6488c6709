"""One run lifecycle (issue 42): :func:`servolab.robots.lifecycle.run_task` owns a robot
command's run, the command supplies only its task. Checked on a task that writes down what was
asked of it: the order of the way out, a stop or an error mid-run, a step that fails on the way
out, a signal held back while the motors stop, an opening that fails, the view served only
while the run runs; and no robot command's body over 60 lines."""

from __future__ import annotations

import ast
import json
import os
import signal
import socket
from contextlib import ExitStack
from pathlib import Path
from typing import Any

import pytest

from servolab.harness import StopSignal, exit_status, stop_signals_raise
from servolab.robots.errors import RobotError
from servolab.robots.lifecycle import Step, Task, replaced, run_task
from servolab.runs import RunFolder
from tests.middleware.conftest import free_port

SRC = Path(__file__).resolve().parents[2] / "src" / "servolab"
LONGEST = 60  # lines of a command's body or a run module's function


class Closed:
    """Something a task opens; says when it was closed."""

    def __init__(self, log: list[str]) -> None:
        self.log = log

    def __enter__(self) -> Closed:
        return self

    def __exit__(self, *exc: object) -> None:
        self.log.append("closed")


class Recording(Task):
    """A task that writes each call into ``log``; ``during`` is what its run does."""

    name = "test"

    def __init__(self, log: list[str], during: Any = None, *, failing_step: bool = False,
                 failing_open: bool = False) -> None:
        self.log, self.during = log, during
        self.failing_step, self.failing_open = failing_step, failing_open
        self.summary: dict[str, Any] = {"motors_on_stop": "the test's"}
        self.reported: list[BaseException | None] = []

    def open(self, opened: ExitStack) -> None:
        self.log.append("open")
        opened.enter_context(Closed(self.log))
        if self.failing_open:
            raise RobotError("no robot on that port")

    def start(self) -> None:
        self.log.append("start")

    def run(self) -> None:
        self.log.append("run")
        if self.during is not None:
            self.during()
        self.log.append("ran to its end")

    def stop(self, ended: BaseException | None) -> list[Step]:
        def motors() -> None:
            self.log.append("motors stopped")
            self.summary["wheels_after_stop"] = [0, 0]

        return [Step("stopping the motors", motors)]

    def way_out(self, ended: BaseException | None) -> list[Step]:
        def plot() -> None:
            if self.failing_step:
                raise OSError("disk full")
            self.log.append("plotted")

        return [Step("plotting", plot),
                Step("measuring", lambda: self.log.append("measured"))]

    def verdict(self, ended: BaseException | None) -> None:
        self.summary["verdict"] = "stopped" if ended is not None else "done"

    def report(self, ended: BaseException | None) -> None:
        self.reported.append(ended)


def _summary(folder: RunFolder) -> dict[str, Any]:
    return json.loads(folder.file("summary.json").read_text())  # type: ignore[no-any-return]


def test_a_run_that_finishes_takes_the_whole_way_out_in_order(tmp_path: Path) -> None:
    log: list[str] = []
    folder = RunFolder.create("test", tmp_path)
    task = Recording(log)
    returned = run_task(folder, task, say=lambda _: None)
    assert log == ["open", "start", "run", "ran to its end", "motors stopped", "plotted",
                   "measured", "closed"]
    summary = _summary(folder)
    assert summary["interrupted"] is None and summary["verdict"] == "done"
    assert summary["wheels_after_stop"] == [0, 0] and summary["motors_on_stop"] == "the test's"
    assert returned is task.summary and task.reported == [None]


def test_an_error_mid_run_still_stops_the_motors_and_is_raised_after_the_summary(
        tmp_path: Path) -> None:
    log: list[str] = []
    folder = RunFolder.create("test", tmp_path)
    task = Recording(log, during=lambda: (_ for _ in ()).throw(RobotError("motor 3 silent")))
    with pytest.raises(RobotError, match="motor 3 silent") as info:
        run_task(folder, task, say=lambda _: None)
    assert "ran to its end" not in log
    assert log[-4:] == ["motors stopped", "plotted", "measured", "closed"]
    summary = _summary(folder)
    assert summary["interrupted"] == "RobotError: motor 3 silent"
    assert summary["verdict"] == "stopped" and task.reported == [info.value]
    assert exit_status(info.value) == 1


def test_a_failing_step_is_recorded_and_the_next_still_runs(tmp_path: Path) -> None:
    log: list[str] = []
    folder = RunFolder.create("test", tmp_path)
    with pytest.raises(OSError, match="disk full"):  # the first cause, after the summary
        run_task(folder, Recording(log, failing_step=True), say=lambda _: None)
    assert log[-2:] == ["measured", "closed"]
    summary = _summary(folder)
    assert summary["failures_on_the_way_out"] == ["plotting: OSError: disk full"]
    assert summary["interrupted"] == "OSError: disk full"


class BrokenTask(Recording):
    """A task whose own ``stop``, ``way_out`` or ``verdict`` raises (a bug in a plug-in)."""

    def __init__(self, log: list[str], broken: str) -> None:
        super().__init__(log)
        self.broken = broken

    def stop(self, ended: BaseException | None) -> list[Step]:
        if self.broken == "stop":
            raise AttributeError("'Task' object has no attribute 'wheels'")
        return super().stop(ended)

    def way_out(self, ended: BaseException | None) -> list[Step]:
        if self.broken == "way_out":
            raise KeyError("bag")
        return super().way_out(ended)

    def verdict(self, ended: BaseException | None) -> None:
        if self.broken == "verdict":
            raise ZeroDivisionError("division by zero")
        super().verdict(ended)


@pytest.mark.parametrize(("broken", "error"), [("stop", AttributeError),
                                               ("way_out", KeyError),
                                               ("verdict", ZeroDivisionError)])
def test_a_task_whose_own_way_out_fails_still_closes_the_robot_and_writes_the_summary(
        tmp_path: Path, broken: str, error: type[Exception]) -> None:
    log: list[str] = []
    folder = RunFolder.create("test", tmp_path)
    with pytest.raises(error):
        run_task(folder, BrokenTask(log, broken), say=lambda _: None)
    assert log[-1] == "closed"
    if broken != "stop":
        assert "motors stopped" in log
    if broken != "way_out":
        assert "measured" in log
    summary = _summary(folder)
    (failure,) = summary["failures_on_the_way_out"]
    assert failure.startswith({"stop": "stopping the motors: AttributeError",
                               "way_out": "the way out: KeyError",
                               "verdict": "the verdict: ZeroDivisionError"}[broken])
    assert summary["interrupted"].startswith(error.__name__)


def test_a_verdict_that_fails_after_an_error_leaves_the_first_cause_raised(
        tmp_path: Path) -> None:
    """The motor fault that ended the run is what the user sees (and its exit status), not
    the task's own bug in judging it; the bug is kept in the summary."""
    log: list[str] = []
    folder = RunFolder.create("test", tmp_path)
    task = BrokenTask(log, "verdict")
    task.during = lambda: (_ for _ in ()).throw(RobotError("motor 3 silent"))
    with pytest.raises(RobotError, match="motor 3 silent") as info:
        run_task(folder, task, say=lambda _: None)
    assert log[-1] == "closed" and task.reported == [info.value]
    summary = _summary(folder)
    assert summary["interrupted"] == "RobotError: motor 3 silent"
    assert summary["failures_on_the_way_out"] == [
        "the verdict: ZeroDivisionError: division by zero"]


def test_a_stop_signal_stops_the_motors_and_a_second_one_waits_for_the_way_out(
        tmp_path: Path) -> None:
    log: list[str] = []
    folder = RunFolder.create("test", tmp_path)

    class SecondSignal(Recording):
        def stop(self, ended: BaseException | None) -> list[Step]:
            # a SIGHUP while the motors stop is held back: the stop runs to its end
            return [Step("hangup", lambda: os.kill(os.getpid(), signal.SIGHUP)),
                    *super().stop(ended)]

    task = SecondSignal(log, during=lambda: os.kill(os.getpid(), signal.SIGTERM))
    with pytest.raises(StopSignal) as info, stop_signals_raise():
        run_task(folder, task, say=lambda _: None)
    assert info.value.signum == signal.SIGTERM and exit_status(info.value) == 143
    assert "ran to its end" not in log
    assert log[-4:] == ["motors stopped", "plotted", "measured", "closed"]
    assert _summary(folder)["interrupted"] == "SIGTERM"


def test_a_signal_held_back_on_the_way_out_ends_a_run_that_finished(tmp_path: Path) -> None:
    """The run finished, then SIGTERM came while the motors stopped: the stop ran whole and
    the summary and the exit status say the signal."""
    log: list[str] = []
    folder = RunFolder.create("test", tmp_path)

    class LateSignal(Recording):
        def stop(self, ended: BaseException | None) -> list[Step]:
            return [Step("terminated", lambda: os.kill(os.getpid(), signal.SIGTERM)),
                    *super().stop(ended)]

    with pytest.raises(StopSignal) as info, stop_signals_raise():
        run_task(folder, LateSignal(log), say=lambda _: None)
    assert exit_status(info.value) == 143
    assert log[-4:] == ["motors stopped", "plotted", "measured", "closed"]
    assert _summary(folder)["interrupted"] == "SIGTERM"


def test_an_opening_that_fails_closes_what_was_opened_and_runs_nothing(
        tmp_path: Path) -> None:
    log: list[str] = []
    with pytest.raises(RobotError, match="no robot"), \
            RunFolder.create("test", tmp_path) as folder:
        run_task(folder, Recording(log, failing_open=True), say=lambda _: None)
    assert log == ["open", "closed"]
    summary = _summary(folder)  # the run folder's own, for a run that never started
    assert summary["stage"] == "setting up, before the run started"
    assert summary["interrupted"] == "RobotError: no robot on that port"


def _listening(port: int) -> bool:
    with socket.socket() as s:
        return s.connect_ex(("127.0.0.1", port)) == 0


def test_the_view_is_served_while_the_run_runs_and_closed_after(tmp_path: Path) -> None:
    from servolab.middleware.context import Context
    from servolab.middleware.view.run_view import ViewRequest

    port, seen, said = free_port(), list[bool](), list[str]()

    class Viewed(Recording):
        def open(self, opened: ExitStack) -> None:
            super().open(opened)
            self.context = opened.enter_context(Context.open())

        def served(self) -> Context:
            return self.context

    log: list[str] = []
    task = Viewed(log, during=lambda: seen.append(_listening(port)))
    run_task(RunFolder.create("test", tmp_path), task,
             view=ViewRequest(host="127.0.0.1", port=port), say=said.append)
    assert seen == [True] and not _listening(port)
    assert any(f"ws://127.0.0.1:{port}" in line for line in said)
    seen.clear()
    run_task(RunFolder.create("test", tmp_path / "unviewed"),
             Viewed([], during=lambda: seen.append(_listening(port))), say=said.append)
    assert seen == [False]  # no view asked: none served


def test_what_the_graph_dropped_as_malformed_is_in_the_summary(tmp_path: Path) -> None:
    """A robot's nodes that received bytes not of their topic's type (issue 45,
    servolab.middleware.malformed): the run goes on and its summary counts them per topic
    and publisher; a run whose graph dropped nothing says so with an empty table."""
    from servolab.middleware.context import Context

    class WithGraph(Recording):
        def __init__(self, context: Context, *, dropped: int) -> None:
            super().__init__([], lambda: [context.malformed.count("/cmd_vel", b"\x02" * 16)
                                          for _ in range(dropped)])
            self.context = context

        def graph(self) -> Context:
            return self.context

    with Context.open() as context:
        run_task(folder := RunFolder.create("test", tmp_path), WithGraph(context, dropped=3),
                 say=lambda _: None)
    assert _summary(folder)["malformed_messages"] == {"/cmd_vel": {".".join(["02"] * 16): 3}}
    with Context.open() as context:
        run_task(folder := RunFolder.create("test", tmp_path / "clean"),
                 WithGraph(context, dropped=0), say=lambda _: None)
    assert _summary(folder)["malformed_messages"] == {}


def test_replaced_frees_the_path_of_an_earlier_bag(tmp_path: Path) -> None:
    bag = tmp_path / "walk_bag"
    bag.mkdir()
    (bag / "walk_bag_0.mcap").write_bytes(b"old")
    assert replaced(bag) == bag and not bag.exists()


def _robot_commands() -> list[Path]:
    """The commands of the ``robots`` group: their modules' ``COMMAND`` says so."""
    found = []
    for path in sorted((SRC / "apps").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.keyword) and node.arg == "group" and \
                    isinstance(node.value, ast.Constant) and node.value.value == "robots":
                found.append(path)
                break
    return found


def too_long(paths: list[Path], root: Path = SRC) -> list[str]:
    out = []
    for path in paths:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                lines = (node.end_lineno or node.lineno) - node.lineno + 1
                if lines > LONGEST:
                    out.append(f"{path.relative_to(root)}:{node.lineno} {node.name}: {lines}")
    return out


def test_no_robot_command_body_is_over_60_lines() -> None:
    """The lifecycle is written once: a run module's functions and a robot command's body
    hold only what is their robot's own."""
    runs = sorted(SRC.glob("robots/*/run.py"))
    commands = _robot_commands()
    assert len(runs) >= 4 and {p.stem for p in commands} >= {"walk", "drive", "navigate",
                                                              "flyball"}
    assert too_long(runs + commands) == []


def test_no_command_function_is_over_60_lines() -> None:
    """The CLI only parses and calls (ARCHITECTURE.md, "Layers"): every command module's
    functions, not only the robots', stay short enough to read at once."""
    apps = sorted((SRC / "apps").glob("*.py"))
    assert len(apps) > 20
    assert too_long(apps) == []


def test_the_length_check_sees_a_long_body(tmp_path: Path) -> None:
    """A mutant of the checker that measured nothing would pass everything."""
    long = tmp_path / "long.py"
    long.write_text("def f():\n" + "    x = 1\n" * LONGEST)
    short = tmp_path / "short.py"
    short.write_text("def f():\n" + "    x = 1\n" * (LONGEST - 1))
    assert too_long([long, short], tmp_path) == [f"long.py:1 f: {LONGEST + 1}"]
