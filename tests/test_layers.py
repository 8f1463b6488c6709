"""Imports point down only (docs/layout.md): nothing below the robots imports them or the
commands, the algorithms import nothing of servolab but each other and the core's
errors, and the driver never imports the emulator. Checked on the source, every import
statement (also those inside functions), relative ones resolved."""

from __future__ import annotations

import ast
import functools
import re
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = SRC / "servolab"
ALGORITHMS = ("kinematics", "gait", "planning", "estimation", "vision", "trajectories")
CORE = ("clock", "configfile", "errors", "limits", "runs", "signals", "harness")


def _module(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def parsed(path: Path) -> ast.Module:
    """``path``'s syntax tree. The checks below read every file of the package, some many
    times over (one per layer, each graph): each file is parsed once for them all, and again
    only if it changed (its modification time or size); the trees are only read."""
    stat = path.stat()
    return _parse(path, stat.st_mtime_ns, stat.st_size)


@functools.cache
def _parse(path: Path, mtime_ns: int, size: int) -> ast.Module:
    return ast.parse(path.read_text(), str(path))


@pytest.fixture(autouse=True, scope="module")
def _parsed_for_this_module_only() -> Iterator[None]:
    """The trees (about 100 MB of them) are let go once this module's tests are done: the
    worker runs other modules after it."""
    yield
    _parse.cache_clear()
    _imports.cache_clear()


def imports(path: Path) -> list[tuple[int, str]]:
    """(line, absolute module) of every import in ``path``."""
    stat = path.stat()
    return list(_imports(path, SRC, stat.st_mtime_ns, stat.st_size))


@functools.cache
def _imports(path: Path, src: Path, mtime_ns: int, size: int) -> tuple[tuple[int, str], ...]:
    """:func:`imports`, once per file and version; ``src`` is the source root the module names
    are taken from (``SRC``, which a test points elsewhere)."""
    module = _module(path)
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    found = []
    for node in ast.walk(parsed(path)):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package.split(".")
            if node.level:
                base = base[:len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            found.append((node.lineno, target))
            if not node.module:  # from . import x: x may be a module
                found += [(node.lineno, f"{target}.{a.name}") for a in node.names]
    return tuple(found)


def _layer(name: str) -> str:
    parts = name.split(".")
    return parts[1] if len(parts) > 1 and parts[0] == "servolab" else ""


def offences(packages: tuple[str, ...], forbidden: tuple[str, ...]) -> list[str]:
    out = []
    for layer in packages:
        files = [PACKAGE / f"{layer}.py"] if (PACKAGE / f"{layer}.py").exists() else sorted(
            (PACKAGE / layer).rglob("*.py"))
        for path in files:
            for line, target in imports(path):
                if _layer(target) in forbidden:
                    out.append(f"{path.relative_to(SRC)}:{line} imports {target}")
    return out


@pytest.mark.slow
def test_the_checker_sees_relative_imports() -> None:
    """A mutant of the checker that missed ``from ..robots import x`` would pass everything."""
    robots_run = PACKAGE / "robots" / "base" / "run.py"
    assert any(t == "servolab.robots.base.mobile_base" for _, t in imports(robots_run))
    assert offences(("robots",), ("apps",)) == []
    assert offences(("apps",), ("robots",)), "apps import robots: the checker must see it"


@pytest.mark.parametrize("layer", ["sim", "middleware", "dynamixel", "rclpy", "interfaces",
                                   *ALGORITHMS, *CORE])
def test_nothing_below_the_robots_imports_them_or_the_commands(layer: str) -> None:
    assert offences((layer,), ("robots", "apps", "cli")) == []


def test_algorithms_are_pure() -> None:
    """Arrays in, arrays out: no bus, no topics, no simulation, no run folders."""
    assert offences(ALGORITHMS, ("dynamixel", "middleware", "sim", "robots", "apps", "runs",
                                 "clock", "harness", "rclpy")) == []


def test_the_core_imports_no_layer_above_it() -> None:
    assert offences(CORE, ("dynamixel", "middleware", "sim", "robots", "apps", "rclpy",
                           *ALGORITHMS)) == []


def test_the_driver_never_imports_the_emulator() -> None:
    driver = [PACKAGE / "dynamixel" / name for name in
              ("ports.py", "packets.py", "protocol1.py", "protocol2.py")]
    driver += sorted((PACKAGE / "dynamixel" / "bus").glob("*.py"))
    assert [f"{p.name}:{line}" for p in driver for line, target in imports(p)
            if target.endswith(".emulator")] == []


def test_only_the_commands_import_a_robots_run_module() -> None:
    """A robot's ``run`` module is its command's body (docs/layout.md): what another module
    needs from it belongs in the robot's other modules."""
    runs = {f"servolab.robots.{p.parent.name}.run" for p in (PACKAGE / "robots").glob("*/run.py")}
    assert runs, "no run modules found: the checker looks in the wrong place"
    outside = [f"{path.relative_to(SRC)}:{line} imports {target}"
               for path in sorted(PACKAGE.rglob("*.py"))
               if "apps" not in path.relative_to(PACKAGE).parts
               for line, target in imports(path) if target in runs]
    assert outside == []


def _type_checking_lines(tree: ast.Module) -> set[int]:
    """The lines of imports under ``if TYPE_CHECKING:``: read by mypy, never run."""
    lines: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and isinstance(node.test, ast.Name) \
                and node.test.id == "TYPE_CHECKING":
            lines |= {n.lineno for stmt in node.body for n in ast.walk(stmt)
                      if isinstance(n, ast.Import | ast.ImportFrom)}
    return lines


def run_time_graph(package: Path) -> dict[str, set[str]]:
    """Module -> the modules of ``package`` it imports when it runs (at its top or inside a
    function, not under TYPE_CHECKING); ``from .x import name`` counts ``x.name`` when that is
    a module. (Importing ``a.b`` also runs ``a/__init__``, but Python imports a package's
    module while the package is half made, so that edge is no circle.)"""
    modules = {_module(p): p for p in package.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        tree = parsed(path)
        skip = _type_checking_lines(tree)
        targets: set[str] = set()
        names = {(n.lineno, a.name) for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)
                 for a in n.names}
        for line, target in imports(path):
            if line in skip:
                continue
            targets |= {f"{target}.{a}" for ln, a in names if ln == line
                        and f"{target}.{a}" in modules}
            targets.add(target)
        graph[name] = {t for t in targets if t in modules and t != name}
    return graph


def import_circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module: each an import circle."""
    import numpy as np
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    names = sorted(graph)
    index = {n: i for i, n in enumerate(names)}
    rows = [index[a] for a in names for _ in graph[a]]
    cols = [index[b] for a in names for b in graph[a]]
    matrix = csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(names), len(names)))
    count, labels = connected_components(matrix, directed=True, connection="strong")
    groups = [[names[i] for i in np.flatnonzero(labels == k)] for k in range(count)]
    return [g for g in groups if len(g) > 1]


def test_the_circle_finder_sees_a_circle(tmp_path: Path) -> None:
    assert import_circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert import_circles({"a": {"b"}, "b": set()}) == []


def test_no_import_circle_under_robots_at_run_time() -> None:
    """Robots are plug-ins: a robot's modules import shared machinery and never the other
    way round, and no two modules of the robot layer need each other (issue 42: Armstrong's
    description and hardware once did)."""
    graph = {name: {t for t in targets if t.startswith("servolab.robots")}
             for name, targets in run_time_graph(PACKAGE).items()
             if name.startswith("servolab.robots")}
    assert len(graph) > 50, "the checker found too few robot modules"
    assert import_circles(graph) == []


def _docstrings(tree: ast.Module) -> set[int]:
    """The ids of a module's, classes' and functions' docstring nodes (prose, not code)."""
    found: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef) \
                and node.body and isinstance(node.body[0], ast.Expr) \
                and isinstance(node.body[0].value, ast.Constant):
            found.add(id(node.body[0].value))
    return found


def _servolabs_robots() -> dict[str, tuple[str, tuple[str, ...]]]:
    """Each name (and alias) of servolab's own robots -> (its package under robots/, the
    commands its plug-in says run it)."""
    from servolab.robots.registry import discover

    found = discover({})
    names: dict[str, tuple[str, tuple[str, ...]]] = {}
    for plugin in found.plugins.values():
        if plugin.origin == "servolab":
            package = plugin.open.__module__.split(".")[2]
            names.update({n: (package, plugin.commands) for n in (plugin.name, *plugin.aliases)})
    return names


def shared_mentions(names: dict[str, tuple[str, tuple[str, ...]]]) -> list[str]:
    """Where a module outside every robot's package names a robot in code: a string that is a
    robot's name (or its name and a dot: one of its files, ``armstrong.urdf``), a string
    naming two robots (a list), or an import of a robot's package — unless the module is one of
    the commands that robot's plug-in says run it."""
    packages = {package for package, _ in names.values()}
    words = {n: re.compile(rf"(?<![\w-]){re.escape(n)}(?![\w-])") for n in names}
    found: list[str] = []
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE).parts
        if parts[0] == "robots" and len(parts) > 2 and parts[1] in packages:
            continue
        command = path.stem if parts[0] == "apps" else None
        allowed = {n for n, (_, commands) in names.items() if command in commands}
        tree = parsed(path)
        prose = _docstrings(tree)
        for node in ast.walk(tree):
            if not (isinstance(node, ast.Constant) and isinstance(node.value, str)) \
                    or id(node) in prose:
                continue
            named = {n for n, word in words.items() if word.search(node.value)} - allowed
            keys = {n for n in named if node.value == n or node.value.startswith(f"{n}.")}
            if keys or len(named) > 1:
                found.append(f"{path.relative_to(SRC)}:{node.lineno} names "
                             f"{', '.join(sorted(keys or named))}: {node.value[:60]!r}")
        owners = {f"servolab.robots.{names[n][0]}" for n in names} - \
            {f"servolab.robots.{names[n][0]}" for n in allowed}
        found += [f"{path.relative_to(SRC)}:{line} imports {target}"
                  for line, target in imports(path)
                  if any(target == o or target.startswith(o + ".") for o in owners)]
    return found


def test_the_shared_list_finder_sees_a_list_a_key_and_an_import(tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch
                                                                 ) -> None:
    apps = tmp_path / "servolab" / "apps"
    apps.mkdir(parents=True)
    (apps / "tour.py").write_text('ROBOTS = ("alpha", "beta")\nFILE = "alpha.urdf"\n'
                                  'HELP = "runs alpha, the arm"\n'
                                  "from ..robots.beta import plugin\n")
    (apps / "move.py").write_text('FILE = "alpha.urdf"\nfrom ..robots.alpha import run\n')
    monkeypatch.setattr(sys.modules[__name__], "SRC", tmp_path)
    monkeypatch.setattr(sys.modules[__name__], "PACKAGE", tmp_path / "servolab")
    found = shared_mentions({"alpha": ("alpha", ("move",)), "beta": ("beta", ())})
    assert sorted(found) == ["servolab/apps/tour.py:1 names alpha: 'alpha'",
                     "servolab/apps/tour.py:1 names beta: 'beta'",
                     "servolab/apps/tour.py:2 names alpha: 'alpha.urdf'",
                     "servolab/apps/tour.py:4 imports servolab.robots.beta"]


def test_no_shared_file_names_a_robot() -> None:
    """A robot is a plug-in (issue 42): outside its own package and the commands that run it,
    servolab holds no list of robots to edit — no robot's name as a key or file, no string
    naming two robots, no import of a robot's package. Robots may use each other (the
    navigation drives a base); prose that mentions one (docstrings, a help line's example)
    is not a list."""
    names = _servolabs_robots()
    assert {"armstrong", "seed000", "turtlebot3_waffle", "treadmill", "navigation"} <= set(names)
    assert shared_mentions(names) == []


def test_the_transports_never_reach_up_into_the_entities() -> None:
    """A transport carries bytes for nodes; what a node's publisher, subscription, service or
    client does is above it (issue 44: the Zenoh transport once imported the service module
    for the error encoding that is rmw_zenoh's, ``rmw_zenoh.error_encoding``)."""
    graph = run_time_graph(PACKAGE)
    below = [f"servolab.middleware.{m}" for m in (
        "transport", "transports", "local", "inbox", "zenoh_transport", "zenoh_inbox",
        "rmw_zenoh", "dds_transport", "dds_types", "rmw_dds", "ros2_transport")]
    above = {f"servolab.middleware.{m}" for m in (
        "node", "publisher", "subscription", "service", "client", "executor", "context")}
    assert all(module in graph for module in below), "the checker looks in the wrong place"
    reaching = {module: sorted(graph[module] & above) for module in below
                if graph[module] & above}
    assert reaching == {}
