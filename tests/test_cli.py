"""The ``servolab`` command as a user types it: sim on a pty in one process, scan / read /
write from others, and one-line errors for bad input that leave the motors untouched."""

from __future__ import annotations

import argparse
import importlib
import json
import pkgutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from servolab import apps, cli
from servolab.apps.registry import GROUPS, Command, commands
from servolab.cli import build_parser, main
from servolab.dynamixel.errors import ConfigError, MotorError, NoResponse
from servolab.errors import ConfigFileError
from servolab.harness import StopSignal
from servolab.middleware.errors import MessageError, ServiceError
from tests.clirun import servolab
from tests.simproc import sim_process

pytestmark = pytest.mark.slow


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
    # the emulated RX-28 runs at its e-Manual rating voltage, 18.5 V
    assert lines[0] == "present_voltage = 18.5 V (raw 185)"
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
    # each robot command brought its robot to the tour (Command.demo), and its run finished
    assert summary["walk"]["rows_played"] > 0
    assert summary["drive"]["measured"] and summary["flyball"]["frames"] > 0
    assert summary["navigate"]["status"] == "SUCCEEDED"
    for name in ("walk", "drive", "navigate", "flyball"):
        assert Path(summary[name]["plot"]).is_file()


def test_duplicate_ids_in_a_spec_are_refused(tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "--pty", "--motors", "rx28:1-3,2", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "motor ID 2 is listed twice" in err[0]


# -- the command registry ---------------------------------------------------------------------


def test_help_lists_every_command_under_its_group_in_group_order(
        capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_:
        main(["--help"])
    assert exit_.value.code == 0
    lines = capsys.readouterr().out.splitlines()
    headings = [lines.index(f"{g.title}:") for g in GROUPS]
    assert headings == sorted(headings)
    for group, start, end in zip(GROUPS, headings, [*headings[1:], len(lines)], strict=True):
        listed = [line.split()[0] for line in lines[start + 1:end]
                  if line.startswith("  ") and not line.startswith("  (")]
        registered = [c.name for c in commands() if c.group == group.name]
        assert listed == registered, group.name
        helps = {c.name: c.help for c in commands()}
        for line in lines[start + 1:start + 1 + len(listed)]:
            name = line.split()[0]
            assert line.split(None, 1)[1] == helps[name]
        if not registered:
            assert lines[start + 1] == "  (none yet)"
    assert {"sim", "scan", "read", "write", "topic", "param", "bag", "launch", "demo"} <= {
        c.name for c in commands()}


def test_every_command_module_registers_one_command() -> None:
    """Each module of servolab.apps is a command, a ``_`` helper, or one of the two shared
    modules: a command module that forgot its COMMAND would otherwise vanish silently."""
    helpers = {"registry", "arguments"}
    names = []
    for info in pkgutil.iter_modules(apps.__path__):
        if info.name.startswith("_") or info.name in helpers:
            continue
        command = importlib.import_module(f"servolab.apps.{info.name}").COMMAND
        assert isinstance(command, Command) and callable(command.run)
        assert callable(command.add_arguments) and command.help, info.name
        names.append(command.name)
    assert len(names) == len(set(names))
    assert sorted(names) == sorted(c.name for c in commands())


@pytest.mark.parametrize("name", [c.name for c in commands()])
def test_each_commands_help_works(name: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_:
        main([name, "--help"])
    assert exit_.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith(f"usage: servolab {name} ")
    if "--port PORT" in out:  # every --port takes emulated buses too
        assert "emu://MODEL:IDS" in out


def test_two_modules_with_one_name_are_refused(tmp_path: Path,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    package = tmp_path / "twice"
    package.mkdir()
    (package / "__init__.py").write_text("")
    for module in ("one", "two"):
        (package / f"{module}.py").write_text(
            "from servolab.apps.registry import Command\n"
            "COMMAND = Command(name='walk', group='robots', help='walk',\n"
            "                  add_arguments=lambda p: None, run=lambda a: 0)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(RuntimeError, match=r"'walk' is defined twice: in twice\.one and "
                       r"twice\.two"):
        commands("twice")


def test_a_group_that_does_not_exist_is_refused() -> None:
    with pytest.raises(ValueError, match="group 'robot' is not one of bus, graph, robots"):
        Command(name="walk", group="robot", help="walk", add_arguments=lambda p: None,
                run=lambda a: 0)


def test_unknown_command_is_argparse_error(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_:
        main(["wlak"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert "servolab: error: argument COMMAND: invalid choice: 'wlak'" in err


def test_help_imports_no_command_body() -> None:
    """``servolab --help`` stays fast: the registry imports the command modules, which leave
    the Dynamixel layer, the middleware, Zenoh and matplotlib to their run functions (only
    the middleware's errors, the transports' names and the view's defaults, constants the
    options show, are read;
    the view package's ``__init__`` is lazy)."""
    code = ("import sys\nfrom servolab.cli import main\ntry:\n    main(['--help'])\n"
            "except SystemExit:\n    pass\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('zenoh', 'matplotlib',"
            " 'websockets') or m.startswith(('servolab.dynamixel', 'servolab.middleware.'))"
            " and m not in ('servolab.middleware.errors', 'servolab.middleware.transports',"
            " 'servolab.middleware.view',"
            " 'servolab.middleware.view.defaults')))")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            timeout=60)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines()[-1] == "[]"


def test_protocol_of_read_and_write_defaults_to_the_ports() -> None:
    parser = build_parser()
    args = parser.parse_args(["read", "--port", "emu://rx28:1-3", "--id", "1", "present_position"])
    assert args.protocol is None and args.port == "emu://rx28:1-3"
    args = parser.parse_args(["write", "--port", "/dev/ttyUSB0", "--protocol", "1.0", "--id",
                              "1", "led", "on"])
    assert args.protocol == 1


def _failing(exc: BaseException) -> Command:
    def add_arguments(p: argparse.ArgumentParser) -> None:
        p.add_subparsers(dest="action", required=True).add_parser("go")

    def run(args: argparse.Namespace) -> int:
        raise exc

    return Command(name="fail", group="tools", help="raises", add_arguments=add_arguments,
                   run=run)


@pytest.mark.parametrize(("exc", "status", "line"), [
    (ConfigError("goal_position: 9 rad is outside"), 2,
     "servolab fail go: error: goal_position: 9 rad is outside"),
    (MessageError("unknown message type 'x'"), 2,
     "servolab fail go: error: unknown message type 'x'"),
    (ConfigFileError("bus.yaml", 3, "id", "'x1' is not a int"), 2,
     "servolab fail go: error: bus.yaml:3: 'x1' is not a int"),
    (ServiceError("/talker/get_parameters did not answer"), 1,
     "servolab fail go: error: /talker/get_parameters did not answer"),
    (NoResponse("motor 3 did not answer PING"), 1,
     "servolab fail go: NoResponse: motor 3 did not answer PING"),
    (MotorError(3, "WRITE", ("overload",), 0x20), 1,
     "servolab fail go: MotorError: motor 3: WRITE answered with error overload"),
    (KeyboardInterrupt(), 130, "servolab fail go: stopped by SIGINT"),
    (StopSignal(signal.SIGTERM), 143, "servolab fail go: stopped by SIGTERM"),
    (StopSignal(signal.SIGHUP), 129, "servolab fail go: stopped by SIGHUP"),
])
def test_errors_are_one_line_with_their_exit_status(
        exc: BaseException, status: int, line: str, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(cli, "commands", lambda: (_failing(exc),))
    assert main(["fail", "go"]) == status
    assert capsys.readouterr().err == line + "\n"


def test_an_error_not_raised_on_purpose_keeps_its_traceback(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(cli, "commands", lambda: (_failing(ZeroDivisionError("bug")),))
    with pytest.raises(ZeroDivisionError):
        main(["fail", "go"])


def test_out_that_is_a_file_is_one_line_exit_2(tmp_path: Path) -> None:
    target = tmp_path / "taken"
    target.write_text("")
    result = servolab("scan", "--port", "emu://rx28:1", "--ids", "0-2", "--out", str(target),
                      timeout=60)
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [
        f"servolab scan: error: --out {target}: exists and is not a folder; name a folder (it "
        "is created if missing)"]


def test_a_silent_motor_on_the_wrong_protocol_is_told_so() -> None:
    """RX-28s speak protocol 1.0 only (e-Manual, RX-28: Protocol 1.0 control table): asked in
    2.0 they stay silent, and the one-line error says which flag to try."""
    result = servolab("read", "--port", "emu://rx28:1", "--protocol", "2", "--id", "1",
                      "present_position", timeout=60)
    assert result.returncode == 1
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("servolab read: NoResponse: motor 1:")
    assert lines[0].endswith("if it speaks protocol 1.0, add --protocol 1")


# -- read / write check against the model before the wire -----------------------------------------
# (bus driver, issue 14): register name, range and access are checked against the motor's
# control table before any instruction is sent. With --model nothing at all goes out; without
# it, only what learns the model (PING, and on 1.0 a READ of the model number and mode).

@pytest.mark.parametrize(("command", "args", "named"), [
    ("write", ("goal_positoin", "0.1"), "goal_positoin"),
    ("write", ("goal_position", "9"), "goal_position: 9 rad is outside"),
    ("write", ("goal_position", "1024", True), "outside 0..1023"),
    ("write", ("goal_position", "1.5", True), "not an integer"),
    ("write", ("present_position", "0.1"), "read-only"),
    ("read", (["present_position", "goal_positoin"],), "goal_positoin"),
], ids=["unknown-register", "si-range", "raw-range", "raw-not-integer", "read-only",
        "read-unknown-register"])
@pytest.mark.parametrize("declared", [True, False], ids=["with-model", "pinged"])
def test_read_and_write_check_the_model_before_the_wire(
        monkeypatch: pytest.MonkeyPatch, command: str, args: tuple, named: str,
        declared: bool) -> None:
    import io

    from servolab.apps.read import read
    from servolab.apps.write import write
    from servolab.dynamixel.ports import MemoryPort
    from servolab.dynamixel.protocol1 import PROTOCOL1

    sent: list[bytes] = []
    real_write = MemoryPort.write

    def recording(self: MemoryPort, data: bytes) -> None:
        sent.append(bytes(data))
        real_write(self, data)

    monkeypatch.setattr(MemoryPort, "write", recording)
    options = {"baudrate": 57142, "model": "rx28" if declared else None,
               "stdout": io.StringIO()}
    with pytest.raises(ConfigError) as info:
        if command == "write":
            write("emu://rx28:12", 12, args[0], args[1], raw=len(args) > 2, **options)
        else:
            read("emu://rx28:12", 12, args[0], **options)
    assert named in str(info.value)
    packets = [PROTOCOL1.decode_instruction(p) for p in sent]
    if declared:
        assert packets == []
    else:  # the PING that learns the model, and on 1.0 the READ of its number, firmware and
        # angle limits (0..9)
        assert [PROTOCOL1.instruction_name(p.instruction) for p in packets] == ["PING", "READ"]
        assert packets[1].params == bytes((0, 10))
