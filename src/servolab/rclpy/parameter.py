"""``rclpy.parameter``: :class:`Parameter` with rclpy's shape (``rclpy/parameter.py``):
``Parameter(name, type_=None, value=None)``, ``Parameter.Type`` (rcl_interfaces'
ParameterType values), ``.name``, ``.type_``, ``.value``, ``get_parameter_value()`` and
``to_parameter_msg()`` (``rcl_interfaces`` messages), ``from_parameter_msg``; and the module
functions ``parameter_value_to_python`` and ``get_parameter_value``.

A node's parameters are stored once, by servolab's node (:mod:`servolab.middleware.node`);
this class is how rclpy code sees them.
"""

from __future__ import annotations

import array
import importlib
from enum import Enum
from typing import Any

import yaml

from servolab.middleware import parameters as _p

PARAMETER_SEPARATOR_STRING = "."

_FIELDS = {_p.BOOL: "bool_value", _p.INTEGER: "integer_value", _p.DOUBLE: "double_value",
           _p.STRING: "string_value", _p.BYTE_ARRAY: "byte_array_value",
           _p.BOOL_ARRAY: "bool_array_value", _p.INTEGER_ARRAY: "integer_array_value",
           _p.DOUBLE_ARRAY: "double_array_value", _p.STRING_ARRAY: "string_array_value"}


def _interfaces() -> Any:
    return importlib.import_module("servolab.interfaces.rcl_interfaces.msg")


class Parameter:
    """A parameter's name, type and value (see the module docstring)."""

    class Type(Enum):
        NOT_SET = _p.NOT_SET
        BOOL = _p.BOOL
        INTEGER = _p.INTEGER
        DOUBLE = _p.DOUBLE
        STRING = _p.STRING
        BYTE_ARRAY = _p.BYTE_ARRAY
        BOOL_ARRAY = _p.BOOL_ARRAY
        INTEGER_ARRAY = _p.INTEGER_ARRAY
        DOUBLE_ARRAY = _p.DOUBLE_ARRAY
        STRING_ARRAY = _p.STRING_ARRAY

        @classmethod
        def from_parameter_value(cls, parameter_value: Any) -> Parameter.Type:
            T = Parameter.Type
            if parameter_value is None:
                return T.NOT_SET
            if isinstance(parameter_value, bool):
                return T.BOOL
            if isinstance(parameter_value, int):
                return T.INTEGER
            if isinstance(parameter_value, float):
                return T.DOUBLE
            if isinstance(parameter_value, str):
                return T.STRING
            if isinstance(parameter_value, list | tuple | array.array):
                for kind, python in ((T.BYTE_ARRAY, bytes), (T.BOOL_ARRAY, bool),
                                     (T.INTEGER_ARRAY, int), (T.DOUBLE_ARRAY, float),
                                     (T.STRING_ARRAY, str)):
                    if all(isinstance(v, python) for v in parameter_value):
                        return kind
                raise TypeError("The given value is not a list of one of the allowed types"
                                f" '{parameter_value}'.")
            raise TypeError(f"The given value is not one of the allowed types "
                            f"'{parameter_value}'.")

        def check(self, parameter_value: Any) -> bool:
            T = Parameter.Type
            sequence = (list, tuple)
            checks = {
                T.NOT_SET: lambda v: v is None,
                T.BOOL: lambda v: isinstance(v, bool),
                T.INTEGER: lambda v: isinstance(v, int),
                T.DOUBLE: lambda v: isinstance(v, float),
                T.STRING: lambda v: isinstance(v, str),
                T.BYTE_ARRAY: lambda v: isinstance(v, sequence) and all(
                    isinstance(x, bytes) and len(x) == 1 for x in v),
                T.BOOL_ARRAY: lambda v: isinstance(v, sequence) and all(
                    isinstance(x, bool) for x in v),
                T.INTEGER_ARRAY: lambda v: isinstance(v, (*sequence, array.array)) and all(
                    isinstance(x, int) for x in v),
                T.DOUBLE_ARRAY: lambda v: isinstance(v, (*sequence, array.array)) and all(
                    isinstance(x, float) for x in v),
                T.STRING_ARRAY: lambda v: isinstance(v, sequence) and all(
                    isinstance(x, str) for x in v),
            }
            return bool(checks[self](parameter_value))

    @classmethod
    def from_parameter_msg(cls, param_msg: Any) -> Parameter:
        type_ = Parameter.Type(param_msg.value.type)
        value = None
        if type_ is not Parameter.Type.NOT_SET:
            value = getattr(param_msg.value, _FIELDS[type_.value])
            if hasattr(value, "tolist"):
                value = value.tolist()
            if type_ is Parameter.Type.BYTE_ARRAY:
                value = [bytes([b]) if isinstance(b, int) else b for b in value]
        return cls(param_msg.name, type_, value)

    def __init__(self, name: str, type_: Parameter.Type | None = None,
                 value: Any = None) -> None:
        if type_ is None:
            type_ = Parameter.Type.from_parameter_value(value)
        if not isinstance(type_, Parameter.Type):
            raise TypeError(f"type must be an instance of '{Parameter.Type!r}'")
        if not type_.check(value):
            raise ValueError(f"Type '{type_}' and value '{value}' do not agree")
        self._type_ = type_
        self._name = name
        self._value = value

    @property
    def name(self) -> str:
        return self._name

    @property
    def type_(self) -> Parameter.Type:
        return self._type_

    @property
    def value(self) -> Any:
        return self._value

    def get_parameter_value(self) -> Any:
        """An ``rcl_interfaces/msg/ParameterValue``."""
        msg = _interfaces().ParameterValue(type=self._type_.value)
        if self._type_ is not Parameter.Type.NOT_SET:
            value = self._value
            if self._type_ is Parameter.Type.BYTE_ARRAY:
                value = b"".join(value)
            setattr(msg, _FIELDS[self._type_.value], _as_field(self._type_, value))
        return msg

    def to_parameter_msg(self) -> Any:
        """An ``rcl_interfaces/msg/Parameter``."""
        return _interfaces().Parameter(name=self._name, value=self.get_parameter_value())

    def _stored(self) -> Any:
        """The value as servolab's node stores it (lists, bytes for a byte array)."""
        if self._type_ is Parameter.Type.BYTE_ARRAY:
            return b"".join(self._value)
        if isinstance(self._value, tuple | array.array):
            return list(self._value)
        return self._value


def _as_field(kind: Parameter.Type, value: Any) -> Any:
    """A value as a ParameterValue field takes it (numpy arrays for numeric arrays)."""
    import numpy as np
    dtypes = {Parameter.Type.BOOL_ARRAY: np.bool_, Parameter.Type.INTEGER_ARRAY: np.int64,
              Parameter.Type.DOUBLE_ARRAY: np.float64, Parameter.Type.BYTE_ARRAY: np.uint8}
    if kind in dtypes:
        return np.array(list(value), dtype=dtypes[kind])
    if kind is Parameter.Type.STRING_ARRAY:
        return list(value)
    return value


def from_stored(name: str, kind: int, value: Any) -> Parameter:
    """The rclpy Parameter of a value servolab's node stores with type ``kind``."""
    type_ = Parameter.Type(kind)
    if type_ is Parameter.Type.BYTE_ARRAY:
        value = [bytes([b]) for b in value]
    elif type_ is Parameter.Type.DOUBLE_ARRAY:
        value = [float(v) for v in value]
    return Parameter(name, type_, value)


def parameter_value_to_python(parameter_value: Any) -> Any:
    """The Python value of an ``rcl_interfaces/msg/ParameterValue`` (None when NOT_SET)."""
    if parameter_value.type == _p.NOT_SET:
        return None
    field = _FIELDS.get(parameter_value.type)
    if field is None:
        raise RuntimeError(f"unexpected parameter type {parameter_value.type}")
    value = getattr(parameter_value, field)
    if parameter_value.type >= _p.BYTE_ARRAY:
        value = list(value.tolist() if hasattr(value, "tolist") else value)
    return value


def get_parameter_value(string_value: str) -> Any:
    """The ``ParameterValue`` a string stands for, its type guessed from YAML as rclpy
    does."""
    try:
        value = yaml.safe_load(string_value)
    except yaml.YAMLError:
        value = string_value
    if isinstance(value, list):
        try:
            kind = Parameter.Type.from_parameter_value(value)
        except TypeError:
            kind = Parameter.Type.STRING
            value = string_value
        if kind is Parameter.Type.BYTE_ARRAY:  # YAML gives no bytes: an empty list
            kind = Parameter.Type.BOOL_ARRAY
        return Parameter("", kind, value).get_parameter_value()
    if isinstance(value, bool | int | float):
        return Parameter("", None, value).get_parameter_value()
    return Parameter("", Parameter.Type.STRING,
                     value if isinstance(value, str) else string_value).get_parameter_value()


__all__ = ["PARAMETER_SEPARATOR_STRING", "Parameter", "get_parameter_value",
           "parameter_value_to_python"]
