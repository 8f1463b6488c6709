"""Every example in README.md and docs/*.md (docs/layout.md aside) runs or parses.

- Each ```python block runs, in a fresh namespace and a temporary working directory. A block
  that cannot run alone is marked ``<!-- fragment -->`` on the line before its fence, and is
  only compiled.
- Each ``servolab ...`` command of a ```bash block, and each ``$ servolab ...`` of a
  ```console block, parses with servolab's own parser: the command is registered and its
  options and their values fit. Parsing opens no port, so commands naming a serial device
  parse as they are.
- Each ``servolab ...`` in inline code names a registered command and options it has.
- Each file of the repository, image and servolab module or name the docs write exists.

The Markdown is read by :mod:`tests.docblocks`; each test's id is the block's ``file:line``.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import re
import traceback
from pathlib import Path

import pytest

from servolab.cli import build_parser
from tests.docblocks import (
    DOCS,
    ROOT,
    Block,
    Command,
    code_blocks,
    command_lines,
    inline_code,
    servolab_words,
)

PYTHON = [b for b in code_blocks() if b.language == "python"]
RUNNABLE = [b for b in PYTHON if not b.fragment]
FRAGMENTS = [b for b in PYTHON if b.fragment]
COMMANDS = [c for b in code_blocks() if b.language in ("bash", "console")
            for c in command_lines(b)]


def test_the_docs_have_examples() -> None:
    """The extraction finds the blocks (a changed fence syntax would silently run nothing)."""
    assert len(DOCS) >= 9, DOCS
    assert len(RUNNABLE) >= 10, [b.where for b in RUNNABLE]
    assert len(COMMANDS) >= 40, len(COMMANDS)
    for block in code_blocks():
        # a block without a language would be neither run nor parsed: say what it is
        # (python, bash, console, yaml, text)
        assert block.language, f"{block.where}: a fence without a language"
        # a marked fragment is a Python block, and says it is one right above its fence
        if block.fragment:
            assert block.language == "python", f"{block.where}: only Python blocks are run"


@pytest.mark.slow
@pytest.mark.parametrize("block", RUNNABLE, ids=lambda b: b.where)
def test_python_block_runs(block: Block, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
                           ) -> None:
    """The block runs by itself, in a fresh namespace, in an empty working directory; a
    traceback points at the doc's own lines."""
    monkeypatch.chdir(tmp_path)
    code = compile(block.padded_source, str(block.path), "exec")
    try:
        exec(code, {"__name__": "__main__"})
    except Exception as exc:
        frames = [f for f in traceback.extract_tb(exc.__traceback__)
                  if f.filename == str(block.path)]
        where = f"{block.rel}:{frames[-1].lineno}" if frames else block.where
        pytest.fail(f"{block.where}: the example fails at {where}: "
                    f"{type(exc).__name__}: {exc}", pytrace=False)


def test_python_fragments_compile() -> None:
    """A block marked as a fragment does not run, but is Python all the same."""
    for block in FRAGMENTS:
        compile(block.padded_source, str(block.path), "exec")


@pytest.mark.parametrize("command", COMMANDS, ids=lambda c: c.where)
def test_shell_command_parses(command: Command, capsys: pytest.CaptureFixture[str]
                              ) -> None:
    """``servolab ...`` of a shell block parses: the command, its options, their values."""
    try:
        args = build_parser().parse_args(command.argv)
    except SystemExit:
        error = capsys.readouterr().err.strip().splitlines()
        pytest.fail(f"{command.where}: {command.text!r} does not parse: "
                    f"{error[-1] if error else '?'}", pytrace=False)
    if args.command == "robots" and getattr(args, "action", None) == "show":
        from servolab.robots.registry import shipped_files

        assert args.name in shipped_files(), \
            f"{command.where}: no shipped file or robot description {args.name}"


def _options(parser: argparse.ArgumentParser) -> set[str]:
    """Every option string of ``parser`` and of its subcommands, at any depth."""
    found = set(parser._option_string_actions)
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                found |= _options(sub)
    return found


def _commands() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    raise AssertionError("servolab has no subcommands")


def test_inline_commands_exist() -> None:
    """``servolab COMMAND --option`` in the docs' text: the command and its options exist."""
    commands = _commands()
    wrong = []
    for where, words in servolab_words():
        name = words[1] if len(words) > 1 else ""
        if name not in commands:
            wrong.append(f"{where}: no command 'servolab {name}'")
            continue
        known = _options(commands[name])
        wrong += [f"{where}: 'servolab {name}' has no option {w}" for w in words[2:]
                  if w.startswith("--") and w.split("=")[0] not in known]
    assert not wrong, "\n".join(wrong)


_PATH = re.compile(r"(?<![\w./-])((?:src|tests|configs|benchmarks|docs)/[\w./-]*\w)")
_IMAGE = re.compile(r"!\[[^\]]*\]\(([^)]+)\)")
_MODULE = re.compile(r"^(servolab(?:\.\w+)+)(?:\(\))?$")
_IMPORT = re.compile(r"^from (servolab[\w.]*) import ([\w, ]+)$")


def _imported(names: str) -> list[str]:
    """``A, B as b`` -> ``["A", "B"]``."""
    return [n.split(" as ")[0].strip() for n in names.split(",")]


def _resolve(dotted: str) -> bool:
    """``servolab.a.b.Name.attr``: the longest prefix that imports, then attributes."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            thing = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for name in parts[cut:]:
            if not hasattr(thing, name):
                return False
            thing = getattr(thing, name)
        return True
    return False


def test_named_files_and_modules_exist() -> None:
    """Paths of the repository (``tests/...``, ``configs/...``), paths under
    ``src/servolab`` written from there (``sim/floor.py``), file names (``bus.py``), images,
    and servolab's modules and names (``servolab.robots.base.node.BaseNode``) in the docs."""
    sources = [p for top in ("src", "tests", "benchmarks") for p in (ROOT / top).rglob("*")
               if p.suffix in (".py", ".yaml")]
    names = {p.name for p in sources}
    wrong = []
    for path in DOCS:
        text = path.read_text()
        rel = path.relative_to(ROOT)
        wrong += [f"{rel}: image {m} is missing" for m in _IMAGE.findall(text)
                  if not (path.parent / m).exists()]
        for where, span in inline_code(path):
            for word in span.split():
                word = word.strip(",;:()")
                if "..." in word or "*" in word or "<" in word:
                    continue
                if _PATH.fullmatch(word):
                    if not (ROOT / word).exists():
                        wrong.append(f"{where}: {word} does not exist")
                elif (re.fullmatch(r"[\w/]+/\w+\.(py|yaml)", word)
                      and (ROOT / "src" / "servolab" / word.split("/")[0]).is_dir()):
                    if not (ROOT / "src" / "servolab" / word).exists():
                        wrong.append(f"{where}: src/servolab/{word} does not exist")
                elif re.fullmatch(r"\w+\.py", word) and word not in names:
                    wrong.append(f"{where}: no file {word} in src/, tests/ or benchmarks/")
            module = _MODULE.match(span)
            if module and not _resolve(module.group(1)):
                wrong.append(f"{where}: {module.group(1)} does not exist")
            imported = _IMPORT.match(span)
            if imported:
                for name in _imported(imported.group(2)):
                    if not _resolve(f"{imported.group(1)}.{name}"):
                        wrong.append(f"{where}: {span!r}: no {name}")
    assert not wrong, "\n".join(wrong)


def test_python_blocks_import_what_exists() -> None:
    """A fragment's imports are still checked: every ``from servolab... import X`` of every
    Python block names something that exists."""
    wrong = []
    for block in PYTHON:
        for number, line in enumerate(block.source.splitlines(), block.line + 1):
            imported = _IMPORT.match(line.split("#")[0].strip())
            if not imported:
                continue
            for name in _imported(imported.group(2)):
                with contextlib.suppress(Exception):
                    if _resolve(f"{imported.group(1)}.{name}"):
                        continue
                wrong.append(f"{block.rel}:{number}: no {imported.group(1)}.{name}")
    assert not wrong, "\n".join(wrong)
