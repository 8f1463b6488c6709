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
