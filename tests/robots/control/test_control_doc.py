"""docs/control.md's robot is the one the tests run: its URDF and controllers blocks are
tests/robots/control/data's files (test_control_cli.py runs that robot through every step the
page shows, over a pty at 1 Mbps), so a student who copies the page gets a robot that works."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import yaml

from tests.docblocks import ROOT, code_blocks

from .conftest import CONTROLLERS, TWO_JOINT

DOC = ROOT / "docs" / "control.md"


def _blocks(language: str) -> list[str]:
    return [b.source for b in code_blocks() if b.path == DOC and b.language == language]


def _canonical(text: str) -> str:
    return ET.canonicalize(text.split("?>", 1)[-1], strip_text=True)


def test_the_pages_urdf_is_the_tested_one() -> None:
    (urdf,) = _blocks("xml")
    assert _canonical(urdf) == _canonical(TWO_JOINT.read_text())


def test_the_pages_controllers_file_is_the_tested_one() -> None:
    (controllers,) = _blocks("yaml")
    assert yaml.safe_load(controllers) == yaml.safe_load(CONTROLLERS.read_text())
