"""The robots servolab can open, found where they live — never listed by hand.

Three places, in this order:

1. **servolab's own robots**: every subpackage of :mod:`servolab.robots` with a ``plugin``
   module, whose ``ROBOTS`` is a tuple of :class:`~.plugin.RobotPlugin` (as ``servolab``'s
   commands are the modules of :mod:`servolab.apps` with a ``COMMAND``);
2. **installed plug-ins**: the Python entry points of the group ``servolab.robots``; an entry
   point names a :class:`~.plugin.RobotPlugin`, a tuple of them, or a function returning
   either (a package declares it in its ``pyproject.toml``:
   ``[project.entry-points."servolab.robots"] my_arm = "my_arm.robot:PLUGIN"``);
3. **robot folders**: every folder inside the folders of ``SERVOLAB_ROBOT_PATH`` (joined by
   ``os.pathsep``, as ``PATH``) that holds a URDF with a ``<ros2_control>`` block: a robot made
   of data only (:mod:`.robot_folder`), named after its folder.

A robot that cannot be loaded (a broken entry point, a folder whose URDF does not parse, a
name taken twice) never hides the others: :func:`discover` keeps one line about it in
``problems``, ``servolab robots`` prints it, and loading that name raises it. Nothing is cached:
each call looks again, so a folder made a moment ago is found, and there is no state to reset.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import pkgutil
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import ServolabError, UsageError
from .plugin import RobotPlugin, ShownFile

if TYPE_CHECKING:
    from ..middleware.view.layout import Layout

#: the entry-point group an installed package declares its robots in
ENTRY_POINT_GROUP = "servolab.robots"
#: the environment variable naming folders that hold robot folders
PATH_VARIABLE = "SERVOLAB_ROBOT_PATH"
#: how a robot folder's problem begins (``servolab robots`` prints it)
FOLDER_PROBLEM = "robot folder"


class UnknownRobotError(ServolabError, ValueError):
    """A robot name that no plug-in answers to."""


class RobotPluginError(ServolabError, ValueError):
    """A robot plug-in that cannot be loaded: what it is, where it was found, and why."""


@dataclass(frozen=True)
class Robots:
    """What one look found: the robots by name, the aliases (another name -> the robot's),
    and one line per plug-in that could not be loaded, by the name it would have had."""

    plugins: Mapping[str, RobotPlugin]
    aliases: Mapping[str, str]
    problems: Mapping[str, str]

    def entry(self, name: str) -> RobotPlugin:
        found = self.plugins.get(self.aliases.get(name, name))
        if found is not None:
            return found
        if name in self.problems:
            raise RobotPluginError(self.problems[name])
        raise UnknownRobotError(f"no robot {name!r}; there are {', '.join(self.plugins)}"
                                f" (a robot of your own: docs/layout.md, 'Adding a robot')")


def _as_plugins(value: Any, where: str) -> tuple[RobotPlugin, ...]:
    """An entry point's or a ``plugin`` module's value as plug-ins: one, a tuple or list of
    them, or a function returning either."""
    if callable(value) and not isinstance(value, RobotPlugin):
        value = value()
    if isinstance(value, RobotPlugin):
        return (value,)
    if isinstance(value, list | tuple) and value and all(isinstance(v, RobotPlugin)
                                                         for v in value):
        return tuple(value)
    raise RobotPluginError(f"{where}: expected a servolab.robots.RobotPlugin (or a tuple of "
                           f"them, or a function returning one), got {type(value).__name__}")


def _shipped() -> Iterable[tuple[str, Any]]:
    """(where, value) of each servolab robot package's ``plugin.ROBOTS``."""
    package = __name__.rpartition(".")[0]
    here = importlib.import_module(package)
    for info in sorted(pkgutil.iter_modules(here.__path__), key=lambda i: i.name):
        name = f"{package}.{info.name}.plugin"
        if info.ispkg and importlib.util.find_spec(name) is not None:
            yield f"{name}.ROBOTS", importlib.import_module(name).ROBOTS


def _entry_points() -> Iterable[tuple[str, str, Any]]:
    """(entry point name, where, its value or the exception loading it) of each installed
    plug-in."""
    for point in sorted(metadata.entry_points(group=ENTRY_POINT_GROUP), key=lambda p: p.name):
        where = f"entry point {point.name} = {point.value!r} ({ENTRY_POINT_GROUP})"
        try:
            yield point.name, where, point.load()
        except Exception as exc:  # a third party's import error must not hide the rest
            yield point.name, where, exc


def robot_folders(environ: Mapping[str, str] | None = None) -> list[Path]:
    """The robot folders inside the folders of ``SERVOLAB_ROBOT_PATH``, in path order, each
    folder's robots by name."""
    from .robot_folder import is_robot_folder

    found: list[Path] = []
    seen: set[Path] = set()   # a folder named twice on the path (a/ and a, or a link to it)
    for entry in (environ if environ is not None else os.environ).get(PATH_VARIABLE, "") \
            .split(os.pathsep):
        folder = Path(entry).expanduser()
        if not entry or not folder.is_dir() or folder.resolve() in seen:
            continue
        seen.add(folder.resolve())
        found += sorted(p for p in folder.iterdir() if is_robot_folder(p))
    return found


def discover(environ: Mapping[str, str] | None = None) -> Robots:
    """Look for every robot (see the module's docstring)."""
    plugins: dict[str, RobotPlugin] = {}
    aliases: dict[str, str] = {}
    problems: dict[str, str] = {}

    def add(found: Iterable[RobotPlugin], where: str) -> None:
        for plugin in found:
            names = (plugin.name, *plugin.aliases)
            taken = [n for n in names if n in plugins or n in aliases]
            if taken:
                first = plugins[aliases.get(taken[0], taken[0])].origin
                problems.setdefault(plugin.name, f"robot {taken[0]!r} from {where}: the name is "
                                    f"taken by {first}; rename one of them")
                continue
            plugins[plugin.name] = replace(plugin, origin=where)
            aliases.update({alias: plugin.name for alias in plugin.aliases})

    for where, value in _shipped():
        add(_as_plugins(value, where), "servolab")
    for name, where, value in _entry_points():
        try:
            if isinstance(value, Exception):
                raise RobotPluginError(f"{where}: {type(value).__name__}: {value}")
            add(_as_plugins(value, where), where)
        except Exception as exc:
            problems.setdefault(name, str(exc) if isinstance(exc, RobotPluginError)
                                else f"{where}: {type(exc).__name__}: {exc}")
    for folder in robot_folders(environ):
        from .robot_folder import folder_plugin

        try:
            add((folder_plugin(folder),), f"folder {folder}")
        except ServolabError as exc:
            problems.setdefault(folder.name, f"{FOLDER_PROBLEM} {folder}: {exc}")
    return Robots(plugins, aliases, problems)


def robots() -> Mapping[str, RobotPlugin]:
    """Every robot found, by name."""
    return discover().plugins


def entry(name: str) -> RobotPlugin:
    """The robot called ``name`` (or one of its aliases); one line naming the robots there are
    when none is, or saying why the one of that name cannot be loaded."""
    return discover().entry(name)


def default_robot(command: str, environ: Mapping[str, str] | None = None) -> str:
    """The robot ``servolab COMMAND`` runs without ``--robot``: the one plug-in whose
    ``default_for`` names the command. A lab's own plug-in (an entry point)
    that says so wins over servolab's: installing one's arm makes it the default; two of a
    lab's own that both say so are refused in one line, as is a command no robot claims.
    So is falling back on servolab's own while a lab's plug-in could not be loaded: that one
    may have been the default, and the shipped robot's motors are not the lab's."""
    found = discover(environ)
    claiming = [p for p in found.plugins.values() if command in p.default_for]
    own = [p for p in claiming if p.origin != "servolab"]
    # a robot folder cannot claim a command (it has no default_for): only a plug-in's
    # failure may hide the default
    failed = {n: p for n, p in found.problems.items() if not p.startswith(FOLDER_PROBLEM)}
    if not own and failed:
        name, problem = next(iter(failed.items()))
        raise UsageError(f"servolab {command}: robot {name!r} could not be loaded ({problem}) "
                         "and may be the default; give --robot NAME, or fix it (servolab "
                         "robots says why)")
    chosen = own or claiming
    if len(chosen) == 1:
        return chosen[0].name
    if not chosen:
        raise UsageError(f"servolab {command}: no robot is its default; give --robot NAME "
                         "(servolab robots lists them)")
    raise UsageError(f"servolab {command}: {' and '.join(p.name for p in chosen)} each say "
                     "they are its default; give --robot NAME")


def load(name: str, port: str | None = None) -> Any:
    """The robot ``name`` on emulated motors, or on the serial port (or pyserial URL)
    ``port``, as ``dm_control.suite.load`` gives a domain: Armstrong's
    :class:`~.armstrong.control_node.Armstrong`, a base's :class:`~.base.mobile_base.MobileBase`,
    the treadmill's :class:`~.treadmill.node.Treadmill`, a robot folder's
    :class:`~.urdf_robot.UrdfRobot`. Each has ``bus`` and closes with ``close()``."""
    return entry(name).load(port)


def shipped_files(plugins: Mapping[str, RobotPlugin] | None = None) -> dict[str, ShownFile]:
    """Every file ``servolab robots show`` prints, by the name it takes: each robot's default
    configuration, its URDF and the other files its plug-in names (of ``plugins``, else of
    every robot found). A user's robot whose files cannot be named (a robot folder whose URDF
    does not parse) is left out: ``servolab robots`` says why."""
    files: dict[str, ShownFile] = {}
    for plugin in (plugins if plugins is not None else robots()).values():
        try:
            files.update(plugin.shown_files())
        except Exception:  # a user's robot's fault must not hide the others' files
            if plugin.origin == "servolab":  # a shipped robot's is servolab's bug: raised
                raise
    return files


def layouts() -> dict[str, Layout]:
    """Every robot's Foxglove layout, by the layout's own name (bases share one, ``base``).
    A user's robot whose layout cannot be made (a robot folder whose URDF does not parse) is
    left out, so that it does not hide the others'; :func:`layout_named` raises its error."""
    found: dict[str, Layout] = {}
    for plugin in robots().values():
        if plugin.layout is None:
            continue
        try:
            layout = plugin.layout()
        except Exception:  # servolab robots says why a user's robot cannot be loaded
            if plugin.origin == "servolab":  # a shipped robot's is servolab's bug: raised
                raise
            continue
        found[layout.name] = layout
    return found


def layout_named(name: str) -> Layout:
    """The layout of the robot ``name`` (or alias), or the layout called ``name``; else one
    line listing the names there are."""
    found = discover()
    plugin = found.plugins.get(found.aliases.get(name, name))
    if plugin is not None and plugin.layout is not None:
        return plugin.layout()
    every = layouts()
    if name in every:
        return every[name]
    names = {*every, *(n for n, p in found.plugins.items() if p.layout is not None)}
    raise UsageError(f"no layout {name!r}; there are: {', '.join(sorted(names))}")
