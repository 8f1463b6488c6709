"""The OpenMANIPULATOR-X is a robot plug-in like any lab's: found without a shared list, its files
shown, its layout made, and its package written against servolab's public API only."""

from __future__ import annotations

import ast
import importlib
import pkgutil
from pathlib import Path

import pytest

import servolab.robots.open_manipulator_x as package
from servolab.cli import main
from servolab.robots.open_manipulator_x import CONTROLLERS, NAME, URDF
from servolab.robots.open_manipulator_x.plugin import SUMMARY
from servolab.robots.registry import discover, layout_named

from .conftest import IDS


def test_it_is_found_among_servolabs_own_robots() -> None:
    plugin = discover({}).entry(NAME)
    assert (plugin.name, plugin.summary, plugin.origin) == (NAME, SUMMARY, "servolab")
    # its opener lives in its own package (what tests/test_layers.py takes for the robot's
    # package when it checks that no other file names it)
    assert plugin.open.__module__.startswith(package.__name__ + ".")
    assert plugin.on_stop.startswith("the joints hold where they are")


@pytest.mark.parametrize(("shown", "path"), [(NAME, URDF), (f"{NAME}.urdf", URDF),
                                             (f"{NAME}.controllers", CONTROLLERS)])
def test_robots_show_prints_its_files(shown: str, path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["robots", "show", shown]) == 0
    assert capsys.readouterr().out == path.read_text(encoding="utf-8")


def test_control_run_finds_its_urdf_and_controllers_file() -> None:
    from servolab.apps.control import robot_files

    urdf, source, controllers, plugin = robot_files(NAME, None)
    assert (urdf, source, controllers) == (URDF.read_text(encoding="utf-8"), f"{NAME}.urdf",
                                           CONTROLLERS)
    assert plugin.name == NAME


def test_the_listing_names_its_bus(capsys: pytest.CaptureFixture[str]) -> None:
    bus = discover({}).entry(NAME).bus()
    assert str(bus) == "5 x XM430-W350 (IDs 11-15), Protocol 2.0, 1000000 bps"
    assert main(["robots"]) == 0
    out = capsys.readouterr().out
    assert f"{NAME}: {SUMMARY}" in out and str(bus) in out


def test_it_opens_on_emulated_motors_and_every_motor_answers() -> None:
    """What tests/robots/test_registry.py asks of every robot, and a move of the arm."""
    robot = discover({}).entry(NAME).load()
    try:
        for motor_id in IDS.values():
            found = robot.bus.ping(motor_id)
            assert found.model is not None and found.model.name == "XM430-W350"
        reached = robot.move_to({"joint1": 0.4, "joint2": -0.3})
        assert reached["joint1"] == pytest.approx(0.4, abs=0.02)
        assert reached["joint2"] == pytest.approx(-0.3, abs=0.02)
    finally:
        robot.close()


def test_its_layout_shows_the_arm_its_joints_and_its_load() -> None:
    layout = layout_named(NAME)
    assert layout.name == NAME
    assert layout.topics() == {"/tf", "/tf_static", "/robot_description", "/joint_states"}
    panels = layout.to_json()["configById"]
    assert set(panels) == {"3D!robot", "Plot!joints", "Plot!gripper", "Plot!load"}
    assert panels["3D!robot"]["followTf"] == "world"   # the URDF's root link


def _modules() -> list[Path]:
    """Every Python module of the robot's package."""
    found = [Path(package.__file__)]
    for info in pkgutil.iter_modules(package.__path__):
        found.append(Path(package.__path__[0]) / f"{info.name}.py")
    return found


def _imported(path: Path) -> list[tuple[int, str]]:
    """(line, dotted name) of everything ``path`` imports, relative imports made absolute and
    each ``from X import name`` as ``X.name``."""
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    found: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package.__name__.rsplit(".", node.level - 1)[0] if node.level > 1 \
                    else package.__name__
                base = f"{parent}.{base}" if base else parent
            found += [(node.lineno, f"{base}.{alias.name}") for alias in node.names]
    return found


def test_the_package_imports_nothing_private() -> None:
    """Written against the public API only: no module or name it imports from servolab starts
    with an underscore (``servolab.robots._x``, ``from servolab.sim import _y``), and every
    one exists."""
    modules = _modules()
    assert {p.name for p in modules} >= {"__init__.py", "plugin.py", "world.py", "layout.py"}
    private: list[str] = []
    checked = 0
    for path in modules:
        for line, name in _imported(path):
            if not name.startswith("servolab."):
                continue
            checked += 1
            if any(part.startswith("_") for part in name.split(".")):
                private.append(f"{path.name}:{line} imports {name}")
            module, _, attribute = name.rpartition(".")
            try:   # the name is there: a submodule or an attribute of its module
                importlib.import_module(name)
            except ImportError:
                assert hasattr(importlib.import_module(module), attribute), name
    assert checked > 15, "the checker found too few imports"
    assert private == []

