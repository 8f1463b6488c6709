"""Errors tell bugs from bad input (src/servolab/errors.py): every error servolab raises on
purpose is a :class:`~servolab.errors.ServolabError` of its layer, so that ``servolab`` prints
it as one line and keeps the traceback of anything else, which is a bug.

Checked on the source with ``ast``: no bare ``raise ValueError(...)`` (nor KeyError, TypeError,
RuntimeError) outside the allow-list below; no command that catches ValueError or Exception
to print it, or that exits with a message (``SystemExit("...")`` exits 1, even for bad
input); and every ``*Error`` class (and ``NoPath``) of servolab is a ServolabError.
"""

from __future__ import annotations

import ast
import importlib
from dataclasses import dataclass
from pathlib import Path

import pytest

from servolab.errors import ServolabError

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = SRC / "servolab"
BUILTINS = ("ValueError", "KeyError", "TypeError", "RuntimeError", "TimeoutError", "OSError",
            "IOError", "IndexError", "LookupError")

#: Builtin errors raised on purpose that stay builtin, by (file, function, class). Each is a
#: programming error in the code that calls servolab (or in servolab itself), never something
#: a user reaches through a command line, a configuration file or a message, so its traceback
#: is the useful report.
ALLOWED = {
    # A command module that names a group that does not exist, or two modules claiming one
    # name: a bug in servolab's own commands, caught by tests/test_cli.py.
    ("apps/registry.py", "Command.__post_init__", "ValueError"),
    ("apps/registry.py", "commands", "RuntimeError"),
    # An internal invariant of D* Lite (marked "pragma: no cover"): only a planner bug fails it.
    ("planning/dstar_lite.py", "DStarLite.path", "RuntimeError"),
    # A call with the wrong arguments or an object of the wrong type: Python's own TypeError,
    # as rclpy raises it for the same mistakes.
    ("middleware/node.py", "Node.__init__", "TypeError"),
    ("middleware/qos.py", "as_profile", "TypeError"),
    ("middleware/subscription.py", "_check_signature", "TypeError"),
    # rclpy.init() twice, shutdown() without init(): rclpy raises RuntimeError, and node code
    # ported from rclpy catches that.
    ("middleware/default_context.py", "init", "RuntimeError"),
    ("rclpy/__init__.py", "shutdown", "RuntimeError"),
    # The system's own I/O error, raised where the system gave none, for the code around it to
    # turn into the layer's error as it does the system's (PortError, BagError).
    ("dynamixel/ports.py", "SerialPort._read", "OSError"),
    ("middleware/bag/writer.py", "_DirectFile.write", "OSError"),
    # The Mapping protocol: a missing key of a read-only mapping (MODELS["x"]) is KeyError, as
    # `in`, .get() and dict(...) rely on; model(name) is the lookup a user reaches, with its
    # ConfigError and "did you mean".
    ("dynamixel/models.py", "_Models.__getitem__", "KeyError"),
    ("dynamixel/models.py", "_ByNumber.__getitem__", "KeyError"),
    ("dynamixel/models.py", "_AllowedModes.__getitem__", "KeyError"),
}

@dataclass(frozen=True)
class Raise:
    path: str  # relative to src/servolab
    line: int
    function: str  # dotted: Class.method
    name: str

    @property
    def key(self) -> tuple[str, str, str]:
        return self.path, self.function, self.name

    def __str__(self) -> str:
        return f"src/servolab/{self.path}:{self.line}: raise {self.name}(...) in {self.function}"


def _sources(root: Path = PACKAGE) -> list[Path]:
    return sorted(root.rglob("*.py"))


def _relative(path: Path) -> str:
    return path.relative_to(PACKAGE).as_posix()


def builtin_raises(source: str, path: str) -> list[Raise]:
    """Every ``raise ValueError(...)`` (or ``raise ValueError``) of the builtins above in
    ``source`` (of ``path``, relative to src/servolab), with the function it is in; except
    those that an enclosing ``try`` of the same function catches by that name (control flow
    of a parser, which its handler turns into the layer's error)."""
    found: list[Raise] = []

    def visit(node: ast.AST, scope: list[str], caught: frozenset[str]) -> None:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            scope, caught = [*scope, node.name], frozenset()  # a try outside does not catch
        elif isinstance(node, ast.Raise) and node.exc is not None:
            target = node.exc.func if isinstance(node.exc, ast.Call) else node.exc
            if isinstance(target, ast.Name) and target.id in BUILTINS and target.id not in caught:
                found.append(Raise(path, node.lineno, ".".join(scope) or "<module>", target.id))
        elif isinstance(node, ast.Try):
            names = frozenset(n for h in node.handlers for n in _caught(h))
            for stmt in node.body:
                visit(stmt, scope, caught | names)
            for part in (*node.handlers, *node.orelse, *node.finalbody):
                visit(part, scope, caught)
            return
        for child in ast.iter_child_nodes(node):
            visit(child, scope, caught)

    visit(ast.parse(source, path), [], frozenset())
    return found


def _all_raises() -> list[Raise]:
    return [r for path in _sources() for r in builtin_raises(path.read_text(), _relative(path))]


@pytest.fixture(scope="module")
def all_raises() -> list[Raise]:
    """:func:`_all_raises` of src/servolab, found once for the tests that only read them."""
    return _all_raises()


def test_the_checker_sees_a_bare_raise() -> None:
    """A checker that missed them would pass everything."""
    source = ("class A:\n    def f(self):\n        raise ValueError('x')\n"
              "def g():\n    raise KeyError\n"
              "def h():\n    raise ServolabError('fine')\n"
              "def parse(text):\n    try:\n        raise ValueError\n"
              "    except ValueError:\n        raise ServolabError(text) from None\n"
              "def io():\n    try:\n        raise TypeError('t')\n    except OSError:\n"
              "        pass\n")
    found = builtin_raises(source, "sample.py")
    assert [(r.line, r.function, r.name) for r in found] == [(3, "A.f", "ValueError"),
                                                            (5, "g", "KeyError"),
                                                            (15, "io", "TypeError")]


#: ``servolab.rclpy`` is rclpy's API, exceptions included: a wrong argument to ``Time``,
#: ``Parameter`` or ``Node.declare_parameters`` is rclpy's TypeError or ValueError, which code
#: ported from rclpy catches (rclpy/time.py, rclpy/parameter.py, rclpy/node.py upstream).
RCLPY_SHAPED = "rclpy/"


@pytest.mark.slow
def test_no_bare_builtin_error_is_raised_on_purpose(all_raises: list[Raise]) -> None:
    """Each layer raises its own classes (a value error also subclasses ValueError, so
    ``except ValueError`` keeps working); a bare builtin would be printed as a bug."""
    offences = [str(r) for r in all_raises
                if r.key not in ALLOWED and not r.key[0].startswith(RCLPY_SHAPED)]
    assert offences == [], "raise the layer's error (servolab/<layer>/errors.py):\n" + \
        "\n".join(offences)


def test_the_allow_list_has_nothing_stale(all_raises: list[Raise]) -> None:
    """An entry whose raise is gone would let a new one in unseen: remove it."""
    seen = {r.key for r in all_raises}
    assert sorted((ALLOWED) - seen) == []


# -- commands -----------------------------------------------------------------------------------

#: what a command must not catch to print: these hide bugs behind a one-line message
BROAD = {"ValueError", "KeyError", "TypeError", "RuntimeError", "Exception", "BaseException"}


def _caught(handler: ast.ExceptHandler) -> set[str]:
    if handler.type is None:
        return {"BaseException"}
    types = handler.type.elts if isinstance(handler.type, ast.Tuple) else [handler.type]
    return {t.id if isinstance(t, ast.Name) else ast.unparse(t) for t in types}


def _is_text(node: ast.expr) -> bool:
    if isinstance(node, ast.Constant):
        return isinstance(node.value, str)
    if isinstance(node, ast.BinOp):
        return _is_text(node.left) or _is_text(node.right)
    return isinstance(node, ast.JoinedStr)


def _is_system_exit(call: ast.AST) -> bool:
    """``raise SystemExit("...")`` or ``sys.exit("...")``: a message, which exits 1."""
    if not (isinstance(call, ast.Call) and call.args and _is_text(call.args[0])):
        return False
    func = call.func
    return (isinstance(func, ast.Name) and func.id == "SystemExit") or (
        isinstance(func, ast.Attribute) and func.attr == "exit"
        and isinstance(func.value, ast.Name) and func.value.id == "sys")


def _prints(node: ast.AST) -> bool:
    """``print(...)`` or ``sys.stderr.write(...)`` (``sys.stdout`` too)."""
    return isinstance(node, ast.Call) and (
        (isinstance(node.func, ast.Name) and node.func.id == "print")
        or (isinstance(node.func, ast.Attribute) and node.func.attr == "write"
            and ast.unparse(node.func.value) in ("sys.stderr", "sys.stdout")))


def command_offences(source: str, where: str) -> list[str]:
    tree = ast.parse(source, where)
    out: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if _is_system_exit(node):
            out.append((node.lineno, f"{where}:{node.lineno}: exits with a message (exit "
                        "status 1); raise UsageError or the layer's error instead"))
        if isinstance(node, ast.ExceptHandler) and _caught(node) & BROAD:
            body = [n for stmt in node.body for n in ast.walk(stmt)]
            if any(_prints(n) or _is_system_exit(n) for n in body):
                out.append((node.lineno, f"{where}:{node.lineno}: catches "
                            f"{', '.join(sorted(_caught(node)))} to print it; let "
                            "ServolabErrors through (the CLI prints them)"))
    return [text for _, text in sorted(out)]


def test_commands_neither_print_caught_errors_nor_exit_with_a_message() -> None:
    """The argparse type functions of apps/arguments.py catch ValueError from ``float()``
    and raise ArgumentTypeError: that is parsing, and passes."""
    files = [*_sources(PACKAGE / "apps"), PACKAGE / "cli.py"]
    assert [o for path in files
            for o in command_offences(path.read_text(), f"src/servolab/{_relative(path)}")] == []


def test_the_command_checker_sees_both_patterns() -> None:
    source = ("def run(args):\n    try:\n        go()\n    except ValueError as exc:\n"
              "        raise SystemExit(f'servolab x: {exc}') from None\n"
              "def other(args):\n    try:\n        go()\n    except (KeyError, OSError) as exc:\n"
              "        print(exc)\n"
              "def fine(text):\n    try:\n        return float(text)\n    except ValueError:\n"
              "        raise ArgumentTypeError('not a number') from None\n")
    found = command_offences(source, "sample.py")
    assert [o.split(": ", 1)[0].rsplit(":", 1)[1] for o in found] == ["4", "5", "9"]


# -- classes ------------------------------------------------------------------------------------

def _error_classes() -> list[tuple[str, str]]:
    """(module, class name) of every top-level class named ``*Error`` or ``NoPath``."""
    found = []
    for path in _sources():
        parts = list(path.relative_to(SRC).with_suffix("").parts)
        module = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        for node in ast.parse(path.read_text(), str(path)).body:
            if isinstance(node, ast.ClassDef) and (node.name.endswith("Error")
                                                   or node.name == "NoPath"):
                found.append((module, node.name))
    return found


@pytest.mark.slow
def test_every_error_class_is_a_servolab_error() -> None:
    classes = _error_classes()
    assert ("servolab.planning.errors", "NoPath") in classes  # the walk found them
    assert len(classes) > 30
    offences = []
    for module, name in classes:
        cls = getattr(importlib.import_module(module), name)
        if not (isinstance(cls, type) and issubclass(cls, ServolabError)):
            offences.append(f"{module}.{name}")
    assert offences == []


@pytest.mark.parametrize(("layer", "base", "value"), [
    ("dynamixel", "DynamixelError", "ConfigError"),
    ("middleware", "MiddlewareError", "MiddlewareValueError"),
    ("robots", "RobotError", "RobotValueError"),
    ("planning", "PlanningError", "PlanningValueError"),
    ("vision", "VisionError", "VisionValueError"),
    ("kinematics", "KinematicsError", "KinematicsValueError"),
    ("gait", "GaitError", "GaitValueError"),
    ("estimation", "EstimationError", "EstimationValueError"),
    ("sim", "SimError", "SimulationError"),
])
def test_each_layer_has_a_base_and_a_value_error(layer: str, base: str, value: str) -> None:
    """The base is a failure at run time (``servolab`` exits 1), the value error bad input
    (exit 2) that ``except ValueError`` still catches."""
    from servolab.harness import exit_status

    errors = importlib.import_module(f"servolab.{layer}.errors")
    base_cls, value_cls = getattr(errors, base), getattr(errors, value)
    assert issubclass(base_cls, ServolabError) and not issubclass(base_cls, ValueError)
    assert issubclass(value_cls, base_cls) and issubclass(value_cls, ValueError)
    assert exit_status(value_cls("x")) == 2


def test_no_path_is_a_failure_not_bad_input() -> None:
    from servolab.harness import exit_status
    from servolab.planning.errors import NoPath, PlanningError

    assert issubclass(NoPath, PlanningError) and not issubclass(NoPath, ValueError)
    assert exit_status(NoPath("no path")) == 1


def test_a_lookup_by_name_is_a_key_error_shown_as_one_line() -> None:
    from servolab.gait.errors import GaitValueError, UnknownMotorError

    error = UnknownMotorError("no motor 'c' in this motion (a, b)")
    assert isinstance(error, KeyError) and isinstance(error, GaitValueError)
    assert str(error) == "no motor 'c' in this motion (a, b)"  # KeyError's would be quoted
