"""The examples of README.md and docs/*.md, read from the Markdown for the docs' tests.

A fenced block is ```` ```LANGUAGE ```` ... ```` ``` ````; a Python block that cannot run by
itself has ``<!-- fragment -->`` (or ``<!-- fragment: why -->``) on the line before its
fence. docs/layout.md is left out: it describes the package for contributors and is tested
with the package.
"""

from __future__ import annotations

import re
import shlex
from collections.abc import Iterator
from dataclasses import dataclass
from functools import cache
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: the documents whose examples are tested
DOCS: tuple[Path, ...] = (ROOT / "README.md", *sorted(
    p for p in (ROOT / "docs").glob("*.md") if p.name != "layout.md"))

_FENCE = re.compile(r"^\s*```(\w*)\s*$")
_FRAGMENT = re.compile(r"^\s*<!--\s*fragment\b.*-->\s*$")
#: shell operators that end a command: what follows is another program or a file
_OPERATORS = {"|", "||", "&", "&&", ";", ">", ">>", "<", "2>", "2>&1"}


@dataclass(frozen=True)
class Block:
    """A fenced block: its file, the line of its opening fence (1-based), language, text."""

    path: Path
    line: int
    language: str
    source: str
    fragment: bool

    @property
    def rel(self) -> str:
        return self.path.relative_to(ROOT).as_posix()

    @property
    def where(self) -> str:
        return f"{self.rel}:{self.line}"

    @property
    def padded_source(self) -> str:
        """The source with blank lines before it, so that its line numbers are the doc's."""
        return "\n" * self.line + self.source


@dataclass(frozen=True)
class Command:
    """One ``servolab ...`` command of a shell block: where, as written, and its arguments."""

    where: str
    text: str
    argv: list[str]


@cache
def code_blocks() -> tuple[Block, ...]:
    """Every fenced block of :data:`DOCS`, in order."""
    blocks: list[Block] = []
    for path in DOCS:
        lines = path.read_text().splitlines()
        i = 0
        while i < len(lines):
            opening = _FENCE.match(lines[i])
            if opening is None:
                i += 1
                continue
            end = i + 1
            while end < len(lines) and _FENCE.match(lines[end]) is None:
                end += 1
            if end == len(lines):
                raise ValueError(f"{path}:{i + 1}: a fence that is never closed")
            fragment = i > 0 and _FRAGMENT.match(lines[i - 1]) is not None
            blocks.append(Block(path, i + 1, opening.group(1), "\n".join(lines[i + 1:end]),
                                fragment))
            i = end + 1
    return tuple(blocks)


def _words(text: str) -> list[str]:
    """A shell line's words, up to its first operator (``>``, ``|``, ``&``) or comment."""
    lexer = shlex.shlex(text, posix=True, punctuation_chars=True)
    lexer.whitespace_split = True
    words = []
    for word in lexer:
        if word in _OPERATORS or set(word) <= set("();<>|&"):
            break
        words.append(word)
    return words


def command_lines(block: Block) -> Iterator[Command]:
    """The ``servolab`` commands of a ```bash block (every line that runs ``servolab``) or
    a ```console block (the lines after a ``$`` prompt); ``\\`` continues a line."""
    lines = block.source.splitlines()
    i = 0
    while i < len(lines):
        number, text = block.line + 1 + i, lines[i].strip()
        while text.endswith("\\") and i + 1 < len(lines):
            i += 1
            text = text[:-1] + " " + lines[i].strip()
        i += 1
        if block.language == "console":
            if not text.startswith("$ "):
                continue
            text = text[2:]
        words = _words(text)
        if words and Path(words[0]).name == "servolab":
            yield Command(f"{block.rel}:{number}", text, words[1:])


def inline_code(path: Path) -> Iterator[tuple[str, str]]:
    """``(file:line, span)`` for each inline code span outside the fenced blocks; a span may
    run over a line break, as the docs wrap them."""
    text = path.read_text()
    rel = path.relative_to(ROOT).as_posix()
    fenced = {n for b in code_blocks() if b.path == path
              for n in range(b.line, b.line + b.source.count("\n") + 3)}
    lines = text.splitlines()
    prose = "\n".join("" if n + 1 in fenced else line for n, line in enumerate(lines))
    for match in re.finditer(r"(?<!`)`([^`]+)`(?!`)", prose):
        line = prose.count("\n", 0, match.start()) + 1
        yield f"{rel}:{line}", " ".join(match.group(1).split())


def servolab_words() -> Iterator[tuple[str, list[str]]]:
    """Each ``servolab ...`` of the docs that is not a command to run as it is: an inline
    span, or a line of a ```text block (a synopsis such as ``servolab scan --port PORT
    [--ids A-B]``); as words, placeholders kept."""
    for path in DOCS:
        for where, span in inline_code(path):
            if span.startswith("servolab "):
                yield where, span.split()
    for block in code_blocks():
        if block.language == "text":
            for number, line in enumerate(block.source.splitlines(), block.line + 1):
                if line.startswith("servolab "):
                    words = [w.strip("[]") for w in line.split() if w != "..."]
                    yield f"{block.rel}:{number}", words


def prose(path: Path) -> str:
    """The doc's text with every run of white space (line breaks too) made one space, as a
    number and its words are searched in it."""
    return " ".join(path.read_text().split())
