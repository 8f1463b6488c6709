"""``--view`` and ``servolab view`` refuse what they cannot do, in one line, before a run folder
is made or anything moves."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.clirun import refusal


@pytest.mark.parametrize(("args", "words"), [
    (["walk", "--view-speed", "2"], "--view-speed goes with --view"),
    (["navigate", "--goal", "1", "1", "--view-speed", "2"], "--view-speed goes with --view"),
    (["walk", "--view", "1", "--view-speed", "0.001"], "must be 0.01 to 100"),
    (["walk", "--view", "70000"], "'70000' is not a TCP port"),
    (["launch", "--view", "talk.launch.yaml"], "put it after the other arguments"),
    (["view", "--loop"], "--rate and --loop go with BAG"),
    (["view", "--rate", "2"], "--rate and --loop go with BAG"),
    (["view", "run_bag", "--connect", "tcp/127.0.0.1:1"], "--listen and --connect go without"),
    (["view", "--ws-port", "-1"], "'-1' is not a TCP port"),
    (["view", "--rate", "-1", "run_bag"], "must be a number >= 0"),
    (["view", "--ws-allow-origin", "https://lab.example/app"], "an origin has no path"),
    (["view", "--ws-allow-origin", "lab.example"], "is not an origin"),
    (["view", "--ws-token", "short"], "at least 8 characters"),
    (["view", "--max-qos-depth", "0"], "must be 1 or more"),
    (["view", "--min-qos-depth", "30"], "--min-qos-depth 30 is more than --max-qos-depth 25"),
    (["walk", "--ws-read-only"], "--ws-read-only goes with --view"),
    (["walk", "--ws-allow-origin", "https://lab.example"], "--ws-allow-origin goes with --view"),
])
def test_a_bad_view_option_is_refused_before_anything_runs(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str],
        words: str) -> None:
    out = tmp_path / "run"
    status, line = refusal([*args, "--out", str(out)] if args[0] in ("walk", "navigate")
                           else args, capsys)
    assert status == 2
    assert words in line
    assert not out.exists()  # refused before the run folder


def test_a_missing_bag_is_named(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "nope_bag"
    status, line = refusal(["view", str(missing), "--ws-port", "0"], capsys)
    assert status != 0
    assert str(missing) in line
