"""``servolab id``, ``servolab baud`` and raw access by address in ``servolab read`` / ``write``,
run in-process on emulated motors as a user types them: what they print, their one-line
refusals, and that a refusal writes nothing (issue 29)."""

from __future__ import annotations

import errno
from collections.abc import Iterator
from pathlib import Path

import pytest
import serial

from servolab.cli import build_parser, main
from servolab.dynamixel import Bus
from servolab.dynamixel.ports import MemoryPort
from servolab.dynamixel.protocol2 import PROTOCOL2
from tests.clirun import refusal


@pytest.fixture
def wire(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[bytes]]:
    """Every packet any emulated bus sends during the test."""
    packets: list[bytes] = []
    real = MemoryPort.write

    def recording(self: MemoryPort, data: bytes) -> None:
        packets.append(bytes(data))
        real(self, data)

    monkeypatch.setattr(MemoryPort, "write", recording)
    yield packets


def instructions(packets: list[bytes]) -> list[str]:
    return [PROTOCOL2.instruction_name(PROTOCOL2.decode_instruction(p).instruction)
            for p in packets]


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    assert main(argv) == 0
    return capsys.readouterr().out.strip()


X2 = ["--port", "emu://xm430-w350:1,12"]


def test_id_to_a_free_id(capsys: pytest.CaptureFixture[str]) -> None:
    out = run(["id", *X2, "1", "13"], capsys)
    assert out == "motor 1 (XM430-W350) is now ID 13: it answers there at 57600 bps"


def test_id_to_a_used_id_is_refused_and_writes_nothing(
        capsys: pytest.CaptureFixture[str], wire: list[bytes]) -> None:
    status, line = refusal(["id", *X2, "1", "12"], capsys)
    assert status == 2
    assert line.startswith("servolab id: error: ID 12 is taken") and "nothing was written" in line
    assert wire and "WRITE" not in instructions(wire)


def test_write_id_is_the_same_as_servolab_id(capsys: pytest.CaptureFixture[str],
                                             wire: list[bytes]) -> None:
    status, line = refusal(["write", *X2, "--id", "1", "id", "12"], capsys)
    assert status == 2 and "ID 12 is taken" in line
    assert "WRITE" not in instructions(wire)
    out = run(["write", *X2, "--id", "1", "id", "13"], capsys)
    assert out == "motor 1 (XM430-W350) is now ID 13: it answers there at 57600 bps"


@pytest.mark.parametrize(("argv", "said"), [
    (["baud", "--port", "emu://xm430-w350:1", "--id", "1", "1000000"],
     "motor 1 (XM430-W350) now talks at 1000000 bps (baud_rate 3)"),
    (["baud", "--port", "emu://rx28:1", "--baud", "57600", "--id", "1", "1e6"],
     "motor 1 (RX-28) now talks at 1000000 bps (baud_rate 1)"),
    (["write", "--port", "emu://rx28:1", "--id", "1", "baud_rate", "115200"],
     "motor 1 (RX-28) now talks at 117647 bps (baud_rate 16)"),
    (["write", "--port", "emu://xm430-w350:1", "--id", "1", "--raw", "baud_rate", "4"],
     "motor 1 (XM430-W350) now talks at 2000000 bps (baud_rate 4)"),
], ids=["x", "rx28", "write-si", "write-raw"])
def test_baud(argv: list[str], said: str, capsys: pytest.CaptureFixture[str]) -> None:
    out = run(argv, capsys)
    assert out.startswith(said) and "use --baud" in out


def test_baud_the_model_cannot_use(capsys: pytest.CaptureFixture[str],
                                   wire: list[bytes]) -> None:
    status, line = refusal(["baud", "--port", "emu://xm430-w350:1", "--id", "1", "250000"],
                           capsys)
    assert status == 2 and "250000 bps is not a baud rate it can use" in line
    assert "WRITE" not in instructions(wire)


def test_raw_read_by_address(capsys: pytest.CaptureFixture[str]) -> None:
    port = ["--port", "emu://xm430-w350:1", "--id", "1"]
    assert run(["read", *port, "--address", "132", "--size", "4"], capsys) == \
        "address 132, 4 bytes: 00 08 00 00 = 2048 (present_position)"
    # the size of the register there, when not given
    assert run(["read", *port, "--address", "7"], capsys) == "address 7, 1 byte: 01 = 1 (id)"


def test_raw_write_by_address(capsys: pytest.CaptureFixture[str], wire: list[bytes]) -> None:
    out = run(["write", "--port", "emu://xm430-w350:1", "--id", "1", "--address", "116",
               "--size", "4", "0xbb8"], capsys)
    assert out == "motor 1: address 116, 4 bytes <- b8 0b 00 00 (3000) (goal_position)"
    last = PROTOCOL2.decode_instruction(wire[-1])
    assert last.params == bytes((116, 0, 0xB8, 0x0B, 0, 0))


@pytest.mark.parametrize(("argv", "said"), [
    (["read", "--address", "0", "--size", "2000"], "1..1020 bytes"),
    (["read", "--address", "70000", "--size", "1"], "outside protocol 2.0's 0..65535"),
    (["read", "--address", "116", "goal_position"], "not both"),
    (["read", "--size", "4", "goal_position"], "--size goes with --address"),
    (["write", "--address", "116", "--size", "2", "5"], "part of goal_position"),
    (["write", "--address", "116", "--size", "1", "300"], "does not fit 1 byte"),
    (["write", "--address", "116", "--size", "4", "x"], "is not an integer"),
    (["write", "--address", "116", "goal_position", "5"], "with --address give VALUE only"),
    (["read", "--address", "2000"], "--size N is needed"),
    (["read", "presnt_position"], "did you mean present_position"),
    (["write", "goal_position", "99"], "position limits"),
], ids=["size", "address", "both", "size-alone", "partial", "fit", "not-int", "two-words",
        "no-size", "did-you-mean", "limits"])
def test_refusals_are_one_line_and_write_nothing(argv: list[str], said: str,
                                                 capsys: pytest.CaptureFixture[str],
                                                 wire: list[bytes]) -> None:
    status, line = refusal([argv[0], "--port", "emu://xm430-w350:1", "--id", "1", *argv[1:]],
                           capsys)
    assert status == 2 and said in line, line
    assert "WRITE" not in instructions(wire)


def test_eeprom_write_with_torque_on_is_one_line(monkeypatch: pytest.MonkeyPatch,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    """The most asked X-series question (DynamixelSDK issue #306), answered before the
    wire."""
    from servolab.apps import _bus

    def torque_on(device: str, protocol: int | None, baudrate: int, model: str | None,
                  motor_id: int) -> Bus:
        bus = Bus.open(device, protocol=protocol, baudrate=baudrate)
        bus.write(motor_id, "torque_enable", 1)
        return bus

    monkeypatch.setattr(_bus, "open_bus", torque_on)
    for argv in (["write", "--id", "1", "operating_mode", "4"], ["id", "1", "5"],
                 ["baud", "--id", "1", "1000000"]):
        status, line = refusal([argv[0], "--port", "emu://xm430-w350:1", *argv[1:]], capsys)
        assert status == 2 and line.endswith("switch torque off first (torque_enable 0)"), line


def test_permission_denied_says_how_to_join_dialout(monkeypatch: pytest.MonkeyPatch,
                                                   tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    device = tmp_path / "ttyUSB0"
    device.touch()

    def refuse(*args: object, **kwargs: object) -> None:
        raise serial.SerialException(errno.EACCES, f"could not open port {device}: [Errno 13] "
                                     f"Permission denied: '{device}'")

    monkeypatch.setattr(serial, "Serial", refuse)
    status, line = refusal(["id", "--port", str(device), "1", "2"], capsys)
    assert status == 2
    assert line.endswith("join the dialout group (sudo usermod -aG dialout $USER), then log "
                         "out and in again"), line


def test_the_commands_are_listed_and_parse() -> None:
    parser = build_parser()
    args = parser.parse_args(["id", "--port", "/dev/ttyUSB0", "--protocol", "1", "1", "12"])
    assert (args.command, args.old, args.new, args.protocol) == ("id", 1, 12, 1)
    args = parser.parse_args(["baud", "--port", "/dev/ttyUSB0", "--id", "3", "1e6"])
    assert (args.command, args.motor_id, args.rate) == ("baud", 3, 1_000_000)
