"""``servolab scan`` in seconds and ``servolab write --broadcast``, run in-process as a user
types them, on an emulated bus that mixes Protocol 1.0 and 2.0 motors at both factory rates
(``tests.mixedbus``, on a virtual clock: every byte takes its wire time, no wall time passes).
The times asserted are simulated, from the run's summary."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from servolab.cli import build_parser, main
from tests.clirun import refusal, servolab
from tests.mixedbus import mixed_bus, use_mixed_scheme


def rows(out: str) -> set[tuple[int, str, str, int]]:
    """(ID, model, protocol, baud) of each motor the table lists."""
    lines = out.strip().splitlines()
    assert lines[0].split() == ["ID", "model", "number", "firmware", "protocol", "baud"]
    assert lines[-1] == f"{len(lines) - 2} motor(s) found"
    return {(int(r[0]), r[1], r[4], int(r[5])) for r in (line.split() for line in lines[1:-1])}


def summary(folder: Path) -> dict[str, object]:
    return json.loads((folder / "summary.json").read_text())  # type: ignore[no-any-return]


def test_scan_with_no_options_finds_both_protocols_at_both_factory_rates(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
        tmp_path: Path) -> None:
    bus = mixed_bus()
    url = use_mixed_scheme(monkeypatch, bus)
    assert main(["scan", "--port", url, "--out", str(tmp_path)]) == 0
    out, err = capsys.readouterr()
    assert rows(out) == {(i, name, f"{v}.0", baud) for i, name, v, baud in bus.found()}
    said = err.splitlines()
    # how long it takes, said before it starts
    assert said[0].startswith("scanning at 57600 and 1000000 bps, protocol 2.0 and 1.0, "
                              "every ID: this takes about ")
    assert re.fullmatch(r"scanning protocol 2\.0 and 1\.0 at 57600 bps \(about \d\.\d s\) \.\.\.",
                        said[1]), said[1]
    figures = summary(tmp_path)
    assert figures["plan"] == [{"baudrate": 57600, "protocols": [2, 1]},
                               {"baudrate": 1_000_000, "protocols": [2, 1]}]
    took, estimate = figures["scan_s"], figures["estimate_s"]
    assert isinstance(took, float) and isinstance(estimate, float)
    assert took < 10.0 and took == pytest.approx(estimate, rel=0.05)
    sides = bus.emulator.sides
    assert (sides[2].instructions_seen, sides[1].instructions_seen) == (2, 2 * 254 + 4)


def test_every_baud_given_is_scanned(monkeypatch: pytest.MonkeyPatch,
                                     capsys: pytest.CaptureFixture[str],
                                     tmp_path: Path) -> None:
    """``--baud 57600 --baud 1000000`` scans both (argparse's append used to keep the
    last), as does ``--baud 57600 1000000``."""
    args = build_parser().parse_args(["scan", "--port", "P", "--baud", "57600", "--baud",
                                      "1e6"])
    assert args.baud == [57600, 1_000_000]
    assert build_parser().parse_args(["scan", "--port", "P", "--baud", "57600",
                                      "1000000"]).baud == [57600, 1_000_000]
    url = use_mixed_scheme(monkeypatch, mixed_bus())
    assert main(["scan", "--port", url, "--protocol", "1", "--baud", "57600", "--baud",
                 "1000000", "--out", str(tmp_path)]) == 0
    found = rows(capsys.readouterr().out)
    assert found == {(11, "RX-28", "1.0", 57600), (12, "RX-28", "1.0", 57600),
                     (30, "MX-28", "1.0", 57600), (21, "AX-12A", "1.0", 1_000_000)}


def test_a_sweep_of_every_baud_rate_says_first_how_long_it_takes(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
        tmp_path: Path) -> None:
    bus = mixed_bus((("XM430-W210", 1), ("RX-28", 2)))
    bus.emulator.motor(1).set_raw("baud_rate", 4)      # 2 Mbps
    url = use_mixed_scheme(monkeypatch, bus)
    assert main(["scan", "--port", url, "--all-bauds", "--ids", "0-5",
                 "--out", str(tmp_path)]) == 0
    out, err = capsys.readouterr()
    assert rows(out) == {(1, "XM430-W210", "2.0", 2_000_000), (2, "RX-28", "1.0", 57600)}
    first = err.splitlines()[0]
    figures = summary(tmp_path)
    estimate = figures["estimate_s"]
    assert first == (f"sweeping every baud rate the models take (16 rates, 9600 to 4500000 "
                     f"bps), protocol 2.0 and 1.0, IDs 0-5: this takes about "
                     f"{estimate:.1f} s")
    plan = figures["plan"]
    assert isinstance(plan, list)
    # 1.0 only where a 1.0 model runs (not at 4 Mbps), 2.0 likewise (not at 19200 bps)
    assert {"baudrate": 4_000_000, "protocols": [2]} in plan
    assert {"baudrate": 19_200, "protocols": [1]} in plan
    took = figures["scan_s"]
    assert isinstance(took, float) and took == pytest.approx(estimate, rel=0.05)


def test_all_bauds_and_baud_do_not_go_together(capsys: pytest.CaptureFixture[str]) -> None:
    status, line = refusal(["scan", "--port", "P", "--all-bauds", "--baud", "57600"], capsys)
    assert status == 2 and "not allowed with argument" in line


def test_write_broadcast_reaches_every_motor_at_the_rate_and_protocol(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    bus = mixed_bus()
    url = use_mixed_scheme(monkeypatch, bus)
    assert main(["write", "--port", url, "--protocol", "2", "--baud", "57600", "--broadcast",
                 "led", "on"]) == 0
    out = capsys.readouterr().out.strip()
    assert out == ("every motor (broadcast ID 254, protocol 2.0, 57600 bps): led <- on; "
                   "checked for the 3 motor(s) found, 1, 2, 3 (XL430-W250, XM430-W210); no "
                   "status is expected")
    lit = {m.id for m in bus.emulator.motors if m.get_raw("led")}
    assert lit == {1, 2, 3}          # not the XL-320 at 1 Mbps, nor the 1.0 motors


def test_write_broadcast_refuses_what_the_tables_disagree_on(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    bus = mixed_bus()
    url = use_mixed_scheme(monkeypatch, bus)
    before = {m.id: m.get_raw("goal_position") for m in bus.emulator.motors}
    status, line = refusal(["write", "--port", url, "--protocol", "1", "--broadcast",
                            "goal_position", "0.5"], capsys)
    assert status == 2 and "the motors' tables disagree" in line
    assert "RX-28 (motors 11, 12)" in line and "MX-28 (motor 30)" in line
    assert {m.id: m.get_raw("goal_position") for m in bus.emulator.motors} == before


def test_write_to_id_254_points_at_broadcast(capsys: pytest.CaptureFixture[str]) -> None:
    status, line = refusal(["write", "--port", "emu://rx28:1", "--id", "254", "led", "1"],
                           capsys)
    assert status == 2
    assert line.endswith("motor ID 254 is the broadcast ID: to write every motor at once, "
                         "give --broadcast instead of --id 254")


@pytest.mark.slow
def test_servolab_sim_serves_a_mixed_bus_that_scan_finds_at_wire_speed(tmp_path: Path) -> None:
    """A motor spec of both protocols is one mixed bus (each motor parses the line in its own
    protocol, as under DynamixelSDK's protocol_combined example); `servolab sim --pty` serves
    it in real time and `servolab scan` with no options finds every motor, each in its own
    protocol, in a separate process, through the pty."""

    from tests.simproc import sim_process

    spec = "xm430-w210:1-2;xl430-w250:3;rx28:11-12;ax12a:21"
    with sim_process("--motors", spec, "--baud", "1000000", out_dir=tmp_path / "sim") as (
            device, _):
        done = servolab("scan", "--port", device, "--out", str(tmp_path / "scan"), timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert rows(done.stdout) == {(1, "XM430-W210", "2.0", 1_000_000),
                                 (2, "XM430-W210", "2.0", 1_000_000),
                                 (3, "XL430-W250", "2.0", 1_000_000),
                                 (11, "RX-28", "1.0", 1_000_000),
                                 (12, "RX-28", "1.0", 1_000_000),
                                 (21, "AX-12A", "1.0", 1_000_000)}
    assert "this takes about" in done.stderr  # said before it started
