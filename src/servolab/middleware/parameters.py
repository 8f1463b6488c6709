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

from .errors import ParameterError

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
    raise ParameterError(f"parameter {name} is a {TYPE_NAMES[kind]}; {value!r} is a "
                         f"{TYPE_NAMES[given]}")


@dataclass
class Parameter:
    """A declared parameter."""

    name: str
    value: Any
    type: int
    description: str = ""
    read_only: bool = False


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
    def from_file(cls, path: str | Path) -> ParameterOverrides:
        """Read a ROS 2 parameter file; errors name the file, line and key."""
        path = Path(path)
        try:
            text = path.read_text()
        except OSError as exc:
            raise ParameterError(f"parameter file {path}: {exc.strerror}") from None
        return cls.from_text(text, str(path))

    @classmethod
    def from_text(cls, text: str, source: str = "<parameters>") -> ParameterOverrides:
        try:
            root = yaml.compose(text)
        except yaml.YAMLError as exc:
            mark = getattr(exc, "problem_mark", None)
            line = f":{mark.line + 1}" if mark is not None else ""
            raise ParameterError(f"{source}{line}: not valid YAML "
                                 f"({getattr(exc, 'problem', exc)})") from None
        overrides = cls()
        if root is None:
            return overrides
        if not isinstance(root, yaml.MappingNode):
            raise ParameterError(f"{source}:{root.start_mark.line + 1}: a parameter file is a "
                                 "mapping of node names to {ros__parameters: ...}")
        for key_node, node_value in root.value:
            node = key_node.value
            where = f"{source}:{key_node.start_mark.line + 1}"
            if not isinstance(node_value, yaml.MappingNode):
                raise ParameterError(f"{where}: node {node!r} needs a mapping with "
                                     "ros__parameters")
            entries = {k.value: (k, v) for k, v in node_value.value}
            if "ros__parameters" not in entries:
                raise ParameterError(f"{where}: key 'ros__parameters' missing under {node!r}")
            for other, (k, _) in entries.items():
                if other != "ros__parameters":
                    raise ParameterError(f"{source}:{k.start_mark.line + 1}: unexpected key "
                                         f"{other!r} under {node!r} (only ros__parameters)")
            params_node = entries["ros__parameters"][1]
            values: dict[str, Any] = {}
            _flatten(params_node, "", values, source)
            overrides.by_node.setdefault(_node_key(node), {}).update(values)
        return overrides


def _flatten(node: yaml.Node, prefix: str, out: dict[str, Any], source: str) -> None:
    if not isinstance(node, yaml.MappingNode):
        raise ParameterError(f"{source}:{node.start_mark.line + 1}: ros__parameters must be a "
                             "mapping of names to values")
    for key, value in node.value:
        name = f"{prefix}{key.value}"
        if isinstance(value, yaml.MappingNode):
            _flatten(value, f"{name}.", out, source)
            continue
        data = yaml.safe_load(yaml.serialize(value))
        try:
            type_of(data)
        except ParameterError as exc:
            raise ParameterError(f"{source}:{value.start_mark.line + 1}: {name}: {exc}") from None
        out[name] = data


def _node_key(node: str) -> str:
    node = node.strip()
    if node in ("/**", "**"):
        return "/**"
    return node if node.startswith("/") else f"/{node}"


def to_parameter_value(types: Any, value: Any) -> Any:
    """An ``rcl_interfaces/msg/ParameterValue`` message for a Python value."""
    kind = type_of(value)
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
