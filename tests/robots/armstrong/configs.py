"""Copies of the seed's armstrong.yaml that tests walk with."""

from __future__ import annotations

from pathlib import Path

from servolab.configfile import shipped

SHIPPED_CONFIG = shipped("servolab.robots.armstrong", "armstrong.yaml")
PING_RANGE = "      max_motor_id: 65\n"


def ping_once_config(folder: Path) -> Path:
    """The seed's configuration with each absent ID pinged once rather than five times, as
    ``ping_retries: 1``: the 45 absent IDs' start-up at 57142 bps (8 s on a busy CPU) is not
    what a walk test is about; everything else as shipped."""
    text = SHIPPED_CONFIG.read_text()
    if text.count(PING_RANGE) != 1:
        raise AssertionError(f"{SHIPPED_CONFIG}: expected one {PING_RANGE.strip()!r}")
    path = folder / "armstrong.yaml"
    path.write_text(text.replace(PING_RANGE, PING_RANGE + "      ping_retries: 1\n"))
    return path
