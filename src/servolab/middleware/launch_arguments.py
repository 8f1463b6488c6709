"""A launch file's arguments and their substitutions, as ROS 2 launch has them: ``arguments``
declares each with its default (``DeclareLaunchArgument``, ``<arg name= default=/>``), the
command line sets them as ``ros2 launch`` does (``servolab launch FILE robots:=3``), and
``$(var NAME)`` in any text of the file is replaced by the value (ROS 2's ``$(var ...)``
substitution, ``LaunchConfiguration``). In a group of several instances, ``$(var instance)``
is the instance's number, 1 to N: what a ROS 2 Python launch file's ``for`` loop would give.

The substitution works on the located values of :mod:`servolab.configfile`, so an error after
it still names the line the text was on. A text that is one substitution and nothing else
takes the type of its value as YAML reads it (``rate: $(var rate)`` with ``rate:=4.5`` is
the number 4.5), as ROS 2 launch reads a parameter's substituted text; text with a
substitution among other text stays text (``/robot$(var instance)``).
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence

import yaml

from ..configfile import ConfigList, ConfigMapping, ConfigScalar, ConfigValue, suggest
from ..errors import UsageError
from ..limits import quoted

#: ``$(var NAME)``: ROS 2 launch's substitution of a launch argument.
VARIABLE = re.compile(r"\$\(var ([A-Za-z_][A-Za-z0-9_]*)\)")
#: In a group of ``instances``, the instance's number.
INSTANCE = "instance"
_ARGUMENT = re.compile(r"([A-Za-z_][A-Za-z0-9_]*):=(.*)", re.DOTALL)


def command_line_arguments(texts: Sequence[str]) -> dict[str, str]:
    """``NAME:=VALUE`` arguments as ``ros2 launch`` takes them after the file."""
    given: dict[str, str] = {}
    for text in texts:
        if not (match := _ARGUMENT.fullmatch(text)):
            raise UsageError(f"launch argument {quoted(text)} is not NAME:=VALUE (e.g. "
                             "robots:=3)")
        given[match[1]] = match[2]
    return given


def declared(arguments: ConfigValue | None, given: Mapping[str, str]) -> dict[str, str]:
    """The file's ``arguments`` (name: default; ``null``: the command line must set it) with
    the command line's values on top; a value the file does not declare, or one it needs and
    is not given, is refused in one line."""
    values: dict[str, str] = {}
    names: list[str] = []
    if arguments is not None:
        if not isinstance(arguments, ConfigMapping):
            raise arguments.error("key 'arguments': must be a mapping of name: default")
        for name, default in arguments.items():
            key = arguments.key_of(name)
            if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name) or name == INSTANCE:
                raise key.error(f"argument {quoted(name)}: a name is letters, digits and '_', "
                                f"and {INSTANCE!r} is the number of a group's instance")
            if not isinstance(default, ConfigScalar):
                raise default.error(f"argument {quoted(name)}: the default must be one value")
            names.append(name)
            if default.value is not None:
                values[name] = default.text
    for name, value in given.items():
        if name not in names:
            close = suggest(name, names)
            raise UsageError(f"launch argument {quoted(name)} is not declared by the file "
                             f"(its arguments: {', '.join(names) or 'none'})"
                             + (f"; did you mean {close!r}?" if close else ""))
        values[name] = value
    missing = [n for n in names if n not in values]
    if missing:
        raise UsageError(f"launch argument(s) {', '.join(missing)} have no default: give "
                         f"{' '.join(f'{n}:=VALUE' for n in missing)} after the file")
    return values


def substitute(value: ConfigValue, variables: Mapping[str, str]) -> ConfigValue:
    """``value`` with every ``$(var NAME)`` in its texts (keys too) replaced; an unknown name
    is an error at its line."""
    if isinstance(value, ConfigScalar):
        return _scalar(value, variables)
    if isinstance(value, ConfigList):
        return ConfigList(value.path, value.line, value.key, value.error_class,
                          tuple(substitute(item, variables) for item in value))
    if isinstance(value, ConfigMapping):
        entries: dict[str, tuple[ConfigScalar, ConfigValue]] = {}
        for name, item in value.items():
            key = _scalar(value.key_of(name), variables)
            if str(key.value) in entries:  # two keys that read alike once substituted
                raise key.error(f"key {quoted(name)} is {quoted(str(key.value))} once its "
                                "arguments are substituted, as another key of this mapping "
                                "is: give them different names")
            entries[str(key.value)] = (key, substitute(item, variables))
        return ConfigMapping(value.path, value.line, value.key, value.error_class, entries)
    return value


def _scalar(value: ConfigScalar, variables: Mapping[str, str]) -> ConfigScalar:
    if not isinstance(value.value, str) or "$(" not in value.value:
        return value
    text = value.value

    def replaced(match: re.Match[str]) -> str:
        name = match[1]
        if name not in variables:
            known = sorted(variables)
            raise value.error(f"$(var {name}): no launch argument {quoted(name)} (arguments: "
                              f"{', '.join(known) or 'none'}"
                              + (f"; {INSTANCE!r} only in a group of instances)"
                                 if name == INSTANCE else ")"))
        return variables[name]

    result = VARIABLE.sub(replaced, text)
    if VARIABLE.fullmatch(text):
        try:
            typed = yaml.safe_load(result)
        except yaml.YAMLError:
            typed = result
        if not isinstance(typed, str | int | float | bool) or typed is None:
            typed = result
        return ConfigScalar(value.path, value.line, value.key, value.error_class, typed, result)
    return ConfigScalar(value.path, value.line, value.key, value.error_class, result, result)
