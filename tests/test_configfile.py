"""The one YAML loader (servolab.configfile) and the errors of the files it reads.

Every value keeps its file, line and key path; duplicate keys are refused naming both lines;
the accessors are strict (a bool is not a number, a list is not a string); and each consumer
(launch files, ROS 2 parameter files, motor specs) raises an error that is both a
ConfigFileError, carrying path, line and key, and its family's old class.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from servolab.configfile import (
    ConfigList,
    ConfigMapping,
    ConfigScalar,
    ConfigValue,
    load,
    load_text,
    unknown_key,
)
from servolab.dynamixel import motorspec
from servolab.dynamixel.errors import ConfigError, DynamixelError, MotorSpecFileError
from servolab.errors import ConfigFileError, ServolabError
from servolab.middleware.errors import (
    LaunchError,
    LaunchFileError,
    MiddlewareError,
    ParameterError,
    ParameterFileError,
)
from servolab.middleware.launch_file import check_entries, load_launch
from servolab.middleware.parameters import ParameterOverrides


def write(tmp_path: Path, text: str, name: str = "config.yaml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def located(error: ConfigFileError, path: str | Path, line: int, key: str) -> None:
    """The error's attributes and its one-line text agree on where the problem is."""
    assert (error.path, error.line, error.key) == (str(path), line, key)
    assert str(error) == f"{path}:{line}: {error.message}"
    assert "\n" not in str(error)


# -- locations -------------------------------------------------------------------------------

NESTED = """\
nodes:
  - name: talker
    parameters:
      rate: 10.0
      camera: {width: 640, names: [a, b]}
  - name: listener
"""


def test_every_value_keeps_its_line_and_key_path() -> None:
    root = load_text(NESTED, "robot.yaml").as_mapping()
    assert (root.path, root.line, root.key) == ("robot.yaml", 1, "")
    nodes = root.require("nodes").as_list()
    talker, listener = nodes
    parameters = talker.as_mapping().require("parameters").as_mapping()
    rate = parameters.require("rate")
    camera = parameters.require("camera").as_mapping()
    names = camera.require("names").as_list()
    where = {value.key: value.line for value in (nodes, talker, parameters, rate, camera,
                                                   camera.require("width"), names, names[1],
                                                   listener.as_mapping().require("name"))}
    assert where == {
        "nodes": 2, "nodes[0]": 2, "nodes[0].parameters": 4, "nodes[0].parameters.rate": 4,
        "nodes[0].parameters.camera": 5, "nodes[0].parameters.camera.width": 5,
        "nodes[0].parameters.camera.names": 5, "nodes[0].parameters.camera.names[1]": 5,
        "nodes[1].name": 6}
    # the key itself is located too, apart from its value
    assert talker.as_mapping().key_of("parameters").line == 3
    assert talker.as_mapping().key_of("parameters").key == "nodes[0].parameters"
    # an error made at a value points there
    error = rate.error("too fast")
    assert isinstance(error, ConfigFileError)
    located(error, "robot.yaml", 4, "nodes[0].parameters.rate")


def test_values_are_what_safe_load_reads() -> None:
    text = "a: 1\nb: 1.5\nc: yes\nd: ~\ne: '7'\nf: [1, {g: x}]\nh: 2020-01-02\nk: =\n"
    root = load_text(text).as_mapping()
    assert root.plain() == {"a": 1, "b": 1.5, "c": True, "d": None, "e": "7",
                            "f": [1, {"g": "x"}], "h": root.require("h").plain(), "k": "="}
    h = root.require("h")
    assert isinstance(h, ConfigScalar) and str(h.value) == "2020-01-02"
    e = root.require("e")
    assert isinstance(e, ConfigScalar) and (e.value, e.text) == ("7", "7")
    assert list(root) == ["a", "b", "c", "d", "e", "f", "h", "k"]
    assert isinstance(root.require("f"), ConfigList) and len(root.require("f").as_list()) == 2


def test_an_empty_file_is_a_null_on_line_one(tmp_path: Path) -> None:
    root = load(write(tmp_path, "# only a comment\n"))
    assert isinstance(root, ConfigScalar) and root.value is None and root.line == 1


# -- duplicate keys --------------------------------------------------------------------------

@pytest.mark.parametrize(("text", "line", "first", "key"), [
    ("rate: 1\nname: a\nrate: 2\n", 3, 1, "rate"),
    ("nodes:\n  - name: a\n    parameters:\n      rate: 1\n      rate: 2\n", 5, 4,
     "nodes[0].parameters.rate"),
    ("a: {x: 1, y: 2, x: 3}\n", 1, 1, "a.x"),
    ("- a\n- b: 1\n  b: 2\n", 3, 2, "[1].b"),
])
def test_duplicate_keys_are_refused_naming_both_lines(text: str, line: int, first: int,
                                                      key: str) -> None:
    with pytest.raises(ConfigFileError) as info:
        load_text(text, "dup.yaml")
    located(info.value, "dup.yaml", line, key)
    assert info.value.message == (f"duplicate key {key!r} (first on line {first}, again on "
                                  f"line {line})")


def test_launch_files_refuse_duplicate_keys(tmp_path: Path) -> None:
    top = write(tmp_path, "nodes: [{name: a, node: m:C}]\ntransport: local\n"
                          "transport: zenoh\n", "top.launch.yaml")
    with pytest.raises(LaunchError) as info:
        load_launch(top)
    assert isinstance(info.value, LaunchFileError)
    located(info.value, top, 3, "transport")
    assert "first on line 2" in str(info.value)
    nested = write(tmp_path, """\
        nodes:
          - name: talker
            node: m:C
            parameters:
              rate: 1.0
              rate: 2.0
        """, "nested.launch.yaml")
    with pytest.raises(LaunchError) as info:
        load_launch(nested)
    located(info.value, nested, 6, "nodes[0].parameters.rate")
    assert "first on line 5, again on line 6" in str(info.value)


def test_parameter_files_refuse_duplicate_keys(tmp_path: Path) -> None:
    # PyYAML alone would silently keep rate: 2.0
    top = write(tmp_path, "talker:\n  ros__parameters: {rate: 1.0}\n"
                          "talker:\n  ros__parameters: {rate: 2.0}\n", "top.yaml")
    with pytest.raises(ParameterError) as info:
        ParameterOverrides.from_file(top)
    assert isinstance(info.value, ParameterFileError)
    located(info.value, top, 3, "talker")
    nested = write(tmp_path, "talker:\n  ros__parameters:\n    camera:\n      width: 640\n"
                             "      width: 320\n", "nested.yaml")
    with pytest.raises(ParameterError) as info:
        ParameterOverrides.from_file(nested)
    located(info.value, nested, 5, "talker.ros__parameters.camera.width")
    assert "first on line 4, again on line 5" in str(info.value)


def test_motor_specs_refuse_duplicate_keys(tmp_path: Path) -> None:
    top = write(tmp_path, "baudrate: 57142\nmotors: [{model: rx28, id: 1}]\nbaudrate: 1000000\n",
                "top.yaml")
    with pytest.raises(ConfigError) as info:
        motorspec.load_yaml(top)
    assert isinstance(info.value, MotorSpecFileError)
    located(info.value, top, 3, "baudrate")
    nested = write(tmp_path, """\
        motors:
          - {model: rx28, ids: 1-3}
          - model: rx28
            id: 4
            id: 5
        """, "nested.yaml")
    with pytest.raises(ConfigError) as info:
        motorspec.load_yaml(nested)
    located(info.value, nested, 5, "motors[1].id")
    assert "first on line 4, again on line 5" in str(info.value)


# -- strict accessors ------------------------------------------------------------------------

ACCESSORS = "flag: true\nlist: [1, 2]\nnan: .nan\nquoted: '5'\nempty:\ncount: 3\nrate: 2.5\n"


@pytest.mark.parametrize(("key", "get", "message"), [
    ("flag", lambda v: v.as_int(), "key 'flag': must be an integer, not true"),
    ("flag", lambda v: v.as_float(), "key 'flag': must be a finite number, not true"),
    ("list", lambda v: v.as_str(), "key 'list': must be a string, not a list"),
    ("list", lambda v: v.as_int(), "key 'list': must be an integer, not a list"),
    ("list", lambda v: v.as_bool(), "key 'list': must be true or false, not a list"),
    ("nan", lambda v: v.as_float(), "key 'nan': must be a finite number, not .nan"),
    ("quoted", lambda v: v.as_int(), "key 'quoted': must be an integer, not '5'"),
    ("rate", lambda v: v.as_int(), "key 'rate': must be an integer, not 2.5"),
    ("count", lambda v: v.as_str(), "key 'count': must be a string, not 3"),
    ("empty", lambda v: v.as_str(nonempty=True),
     "key 'empty': must be a non-empty string, not nothing"),
    ("count", lambda v: v.as_mapping(), "key 'count': must be a mapping, not 3"),
    ("count", lambda v: v.as_list(), "key 'count': must be a list, not 3"),
    ("list", lambda v: v.as_strings(), "key 'list[0]': must be a string, not 1"),
    ("flag", lambda v: v.as_bool("node 'a': key 'x'"), None),
    ("flag", lambda v: v.as_int("node 'a': key 'flag'"),
     "node 'a': key 'flag': must be an integer, not true"),
])
def test_wrong_kinds_are_refused_at_their_line(key: str, get, message: str | None) -> None:
    root = load_text(ACCESSORS, "kinds.yaml").as_mapping()
    value = root.require(key)
    if message is None:
        assert get(value) is True
        return
    with pytest.raises(ConfigFileError) as info:
        get(value)
    line = next(n for n, row in enumerate(ACCESSORS.splitlines(), 1)
                if row.startswith(f"{key}:"))
    expected_key = f"{key}[0]" if message.startswith(f"key '{key}[0]'") else key
    located(info.value, "kinds.yaml", line, expected_key)
    assert info.value.message == message


def test_right_kinds_are_returned_typed() -> None:
    root = load_text(ACCESSORS + "one: a\nmany: [a, b]\n").as_mapping()
    assert root.require("count").as_int() == 3
    count_as_float = root.require("count").as_float()
    assert count_as_float == 3.0 and isinstance(count_as_float, float)
    assert root.require("rate").as_float() == 2.5
    assert root.require("flag").as_bool() is True
    assert root.require("quoted").as_str() == "5"
    nan = root.require("nan").as_float(finite=False)
    assert nan != nan  # allowed when asked for
    assert root.require("one").as_strings() == ["a"]
    assert root.require("many").as_strings() == ["a", "b"]
    assert [v.key for v in root.require("many").one_or_many()] == ["many[0]", "many[1]"]
    assert root.get("absent") is None and "absent" not in root


def test_unknown_and_missing_keys() -> None:
    root = load_text("nodes:\n  - name: a\n    paramters: {}\n", "x.yaml").as_mapping()
    entry = root.require("nodes").as_list()[0].as_mapping()
    with pytest.raises(ConfigFileError) as info:
        entry.check_keys(("name", "node", "parameters"))
    located(info.value, "x.yaml", 3, "nodes[0].paramters")
    assert info.value.message == ("unknown key 'nodes[0].paramters' "
                                  "(did you mean 'parameters'?)")
    with pytest.raises(ConfigFileError) as info:
        entry.check_keys(("name", "node", "parameters"), what="node 'a'")
    assert info.value.message == "node 'a': unknown key 'paramters' (did you mean 'parameters'?)"
    with pytest.raises(ConfigFileError) as info:
        entry.check_keys(("name", "paramters", "node"), required=("node",))
    located(info.value, "x.yaml", 2, "nodes[0]")
    assert info.value.message == "key 'nodes[0].node' missing"
    assert unknown_key("xyz", ("name", "node")) == "unknown key 'xyz'"


# -- files that cannot be read ---------------------------------------------------------------

@pytest.mark.parametrize(("text", "line", "problem"), [
    ("a: 1\nb: c: d\n", 2, "mapping values are not allowed here"),
    ("a: [1, 2\nb: 3\n", 2, "while parsing a flow sequence on line 1"),  # the unclosed [
    ("a: 1\n---\nb: 2\n", 2, "expected a single document"),
    ("a: 1\nb: \x07\n", 2, "special characters are not allowed"),
    ("a: !!int x\n", 1, "'x' is not a int"),
    ("<<: {a: 1}\n", 1, "merge keys (<<) are not supported"),
])
def test_invalid_yaml_is_an_error_at_its_line(tmp_path: Path, text: str, line: int,
                                              problem: str) -> None:
    path = write(tmp_path, text)
    with pytest.raises(ConfigFileError) as info:
        load(path)
    assert (info.value.path, info.value.line) == (str(path), line)
    assert problem in info.value.message
    assert str(info.value).startswith(f"{path}:{line}: ")


def test_unreadable_files_are_config_file_errors(tmp_path: Path) -> None:
    missing = tmp_path / "missing.yaml"
    with pytest.raises(ConfigFileError) as info:
        load(missing, what="robot base")
    assert (info.value.path, info.value.line, info.value.key) == (str(missing), 0, "")
    assert str(info.value) == f"{missing}: cannot read robot base (No such file or directory)"
    with pytest.raises(ConfigFileError, match="cannot read configuration file"):
        load(tmp_path)  # a directory
    binary = tmp_path / "binary.yaml"
    binary.write_bytes(b"a: 1\nb: \xff\n")
    with pytest.raises(ConfigFileError) as info:
        load(binary)
    assert info.value.line == 2 and "not UTF-8" in info.value.message


# -- each consumer's errors: a ConfigFileError and the family's old class --------------------

def test_launch_file_errors_are_config_file_errors(tmp_path: Path) -> None:
    path = write(tmp_path, """\
        nodes:
          - name: talker
            node: m:C
            required: yes please
        """, "robot.launch.yaml")
    with pytest.raises(LaunchError) as info:
        load_launch(path)
    error = info.value
    assert isinstance(error, LaunchFileError) and isinstance(error, ConfigFileError)
    assert isinstance(error, MiddlewareError) and isinstance(error, ServolabError)
    located(error, path, 4, "nodes[0].required")
    assert error.message == ("node 'talker': key 'required': must be true or false, not "
                             "'yes please'")
    # a check made after parsing (importing the node class) points at the file too
    path = write(tmp_path, """\
        nodes:
          - {name: a, node: servolab.middleware.demo_nodes:Talker}
          - name: b
            node: servolab.middleware.demo_nodes:NoSuchNode
        """, "import.launch.yaml")
    launch = load_launch(path)
    with pytest.raises(LaunchFileError) as info:
        check_entries(launch, launch.nodes)
    located(info.value, path, 4, "nodes[1].node")
    # an unreadable launch file, and errors that are not about the file
    with pytest.raises(LaunchFileError, match="cannot read launch file"):
        load_launch(tmp_path / "none.launch.yaml")
    with pytest.raises(LaunchError) as info:
        launch.entries_for("nas")
    assert not isinstance(info.value, ConfigFileError)


def test_parameter_file_errors_are_config_file_errors(tmp_path: Path) -> None:
    path = write(tmp_path, "talker:\n  ros__parameters:\n    rate: 4.5\n    names: [a, 1]\n",
                 "params.yaml")
    with pytest.raises(ParameterError) as info:
        ParameterOverrides.from_file(path)
    assert isinstance(info.value, ParameterFileError)
    located(info.value, path, 4, "talker.ros__parameters.names")
    assert info.value.message.startswith("names: ")
    with pytest.raises(ParameterFileError) as info:
        ParameterOverrides.from_text("talker:\n  rate: 1\n", "inline")
    located(info.value, "inline", 1, "talker")
    assert info.value.message == "key 'ros__parameters' missing under 'talker'"
    with pytest.raises(ParameterFileError, match="cannot read parameter file"):
        ParameterOverrides.from_file(tmp_path / "none.yaml")
    with pytest.raises(ParameterError) as info:
        ParameterOverrides.from_assignments(["rate=4"])
    assert not isinstance(info.value, ConfigFileError)
    # nested values, flattened as ROS 2 does, and an empty file
    good = write(tmp_path, "/**:\n  ros__parameters:\n    camera: {width: 640, on: true}\n",
                 "good.yaml")
    assert ParameterOverrides.from_file(good).for_node("/x") == {"camera.width": 640,
                                                                 "camera.on": True}
    assert ParameterOverrides.from_text("").by_node == {}


def test_motor_spec_file_errors_are_config_file_errors(tmp_path: Path) -> None:
    path = write(tmp_path, "motors:\n  - {model: rx28, ids: 1-3}\n  - {model: rx28, id: x1}\n",
                 "bus.yaml")
    with pytest.raises(ConfigError) as info:
        motorspec.load_yaml(path)
    error = info.value
    assert isinstance(error, MotorSpecFileError) and isinstance(error, DynamixelError)
    assert isinstance(error, ServolabError)
    located(error, path, 3, "motors[1].id")
    assert str(error) == f"{path}:3: id: 'x1' is not a int"
    # an unknown key names the one meant; a check across motors points at the motor
    typo = write(tmp_path, "motor:\n  - {model: rx28, id: 1}\n", "typo.yaml")
    with pytest.raises(MotorSpecFileError) as info:
        motorspec.load_yaml(typo)
    located(info.value, typo, 1, "motor")
    assert "did you mean 'motors'?" in info.value.message
    twice = write(tmp_path, "motors:\n  - {model: rx28, ids: 1-3}\n  - {model: rx28, id: 2}\n",
                  "twice.yaml")
    with pytest.raises(MotorSpecFileError) as info:
        motorspec.load_yaml(twice)
    located(info.value, twice, 3, "motors[1]")
    assert "motor ID 2 is listed twice" in info.value.message
    with pytest.raises(MotorSpecFileError, match="cannot read motor spec"):
        motorspec.load_yaml(tmp_path / "none.yaml")
    # the short form is not a file: its errors keep the old class alone
    with pytest.raises(ConfigError) as info:
        motorspec.parse_short("rx28:1-3,2")
    assert not isinstance(info.value, ConfigFileError)
    spec = motorspec.load_yaml(write(tmp_path, "motors: [{model: rx28, ids: 1-2, "
                                               "position: 0.5}]\n", "ok.yaml"))
    assert [(m.id, m.position) for m in spec.motors] == [(1, 0.5), (2, 0.5)]


def test_the_families_share_one_root() -> None:
    assert issubclass(DynamixelError, ServolabError)
    assert issubclass(MiddlewareError, ServolabError)
    for cls, family in ((LaunchFileError, LaunchError), (ParameterFileError, ParameterError),
                        (MotorSpecFileError, ConfigError)):
        assert issubclass(cls, ConfigFileError) and issubclass(cls, family)
        error = cls("f.yaml", 3, "a.b", "bad")
        assert (str(error), error.key) == ("f.yaml:3: bad", "a.b")


def test_located_values_are_typed_nodes() -> None:
    root = load_text("a: {b: [1]}\n")
    assert isinstance(root, ConfigMapping) and isinstance(root, ConfigValue)
    b = root.as_mapping().require("a").as_mapping().require("b")
    assert isinstance(b, ConfigList) and isinstance(b[0], ConfigScalar)
    assert b.plain() == [1]


def test_nested_aliases_cannot_blow_up(tmp_path: Path) -> None:
    """Seven levels of ten aliases stand for 10^7 values: refused, naming the file, instead
    of building them for a minute (PyYAML's safe_load shares them; we do not, so each use
    keeps its own key path)."""
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x, x]"]
    for level in range(1, 8):
        refs = ", ".join([f"*a{level - 1}"] * 10)
        lines.append(f"a{level}: &a{level} [{refs}]")
    path = tmp_path / "laughs.yaml"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(ConfigFileError, match="aliases") as info:
        load(path)
    assert info.value.path == str(path)
    few = tmp_path / "few.yaml"                         # aliases within reason still work
    few.write_text("\n".join(lines[:3]) + "\n")
    assert len(load(few).plain()["a2"]) == 10


def test_a_motor_spec_protocol_is_1_or_2(tmp_path: Path) -> None:
    path = tmp_path / "motors.yaml"
    path.write_text("protocol: 1.5\nmotors:\n  - {model: rx28, id: 1}\n")
    with pytest.raises(MotorSpecFileError, match=r"motors.yaml:1: protocol: 1.5 is not 1 or 2"):
        motorspec.load_yaml(path)


def test_a_motor_spec_position_the_motor_cannot_reach_is_refused(tmp_path: Path) -> None:
    """An RX-28's goal_position covers 0..1023 ticks, ±150° around the centre (e-Manual,
    RX-28 Goal Position(30)): 3 rad is outside, named with its line."""
    path = tmp_path / "motors.yaml"
    path.write_text("motors:\n  - {model: rx28, id: 1, position: 0.5}\n"
                    "  - {model: rx28, id: 2, position: 3.0}\n")
    with pytest.raises(MotorSpecFileError, match=r"motors.yaml:3: position: RX-28 "
                       r"goal_position: 3 rad is outside"):
        motorspec.load_yaml(path)
