"""The commands of ``servolab``: what each one is called, where it is listed, its arguments
and the function that runs it.

Every command is a module of :mod:`servolab.apps` with a module-level ``COMMAND``::

    COMMAND = Command(name="scan", group="bus", help="find motors on a port",
                      add_arguments=_add_arguments, run=_run)

and :func:`commands` finds them by walking the package with :mod:`pkgutil`, not from a list
kept here. A new command (the robots' walk, drive, plan, ... are coming, each from whoever
builds that robot) is then one new file and nothing else: no shared list for every author
to edit, so no merge conflicts and no command written but never listed. The price is that
``servolab --help`` imports every module of the package, so those modules must stay cheap
to import: heavy imports (the middleware and Zenoh, matplotlib, the Dynamixel layer) go
inside the run functions. Modules whose name starts with ``_`` are never imported here;
they hold work two commands share and may import what they like. A module without
``COMMAND`` (this one, :mod:`.arguments`) is a helper and is skipped.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..runs import RunFolder

#: a command's part of ``servolab demo``: (run folder, say) -> its figures
Demo = Callable[["RunFolder", Callable[[str], None]], dict[str, object]]


@dataclass(frozen=True)
class Group:
    """A heading of ``servolab --help``: ``name`` is what a :class:`Command` gives as its
    group, ``title`` what the user reads."""

    name: str
    title: str


#: The headings of ``servolab --help``, in the order they are shown. Fixed here rather than
#: taken from the commands, so the order does not depend on which modules exist.
GROUPS: tuple[Group, ...] = (
    Group("bus", "bus commands (motors on a serial port, a pty or an emulated bus)"),
    Group("graph", "graph commands (nodes, topics and parameters, as in ROS 2)"),
    Group("robots", "robot commands"),
    Group("tools", "tools"),
)


@dataclass(frozen=True)
class Command:
    """One ``servolab`` command.

    ``help`` is the one line of ``servolab --help``; ``description`` is the text at the top
    of ``servolab NAME --help`` (the ``help`` line when not given) and ``examples`` are
    command lines shown at its end, because a student learns a command fastest from one
    that works. ``add_arguments`` adds
    the command's arguments to its parser; ``run`` gets the parsed arguments and returns the
    exit status. ``run`` raises errors derived from :class:`servolab.errors.ServolabError`
    for the ``servolab`` command to print as one line, rather than printing them itself, so
    every command reports errors the same way.
    """

    name: str
    group: str
    help: str
    add_arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], int]
    description: str | None = None
    examples: tuple[str, ...] = ()
    #: the command's part of ``servolab demo``: a short run in the tour's run folder, saying
    #: its lines through ``say`` (the first is its heading), returning its key figures. A
    #: robot's command brings its robot to the tour, so the tour names no robot itself.
    demo: Demo | None = None

    def __post_init__(self) -> None:
        if self.group not in {g.name for g in GROUPS}:
            raise ValueError(f"command {self.name!r}: group {self.group!r} is not one of "
                             f"{', '.join(g.name for g in GROUPS)}")


def commands(package: str = "servolab.apps") -> tuple[Command, ...]:
    """Every command of ``package``, by group in :data:`GROUPS` order, then by name.

    Sorted, not in the order the files are found, so the listing is the same on every
    machine. Raises :class:`RuntimeError` if two modules claim one name, which would
    otherwise let one command silently hide the other.
    """
    found: dict[str, tuple[Command, str]] = {}
    for info in pkgutil.iter_modules(importlib.import_module(package).__path__):
        if info.name.startswith("_") or info.ispkg:
            continue
        module = importlib.import_module(f"{package}.{info.name}")
        command = getattr(module, "COMMAND", None)
        if not isinstance(command, Command):
            continue
        if command.name in found:
            raise RuntimeError(f"command {command.name!r} is defined twice: in "
                               f"{found[command.name][1]} and {module.__name__}")
        found[command.name] = (command, module.__name__)
    order = {g.name: i for i, g in enumerate(GROUPS)}
    return tuple(sorted((c for c, _ in found.values()), key=lambda c: (order[c.group], c.name)))
