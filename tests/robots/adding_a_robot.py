"""docs/layout.md's "Adding a robot", read for the tests: the files it shows (each fenced block
after a ``<!-- file: PATH -->`` line), and its other blocks in order, so that the tests run the
page a student copies from rather than a copy of it."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from tests.docblocks import ROOT

PAGE = ROOT / "docs" / "layout.md"
SECTION = "## Adding a robot"

_FENCE = re.compile(r"^```(\w*)\s*$")
_FILE = re.compile(r"^<!--\s*file:\s*(\S+)\s*-->\s*$")
_FRAGMENT = re.compile(r"^<!--\s*fragment\b.*-->\s*$")


@dataclass(frozen=True)
class Block:
    """A fenced block of the section: its line in the page, language, text, the file it is
    (None for an example) and whether it is a fragment that cannot run alone."""

    line: int
    language: str
    source: str
    file: str | None
    fragment: bool

    @property
    def where(self) -> str:
        return f"docs/layout.md:{self.line}"


def blocks() -> list[Block]:
    lines = PAGE.read_text().splitlines()
    start = lines.index(SECTION)
    end = next(i for i in range(start + 1, len(lines)) if lines[i].startswith("## "))
    found: list[Block] = []
    i = start
    while i < end:
        fence = _FENCE.match(lines[i])
        if fence is None:
            i += 1
            continue
        close = next(j for j in range(i + 1, end) if lines[j].strip() == "```")
        before = lines[i - 1] if i > 0 else ""
        marked = _FILE.match(before)
        found.append(Block(i + 1, fence.group(1), "\n".join(lines[i + 1:close]) + "\n",
                           marked.group(1) if marked else None,
                           _FRAGMENT.match(before) is not None))
        i = close + 1
    return found


def write_files(folder: Path, prefix: str = "") -> dict[str, Path]:
    """Write every file of the section whose path starts with ``prefix`` under ``folder``."""
    written: dict[str, Path] = {}
    for block in blocks():
        if block.file is not None and block.file.startswith(prefix):
            path = folder / block.file
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(block.source)
            written[block.file] = path
    return written


def examples(language: str) -> list[Block]:
    """The section's runnable examples in ``language`` (not files, not fragments), in order."""
    return [b for b in blocks() if b.language == language and b.file is None
            and not b.fragment]


def commands(block: Block) -> list[str]:
    """The command lines of a shell block, comments dropped."""
    return [line.split("#")[0].strip() for line in block.source.splitlines()
            if line.split("#")[0].strip()]
