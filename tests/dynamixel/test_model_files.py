"""Models as data: the shipped model files, the checks a file goes through, and a lab's own file
added with ``register_model`` and used by the emulator and the Bus.

A wrong model file is a wrong address on a real motor, so every value is checked when the file
is read, and a mistake is reported as ``path:line: message`` on one line (the repository's one
YAML loader, :mod:`servolab.configfile`).
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import pytest

from servolab.dynamixel import MODELS, Bus, ConfigError, model, model_by_number
from servolab.dynamixel import models as models_module
from servolab.dynamixel.models import (
    TABLES_DIR,
    Model,
    ModelFileError,
    load_model,
    register_model,
)

SHIPPED = sorted(TABLES_DIR.glob("*.yaml"))


def test_one_file_a_model() -> None:
    """Every model is one file of model_tables/, and every file there one model."""
    assert len(SHIPPED) == len(MODELS) == 23
    assert {model(name).path for name in MODELS} == {str(p) for p in SHIPPED}


@pytest.mark.parametrize("path", SHIPPED, ids=[p.stem for p in SHIPPED])
def test_shipped_file_is_named_after_its_model_and_cites_its_page(path: Path) -> None:
    """A file is named after its model's e-Manual page (``mx-28-2.yaml`` is MX-28(2.0)) and
    cites that page, which test_tables_emanual.py / test_model_emanual_tables.py check it
    against."""
    m = load_model(path)
    assert models_module._key(path.stem) == models_module._key(m.name)
    assert m.source == f"docs/en/dxl/{m.source.split('/')[3]}/{path.stem}.md"
    assert path.read_text().count(m.source) >= 2   # the header comment and `source:`
    assert model(m.name) == m


def test_a_lookup_reads_only_the_file_it_needs() -> None:
    """Reading a file costs tens of milliseconds: a command that drives one model reads one
    (the index of names and numbers comes from the files' plain name/number lines)."""
    registry = models_module._Registry(TABLES_DIR)
    entry = registry.find("xm430_w210")
    assert entry is not None and entry.model is None
    registry.load(entry)
    assert registry.load(entry) is entry.model
    number = registry.numbered(1060)
    assert number is not None
    registry.load(number)
    assert sorted(e.name for e in registry.entries() if e.model is not None) == [
        "XL430-W250", "XM430-W210"]
    assert registry.numbered(4242) is None and registry.find("xm430") is None


def test_module_constants_are_the_models() -> None:
    """The six models servolab started with keep their module-level names."""
    from servolab.dynamixel.models import EX_106P, XM430_W210

    assert XM430_W210 is model("XM430-W210")
    assert EX_106P is model("EX-106+")
    with pytest.raises(AttributeError, match="XM430_W999"):
        models_module.XM430_W999  # noqa: B018


# -- a file's mistakes -----------------------------------------------------------------------

def lab_text(name: str = "LAB-XM430", number: int = 64001) -> str:
    """A lab's model file: the XM430-W210's, renamed."""
    text = (TABLES_DIR / "xm430-w210.yaml").read_text()
    text = text.replace("name: XM430-W210", f"name: {name}")
    text = text.replace("number: 1030", f"number: {number}")
    return text.replace("default: 1030}", f"default: {number}}}")


def line_of(text: str, fragment: str) -> int:
    return text[:text.index(fragment)].count("\n") + 1


# (what, replace this, with this, the line of which fragment of the result, message pattern)
MISTAKES = [
    ("unknown top key", "number: 64001", "nmber: 64001", "nmber:",
     r"unknown key 'nmber' \(did you mean 'number'\?\)"),
    ("size of 3 bytes", "address: 20,  size: 4", "address: 20,  size: 3", "homing_offset",
     r"register 'homing_offset': size must be 1, 2 or 4 bytes, not 3"),
    ("default outside its range", "default: 330,", "default: 2000,", "velocity_limit:",
     r"register 'velocity_limit': default 2000 is outside its range 0\.\.1023"),
    ("overlap", "velocity_limit:         {address: 44,", "velocity_limit:         {address: 39,",
     "velocity_limit:", r"register 'velocity_limit' \(address 39\) overlaps 'current_limit'"),
    ("unit typo", "range: [0, 4095], unit: position}", "range: [0, 4095], unit: positon}",
     "unit: positon", r"unknown unit 'positon' \(did you mean 'position'\?\)"),
    ("access", "access: R,  default: 0,    range: [0, 1], unit: bool}\n  hardware",
     "access: W,  default: 0,    range: [0, 1], unit: bool}\n  hardware",
     "access: W", r"access must be R or RW, not 'W'"),
    ("range wider than the size", "range: [0, 885], unit: pwm}", "range: [0, 88500], unit: pwm}",
     "88500", r"\[0, 88500\] does not fit 2 unsigned bytes"),
    ("baud value without a rate", "range: [0, 7], unit: baud", "range: [0, 8], unit: baud",
     "baud_rate:\n", r"baud_rate: register value 8 .* has no rate"),
    ("unknown operating mode", "operating_modes: [current,", "operating_modes: [torque,",
     "operating_modes:", r"operating_modes: unknown mode 'torque'"),
    ("instruction of the other protocol", "instructions: [PING,", "instructions: [RESET, PING,",
     "instructions:", r"'RESET' is no Protocol 2\.0 instruction"),
    ("model number where PING reads it", "default: 64001}", "default: 1030}",
     "model_number:", r"model_number must be 2 bytes at address 0 with default 64001"),
    ("a register servolab needs", "  id:                     {address: 7,", "  ident:    "
     "             {address: 7,", "servolab_model:", r"has no register 'id' \(servolab needs"),
    ("a name twice in one area", "  led:                    {address: 65,",
     "  torque_enable:          {address: 65,", "torque_enable:          {address: 65,",
     r"duplicate key 'ram\.torque_enable' \(first on line \d+, again on line \d+\)"),
    ("a name in both areas", "  pwm_limit:              {address: 36,",
     "  torque_enable:          {address: 36,", "torque_enable:          {address: 64,",
     r"register 'torque_enable' is defined twice \(first on line \d+\)"),
    ("a name typed on a command line", "name: LAB-XM430", "name: LAB XM430;2", "name:",
     r"name: 'LAB XM430;2' may hold letters, digits and \+ - _ \. \( \) only"),
]


@pytest.mark.parametrize(("what", "old", "new", "at", "message"), MISTAKES,
                         ids=[m[0] for m in MISTAKES])
def test_a_mistake_is_refused_naming_file_and_line(tmp_path: Path, what: str, old: str,
                                                   new: str, at: str, message: str) -> None:
    text = lab_text()
    assert old in text, what
    text = text.replace(old, new, 1)
    path = tmp_path / "lab.yaml"
    path.write_text(text)
    with pytest.raises(ModelFileError) as info:
        load_model(path)
    error = str(info.value)
    assert "\n" not in error
    assert error.startswith(f"{path}:{line_of(text, at)}: "), error
    assert re.search(message, error), error
    assert isinstance(info.value, ConfigError)   # callers catching ConfigError keep working


def test_a_file_that_is_no_model_file(tmp_path: Path) -> None:
    """A motor spec (or any other YAML) given by mistake says what it is not."""
    path = tmp_path / "bus.yaml"
    path.write_text("motors:\n  - {model: RX-28, ids: 1-4}\n")
    with pytest.raises(ModelFileError, match=r"bus\.yaml:1: not a Dynamixel model file"):
        load_model(path)
    path.write_text("servolab_model: 1\nname: [\n")
    with pytest.raises(ModelFileError, match=r"bus\.yaml:\d+: not valid YAML"):
        load_model(path)
    with pytest.raises(ModelFileError, match="cannot read Dynamixel model file"):
        load_model(tmp_path / "missing.yaml")


# -- a lab's own model -----------------------------------------------------------------------

@pytest.fixture
def lab_files(tmp_path: Path) -> Iterator[Path]:
    """A directory for model files; whatever a test registered is forgotten afterwards."""
    before = set(MODELS)
    yield tmp_path
    for name in set(MODELS) - before:
        models_module._REGISTRY.forget(name)


def test_a_registered_model_is_emulated_and_driven_by_name(lab_files: Path) -> None:
    """A lab's file (here an XM430-W210 whose velocity limit the lab raised to 500, under a
    model number of its own) is known to the lookups, runs in the emulator and is read and
    written by name through the Bus."""
    path = lab_files / "lab-xm430.yaml"
    path.write_text(lab_text().replace("default: 330,", "default: 500,"))
    lab = register_model(path)
    assert isinstance(lab, Model) and lab.path == str(path.resolve())
    assert model("lab_xm430") is lab is model_by_number(64001) is MODELS["LAB-XM430"]
    assert register_model(path) is lab       # the same file again: no clash
    bus = Bus.open("emu://lab-xm430:3", baudrate=57600)
    try:
        found = bus.ping(3)
        assert (found.model_number, found.model) == (64001, lab)
        assert bus.read(3, "velocity_limit", raw=True) == 500
        bus.write(3, "led", 1)
        assert bus.read(3, "led", raw=True) == 1
        bus.write(3, "goal_velocity", 480, raw=True)   # within the lab's limit of 500
        assert bus.read(3, "goal_velocity", raw=True) == 480
    finally:
        bus.close()


def test_a_clash_of_name_or_number_is_refused_in_one_line(lab_files: Path) -> None:
    for text, at, message in (
            (lab_text(name="xm430_w210"), "name:", r"model name 'xm430_w210' is taken: .*"
             r"xm430-w210\.yaml defines 'XM430-W210'"),
            (lab_text(number=1030), "number:", r"model number 1030 is XM430-W210's")):
        path = lab_files / "clash.yaml"
        path.write_text(text)
        with pytest.raises(ModelFileError) as info:
            register_model(path)
        error = str(info.value)
        assert error.startswith(f"{path.resolve()}:{line_of(text, at)}: "), error
        assert re.search(message, error) and "\n" not in error, error
    assert set(MODELS) == {load_model(p).name for p in SHIPPED}


def test_a_bad_file_is_not_registered(lab_files: Path) -> None:
    path = lab_files / "bad.yaml"
    text = lab_text().replace("default: 330,", "default: -5,")
    path.write_text(text)
    with pytest.raises(ModelFileError, match=rf"bad\.yaml:{line_of(text, 'default: -5')}: "
                       r"register 'velocity_limit': default -5 is outside"):
        register_model(path)
    with pytest.raises(ConfigError, match="unknown Dynamixel model 'LAB-XM430'"):
        model("LAB-XM430")


def test_model_path_variable_adds_a_labs_models_to_every_command(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """SERVOLAB_MODEL_PATH names files or directories of model files that every servolab
    command knows (here a fresh registry, as a new process has); a clash there is refused as
    register_model refuses it."""
    (tmp_path / "lab").mkdir()
    (tmp_path / "lab" / "lab-xm430.yaml").write_text(lab_text())
    (tmp_path / "other.yaml").write_text(lab_text(name="LAB-OTHER", number=64002))
    monkeypatch.setenv("SERVOLAB_MODEL_PATH", f"{tmp_path / 'lab'}:{tmp_path / 'other.yaml'}")
    registry = models_module._Registry(TABLES_DIR)
    lab, other = registry.find("lab-xm430"), registry.numbered(64002)
    assert lab is not None and other is not None
    assert registry.load(other).name == "LAB-OTHER"
    assert len(registry.entries()) == len(SHIPPED) + 2
    clash = tmp_path / "clash.yaml"
    clash.write_text(lab_text(number=1060))
    monkeypatch.setenv("SERVOLAB_MODEL_PATH", str(clash))
    with pytest.raises(ModelFileError, match=r"clash\.yaml:\d+: model number 1060 is "
                       r"XL430-W250's"):
        models_module._Registry(TABLES_DIR).entries()
    monkeypatch.setenv("SERVOLAB_MODEL_PATH", str(tmp_path / "nowhere"))
    with pytest.raises(ModelFileError, match=r"SERVOLAB_MODEL_PATH names .*nowhere"):
        models_module._Registry(TABLES_DIR).entries()
