"""Node parameters: typed values declared with defaults, set from YAML files and the command
line, listed and changed at run time.

The file format is ROS 2's, so a user's parameter files work unchanged::

    talker:                 # node name, /namespace/name, or /** for every node
      ros__parameters:
        rate: 4.5
        camera:
          width: 640        # the parameter "camera.width"

A parameter's type is fixed when it is declared (by its default), as in ROS 2: setting
``rate`` to ``"fast"`` is refused with the parameter and the value named, and an integer given
for a floating-point parameter is taken as that float.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from ..configfile import ConfigMapping, ConfigScalar, ConfigValue, load, load_text
from ..limits import InputLimits, clip, quoted
from .errors import ParameterError, ParameterFileError
from .names import node_namespace

# rcl_interfaces/msg/ParameterType
NOT_SET, BOOL, INTEGER, DOUBLE, STRING, BYTE_ARRAY = 0, 1, 2, 3, 4, 5
BOOL_ARRAY, INTEGER_ARRAY, DOUBLE_ARRAY, STRING_ARRAY = 6, 7, 8, 9
TYPE_NAMES = {NOT_SET: "not set", BOOL: "bool", INTEGER: "integer", DOUBLE: "double",
              STRING: "string", BYTE_ARRAY: "byte array", BOOL_ARRAY: "bool array",
              INTEGER_ARRAY: "integer array", DOUBLE_ARRAY: "double array",
              STRING_ARRAY: "string array"}
_VALUE_FIELDS = {BOOL: "bool_value", INTEGER: "integer_value", DOUBLE: "double_value",
                 STRING: "string_value", BYTE_ARRAY: "byte_array_value",
                 BOOL_ARRAY: "bool_array_value", INTEGER_ARRAY: "integer_array_value",
                 DOUBLE_ARRAY: "double_array_value", STRING_ARRAY: "string_array_value"}


def type_of(value: Any) -> int:
    """The ROS 2 parameter type of a Python value."""
    if isinstance(value, bool):
        return BOOL
    if isinstance(value, int):
        return INTEGER
    if isinstance(value, float):
        return DOUBLE
    if isinstance(value, str):
        return STRING
    if isinstance(value, bytes):
        return BYTE_ARRAY
    if isinstance(value, list | tuple):
        kinds = {type_of(v) for v in value}
        if kinds <= {BOOL}:
            return BOOL_ARRAY if value else DOUBLE_ARRAY
        if kinds <= {INTEGER}:
            return INTEGER_ARRAY
        if kinds <= {INTEGER, DOUBLE}:
            return DOUBLE_ARRAY
        if kinds <= {STRING}:
            return STRING_ARRAY
    raise ParameterError(f"{value!r} is not a parameter value (bool, int, float, str or a "
                         "list of one of them)")


def coerce(name: str, kind: int, value: Any) -> Any:
    """``value`` as a parameter of type ``kind``, or a :class:`ParameterError` naming both."""
    given = type_of(value)
    if given == kind:
        return list(value) if isinstance(value, tuple) else value
    if kind == DOUBLE and given == INTEGER:
        return float(value)
    if kind == DOUBLE_ARRAY and given in (INTEGER_ARRAY, BOOL_ARRAY) and not value:
        return []
    if kind == DOUBLE_ARRAY and given == INTEGER_ARRAY:
        return [float(v) for v in value]
    if kind in (INTEGER_ARRAY, STRING_ARRAY, BOOL_ARRAY) and given == DOUBLE_ARRAY and not value:
        return []
    raise ParameterError(f"parameter {name} is {_a(TYPE_NAMES[kind])}; {value!r} is "
                         f"{_a(TYPE_NAMES[given])}")


def _a(noun: str) -> str:
    return f"an {noun}" if noun[0] in "aeiou" else f"a {noun}"


@dataclass
class Parameter:
    """A declared parameter."""

    name: str
    value: Any
    type: int
    description: str = ""
    read_only: bool = False


@dataclass
class SetParametersResult:
    """What an on-set-parameters callback returns, as ``rcl_interfaces/msg/SetParametersResult``
    (any object with ``successful`` and ``reason`` will do, that message included)."""

    successful: bool = True
    reason: str = ""


def list_names(names: list[str], prefixes: list[str], depth: int) -> tuple[list[str], list[str]]:
    """The names and prefixes ``~/list_parameters`` answers for ``prefixes`` and ``depth``
    (0 is DEPTH_RECURSIVE), as rclpy's ``Node.list_parameters`` (``rclpy/node.py``) does: with
    no prefixes, names with fewer than ``depth`` dots; with prefixes, each prefix itself and
    the names below it, at most ``depth`` levels down. Prefixes are the names' parents."""
    def shallow(name: str) -> bool:
        return name.count(".") < depth

    def wanted(name: str) -> bool:
        if not prefixes:
            return depth == 0 or shallow(name)
        return any(name == p or (name.startswith(f"{p}.")
                                 and (depth == 0 or shallow(name[len(p) + 1:])))
                   for p in prefixes)

    found: list[str] = []
    parents: list[str] = []
    for name in names:
        if not wanted(name):
            continue
        found.append(name)
        parent = name.rpartition(".")[0]
        if parent and parent not in parents:
            parents.append(parent)
    return found, parents


@dataclass
class ParameterOverrides:
    """Values given before nodes start: from ``--params-file`` and ``-p name:=value``.

    ``by_node`` maps a node's fully qualified name (or ``/**`` for all) to its values.
    """

    by_node: dict[str, dict[str, Any]] = field(default_factory=dict)

    def for_node(self, fully_qualified_name: str) -> dict[str, Any]:
        """The values for one node: wildcard entries first, then the node's own."""
        values = dict(self.by_node.get("/**", {}))
        values.update(self.by_node.get(fully_qualified_name, {}))
        return values

    def merge(self, other: ParameterOverrides) -> None:
        for node, values in other.by_node.items():
            self.by_node.setdefault(node, {}).update(values)

    def set(self, node: str, name: str, value: Any) -> None:
        self.by_node.setdefault(_node_key(node), {})[name] = value

    def in_namespace(self, namespace: str) -> ParameterOverrides:
        """The same values for the same nodes started in ``namespace``: ``/controller_manager``
        becomes ``/robot1/controller_manager``, as nav2_common's ``RewrittenYaml`` with
        ``root_key=namespace`` rewrites one robot's parameter file for each robot of a fleet
        (rcl itself matches a file's ``controller_manager:`` to ``/controller_manager``
        only). ``/**`` stays every node's, and a node already in the namespace stays too; where
        a file has both (``controller_manager:`` and ``/robot1/controller_manager:``), the
        robot's own values win whatever their order in the file."""
        namespace = node_namespace(namespace)
        if namespace == "/":
            return ParameterOverrides({node: dict(v) for node, v in self.by_node.items()})
        moved = ParameterOverrides()
        own: list[tuple[str, dict[str, Any]]] = []
        for node, values in self.by_node.items():
            if node == "/**" or node.startswith(f"{namespace}/"):
                own.append((node, values))
            else:
                moved.by_node.setdefault(namespace + node, {}).update(values)
        for node, values in own:   # after the moved ones: the robot's own entries win
            moved.by_node.setdefault(node, {}).update(values)
        return moved

    @classmethod
    def from_assignments(cls, assignments: list[str]) -> ParameterOverrides:
        """``name:=value`` (every node) or ``node:name:=value``; values are YAML
        (``rate:=4.5``, ``names:=[a, b]``), as ``--ros-args -p`` takes them."""
        overrides = cls()
        for text in assignments:
            if ":=" not in text:
                raise ParameterError(f"parameter assignment {text!r} is not name:=value")
            target, _, raw = text.partition(":=")
            node, _, name = target.rpartition(":")
            if not name:
                raise ParameterError(f"parameter assignment {text!r} has no name")
            try:
                value = yaml.safe_load(raw) if raw.strip() else ""
            except yaml.YAMLError:
                raise ParameterError(f"parameter assignment {text!r}: {raw!r} is not a "
                                     "YAML value") from None
            type_of(value)
            overrides.set(node or "/**", name, value)
        return overrides

    @classmethod
    def from_file(cls, path: str | Path, *,
                  limits: InputLimits | None = None) -> ParameterOverrides:
        """Read a ROS 2 parameter file; errors (:class:`ParameterFileError`) name the file,
        line and key.

        A file over the YAML size limit (:mod:`servolab.limits`, ``SERVOLAB_MAX_YAML_MB``) is
        refused unread, and one that is not a parameter file (not UTF-8 YAML, or YAML that
        is no mapping of node names to ``{ros__parameters: ...}``) is refused as ``not a
        parameter file`` with its line and column, quoting nothing of it: a launch file may
        name any file as its parameters, ``/etc/shadow`` too."""
        return cls._from_root(load(path, what="parameter file", error=ParameterFileError,
                                   kind="parameter file", limits=limits))

    @classmethod
    def from_text(cls, text: str, source: str = "<parameters>") -> ParameterOverrides:
        """Read the text of a ROS 2 parameter file; ``source`` stands for its path in errors."""
        return cls._from_root(load_text(text, source, error=ParameterFileError,
                                        kind="parameter file"))

    @classmethod
    def _from_root(cls, root: ConfigValue) -> ParameterOverrides:
        overrides = cls()
        if isinstance(root, ConfigScalar) and root.value is None:
            return overrides  # an empty file sets nothing
        if not isinstance(root, ConfigMapping):
            raise root.error("a parameter file is a mapping of node names to "
                             f"{{ros__parameters: ...}}: this is {root.describe()}, not a "
                             "parameter file")
        for node, node_value in root.items():
            key = root.key_of(node)
            if not isinstance(node_value, ConfigMapping):  # the name is not echoed: this
                raise key.error(  # may be any file that reads as YAML (/proc/meminfo)
                    "not a parameter file: each node name maps to {ros__parameters: ...}, "
                    "and the one here does not")
            if "ros__parameters" not in node_value:
                raise key.error(f"key 'ros__parameters' missing under {quoted(node)}")
            for other in node_value:
                if other != "ros__parameters":
                    raise node_value.key_of(other).error(
                        f"unexpected key {quoted(other)} under {quoted(node)} (only "
                        "ros__parameters)")
            values: dict[str, Any] = {}
            _flatten(node_value.require("ros__parameters"), "", values)
            overrides.by_node.setdefault(_node_key(node), {}).update(values)
        return overrides


def _flatten(node: ConfigValue, prefix: str, out: dict[str, Any]) -> None:
    """Nested mappings become dotted names (``camera: {width: 640}`` is ``camera.width``)."""
    if not isinstance(node, ConfigMapping):
        raise node.error("ros__parameters must be a mapping of names to values")
    for key, value in node.items():
        name = f"{prefix}{key}"
        if isinstance(value, ConfigMapping):
            _flatten(value, f"{name}.", out)
            continue
        data = value.plain()
        try:
            type_of(data)
        except ParameterError:
            raise value.error(f"{clip(name)}: {quoted(data)} is not a parameter value (bool, "
                              "int, float, str or a list of one of them)") from None
        out[name] = data


def _node_key(node: str) -> str:
    node = node.strip()
    if node in ("/**", "**"):
        return "/**"
    return node if node.startswith("/") else f"/{node}"


def to_parameter_value(types: Any, value: Any, kind: int | None = None) -> Any:
    """An ``rcl_interfaces/msg/ParameterValue`` message for a Python value (of type ``kind``
    if given: an empty list is any array type); ``None`` is PARAMETER_NOT_SET."""
    if value is None:
        return types.from_value("rcl_interfaces/msg/ParameterValue", {"type": NOT_SET})
    kind = type_of(value) if kind is None else kind
    return types.from_value("rcl_interfaces/msg/ParameterValue",
                            {"type": kind, _VALUE_FIELDS[kind]: value})


def from_parameter_value(msg: Any) -> Any:
    """The Python value of an ``rcl_interfaces/msg/ParameterValue`` (None if not set)."""
    if msg.type == NOT_SET:
        return None
    field_name = _VALUE_FIELDS.get(msg.type)
    if field_name is None:
        raise ParameterError(f"parameter value of unknown type {msg.type}")
    value = getattr(msg, field_name)
    if hasattr(value, "tolist"):
        value = value.tolist()
    if msg.type == BYTE_ARRAY:
        value = bytes(value)
    return value


def check_values(values: Mapping[str, Any]) -> None:
    for name, value in values.items():
        try:
            type_of(value)
        except ParameterError as exc:
            raise ParameterError(f"parameter {name}: {exc}") from None
