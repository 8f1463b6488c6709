"""The ``servolab`` command as a user types it: sim on a pty in one process, scan / read /
write from others, and one-line errors for bad input that leave the motors untouched."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from servolab.cli import main
from tests.simproc import sim_process

pytestmark = pytest.mark.slow


def servolab(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "servolab", *args], capture_output=True,
                          text=True, timeout=120, stdin=subprocess.DEVNULL)


@pytest.fixture(scope="module")
def rx28_pty(tmp_path_factory: pytest.TempPathFactory):
    out = tmp_path_factory.mktemp("sim")
    link = out / "dxl"
    with sim_process("--motors", "rx28:11-13", "--link", str(link), out_dir=out) as (dev, _):
        yield dev, link


def test_sim_makes_the_link(rx28_pty: tuple[str, Path]) -> None:
    device, link = rx28_pty
    assert link.is_symlink() and str(link.resolve()) == str(Path(device).resolve())


def test_scan_lists_id_model_number_firmware(rx28_pty: tuple[str, Path],
                                             tmp_path: Path) -> None:
    _, link = rx28_pty
    result = servolab("scan", "--port", str(link), "--protocol", "1", "--baud", "57600",
                      "1000000", "--ids", "9-14", "--out", str(tmp_path))
    assert result.returncode == 0, result.stderr
    rows = [line.split() for line in result.stdout.splitlines()[1:-1]]
    assert result.stdout.splitlines()[-1] == "3 motor(s) found"
    assert [r[0] for r in rows] == ["11", "12", "13"]
    for row in rows:
        assert row[1:4] == ["RX-28", "28", "30"]
        assert row[5] == "57600"  # found at the pty speed within tolerance of 57142
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert [m["id"] for m in summary["found"]] == [11, 12, 13]
    assert summary["command"] == "scan"


def test_read_and_write_in_si_units(rx28_pty: tuple[str, Path]) -> None:
    _, link = rx28_pty
    common = ["--port", str(link), "--protocol", "1", "--id", "12"]
    result = servolab("write", *common, "goal_position", "0.5")
    assert result.returncode == 0, result.stderr
    # 0.5 rad on an RX-28 (300 deg over 1023 ticks, 512 = 0 rad) is raw 512 + 97.7 -> 610.
    assert "raw 610" in result.stdout
    result = servolab("read", *common, "goal_position", "--raw")
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "goal_position = 610"
    result = servolab("read", *common, "present_voltage", "goal_position")
    lines = result.stdout.splitlines()
    assert lines[0].startswith("present_voltage = 12") and lines[0].endswith("V (raw 120)")
    value = float(lines[1].split("=")[1].split()[0])
    assert value == pytest.approx(0.5, abs=0.005)


@pytest.mark.parametrize(("args", "named"), [
    (["write", "--id", "12", "goal_positoin", "0.1"], "goal_positoin"),
    (["write", "--id", "12", "goal_position", "9"], "goal_position: 9 rad is outside"),
    (["write", "--id", "12", "goal_position", "abc"], "'abc' is not a number"),
    (["write", "--id", "12", "present_position", "0.1"], "read-only"),
    (["write", "--id", "254", "goal_position", "0.1"], "motor ID 254"),
    (["write", "--id", "12", "--raw", "goal_position", "1.5"], "not an integer"),
])
def test_bad_write_is_one_line_and_writes_nothing(rx28_pty: tuple[str, Path],
                                                  args: list[str], named: str) -> None:
    _, link = rx28_pty
    common = ["--port", str(link), "--protocol", "1"]
    before = servolab("read", *common, "--id", "12", "--raw", "goal_position").stdout
    result = servolab(args[0], *common, *args[1:])
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and named in lines[0], result.stderr
    after = servolab("read", *common, "--id", "12", "--raw", "goal_position").stdout
    assert before == after


def test_unknown_model_in_sim_spec(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "--pty", "--motors", "rx29:1-3", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown Dynamixel model 'rx29'" in err[0]


def test_port_that_does_not_exist(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["read", "--port", "/dev/ttyNOPE9", "--id", "1", "present_position"])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "/dev/ttyNOPE9" in err[0] and "does not exist" in err[0]


def test_yaml_spec_errors_name_file_line_field(tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    spec = tmp_path / "bus.yaml"
    spec.write_text("motors:\n  - {model: rx28, ids: 1-3}\n  - {model: rx28, id: x1}\n")
    assert main(["sim", "--pty", "--motors", str(spec), "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert f"{spec}:3: id: 'x1' is not a int" in err


def test_demo_runs_and_leaves_a_run_folder(tmp_path: Path) -> None:
    result = servolab("demo", "--out", str(tmp_path / "run"))
    assert result.returncode == 0, result.stderr
    assert "found ID 16: RX-28" in result.stdout
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["rx28"]["motors_found"] == [11, 12, 13, 14, 15, 16]
    assert summary["rx28"]["final_position_rad"] == pytest.approx(0.8, abs=0.006)
    assert (tmp_path / "run" / "demo_motion.png").stat().st_size > 10_000


def test_duplicate_ids_in_a_spec_are_refused(tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "--pty", "--motors", "rx28:1-3,2", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "motor ID 2 is listed twice" in err[0]
