"""One run lifecycle for every robot command, in the spirit of dm_control's
``Environment(physics, task)``: :func:`run_task` owns the run, the command supplies its
:class:`Task`.

The run owns what every robot command does the same way: it opens the task (a failure there,
or a stop signal, ends the run before it started: :class:`~servolab.runs.RunFolder` then writes
the summary), starts and runs it with a stop signal or an error caught, serves it to Foxglove
while it runs (``--view``: :func:`~servolab.middleware.view.run_view.serve_run`), and then
takes the way out with signals held back (:func:`~servolab.harness.stops_deferred`): the task's
stop (the motors stopped or held first, whatever else fails), the view closed, the task's own
steps (close the bag, measure, plot), what the task opened closed, and ``summary.json`` written
with ``"interrupted"`` and any failure on the way out (:class:`~servolab.harness.RunEnding`).
Then the task reports, and what ended the run goes on to the caller, whose exit status
:func:`~servolab.harness.exit_status` decides.

A task says only what is its robot's own: how to open it, what to run, how to stop or hold
its motors, and what to measure and plot into the summary.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable, Sequence
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..harness import RunEnding, stops_deferred

if TYPE_CHECKING:
    from ..middleware.context import Context
    from ..middleware.view.run_view import ViewRequest
    from ..middleware.view.server import ViewServer
    from ..runs import RunFolder

Say = Callable[[str], None]


@dataclass(frozen=True)
class Step:
    """One step of the way out: ``name`` is what ``summary.json``'s
    ``failures_on_the_way_out`` says was being done when it failed."""

    name: str
    do: Callable[[], object]


class Task:
    """What a robot command supplies to :func:`run_task`. Subclasses set ``name`` (the
    command's: the view is ``servolab NAME``) and ``summary`` (what is known before the run;
    the way out adds to it) and override what their robot does; every method has a harmless
    default but :meth:`run`."""

    name = "run"
    summary: dict[str, Any]

    def open(self, opened: ExitStack) -> None:
        """Open the robot, entering what must be closed into ``opened`` (closed on the way
        out, or at once when opening fails). Nothing may move yet."""

    def start(self) -> None:
        """Make what the run needs once the robot is open (nodes, the recorder): a failure
        or a stop here takes the way out."""

    def served(self) -> Context | None:
        """The context ``--view`` serves (made only when a view is asked for), or None."""
        return None

    def graph(self) -> Context | None:
        """The context the robot's nodes run in, if it has one whatever the options: what it
        received from outside that did not deserialize goes into the summary
        (``malformed_messages``, :mod:`servolab.middleware.malformed`)."""
        return None

    def run(self) -> None:
        """What the robot does; a stop signal or an error ends it."""
        raise NotImplementedError

    def stop(self, ended: BaseException | None) -> Sequence[Step]:
        """The way out's first steps: stop or hold the motors. ``ended``: what ended the run
        (None: it finished)."""
        return ()

    def way_out(self, ended: BaseException | None) -> Sequence[Step]:
        """The steps after the motors and the view: close the bag, measure, plot."""
        return ()

    def verdict(self, ended: BaseException | None) -> None:
        """Put the run's verdict into the summary, once what ended it is settled (a signal
        held back on the way out, or a step that failed, counts)."""

    def report(self, ended: BaseException | None) -> None:
        """Said (or judged: a goal not reached is raised here) once the summary is written."""


def run_task(run_folder: RunFolder, task: Task, *, view: ViewRequest | None = None,
             say: Say = print) -> dict[str, Any]:
    """Run ``task`` from its opening to its summary (see the module docstring); returns the
    summary, or raises what ended the run once the summary is written."""
    opened = ExitStack()  # from here on the way out closes it
    try:
        task.open(opened)
    except BaseException:  # nothing moved yet: close what was opened, and the run ends
        opened.close()
        raise
    viewer: ViewServer | None = None
    context: Context | None = None
    interrupted: BaseException | None = None
    try:
        task.start()
        context = task.served() if view is not None else None
        if view is not None and context is not None:  # served from here on
            from ..middleware.view.run_view import serve_run

            viewer = serve_run(context, view, say, name=f"servolab {task.name}")
        task.run()
    except BaseException as error:  # a stop signal or an error: the way out below
        interrupted = error
    ending = RunEnding(interrupted)
    with stops_deferred() as late:  # the way out is not cut short by a signal
        _take(ending, "stopping the motors", lambda: task.stop(interrupted))
        if viewer is not None:
            _take(ending, "closing the view", lambda: [Step("closing the view", viewer.close)])
        # asked now: the stop may change what the way out is
        _take(ending, "the way out", lambda: task.way_out(interrupted))
        _take(ending, "closing the robot", lambda: [Step("closing the robot", opened.close)])
        ended = ending.settle(late, task.summary)
        # a verdict that fails is one more failure on the way out: the summary of what was
        # done is still written, and what ended the run first is what is raised
        with ending.step("the verdict"):
            task.verdict(ended)
        graph = task.graph() or context
        if graph is not None:  # {topic: {publisher: dropped}}, {} when nothing was
            task.summary["malformed_messages"] = graph.malformed.as_figures()
        run_folder.write_summary(task.summary, interrupted=ending.settle(late, task.summary))
    task.report(ending.error)
    ending.raise_if_ended()
    return task.summary


def _take(ending: RunEnding, what: str, steps: Callable[[], Sequence[Step]]) -> None:
    """Each of the steps ``steps()`` gives, run even when one before failed; a task whose
    ``steps()`` itself fails is one failed step (``what``), so the steps after it still run."""
    built: Sequence[Step] = ()
    with ending.step(what):
        built = steps()
    for step in built:
        with ending.step(step.name):
            step.do()


def replaced(path: Path) -> Path:
    """``path`` made free for a new bag: a run folder's files are replaced
    (:mod:`servolab.runs`)."""
    if path.exists():
        shutil.rmtree(path)
    return path
