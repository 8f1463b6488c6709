"""One loader for the YAML files a user writes: every value keeps its file, line and key path.

Why one loader: launch files, ROS 2 parameter files and motor specs each used to compose YAML
and track lines their own way, and more formats are coming (controller, costmap and robot base
configurations). A mistake in any of them should read the same way, ``path:line: message``,
raised as one class, :class:`servolab.errors.ConfigFileError` (a consumer passes its own
subclass, so its callers keep catching the family's error too).

Why not ``yaml.safe_load``: it forgets where a value was written, and it silently keeps the last
of two equal keys, so a doubled ``rate:`` is a value the user never sees being ignored. Here the
file is composed with PyYAML's SafeLoader (lines kept), duplicate keys are refused naming both
lines, and each scalar is built with the safe constructor, so the values are those
``safe_load`` would give. Mapping keys are names: the key as written (``1:`` is the key ``"1"``).

The result is a tree of :class:`ConfigValue`: :class:`ConfigMapping`, :class:`ConfigList` and
:class:`ConfigScalar`. Each knows its ``path``, ``line`` (from 1) and ``key``, the dotted path
from the top with ``[i]`` for list items counted from 0 (``nodes[2].parameters.rate``), and
makes errors there with :meth:`ConfigValue.error`. The typed accessors (``as_int``,
``as_bool``, ...) are strict, in the spirit of rosbags' checks: ``true`` is not a number,
``.nan`` is not a usable float unless asked for, a list is not a string. Their messages say
``<what>: must be <kind>, not <what was written>``, where ``what`` defaults to
``key '<key path>'`` and a consumer may name the value in its own words.
"""

from __future__ import annotations

import difflib
import math
import re
from abc import ABC, abstractmethod
from collections.abc import Collection, Iterator
from datetime import date
from pathlib import Path
from typing import TypeAlias

import yaml
from yaml.constructor import SafeConstructor

from .errors import ConfigFileError
from .limits import ECHO_WIDTH, InputLimits, clip, quoted, read_limited

#: What a scalar can hold: what ``yaml.safe_load`` makes of one (``!!binary`` gives bytes,
#: a timestamp a date or datetime).
ScalarValue: TypeAlias = bool | int | float | str | bytes | date | None
#: The plain Python value of a subtree, as ``yaml.safe_load`` would give it (keys as written).
Plain: TypeAlias = ScalarValue | list["Plain"] | dict[str, "Plain"]

_MAP_TAG = "tag:yaml.org,2002:map"
_SEQ_TAG = "tag:yaml.org,2002:seq"
_MERGE_TAG = "tag:yaml.org,2002:merge"
#: Tags PyYAML gives the plain scalars ``<<`` and ``=`` but cannot construct; as values they
#: are the text written, as ``=`` in a command's arguments.
_TEXT_TAGS = (_MERGE_TAG, "tag:yaml.org,2002:value")
_SCALAR_TYPES = (type(None), bool, int, float, str, bytes, date)


def suggest(name: str, choices: Collection[str]) -> str | None:
    """The choice ``name`` was most likely meant to be, if one is close (a typo)."""
    close = difflib.get_close_matches(name, list(choices), n=1)
    return close[0] if close else None


def unknown_key(name: str, allowed: Collection[str]) -> str:
    """``unknown key 'x'``, with ``(did you mean 'y'?)`` when an allowed key is close."""
    close = suggest(name, allowed)
    return f"unknown key {quoted(name)}" + (f" (did you mean {close!r}?)" if close else "")


class ConfigValue(ABC):
    """A value of a configuration file and where it was written.

    The accessors check the kind of value a consumer needs and return it as a Python value,
    or raise the file's error class at this value's line; ``what`` replaces
    ``key '<key path>'`` at the start of their messages (e.g. ``"node 'talker': key 'rate'"``).
    """

    __slots__ = ("_error", "key", "line", "path")

    def __init__(self, path: str, line: int, key: str, error: type[ConfigFileError]) -> None:
        self.path = path
        self.line = line
        self.key = key
        self._error = error

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.key or '(top)'!r} at {self.path}:{self.line}>"

    def error(self, message: str) -> ConfigFileError:
        """An error at this value: ``path:line: message``, carrying path, line and key."""
        return self._error(self.path, self.line, self.key, message)

    @property
    def error_class(self) -> type[ConfigFileError]:
        """The class this file's errors are raised as: a value made from this one (a launch
        file's substitution) keeps it."""
        return self._error

    @abstractmethod
    def describe(self) -> str:
        """What was written here, in a few words, for an error message."""

    @abstractmethod
    def plain(self) -> Plain:
        """The plain Python value of this subtree (for values passed on as they are, such as
        ROS parameter values)."""

    def child_key(self, name: str | int) -> str:
        """The key path of an entry of this mapping (a name) or item of this list (an index)."""
        if isinstance(name, int):
            return f"{self.key}[{name}]"
        return f"{self.key}.{name}" if self.key else name

    def _subject(self, what: str | None) -> str:
        if what is not None:
            return what
        return f"key {quoted(self.key)}" if self.key else "the file"

    def _wrong(self, what: str | None, wanted: str) -> ConfigFileError:
        return self.error(f"{self._subject(what)}: must be {wanted}, not {self.describe()}")

    def as_mapping(self, what: str | None = None) -> ConfigMapping:
        raise self._wrong(what, "a mapping")

    def as_list(self, what: str | None = None) -> ConfigList:
        raise self._wrong(what, "a list")

    def as_str(self, what: str | None = None, *, nonempty: bool = False) -> str:
        """A string as YAML reads it: ``5`` or ``true`` is refused, ``"5"`` is a string."""
        raise self._wrong(what, "a non-empty string" if nonempty else "a string")

    def as_int(self, what: str | None = None) -> int:
        """An integer; ``true`` and ``2.0`` are refused (YAML's bool is a Python int)."""
        raise self._wrong(what, "an integer")

    def as_float(self, what: str | None = None, *, finite: bool = True) -> float:
        """A number as a float (``2`` is 2.0); ``true`` is refused, and so are ``.nan`` and
        ``.inf`` unless ``finite`` is False."""
        raise self._wrong(what, "a finite number" if finite else "a number")

    def as_bool(self, what: str | None = None) -> bool:
        """``true`` or ``false`` (YAML 1.1 also reads ``yes``/``no``/``on``/``off``)."""
        raise self._wrong(what, "true or false")

    def one_or_many(self) -> list[ConfigValue]:
        """The items of a list, or this value alone (for keys taking one thing or several)."""
        return [self]

    def as_strings(self, what: str | None = None, *, nonempty: bool = False) -> list[str]:
        """A string or a list of strings, as a list."""
        return [item.as_str(what, nonempty=nonempty) for item in self.one_or_many()]


class ConfigScalar(ConfigValue):
    """A single value: ``value`` as ``yaml.safe_load`` reads it, ``text`` as written."""

    __slots__ = ("text", "value")

    def __init__(self, path: str, line: int, key: str, error: type[ConfigFileError],
                 value: ScalarValue, text: str) -> None:
        super().__init__(path, line, key, error)
        self.value = value
        self.text = text

    def describe(self) -> str:
        if not self.key:  # the whole file is this one value: say what kind, not what
            return ("nothing" if self.value is None else "text"
                    if isinstance(self.value, str) else "a single value")
        if isinstance(self.value, str):
            return quoted(self.value, 42)
        if self.value is None:
            return clip(self.text, 42) or "nothing"
        if isinstance(self.value, bytes):
            return "binary data"
        return clip(self.text, 42)

    def plain(self) -> ScalarValue:
        return self.value

    def as_str(self, what: str | None = None, *, nonempty: bool = False) -> str:
        if isinstance(self.value, str) and (self.value or not nonempty):
            return self.value
        return super().as_str(what, nonempty=nonempty)

    def as_int(self, what: str | None = None) -> int:
        if isinstance(self.value, int) and not isinstance(self.value, bool):
            return self.value
        return super().as_int(what)

    def as_float(self, what: str | None = None, *, finite: bool = True) -> float:
        value = self.value
        if (isinstance(value, int | float) and not isinstance(value, bool)
                and (not finite or math.isfinite(value))):
            return float(value)
        return super().as_float(what, finite=finite)

    def as_bool(self, what: str | None = None) -> bool:
        if isinstance(self.value, bool):
            return self.value
        return super().as_bool(what)


class ConfigList(ConfigValue):
    """A sequence; its items are located values too."""

    __slots__ = ("items",)

    def __init__(self, path: str, line: int, key: str, error: type[ConfigFileError],
                 items: tuple[ConfigValue, ...]) -> None:
        super().__init__(path, line, key, error)
        self.items = items

    def __iter__(self) -> Iterator[ConfigValue]:
        return iter(self.items)

    def __len__(self) -> int:
        return len(self.items)

    def __getitem__(self, index: int) -> ConfigValue:
        return self.items[index]

    def describe(self) -> str:
        return "a list"

    def plain(self) -> list[Plain]:
        return [item.plain() for item in self.items]

    def as_list(self, what: str | None = None) -> ConfigList:
        return self

    def one_or_many(self) -> list[ConfigValue]:
        return list(self.items)


class ConfigMapping(ConfigValue):
    """A mapping of names (in file order, without duplicates) to located values; each key is
    located too (:meth:`key_of`), for errors about the key itself rather than its value."""

    __slots__ = ("_entries",)

    def __init__(self, path: str, line: int, key: str, error: type[ConfigFileError],
                 entries: dict[str, tuple[ConfigScalar, ConfigValue]]) -> None:
        super().__init__(path, line, key, error)
        self._entries = entries

    def __contains__(self, name: object) -> bool:
        return name in self._entries

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries)

    def __len__(self) -> int:
        return len(self._entries)

    def items(self) -> Iterator[tuple[str, ConfigValue]]:
        for name, (_, value) in self._entries.items():
            yield name, value

    def key_of(self, name: str) -> ConfigScalar:
        """Where the key ``name`` is written (a KeyError if it is not: check first)."""
        return self._entries[name][0]

    def get(self, name: str) -> ConfigValue | None:
        entry = self._entries.get(name)
        return entry[1] if entry is not None else None

    def require(self, name: str, what: str | None = None) -> ConfigValue:
        """The value of ``name``, or an error at this mapping saying it is missing
        (``what`` names the mapping, e.g. ``"node 'talker'"``)."""
        entry = self._entries.get(name)
        if entry is None:
            raise self.error(self._key_message(what, name, "key {} missing"))
        return entry[1]

    def check_keys(self, allowed: Collection[str], *, required: Collection[str] = (),
                   what: str | None = None) -> None:
        """Refuse any key not in ``allowed`` (at the key, suggesting the closest allowed one),
        then any key of ``required`` that is missing (at the mapping)."""
        for name, (key, _) in self._entries.items():
            if name not in allowed:
                close = suggest(name, allowed) if len(name) <= ECHO_WIDTH else None
                hint = f" (did you mean {close!r}?)" if close else ""
                raise key.error(self._key_message(what, name, "unknown key {}") + hint)
        for name in required:
            self.require(name, what)

    def describe(self) -> str:
        return "a mapping"

    def plain(self) -> dict[str, Plain]:
        return {name: value.plain() for name, (_, value) in self._entries.items()}

    def as_mapping(self, what: str | None = None) -> ConfigMapping:
        return self

    def _key_message(self, what: str | None, name: str, template: str) -> str:
        if what is not None:
            return f"{what}: " + template.format(quoted(name))
        return template.format(quoted(self.child_key(name)))


# -- loading ---------------------------------------------------------------------------------


def shipped(package: str, name: str) -> Path:
    """The configuration file ``name`` that servolab installs as package data of ``package``
    (``shipped("servolab.robots.armstrong", "armstrong.yaml")``).

    Defaults live beside the code that reads them, as dm_control's ``cartpole.xml`` does, so a
    ``pip install`` gives every command its defaults from any directory; a clone's
    ``configs/`` holds only launch files and examples to copy. A path rather than a
    ``Traversable``: errors name the file and line, and a wheel installs to the file system.
    """
    from importlib.resources import files

    return Path(str(files(package).joinpath(name)))


def load(path: str | Path, *, what: str = "configuration file",
         error: type[ConfigFileError] = ConfigFileError, kind: str | None = None,
         limits: InputLimits | None = None) -> ConfigValue:
    """Read and compose a YAML file; ``what`` names the kind of file in the error when it
    cannot be read, ``error`` is the class every error of this file is raised as.

    A file larger than the YAML limit (:class:`servolab.limits.InputLimits`, ``yaml_mb``) is
    refused before it is read. With ``kind`` (``"parameter file"``), a file that is not
    UTF-8 YAML text is refused as ``not a <kind>``, with where the reader stopped and
    nothing of what it holds (a launch file naming ``/etc/shadow`` as its parameters echoes
    none of it); see :func:`load_text`.

    An empty file (or one of comments only) is a null scalar on line 1.
    """
    def too_big(message: str) -> ConfigFileError:
        return error(path, 0, "", message)

    try:
        data = read_limited(path, "yaml_mb", what, too_big, limits)
    except OSError as exc:
        raise error(path, 0, "", f"cannot read {what} ({exc.strerror or exc})") from None
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        if kind is not None:
            raise error(path, line, "", f"not UTF-8 text: not {_a(kind)}") from None
        raise error(path, line, "", f"not UTF-8 text (byte 0x{data[exc.start]:02x}; "
                    f"is this a {what}?)") from None
    return load_text(text, str(path), error=error, kind=kind)


def _a(noun: str) -> str:
    return f"an {noun}" if noun[:1] in "aeiou" else f"a {noun}"


def load_text(text: str, source: str = "<text>", *,
              error: type[ConfigFileError] = ConfigFileError,
              kind: str | None = None) -> ConfigValue:
    """Compose YAML text; ``source`` stands for the path in errors.

    A syntax error is ``not valid YAML (<PyYAML's problem>) at column C`` on its line,
    without the characters PyYAML would quote from the text; with ``kind``, it ends
    ``: not a <kind>``."""
    suffix = f": not {_a(kind)}" if kind is not None else ""
    try:
        root = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError as exc:
        line, column, problem = _yaml_problem(exc, text)
        at = f" at column {column}" if column else ""
        raise error(source, line, "", f"not valid YAML ({problem}){at}{suffix}") from None
    except RecursionError:
        raise error(source, 0, "", f"not valid YAML (nested too deeply){suffix}") from None
    if root is None:
        return ConfigScalar(source, 1, "", error, None, "")
    try:
        return _Builder(source, error, suffix).build(root, "", frozenset())
    except RecursionError:
        raise error(source, 0, "", "nested too deeply") from None


#: What PyYAML quotes of the text in a problem (a character, a tag, an escape): left out
#: of errors, which name the line and column instead.
_QUOTED = re.compile(r""" ?(?:'(?:[^'\\]|\\.)*'|"(?:[^"\\]|\\.)*"|#x[0-9a-fA-F]+)""")


_SYNTAX = {f"'{c}'" for c in ",[]{}:?-"}


def _unquoted(problem: str) -> str:
    def shown(match: re.Match[str]) -> str:
        quote = match.group().strip()
        if (quote.startswith("'<") and quote.endswith(">'")) or quote in _SYNTAX:
            return match.group()  # a token ('<stream end>') or YAML's own punctuation
        return " (a tab)" if quote == "'\\t'" else ""

    return clip(" ".join(_QUOTED.sub(shown, problem).split()))


def _yaml_problem(exc: yaml.YAMLError, text: str) -> tuple[int, int, str]:
    """The line, column (both from 1; 0 if unknown) and one-line description of a YAML syntax
    error, without the text PyYAML quotes."""
    if isinstance(exc, yaml.reader.ReaderError):  # a character YAML does not allow
        start = text.rfind("\n", 0, exc.position) + 1
        return (text.count("\n", 0, exc.position) + 1, exc.position - start + 1,
                _unquoted(str(exc).splitlines()[0]))
    mark = getattr(exc, "problem_mark", None)
    line = mark.line + 1 if mark is not None else 1
    column = mark.column + 1 if mark is not None else 0
    problem = _unquoted(str(getattr(exc, "problem", None) or str(exc).splitlines()[0]))
    context, context_mark = getattr(exc, "context", None), getattr(exc, "context_mark", None)
    if context and context_mark is not None and context_mark.line + 1 != line:
        problem += f"; {_unquoted(context)} on line {context_mark.line + 1}"  # an unclosed [
    return line, column, problem


class _Builder:
    """Turns composed nodes into located values, refusing what ``safe_load`` would not read
    the same way (duplicate keys, merge keys) and what no consumer can use (keys that are
    not names, tags of collections)."""

    #: Values one file may hold once its aliases are expanded. Every alias is built anew (so
    #: each use keeps its own key path), so a few nested aliases could otherwise stand for
    #: billions of values (the "billion laughs").
    MAX_VALUES = 200_000

    def __init__(self, source: str, error: type[ConfigFileError], suffix: str = "") -> None:
        #: ``": not a <kind>"`` when the file was read as one kind: its values are not quoted
        self.suffix = suffix
        self.source = source
        self.error = error
        self.constructor = SafeConstructor()
        self.built = 0

    def fail(self, node: yaml.Node, key: str, message: str) -> ConfigFileError:
        return self.error(self.source, node.start_mark.line + 1, key, message)

    def tag(self, node: yaml.Node) -> str:
        """The node's tag for an error: quoted, unless the file was read as one kind."""
        return "a tag" if self.suffix else f"tag {quoted(node.tag)}"

    def build(self, node: yaml.Node, key: str, parents: frozenset[int]) -> ConfigValue:
        line = node.start_mark.line + 1
        self.built += 1
        if self.built > self.MAX_VALUES:
            raise self.fail(node, key, f"more than {self.MAX_VALUES} values once its aliases "
                            "are expanded; write the file without nested aliases")
        if id(node) in parents:
            raise self.fail(node, key, "an alias refers to a value that contains it")
        if isinstance(node, yaml.ScalarNode):
            return self.scalar(node, key)
        parents = parents | {id(node)}
        if isinstance(node, yaml.SequenceNode):
            if node.tag != _SEQ_TAG:
                raise self.fail(node, key, f"{self.tag(node)} is not supported here{self.suffix}")
            items = tuple(self.build(item, f"{key}[{index}]", parents)
                          for index, item in enumerate(node.value))
            return ConfigList(self.source, line, key, self.error, items)
        assert isinstance(node, yaml.MappingNode)
        if node.tag != _MAP_TAG:
            raise self.fail(node, key, f"{self.tag(node)} is not supported here{self.suffix}")
        entries: dict[str, tuple[ConfigScalar, ConfigValue]] = {}
        for key_node, value_node in node.value:
            if not isinstance(key_node, yaml.ScalarNode) or not key_node.value:
                raise self.fail(key_node, key, "keys must be names")
            name = str(key_node.value)
            child = f"{key}.{name}" if key else name
            if key_node.tag == _MERGE_TAG:
                raise self.fail(key_node, child, "merge keys (<<) are not supported; write "
                                "the keys out")
            if name in entries:
                first = entries[name][0].line
                raise self.fail(key_node, child, f"duplicate key {quoted(child)} (first on "
                                f"line {first}, again on line {key_node.start_mark.line + 1})")
            located = ConfigScalar(self.source, key_node.start_mark.line + 1, child,
                                   self.error, name, name)
            entries[name] = (located, self.build(value_node, child, parents))
        return ConfigMapping(self.source, line, key, self.error, entries)

    def scalar(self, node: yaml.ScalarNode, key: str) -> ConfigScalar:
        text = str(node.value)
        value: object
        if node.tag in _TEXT_TAGS:
            value = text
        else:
            try:
                value = self.constructor.construct_object(node, deep=True)
            except yaml.YAMLError as exc:
                raise self.fail(node, key, "not valid YAML "
                                f"({_unquoted(str(getattr(exc, 'problem', None) or exc))})"
                                + self.suffix) from None
            except (ValueError, TypeError):  # an explicit tag that does not fit: !!int x
                kind = clip(node.tag.rsplit(":", 1)[-1], 40)
                shown = "a value" if self.suffix else quoted(text, 40)
                raise self.fail(node, key, f"not valid YAML ({shown} is not a {kind})"
                                + self.suffix) from None
        if not isinstance(value, _SCALAR_TYPES):
            raise self.fail(node, key, f"{self.tag(node)} is not supported here{self.suffix}")
        return ConfigScalar(self.source, node.start_mark.line + 1, key, self.error, value, text)


def positive_float(value: ConfigValue) -> float:
    """The value as a finite number > 0, or the file's error at its line."""
    number = value.as_float()
    if number <= 0:
        raise value.error(f"key {quoted(value.key)}: must be > 0, not {number:g}")
    return number


def nonnegative_float(value: ConfigValue) -> float:
    """The value as a finite number >= 0, or the file's error at its line."""
    number = value.as_float()
    if number < 0:
        raise value.error(f"key {quoted(value.key)}: must be >= 0, not {number:g}")
    return number


# -- command-line overrides ------------------------------------------------------------------


def overridden(root: ConfigValue, assignments: Collection[str], *,
               error: type[ConfigFileError] = ConfigFileError) -> ConfigValue:
    """``root`` with each ``key.path=value`` of ``assignments`` (a command's ``--set``) put in
    place; ``value`` is YAML (``60``, ``dark``, ``[0, 0, 640, 376]``, ``null``).

    Why here: a rig file and the command line are two ways to say one thing, so they go
    through one reader. An override is a small document of its own, located at
    ``--set key.path=value``, so a wrong one is refused by the consumer's own checks, naming
    what was typed (``--set tracker.thresold=60:1: tracker: unknown key 'thresold' (did you
    mean 'threshold'?)``). A key path that is no mapping's key is added, and refused
    there."""
    result = root
    for assignment in assignments:
        name, equals, text = assignment.partition("=")
        parts = name.strip().split(".")
        source = f"--set {clip(assignment)}"
        if not equals or not all(part.strip() for part in parts):
            raise error(source, 0, name, "must be KEY.PATH=VALUE, as in "
                        "--set tracker.threshold=60")
        document = text
        for part in reversed(parts):
            document = f"{{{part.strip()}: {document if document.strip() else 'null'}}}"
        override = load_text(document, source, error=error)
        level = override
        for part in parts:  # one value at the path, not more keys smuggled in beside it
            if not isinstance(level, ConfigMapping) or list(level) != [part.strip()]:
                raise error(source, 0, name, "must set one value: quote a value holding "
                            "',' or ':' (--set 'key.path=\"a, b\"')")
            level = level.require(part.strip())
        if not isinstance(result, ConfigMapping):
            raise error(source, 0, name, f"cannot be set: {result.describe()} is not a "
                        "mapping of keys")
        result = _merged(result, override.as_mapping())
    return result


def _merged(base: ConfigMapping, over: ConfigMapping) -> ConfigMapping:
    entries = dict(base._entries)
    for name, (key, value) in over._entries.items():
        old = entries.get(name)
        if old is not None and isinstance(old[1], ConfigMapping) and isinstance(
                value, ConfigMapping):
            entries[name] = (old[0], _merged(old[1], value))
        else:
            entries[name] = (key, value)
    return ConfigMapping(base.path, base.line, base.key, base._error, entries)
