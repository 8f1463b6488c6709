"""Lets the tests import servolab from src/ while the package is not installed yet."""

import sys
from pathlib import Path

try:
    import servolab  # noqa: F401
except ImportError:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))
