"""Imports point down only (docs/layout.md): nothing below the robots imports them or the
commands, the algorithms import nothing of servolab but each other and the core's
errors, and the driver never imports the emulator. Checked on the source, every import
statement (also those inside functions), relative ones resolved."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = SRC / "servolab"
ALGORITHMS = ("kinematics", "gait", "planning", "estimation", "vision")
CORE = ("clock", "configfile", "errors", "runs", "signals", "harness")


def _module(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path) -> list[tuple[int, str]]:
    """(line, absolute module) of every import in ``path``."""
    module = _module(path)
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
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
    return found


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
        tree = ast.parse(path.read_text(), str(path))
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
