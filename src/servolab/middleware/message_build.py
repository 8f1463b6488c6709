"""A message type's builder from plain values, worked out once per type: the fast path of
:meth:`~.messages.MessageTypes.from_value`.

Every robot builds its messages from plain values (``node.message(TYPE, **fields)``): a
controller's state at its sweep rate, odometry and TF at the base's, the treadmill's frames.
``from_value`` walks the type's description for each of them, naming every field's path as it
goes so that an error can say where it is; an ``nav_msgs/Odometry`` cost about 0.7 ms that
way, most of it building paths that only an error needs. A builder does the same checks with
the path left out: each field's converter is made once, from its description, and accepts
only what it can take without doubt (a float given for a float, an int in range for an int,
a ``dict`` for a nested message, a list of numbers for a numeric sequence). Anything else —
numpy scalars and arrays, a bare value for a one-field type, ``"now"`` for a time, and every
error — raises :class:`Slow`, and ``from_value`` takes the walk it always took, which builds
the same message or raises the same one-line error with its path. So the fast path can only
be faster, never different; ``tests/middleware/test_messages.py`` checks both paths agree.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
from rosbags.interfaces import Nodetype

if TYPE_CHECKING:
    from .messages import MessageTypes

#: what a builder returns for one type: the message, or raises :class:`Slow`
Builder = Callable[[Any], Any]
_MISSING = object()


class Slow(Exception):
    """The fast path declines: ``from_value`` builds the message the long way (or says
    what is wrong with the value)."""


def _slow(value: Any = None) -> Any:
    raise Slow


def compile_builder(types: MessageTypes, name: str) -> Builder:
    """The builder of message type ``name`` (canonical, registered)."""
    from .messages import _built

    _, fields = types.store.fielddefs[name]
    cls = types.store.types[name]
    known = frozenset(field for field, _ in fields)
    written = types._defaults.get(name, {})
    parts: list[tuple[str, Callable[[Any], Any], Callable[[], Any]]] = []
    for field, desc in fields:
        default = (_written_default(types, desc, written[field], field) if field in written
                   else _default(types, desc))
        parts.append((field, _converter(types, desc), default))

    def build(value: Any) -> Any:
        if type(value) is not dict:
            if getattr(value, "__msgtype__", None) == name:
                return value  # a message of the type already: as from_value, itself
            raise Slow
        for key in value:
            if key not in known:
                raise Slow
        get = value.get
        held = {}
        for field, convert, default in parts:
            given = get(field, _MISSING)
            held[field] = default() if given is _MISSING else convert(given)
        return _built(cls, held)
    return build


def _written_default(types: MessageTypes, desc: Any, raw: Any, field: str
                     ) -> Callable[[], Any]:
    """The .msg file's own default of a field, made as from_value makes it."""
    return lambda: types._field(desc, raw, field)


def _default(types: MessageTypes, desc: Any) -> Callable[[], Any]:
    """What a field left out holds (from_value's ``_field_default``), made cheaply: a shared
    immutable value for a number, bool or string, a new nested message or array otherwise."""
    if desc[0] == Nodetype.BASE:
        constant = types._field_default(desc, "")
        return lambda: constant
    if desc[0] == Nodetype.NAME:
        nested = types.builder(desc[1])
        return lambda: nested({})
    template = types._field_default(desc, "")
    if isinstance(template, np.ndarray):  # a covariance's 36 zeros: made once, copied
        return template.copy
    if isinstance(template, list) and not template:
        return list
    return lambda: types._field_default(desc, "")


def _converter(types: MessageTypes, desc: Any) -> Callable[[Any], Any]:
    from .messages import _DTYPES, _FLOATS, _INT_RANGES

    kind = desc[0]
    if kind == Nodetype.BASE:
        return _scalar(desc[1][0], desc[1][1], _FLOATS, _INT_RANGES)
    if kind == Nodetype.NAME:
        nested_name = desc[1]
        nested = types.builder(nested_name)

        def message(value: Any) -> Any:
            if type(value) is dict:
                return nested(value)
            if getattr(value, "__msgtype__", None) == nested_name:
                return value
            raise Slow
        return message
    sub, count = desc[1]
    fixed = kind == Nodetype.ARRAY

    def fits(values: list[Any]) -> bool:
        return len(values) == count if fixed else not count or len(values) <= count

    if sub[0] == Nodetype.BASE and sub[1][0] in _DTYPES and sub[1][0] != "bool":
        element = sub[1][0]
        dtype = _DTYPES[element]
        low_high = _INT_RANGES.get(element)

        def numbers(value: Any) -> Any:
            if type(value) is not list or not fits(value):
                raise Slow
            if low_high is None:  # float32, float64: floats, or ints, never bools
                for x in value:
                    if type(x) is not float and type(x) is not int:
                        raise Slow
            else:
                for x in value:
                    if type(x) is not int:
                        raise Slow
                if value and not (low_high[0] <= min(value) and max(value) <= low_high[1]):
                    raise Slow
            return np.array(value, dtype=dtype)
        return numbers
    if sub[0] == Nodetype.BASE and sub[1][0] in ("string", "wstring"):
        bound = sub[1][1]

        def strings(value: Any) -> Any:
            if type(value) is not list or not fits(value):
                raise Slow
            for x in value:
                if type(x) is not str or (bound and len(x) > bound):
                    raise Slow
            return list(value)
        return strings
    if sub[0] == Nodetype.NAME:
        element_of = _converter(types, sub)

        def messages(value: Any) -> Any:
            if type(value) is not list or not fits(value):
                raise Slow
            return [element_of(x) for x in value]
        return messages
    return _slow  # a sequence of bools: from_value's own walk


def _scalar(kind: str, bound: int, floats: set[str],
            int_ranges: dict[str, tuple[int, int]]) -> Callable[[Any], Any]:
    if kind in floats:
        def real(value: Any) -> Any:
            if type(value) is float:
                return value
            if type(value) is int:
                return float(value)
            raise Slow
        return real
    if kind in int_ranges:
        # a byte above 127 is held signed (messages._signed_octet): the walk converts it
        low, high = (0, 127) if kind == "byte" else int_ranges[kind]

        def integer(value: Any) -> Any:
            if type(value) is int and low <= value <= high:
                return value
            raise Slow
        return integer
    if kind == "bool":
        def boolean(value: Any) -> Any:
            if type(value) is bool:
                return value
            raise Slow
        return boolean
    if kind in ("string", "wstring"):
        def text(value: Any) -> Any:
            if type(value) is str and (not bound or len(value) <= bound):
                return value
            raise Slow
        return text
    return _slow
