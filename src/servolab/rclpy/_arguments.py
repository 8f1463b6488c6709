"""ROS's command-line arguments (``--ros-args -p name:=value -r old:=new ... --``), as rcl
parses them (rcl/arguments.c; the ROS 2 design article "ROS command line arguments"), for
:func:`servolab.rclpy.init`'s ``args`` (every node) and ``Node(cli_args=...)`` (one node).

Understood: ``-p``/``--param name:=value`` (the value is YAML), ``--params-file FILE``,
``-r``/``--remap [node:]old:=new`` including ``__node:=name`` and ``__ns:=/namespace``;
``--log-level``, ``--enclave``/``-e`` and ``--disable-*`` are taken and ignored.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from servolab.middleware.errors import MiddlewareValueError
from servolab.middleware.parameters import ParameterOverrides

_IGNORED_WITH_VALUE = {"--log-level", "--enclave", "-e", "--log-config-file"}
_IGNORED_FLAGS = {"--disable-rosout-logs", "--enable-rosout-logs", "--disable-stdout-logs",
                  "--enable-stdout-logs", "--disable-external-lib-logs",
                  "--enable-external-lib-logs"}


@dataclass
class RosArguments:
    """What ``--ros-args`` said."""

    params: ParameterOverrides = field(default_factory=ParameterOverrides)
    #: (node name or None for every node, from, to)
    remaps: list[tuple[str | None, str, str]] = field(default_factory=list)

    def extend(self, other: RosArguments) -> None:
        self.params.merge(other.params)
        self.remaps += other.remaps

    def node_name(self, name: str) -> str:
        return self._special("__node", name) or name

    def namespace(self, name: str, namespace: str | None) -> str | None:
        return self._special("__ns", name) or namespace

    def _special(self, key: str, name: str) -> str | None:
        found = None
        for target, old, new in self.remaps:
            if old == key and target in (None, name):
                found = new
        return found

    def remappings(self, name: str) -> dict[str, str]:
        return {old: new for target, old, new in self.remaps
                if target in (None, name) and old not in ("__node", "__ns")}

    def overrides(self, fully_qualified_name: str) -> dict[str, Any]:
        return self.params.for_node(fully_qualified_name)


def parse(args: list[str] | None) -> RosArguments:
    """The ROS arguments among ``args`` (each ``--ros-args`` block up to ``--``)."""
    parsed = RosArguments()
    inside = False
    items = list(args or [])
    i = 0
    while i < len(items):
        arg = items[i]
        i += 1
        if arg == "--ros-args":
            inside = True
            continue
        if not inside:
            continue
        if arg == "--":
            inside = False
            continue

        def value(flag: str) -> str:
            nonlocal i
            if i >= len(items):
                raise MiddlewareValueError(f"--ros-args: {flag} needs a value")
            i += 1
            return items[i - 1]

        if arg in ("-p", "--param"):
            text = value(arg)
            if ":=" not in text:
                raise MiddlewareValueError(f"--ros-args -p {text!r}: not name:=value")
            parsed.params.merge(ParameterOverrides.from_assignments([text]))
        elif arg == "--params-file":
            parsed.params.merge(ParameterOverrides.from_file(value(arg)))
        elif arg in ("-r", "--remap"):
            text = value(arg)
            rule, _, new = text.partition(":=")
            if not _ or not rule or not new:
                raise MiddlewareValueError(f"--ros-args -r {text!r}: not from:=to")
            target, _, old = rule.rpartition(":")
            parsed.remaps.append((target or None, old, new))
        elif arg in _IGNORED_WITH_VALUE:
            value(arg)
        elif arg in _IGNORED_FLAGS:
            pass
        else:
            raise MiddlewareValueError(f"--ros-args: unknown ROS argument {arg!r}")
    return parsed


def remove_ros_args(args: list[str]) -> list[str]:
    """``args`` without its ROS arguments (rclpy.utilities.remove_ros_args)."""
    out: list[str] = []
    inside = False
    for arg in args:
        if arg == "--ros-args":
            inside = True
        elif inside and arg == "--":
            inside = False
        elif not inside:
            out.append(arg)
    return out


class Global:
    """The arguments :func:`servolab.rclpy.init` was given, for every node it makes."""

    arguments = RosArguments()
