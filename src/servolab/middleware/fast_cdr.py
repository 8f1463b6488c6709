"""CDR bytes of ROS 2 messages, a generated serializer and deserializer per type.

Why: rosbags' CDR code (``Typestore.serialize_cdr`` / ``deserialize_cdr``) calls one generated
function per nested message and one ``struct`` call per field, and computes every message's
size in a pass of its own before writing it: about 2.8 us for a ``geometry_msgs/msg/Twist``
each way, more than bare Zenoh takes to carry it between two processes (issue 32). Here each
type gets one function, generated from the same type description rosbags holds
(``Typestore.fielddefs``), in which nested messages are inlined and every run of fixed-size
fields whose alignment is known when the code is generated is one precompiled
``struct.Struct``: a Twist is one ``Struct('<xBxx6d').pack`` with the encapsulation header
inside it, and one ``unpack_from`` back.

The layout is CDR's (OMG CDR, XCDR1, as ROS 2's rmw layers and rosbags write it): each
primitive, and each ``uint32`` length or count, is aligned to its own size (at most 8),
counted from the start of the payload after the 4-byte encapsulation header; a string is a
``uint32`` length that counts its NUL, the UTF-8 bytes and the NUL; a sequence is a ``uint32``
count and its elements, the first of a primitive sequence aligned only if there is one. The
generator tracks what it knows of the position modulo 8 (exactly, after fixed-size fields;
nothing, after a string) and emits padding as constant pad bytes of a ``Struct`` where it
knows, and as a runtime ``& (a - 1)`` only where it does not.

What it gives back is what rosbags gives, so that code using a message sees no difference:
rosbags' message classes, built positionally; Python ``int``, ``float``, ``bool`` and ``str``;
lists for sequences of messages or strings; numpy arrays for primitive arrays and sequences,
read by buffer (a view of the bytes given, not a copy; a copy for big-endian bytes, byte
swapped, as rosbags makes it). Serializing writes what rosbags writes for the same objects,
with the same Python conversions (the same ``struct`` codes: rosbags packs ``byte`` signed
and ``char`` unsigned, and writes a primitive array's bytes through ``.view(uint8)``).

rosbags stays the oracle and the fallback: whatever this code does not take (an array that
is not a contiguous numpy array, a value of the wrong kind, malformed bytes, a type with a
``float128`` or ``wstring``), rosbags does, so what is accepted, what is refused and with
which error is rosbags'; tests/middleware/test_fast_cdr.py checks every type byte for byte
against it. Serializing is little-endian (header ``00 01 00 00``); both byte orders are read.
"""

from __future__ import annotations

import dataclasses
import struct
from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
from rosbags.interfaces import Nodetype
from rosbags.serde import SerdeError
from rosbags.typesys.base import normalize_fieldname

from .errors import MessageError

if TYPE_CHECKING:
    from rosbags.interfaces.typing import FieldDesc
    from rosbags.typesys.store import Typestore

#: A serializer: a message to its CDR bytes, header included.
Serializer = Callable[[Any], bytes]
#: A deserializer: CDR bytes, header included, of one byte order to the message.
Deserializer = Callable[[bytes | memoryview], Any]

#: ``struct`` codes of ROS primitives, as rosbags packs them (rosbags.serde.primitives): ``byte``
#: signed, ``char`` unsigned.
_CODES = {"bool": "?", "byte": "b", "char": "B", "int8": "b", "uint8": "B", "int16": "h",
          "uint16": "H", "int32": "i", "uint32": "I", "int64": "q", "uint64": "Q",
          "float32": "f", "float64": "d"}
_SIZES = {base: struct.calcsize(code) for base, code in _CODES.items()}
#: numpy dtypes of primitive arrays, as rosbags makes them (rosbags.serde.utils.ndtype):
#: ``byte`` is int8, ``char`` uint8.
_DTYPES = {"bool": np.dtype(np.bool_), "byte": np.dtype(np.byte), "char": np.dtype(np.uint8),
           "int8": np.dtype(np.int8), "uint8": np.dtype(np.uint8), "int16": np.dtype(np.int16),
           "uint16": np.dtype(np.uint16), "int32": np.dtype(np.int32),
           "uint32": np.dtype(np.uint32), "int64": np.dtype(np.int64),
           "uint64": np.dtype(np.uint64), "float32": np.dtype(np.float32),
           "float64": np.dtype(np.float64)}

#: What a position is known to be: ``(m, r)``, the payload offset is ``r`` modulo ``m``
#: (``m`` in 1, 2, 4, 8; ``(1, 0)`` knows nothing).
Known = tuple[int, int]


class CdrError(MessageError):
    """Bytes the generated code refuses (rosbags then says why) or a type it does not
    generate."""


class _Unsupported(Exception):
    """A type the generator leaves to rosbags (``float128``, ``wstring``)."""


def _blob(value: Any, count: int, nbytes: int) -> bytes:
    """A fixed-size primitive array's bytes, exactly as rosbags writes them: it checks the
    length, then copies ``value.view(uint8)`` (whatever its dtype) into a slot of
    ``nbytes``, which refuses any other shape."""
    if len(value) != count:
        raise SerdeError("Unexpected array length")
    raw = value.view(np.uint8)
    if raw.shape != (nbytes,):
        raise CdrError(f"array of {raw.shape} bytes where {nbytes} belong")
    data: bytes = raw.tobytes()
    return data


def _bad(what: str) -> CdrError:
    return CdrError(what)


def _meet(a: Known, b: Known) -> Known:
    """What is known of a position that is either ``a`` or ``b``."""
    m = min(a[0], b[0])
    while a[1] % m != b[1] % m:
        m //= 2
    return m, a[1] % m


def _after_repeats(start: Known, size: int) -> Known:
    """What is known after any number of ``size`` bytes from ``start``."""
    g = min(start[0], size & -size) if size else start[0]
    return g, start[1] % g


def _plain_fields(cls: type, fields: list[str]) -> dict[str, Any] | None:
    """The attributes beyond ``fields`` that ``cls(*values)`` sets, with the values it sets
    them to (rosbags' ``__msgtype__``), when that is all its ``__init__`` does: then the
    generated code may set them itself on ``object.__new__(cls)``. Else None.

    Asked of the class, not assumed: a dataclass (not frozen, no slots, no ``__post_init__``)
    is made once with a distinct object per field, and what it holds afterwards must be those
    objects under the fields' names, and otherwise only the very default objects of its other
    fields. A class with its own ``__init__`` or ``__new__``, or a field made by a factory, is
    called as it is."""
    if (not dataclasses.is_dataclass(cls) or hasattr(cls, "__post_init__")
            or "__slots__" in vars(cls)
            or cls.__dataclass_params__.frozen  # type: ignore[attr-defined]
            or cls.__new__ is not object.__new__
            # dataclasses compiles the __init__ it writes from a string: one written by
            # hand may do what the probe below cannot see (register the instance, say)
            or getattr(getattr(cls.__init__, "__code__", None), "co_filename", "") != "<string>"):
        return None
    given = [object() for _ in fields]
    # (probed without the field checks MessageTypes puts on assignment, which the generated
    # code does not go through: it writes the instance's dict, with values it read itself)
    probe = type(cls.__name__, (cls,), {"__setattr__": object.__setattr__})
    try:
        made = probe(*given)
    except Exception:
        return None  # it checks its arguments: call it
    held = dict(vars(made))
    if any(held.pop(field, None) is not value for field, value in zip(fields, given,
                                                                       strict=True)):
        return None
    by_name = {f.name: f for f in dataclasses.fields(cls)}
    extra: dict[str, Any] = {}
    for name, value in held.items():
        field = by_name.get(name)
        if field is None or value is not field.default:
            return None  # set by something else than its plain default
        extra[name] = field.default
    return extra


#: Names every generated module sees.
def _u8view(value: Any) -> np.ndarray:
    """A primitive sequence's bytes: a numpy array's (what servolab reads and defaults to), or
    an ``array.array``'s (what assigning a list to the field makes, as rclpy does)."""
    if type(value) is np.ndarray:
        return value.view(np.uint8)
    return np.frombuffer(value, dtype=np.uint8)


_NAMESPACE: dict[str, Any] = {"_new": object.__new__, "_u8view": _u8view,
                              "_fb": np.frombuffer, "_u8": np.uint8,
                              "_blob": _blob, "_bad": _bad, "_SerdeError": SerdeError, "_str": str,
                              "_Z": tuple(bytes(n) for n in range(8)),
                              "_U32LE": struct.Struct("<I"), "_U32BE": struct.Struct(">I")}


class _Source:
    """The text of one generated function and the constants it names."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.ns: dict[str, Any] = dict(_NAMESPACE)
        self._count = 0

    def name(self, prefix: str) -> str:
        self._count += 1
        return f"{prefix}{self._count}"

    def const(self, prefix: str, value: Any) -> str:
        name = self.name(prefix)
        self.ns[name] = value
        return name

    def compile(self, function: str) -> Callable[..., Any]:
        code = "\n".join(self.lines)
        exec(compile(code, f"<servolab.fast_cdr {function}>", "exec"), self.ns)
        func: Callable[..., Any] = self.ns[function]
        func.__doc__ = code  # the generated text, for whoever wonders what runs
        return func


class _Gen(ABC):
    """What the serializer's and deserializer's generators share: the type descriptions,
    what is known of the position, and the run of fixed-size fields being gathered into one
    ``Struct``: (struct code, value expression or target name, or None for padding)."""

    prefix = "<"

    def __init__(self, codec: FastCdr, src: _Source, indent: int, known: Known) -> None:
        self.codec = codec
        self.src = src
        self.indent = indent
        self.m, self.r = known
        self.run: list[tuple[str, str | None]] = []
        self.run_size = 0
        self.dynamic = False  # emitted anything but runs (strings, loops, runtime alignment)

    @property
    def known(self) -> Known:
        return self.m, self.r

    def emit(self, line: str, extra: int = 0) -> None:
        self.src.lines.append("    " * (self.indent + extra) + line)

    @abstractmethod
    def flush(self) -> None: ...

    @abstractmethod
    def runtime_align(self, a: int) -> str: ...

    @abstractmethod
    def skip(self, pad: int) -> str: ...

    def align(self, a: int) -> None:
        """Pad to a multiple of ``a``: pad bytes in the run when the position's remainder is
        known, else a runtime step."""
        if a <= 1:
            return
        if a <= self.m:
            pad = -self.r % a
            if pad:
                self.run.append((f"{pad}x", None))
                self.run_size += pad
                self.r = (self.r + pad) % self.m
            return
        self.flush()
        self.emit(self.runtime_align(a))
        self.dynamic = True
        self.m, self.r = a, 0

    def cond_align(self, a: int, cond: str) -> Known:
        """Align only when ``cond`` holds (a primitive sequence's first element, when there is
        one): what is known then, the run flushed."""
        self.flush()
        if a <= 1:
            return self.known
        if a <= self.m:
            pad = -self.r % a
            if pad:
                self.emit(f"if {cond}: {self.skip(pad)}")
            return self.m, (self.r + pad) % self.m
        self.emit(f"if {cond}: {self.runtime_align(a)}")
        return a, 0

    def item(self, code: str, size: int, token: str | None, align: int = 0) -> None:
        self.align(align or size)
        self.run.append((code, token))
        self.run_size += size
        self.r = (self.r + size) % self.m

    def struct(self, fmt: str) -> tuple[str, int]:
        s = struct.Struct(self.prefix + fmt)
        return self.src.const("S", s), s.size

    def loop_end(self, before: Known, body: Known) -> None:
        """A loop ran zero or more times: known is what holds after either."""
        self.m, self.r = _meet(before, body)
        self.dynamic = True


class _SerGen(_Gen):
    """Emits code appending a message's CDR bytes to the bytearray ``b`` (``len(b) - 4`` is
    the payload offset). ``top``: ``b`` does not exist before the first run, which starts
    with the encapsulation header."""

    def __init__(self, codec: FastCdr, src: _Source, indent: int, known: Known,
                 top: bool = False) -> None:
        super().__init__(codec, src, indent, known)
        self.pre: list[str] = []  # statements the next run's values need
        self.first = top
        if top:
            self.run.append(("xBxx", "1"))  # 00 01 00 00: CDR, little-endian

    def runtime_align(self, a: int) -> str:
        return f"b += _Z[(4 - len(b)) & {a - 1}]"

    def skip(self, pad: int) -> str:
        return f"b += {bytes(pad)!r}"

    def flush(self, final: bool = False) -> None:
        for line in self.pre:
            self.emit(line)
        self.pre = []
        if not self.run:
            return
        name, _ = self.struct("".join(code for code, _ in self.run))
        values = ", ".join(v for _, v in self.run if v is not None)
        if self.first and final:
            self.emit(f"return {name}.pack({values})")
        elif self.first:
            self.emit(f"b = bytearray({name}.pack({values}))")
        else:
            self.emit(f"b += {name}.pack({values})")
        self.first = False
        self.run, self.run_size = [], 0

    def finish(self) -> None:
        """End of the top-level function: return the bytes."""
        if not self.dynamic:
            self.flush(final=True)
            return
        self.flush()
        self.emit("return bytes(b)")

    def message(self, typename: str, expr: str) -> None:
        fields = self.codec.fields(typename)
        if len(fields) > 1 and "." in expr:  # a nested message: look it up once
            local = self.src.name("o")
            self.pre.append(f"{local} = {expr}")
            expr = local
        for name, desc in fields:
            self.field(desc, f"{expr}.{name}")

    def field(self, desc: FieldDesc, expr: str) -> None:
        if desc[0] == Nodetype.BASE:
            base = desc[1][0]
            if base == "string":
                self.string(expr)
            elif base in _CODES:
                self.item(_CODES[base], _SIZES[base], expr)
            else:
                raise _Unsupported(base)
        elif desc[0] == Nodetype.NAME:
            self.message(desc[1], expr)
        elif desc[0] == Nodetype.ARRAY:
            sub, count = desc[1]
            if sub[0] == Nodetype.BASE and sub[1][0] in _CODES:
                size = _SIZES[sub[1][0]]
                self.item(f"{count * size}s", count * size,
                          f"_blob({expr}, {count}, {count * size})", align=size)
                return
            value = self.src.name("a")
            self.pre.append(f"{value} = {expr}")
            self.pre.append(f"if len({value}) != {count}: "
                            "raise _SerdeError('Unexpected array length')")
            self.elements(sub, value)
        else:
            sub = desc[1][0]
            value = self.src.name("a")
            self.pre.append(f"{value} = {expr}")
            if sub[0] == Nodetype.BASE and sub[1][0] in _CODES:
                self.primitives(sub[1][0], value)
                return
            self.item("I", 4, f"len({value})")
            self.elements(sub, value)

    def string(self, expr: str) -> None:
        encoded = self.src.name("s")
        self.pre.append(f"{encoded} = {expr}.encode()")
        self.item("I", 4, f"len({encoded}) + 1")
        self.flush()
        self.emit(f"b += {encoded}")
        self.emit("b += b'\\x00'")
        self.dynamic = True
        self.m, self.r = 1, 0

    def primitives(self, base: str, value: str) -> None:
        """A primitive sequence: its count, then its bytes as rosbags writes them
        (``.view(uint8)``, which must have the count's bytes exactly)."""
        size = _SIZES[base]
        raw, count = self.src.name("r"), self.src.name("n")
        self.pre.append(f"{raw} = _u8view({value})")
        self.pre.append(f"{count} = len({value})")
        self.pre.append(f"if {raw}.shape != ({count} * {size},): "
                        "raise _bad('not a flat array of the sequence')")
        self.item("I", 4, count)
        before = self.known
        start = self.cond_align(size, count)
        self.emit(f"b += memoryview({raw})")
        self.loop_end(before, _after_repeats(start, size))

    def elements(self, sub: Any, value: str) -> None:
        """The elements of an array or sequence of strings or messages, in a loop."""
        self.flush()
        before = self.known
        item = self.src.name("x")
        if sub[0] == Nodetype.NAME and (flat := self.codec.flat(sub[1])):
            fmt, size, paths, first = flat
            start = self.cond_align(first, value)
            name, _ = self.struct(fmt)
            args = ", ".join(f"{item}{path}" for path in paths)
            self.emit(f"for {item} in {value}:")
            self.emit(f"b += {name}.pack({args})", 1)
            self.loop_end(before, _after_repeats(start, size))
            return
        self.emit(f"for {item} in {value}:")
        body = _SerGen(self.codec, self.src, self.indent + 1, (1, 0))
        body.field(sub, item)
        body.flush()
        self.loop_end(before, body.known)


class _DeGen(_Gen):
    """Emits code reading a message from ``d`` at ``p`` (``p - 4`` is the payload offset)
    into locals, and gives back the expression that builds the message from them."""

    def __init__(self, codec: FastCdr, src: _Source, indent: int, known: Known,
                 little: bool) -> None:
        super().__init__(codec, src, indent, known)
        self.little = little
        self.prefix = "<" if little else ">"
        self.swap = "" if little else ".byteswap()"  # rosbags' big-endian arrays: copies
        self.post: list[str] = []  # statements after the run's unpack, ``p`` at its start
        # messages to build once their fields are read: name -> (class, [(field, value)])
        self.builds: dict[str, tuple[type, list[tuple[str, str]]]] = {}

    def runtime_align(self, a: int) -> str:
        return f"p += (4 - p) & {a - 1}"

    def skip(self, pad: int) -> str:
        return f"p += {pad}"

    def flush(self) -> None:
        if not self.run:
            return
        name, size = self.struct("".join(code for code, _ in self.run))
        targets = [t for _, t in self.run if t is not None]
        if targets:
            self.emit(f"{', '.join(targets)}, = {name}.unpack_from(d, p)")
        for line in self.post:
            self.emit(line)
        self.emit(f"p += {size}")
        self.run, self.run_size, self.post = [], 0, []

    def message(self, typename: str) -> str:
        """The name the message will have once :meth:`construct` has built it."""
        values = [(field, self.field(desc)) for field, desc in self.codec.fields(typename)]
        name = self.src.name("o")
        self.builds[name] = (self.codec.store.types[typename], values)
        return name

    def construct(self, name: str) -> None:
        """Emit the statements that build message ``name`` (and those inside it) from the
        locals its fields were read into, now that all are read.

        A plain dataclass (:func:`_plain_fields`) is made with ``object.__new__`` and its
        fields set one by one: what its ``__init__`` does, without a call per nested message,
        which a flood of small messages pays per message (a ``Twist`` is three objects). Any
        other class is called."""
        cls, values = self.builds.pop(name)
        for _, value in values:
            if value in self.builds:
                self.construct(value)
        const = self.src.const("C", cls)
        extra = _plain_fields(cls, [field for field, _ in values])
        if extra is not None:
            self.emit(f"{name} = _new({const})")
            held = self.src.name("d")
            self.emit(f"{held} = {name}.__dict__")
            for field, value in values:
                self.emit(f"{held}[{field!r}] = {value}")
            for field, default in extra.items():
                self.emit(f"{held}[{field!r}] = {self.src.const('K', default)}")
        else:
            self.emit(f"{name} = {const}({', '.join(value for _, value in values)})")

    def field(self, desc: FieldDesc) -> str:
        if desc[0] == Nodetype.BASE:
            base = desc[1][0]
            if base == "string":
                return self.string()
            if base not in _CODES:
                raise _Unsupported(base)
            value = self.src.name("v")
            self.item(_CODES[base], _SIZES[base], value)
            return value
        if desc[0] == Nodetype.NAME:
            return self.message(desc[1])
        if desc[0] == Nodetype.ARRAY:
            sub, length = desc[1]
            if sub[0] == Nodetype.BASE and sub[1][0] in _CODES:
                return self.array(sub[1][0], length)
            self.flush()
            return self.elements(sub, str(length))
        sub = desc[1][0]
        count = self.src.name("n")
        self.item("I", 4, count)
        self.flush()
        if sub[0] == Nodetype.BASE and sub[1][0] in _CODES:
            return self.primitives(sub[1][0], count)
        # rosbags' check_sequence: a count the bytes left cannot hold is an error, found
        # before a loop of billions starts
        least = 5 if sub[0] == Nodetype.BASE else 1
        self.emit(f"if {count} * {least} > len(d) - p: raise _bad('sequence too long')")
        return self.elements(sub, count)

    def string(self) -> str:
        length, end, value = self.src.name("n"), self.src.name("e"), self.src.name("s")
        self.item("I", 4, length)
        self.flush()
        self.emit(f"{end} = p + {length}")
        self.emit(f"if not {length} or d[{end} - 1]: raise _bad('bad string')")
        self.emit(f"{value} = _str(d[p:{end} - 1], 'utf-8')")
        self.emit(f"p = {end}")
        self.dynamic = True
        self.m, self.r = 1, 0
        return value

    def array(self, base: str, count: int) -> str:
        """A fixed-size primitive array inside the run: skipped by the ``Struct``, read as a
        numpy array from its offset."""
        size = _SIZES[base]
        self.align(size)
        value = self.src.name("a")
        dtype = self.src.const("D", _DTYPES[base])
        self.post.append(f"{value} = _fb(d, {dtype}, {count}, p + {self.run_size}){self.swap}")
        self.item(f"{count * size}x", count * size, None, align=size)
        return value

    def primitives(self, base: str, count: str) -> str:
        size = _SIZES[base]
        before = self.known
        start = self.cond_align(size, count)
        value = self.src.name("a")
        dtype = self.src.const("D", _DTYPES[base])
        self.emit(f"{value} = _fb(d, {dtype}, {count}, p){self.swap}")
        self.emit(f"p += {count} * {size}" if size > 1 else f"p += {count}")
        self.loop_end(before, _after_repeats(start, size))
        return value

    def elements(self, sub: Any, count: str) -> str:
        before = self.known
        items = self.src.name("l")
        if sub[0] == Nodetype.NAME and (flat := self.codec.flat(sub[1])):
            # a fixed-size message whose elements follow each other without padding
            fmt, size, paths, first = flat
            start = self.cond_align(first, count)
            name, _ = self.struct(fmt)
            end = self.src.name("e")
            names = [self.src.name("v") for _ in paths]
            build = self.codec.flat_ctor(self.src, sub[1], iter(names))
            self.emit(f"{end} = p + {count} * {size}")
            self.emit(f"if {end} > len(d): raise _bad('sequence too long')")
            self.emit(f"{items} = [{build} for {', '.join(names)}, "
                      f"in {name}.iter_unpack(d[p:{end}])]")
            self.emit(f"p = {end}")
            self.loop_end(before, _after_repeats(start, size))
            return items
        self.emit(f"{items} = []")
        self.emit(f"for _ in range({count}):")
        body = _DeGen(self.codec, self.src, self.indent + 1, (1, 0), self.little)
        value = body.field(sub)
        body.flush()
        if value in body.builds:
            body.construct(value)
        body.emit(f"{items}.append({value})")
        self.loop_end(before, body.known)
        return items


class FastCdr:
    """Generated CDR code for the types of one rosbags :class:`Typestore`, built per type on
    first use. Types registered in the store later are found as well; a type's definition
    never changes once registered (rosbags refuses that)."""

    def __init__(self, store: Typestore) -> None:
        self.store = store
        self._serializers: dict[str, Serializer] = {}
        self._writers: dict[str, Serializer] = {}
        self._deserializers: dict[str, tuple[Deserializer, Deserializer]] = {}
        self._fields: dict[str, list[tuple[str, FieldDesc]]] = {}
        self._flat: dict[str, tuple[str, int, list[str], int] | None] = {}

    # -- what a caller uses ----------------------------------------------------------------

    def serialize(self, msg: Any, typename: str) -> bytes:
        """Little-endian CDR bytes of ``msg``, header included (rosbags' for what the
        generated code does not take, so rosbags' error for what neither does)."""
        return (self._writers.get(typename) or self.writer(typename))(msg)

    def writer(self, typename: str) -> Serializer:
        """What :meth:`serialize` does for one type, as one function a publisher keeps."""
        write = self._writers.get(typename)
        if write is None:
            func, store = self.serializer(typename), self.store

            def write(msg: Any) -> bytes:
                try:
                    return func(msg)
                except Exception:
                    return bytes(store.serialize_cdr(msg, typename, little_endian=True))
            self._writers[typename] = write
        return write

    def deserialize(self, data: bytes | memoryview, typename: str) -> Any:
        """The message of CDR bytes of either byte order (rosbags reads what the generated
        code refuses, and says what is wrong with bytes that neither reads)."""
        if len(data) >= 4 and data[0] == 0 and data[1] in (0, 1):
            funcs = self._deserializers.get(typename) or self._build_deserializers(typename)
            try:
                return funcs[data[1]](data)
            except Exception:
                pass
        return self.store.deserialize_cdr(data, typename)

    def serializer(self, typename: str) -> Serializer:
        """The generated serializer of a type (rosbags' for a type it does not generate)."""
        func = self._serializers.get(typename)
        if func is None:
            try:
                func = self._generate_serializer(typename)
            except _Unsupported:
                store = self.store

                def func(msg: Any) -> bytes:
                    return bytes(store.serialize_cdr(msg, typename, little_endian=True))
            self._serializers[typename] = func
        return func

    def deserializer(self, typename: str, little_endian: bool = True) -> Deserializer:
        """The generated deserializer of a type for one byte order (rosbags' for a type it
        does not generate); it checks the header's byte order no more."""
        funcs = self._deserializers.get(typename) or self._build_deserializers(typename)
        return funcs[little_endian]

    def reader(self, typename: str) -> Deserializer:
        """What :meth:`deserialize` does for one type, as one function a subscription keeps:
        the header's byte order picks the generated code, rosbags reads what it refuses, and
        bytes neither reads raise a one-line :class:`CdrError` (a message's cost per receipt
        is this one call and the generated one)."""
        big, little = self._deserializers.get(typename) or self._build_deserializers(typename)
        store = self.store

        def other(data: bytes | memoryview) -> Any:
            if len(data) >= 4 and data[0] == 0 and data[1] == 0:
                try:
                    return big(data)
                except Exception:
                    pass
            try:
                return store.deserialize_cdr(data, typename)
            except Exception as exc:
                why = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
                raise CdrError(f"{len(data)} bytes are not a CDR {typename}: {why}") from None

        def read(data: bytes | memoryview) -> Any:
            try:  # little-endian CDR, what every ROS 2 writer here sends: two looks, one call
                if data[1] == 1 and not data[0]:
                    return little(data)
            except Exception:
                pass  # too short, or what the generated code refuses: rosbags says why
            return other(data)
        return read

    def source(self, typename: str) -> str | None:
        """The generated Python of a type's serializer and little-endian deserializer, or
        None when rosbags serves the type (what a test or a curious reader looks at)."""
        ser, de = self.serializer(typename), self.deserializer(typename)
        if ser.__name__ != "serialize" or de.__name__ != "deserialize":
            return None
        return f"{ser.__doc__}\n{de.__doc__}"

    # -- generating ------------------------------------------------------------------------

    def _build_deserializers(self, typename: str) -> tuple[Deserializer, Deserializer]:
        try:
            funcs = (self._generate_deserializer(typename, little=False),
                     self._generate_deserializer(typename, little=True))
        except _Unsupported:
            store = self.store

            def fallback(data: bytes | memoryview) -> Any:
                return store.deserialize_cdr(data, typename)
            funcs = (fallback, fallback)
        self._deserializers[typename] = funcs
        return funcs

    def _generate_serializer(self, typename: str) -> Serializer:
        src = _Source()
        src.lines.append("def serialize(m):")
        gen = _SerGen(self, src, 1, (8, 0), top=True)
        gen.message(typename, "m")
        gen.finish()
        func: Serializer = src.compile("serialize")
        return func

    def _generate_deserializer(self, typename: str, little: bool) -> Deserializer:
        src = _Source()
        src.lines.append("def deserialize(d):")
        gen = _DeGen(self, src, 1, (8, 0), little)
        gen.emit("p = 4")
        build = gen.message(typename)
        gen.flush()
        # rosbags allows up to 3 bytes after the message (padding some writers add)
        gen.emit("if p + 3 < len(d): raise _bad('bytes left over')")
        gen.construct(build)
        gen.emit(f"return {build}")
        func: Deserializer = src.compile("deserialize")
        return func

    def fields(self, typename: str) -> list[tuple[str, FieldDesc]]:
        """A type's fields as its class names them (a Python keyword gets a ``_``)."""
        found = self._fields.get(typename)
        if found is None:
            found = [(normalize_fieldname(name), desc)
                     for name, desc in self.store.fielddefs[typename][1]]
            self._fields[typename] = found
        return found

    def const_class(self, src: _Source, typename: str) -> str:
        return src.const("C", self.store.types[typename])

    def first_align(self, desc: Any) -> int:
        """The alignment of what a field starts with (rosbags' ``align``)."""
        if desc[0] == Nodetype.BASE:
            return 4 if desc[1][0] == "string" else _SIZES.get(desc[1][0], 8)
        if desc[0] == Nodetype.NAME:
            return self.first_align(self.fields(desc[1])[0][1])
        if desc[0] == Nodetype.ARRAY:
            return self.first_align(desc[1][0])
        return 4

    def flat(self, typename: str) -> tuple[str, int, list[str], int] | None:
        """A message of fixed-size primitives only (nested or not) whose every element of a
        sequence, aligned to its first field as CDR aligns it, has the same layout and
        follows the one before without padding: ``(struct format, size, attribute paths,
        alignment)``; else None. A ``PoseArray``'s poses, a ``Polygon``'s points."""
        if typename in self._flat:
            return self._flat[typename]
        first = self.first_align((Nodetype.NAME, typename))
        fmt: list[str] = []
        paths: list[str] = []
        offset = 0

        def walk(name: str, path: str) -> bool:
            nonlocal offset
            for field, desc in self.fields(name):
                if desc[0] == Nodetype.NAME:
                    if not walk(desc[1], f"{path}.{field}"):
                        return False
                    continue
                if desc[0] != Nodetype.BASE or desc[1][0] not in _CODES:
                    return False
                size = _SIZES[desc[1][0]]
                if size > first:
                    return False  # its alignment depends on where the element starts
                if pad := -offset % size:
                    fmt.append(f"{pad}x")
                    offset += pad
                fmt.append(_CODES[desc[1][0]])
                paths.append(f"{path}.{field}")
                offset += size
            return True

        found = ("".join(fmt), offset, paths, first) if (
            walk(typename, "") and offset % first == 0) else None
        self._flat[typename] = found
        return found

    def flat_ctor(self, src: _Source, typename: str, names: Any) -> str:
        """The expression building a flat message from its values' names, in order."""
        args = [self.flat_ctor(src, desc[1], names) if desc[0] == Nodetype.NAME
                else next(names) for _, desc in self.fields(typename)]
        return f"{self.const_class(src, typename)}({', '.join(args)})"
