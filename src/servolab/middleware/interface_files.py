"""ROS interface packages read from their own files: ``.msg``, ``.srv`` and ``.action``.

A lab's own interfaces, or a ROS package servolab does not ship, are folders laid out as ROS
lays them out — ``<package>/msg/*.msg``, ``<package>/srv/*.srv``, ``<package>/action/*.action``
(a source package, or an install's ``share/<package>``). :func:`find_packages` finds them
under the folders it is given (a package folder itself, or a folder of packages, as
``SERVOLAB_INTERFACE_PATH`` lists them), and :func:`read_package` reads one into the texts
:meth:`~.messages.MessageTypes.register_package` registers: a message's text, a service's
request and response, an action's goal, result and feedback — split where ROS splits them, on
a line of three dashes. The texts are parsed by rosbags, as every other type is.

Only the file layout is servolab's: a definition is read as written. A file that cannot be
used is a one-line :class:`~.errors.MessageError` naming it, and the line where it can say.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .errors import MessageError

#: The environment variable that lists interface folders (``os.pathsep``-separated), read by
#: the default message types as ``AMENT_PREFIX_PATH`` is by ROS.
INTERFACE_PATH_VARIABLE = "SERVOLAB_INTERFACE_PATH"

#: A ROS package name: lower case letters, digits and underscores, starting with a letter
#: (REP 144).
_PACKAGE = re.compile(r"[a-z][a-z0-9_]*\Z")
#: An interface name: CamelCase, letters and digits (rosidl's rule).
_INTERFACE = re.compile(r"[A-Z][A-Za-z0-9]*\Z")
_KINDS = ("msg", "srv", "action")


@dataclass
class InterfacePackage:
    """One package's interfaces as text, keyed by their full names (``pkg/msg/Name``)."""

    name: str
    path: Path
    msgs: dict[str, str] = field(default_factory=dict)
    #: ``pkg/srv/Name`` -> (request, response)
    srvs: dict[str, tuple[str, str]] = field(default_factory=dict)
    #: ``pkg/action/Name`` -> (goal, result, feedback)
    actions: dict[str, tuple[str, str, str]] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.msgs) + len(self.srvs) + len(self.actions)

    def file_of(self, text: str) -> Path:
        """The file of the first of this package's interfaces that ``text`` names (an error
        about it), else the package's folder."""
        found: tuple[int, Path] | None = None
        # (the longest name first: pkg/msg/FooBar is not pkg/msg/Foo)
        for full in sorted((*self.msgs, *self.srvs, *self.actions), key=len, reverse=True):
            at = text.find(full)
            if at >= 0 and (found is None or at < found[0]):
                _, kind, short = full.split("/")
                found = (at, self.path / kind / f"{short}.{kind}")
        return found[1] if found is not None else self.path


def is_package(folder: Path) -> bool:
    """Whether ``folder`` holds interfaces as a ROS package does (a msg, srv or action
    folder with a definition in it)."""
    return any(any((folder / kind).glob(f"*.{kind}")) for kind in _KINDS
               if (folder / kind).is_dir())


def find_packages(roots: Iterable[str | Path]) -> Iterator[Path]:
    """Every interface package in ``roots``: a root that is a package itself, else its
    sub-folders that are (and an install prefix's ``share/*``), in name order. A root that
    is not a folder is an error naming it."""
    for root in roots:
        path = Path(root).expanduser()
        if not path.is_dir():
            raise MessageError(f"interface folder {str(path)!r} does not exist (check "
                               f"{INTERFACE_PATH_VARIABLE} or the path given)")
        if is_package(path):
            yield path
            continue
        share = path / "share"
        for parent in (path, share) if share.is_dir() else (path,):
            for child in sorted(parent.iterdir()):
                if child.is_dir() and is_package(child):
                    yield child


def environment_roots() -> list[str]:
    """The folders ``SERVOLAB_INTERFACE_PATH`` lists (none when it is unset or empty)."""
    value = os.environ.get(INTERFACE_PATH_VARIABLE, "")
    return [part for part in value.split(os.pathsep) if part.strip()]


def read_package(folder: str | Path) -> InterfacePackage:
    """The interfaces of the package in ``folder``: its name is the folder's (as
    ``share/<package>`` and a source package are named), each file's the interface's."""
    path = Path(folder)
    name = path.name
    if not _PACKAGE.match(name):
        raise MessageError(f"{path}: {name!r} is not a ROS package name (lower case letters, "
                           "digits and underscores, starting with a letter)")
    package = InterfacePackage(name, path)
    for kind in _KINDS:
        for file in sorted((path / kind).glob(f"*.{kind}")):
            short = file.stem
            if not _INTERFACE.match(short):
                raise MessageError(f"{file}: {short!r} is not an interface name (CamelCase "
                                   "letters and digits)")
            try:
                text = file.read_text(encoding="utf-8")
            except (OSError, UnicodeDecodeError) as exc:
                raise MessageError(f"{file}: cannot be read ({exc})") from None
            full = f"{name}/{kind}/{short}"
            if kind == "msg":
                package.msgs[full] = text
            elif kind == "srv":
                request, response = split_parts(text, 2, file)
                package.srvs[full] = (request, response)
            else:
                goal, result, feedback = split_parts(text, 3, file)
                package.actions[full] = (goal, result, feedback)
    return package


def split_parts(text: str, count: int, file: str | Path = "<text>") -> tuple[str, ...]:
    """A ``.srv`` (two parts) or ``.action`` (three) split on its separator lines — a line
    of exactly three dashes, as rosidl reads it — or an error naming the file and saying how
    many it found."""
    parts: list[list[str]] = [[]]
    for line in text.splitlines():
        if line.strip() == "---":
            parts.append([])
        else:
            parts[-1].append(line)
    if len(parts) != count:
        kind = "a service" if count == 2 else "an action"
        raise MessageError(f"{file}: {kind} has {count} parts separated by '---' lines; "
                           f"found {len(parts)}")
    return tuple("\n".join(lines) + "\n" if lines else "" for lines in parts)


# -- default values --------------------------------------------------------------------------
# rosbags' .msg parser reads a field's default value and drops it; rosidl keeps it, and a
# message built without that field has it. These read it as rosidl_adapter's parser does
# (``parse_message_string``, ``parse_value_string``, Jazzy): a line is cut at its first ``#``;
# ``type name default`` is a field with a default, ``type NAME=value`` a constant.

#: one element of a string array's default: quoted (with its escaped quotes) or up to a comma
_ELEMENT = re.compile(r"""\s*("(?:[^"\\]|\\.)*"|'(?:[^'\\]|\\.)*'|[^,]*)\s*(,|\Z)""")


def field_defaults(text: str) -> dict[str, str]:
    """Each field's default value as written (``{"gain": "1.5"}``), for the fields that
    have one."""
    defaults: dict[str, str] = {}
    for raw in text.splitlines():
        line = raw.replace("\t", " ").split("#", 1)[0].strip()   # rosidl: tabs are spaces
        _, _, rest = line.partition(" ")
        rest = rest.lstrip()
        if not rest or "=" in rest:
            continue
        name, _, default = rest.partition(" ")
        if default.strip():
            defaults[name] = default.strip()
    return defaults


def parse_default(base: str, text: str, sequence: bool) -> Any:
    """A default value's text as the value of a field of base type ``base`` (a sequence or
    array of them when ``sequence``), or a :class:`~.errors.MessageError` saying why not."""
    if not sequence:
        return _parse_scalar(base, text)
    if not (text.startswith("[") and text.endswith("]")):
        raise MessageError(f"{text!r}: an array's default starts with '[' and ends with ']'")
    inner = text[1:-1].strip()
    if not inner:
        return []
    items = _string_elements(inner) if base in ("string", "wstring") \
        else [item.strip() for item in inner.split(",")]
    return [_parse_scalar(base, item) for item in items]


def _string_elements(inner: str) -> list[str]:
    """A string array's elements, where a quoted one may hold commas."""
    items, at = [], 0
    while at < len(inner):
        match = _ELEMENT.match(inner, at)
        if match is None or match.end() == at:
            raise MessageError(f"[{inner}]: a string array's default is quoted strings "
                               "separated by commas")
        items.append(match.group(1).strip())
        at = match.end()
    return items


def _parse_scalar(base: str, text: str) -> Any:
    if base == "bool":
        if text.lower() not in ("true", "1", "false", "0"):
            raise MessageError(f"{text!r}: a bool's default is true, false, 1 or 0")
        return text.lower() in ("true", "1")
    if base in ("string", "wstring"):
        for quote in ('"', "'"):
            if len(text) >= 2 and text.startswith(quote) and text.endswith(quote):
                inner = text[1:-1]
                if re.search(rf"(?<!\\){quote}", inner):
                    raise MessageError(f"{text}: a quote inside a quoted string is escaped "
                                       f"(\\{quote})")
                return inner.replace("\\" + quote, quote)
        return text
    if base.startswith("float"):
        try:
            return float(text)
        except ValueError:
            raise MessageError(f"{text!r}: a {base}'s default is a number with '.' as its "
                               "separator") from None
    for radix in (10, 0):  # as rosidl: decimal, then with a 0x / 0o / 0b prefix
        try:
            return int(text, radix)
        except ValueError:
            pass
    raise MessageError(f"{text!r}: a {base}'s default is a whole number")
