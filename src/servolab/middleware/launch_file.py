"""Launch files: the YAML format, read and checked before anything starts.

In the spirit of ROS launch files (``<machine>``, ``<node>``, ``<param>``)::

    transport: zenoh            # local (default) | zenoh
    zenoh: {listen: [tcp/127.0.0.1:7447], connect: []}
    machines:
      pc: {address: localhost, default: true}
      robot: {address: robot.local}
    parameters: params.yaml     # ROS 2 parameter file(s), relative to this file
    nodes:
      - name: talker
        node: servolab.middleware.demo_nodes:Talker
        namespace: /robot
        parameters: {rate: 10.0}        # a mapping, a file, or a list of both
        remappings: {cmd_vel: /turtle/cmd_vel}
        process: camera                 # nodes of one process share it; default "main"
        machine: robot
        required: true                  # when it ends, everything stops
      - name: recorder
        exec: [servolab, bag, record, /cmd_vel, -o, rec]

Why the file is checked so strictly, and up front: a typo in a launch file otherwise shows up
as a node that silently keeps its default, or as a crash in one of several processes minutes
later. Every error is one line naming the file, the line and the key; the node classes are
imported and the commands looked up before anything starts.
"""

from __future__ import annotations

import importlib
import inspect
import re
import shlex
import shutil
import socket
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..configfile import (
    ConfigList,
    ConfigMapping,
    ConfigScalar,
    ConfigValue,
    load,
    unknown_key,
)
from ..limits import InputLimits, clip, quoted
from .errors import LaunchError, LaunchFileError, NameValidationError, ParameterError
from .launch_arguments import INSTANCE, declared, substitute
from .names import check_node_name, node_namespace
from .names import fully_qualified_name as resolve_name
from .node import Node
from .parameters import ParameterOverrides, type_of
from .transport import TransportOptions, environment_domain_id

#: The process group of a node entry that names none.
DEFAULT_PROCESS = "main"
#: In an ``exec`` entry, replaced by the Zenoh endpoint the launch's processes meet on, so a
#: command such as ``servolab bag record ... --connect $(zenoh_endpoint)`` can join them.
ZENOH_ENDPOINT = "$(zenoh_endpoint)"
#: The most instances one group may have: a fleet, not a typo's thousand processes.
MAX_INSTANCES = 100
#: How long the supervisor waits after SIGINT, and after SIGTERM, before the next signal.
STOP_TIMEOUT = 5.0

_TOP_KEYS = ("arguments", "transport", "zenoh", "machines", "parameters", "nodes", "groups")
_GROUP_KEYS = ("namespace", "instances", "nodes")
_ZENOH_KEYS = ("listen", "connect")
_MACHINE_KEYS = ("address", "default")
_NODE_KEYS = ("name", "node", "namespace", "parameters", "remappings", "process", "machine",
              "required")
_EXEC_KEYS = ("name", "exec", "machine", "required")
_IDENT = r"[A-Za-z_]\w*"
_CLASS_PATH = re.compile(rf"{_IDENT}(\.{_IDENT})*:{_IDENT}(\.{_IDENT})*")
_PROCESS_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*")
_ENDPOINT = re.compile(r"[a-z][a-z0-9-]*/\S+")


# -- data model ------------------------------------------------------------------------------


@dataclass(frozen=True)
class Machine:
    """A computer of the robot, as ROS 1's ``<machine name= address= default=/>``."""

    name: str
    address: str
    default: bool = False
    line: int = 0

    @property
    def is_local(self) -> bool:
        return is_local_address(self.address)


@dataclass
class NodeEntry:
    """One entry of ``nodes``: a node class to build (``node``) or a command (``command``).

    ``parameters`` are this node's values, already merged from the entry's mappings and files
    (the launch file's own ``parameters`` files are in :attr:`LaunchFile.parameters`).
    ``process`` is ``""`` for a command, which always runs as its own process; ``machine`` is
    the entry's machine or the default one (None: wherever the launch runs). ``lines`` maps
    each key to the line it is on, for error messages.
    """

    name: str
    node: str | None = None                   # "module:Class"
    command: list[str] = field(default_factory=list)
    namespace: str = "/"
    parameters: dict[str, Any] = field(default_factory=dict)
    remappings: dict[str, str] = field(default_factory=dict)
    process: str = DEFAULT_PROCESS
    machine: str | None = None
    required: bool = False
    line: int = 0
    lines: dict[str, int] = field(default_factory=dict, repr=False, compare=False)

    @property
    def is_exec(self) -> bool:
        return self.node is None

    @property
    def fully_qualified_name(self) -> str:
        return f"{self.namespace.rstrip('/')}/{self.name}"


@dataclass
class LaunchFile:
    """A parsed and checked launch file; see the module docstring for its format."""

    path: Path
    nodes: list[NodeEntry] = field(default_factory=list)
    transport: str = "local"
    listen: list[str] = field(default_factory=list)
    connect: list[str] = field(default_factory=list)
    machines: dict[str, Machine] = field(default_factory=dict)
    parameters: ParameterOverrides = field(default_factory=ParameterOverrides)
    #: the launch arguments the command line gave (``robots:=3``), passed on to the children
    given: dict[str, str] = field(default_factory=dict)
    lines: dict[str, int] = field(default_factory=dict, repr=False, compare=False)

    def error(self, entry: NodeEntry | None, key: str | None, message: str
              ) -> LaunchFileError:
        """A one-line error at ``key`` of ``entry`` (or of the file's top level), for the
        checks made after parsing (such as importing the node classes)."""
        lines = entry.lines if entry is not None else self.lines
        line = lines.get(key or "", entry.line if entry is not None else 1)
        where = f"node {quoted(entry.name)}: " if entry is not None else ""
        what = f"key {quoted(key)}: " if key else ""
        index = next((i for i, e in enumerate(self.nodes) if e is entry), None)
        key_path = f"nodes[{index}]" if index is not None else ""
        if key:
            key_path = f"{key_path}.{key}" if key_path else key
        return LaunchFileError(self.path, line, key_path, f"{where}{what}{message}")

    def process_groups(self, entries: Sequence[NodeEntry] | None = None
                       ) -> dict[str, list[NodeEntry]]:
        """The node entries by process group, in the order the groups first appear."""
        groups: dict[str, list[NodeEntry]] = {}
        for entry in self.nodes if entries is None else entries:
            if not entry.is_exec:
                groups.setdefault(entry.process, []).append(entry)
        return groups

    def process_count(self, entries: Sequence[NodeEntry] | None = None) -> int:
        entries = self.nodes if entries is None else entries
        return len(self.process_groups(entries)) + sum(e.is_exec for e in entries)

    def entries_for(self, machine: str | None = None) -> list[NodeEntry]:
        """The entries that run here: those on ``machine`` if given, else those on no machine
        or on one whose address is this computer's."""
        if machine is not None:
            if machine not in self.machines:
                raise LaunchError(f"{self.path}: no machine {quoted(machine)} "
                                  f"(machines: {', '.join(self.machines) or 'none'})")
            return [e for e in self.nodes if e.machine == machine]
        return [e for e in self.nodes
                if e.machine is None or self.machines[e.machine].is_local]

    def transport_options(self, override: TransportOptions | None = None) -> TransportOptions:
        """The transport the nodes use: the file's, or the command line's ``override``
        (whose endpoints, when it has any, replace the file's)."""
        if override is None:  # the domain, as every ROS 2 program takes it, from ROS_DOMAIN_ID
            return TransportOptions(self.transport, list(self.listen), list(self.connect),
                                    environment_domain_id())
        if override.kind == "local":
            if override.listen or override.connect:
                raise LaunchError("--listen and --connect need --transport zenoh")
            return TransportOptions("local", domain_id=override.domain_id)
        if override.kind == "dds":
            # DDS needs no meeting point: the domain (ROS_DOMAIN_ID) and discovery range do
            return TransportOptions("dds", list(override.listen), list(override.connect),
                                    override.domain_id)
        if override.kind != "zenoh":
            raise LaunchError(f"unknown transport {quoted(override.kind)} (local, zenoh or dds)")
        if override.listen or override.connect:
            return TransportOptions("zenoh", list(override.listen), list(override.connect),
                                    override.domain_id)
        return TransportOptions("zenoh", list(self.listen), list(self.connect),
                                override.domain_id)


def is_local_address(address: str) -> bool:
    """Whether a machine address names this computer (as the launch decides what runs here)."""
    address = address.strip().lower()
    if address in ("localhost", "127.0.0.1", "::1", socket.gethostname().lower()):
        return True
    return address == socket.getfqdn().lower()  # last: it may ask DNS


# -- parsing ---------------------------------------------------------------------------------


def load_launch(path: str | Path, *, limits: InputLimits | None = None,
                arguments: Mapping[str, str] | None = None) -> LaunchFile:
    """Read and check a launch file; errors are one :class:`LaunchFileError` line naming the
    file, line and key, quoting at most :data:`servolab.limits.ECHO_WIDTH` characters of a
    value. Node classes are imported later, by :func:`check_entries`, because a machine need
    only have the classes of the nodes it runs.

    The launch file and the parameter files it names are YAML files, refused unread over
    the YAML size limit (:mod:`servolab.limits`, ``SERVOLAB_MAX_YAML_MB``); a file that is
    not a launch file, or named as parameters and not a parameter file, is refused as such
    with its line and column and nothing of its content.

    ``arguments`` are the command line's ``NAME:=VALUE`` (:mod:`.launch_arguments`)."""
    path = Path(path)
    return _Parser(path, limits, dict(arguments or {})).parse(
        load(path, what="launch file", error=LaunchFileError, kind="launch file",
             limits=limits))


class _Parser:
    def __init__(self, path: Path, limits: InputLimits | None = None,
                 given: dict[str, str] | None = None) -> None:
        self.path = path
        self.given = given or {}
        self.limits = limits
        self.directory = path.parent
        self.entry_fields: list[ConfigMapping] = []  # of each entry of launch.nodes

    def error(self, value: ConfigValue, where: str, message: str) -> LaunchFileError:
        error = value.error(f"{where + ': ' if where else ''}{message}")
        assert isinstance(error, LaunchFileError)
        return error

    def mapping(self, node: ConfigValue, where: str, what: str,
                keys: Sequence[str]) -> ConfigMapping:
        """A mapping whose keys must be among ``keys`` (any, if empty)."""
        if not isinstance(node, ConfigMapping):
            raise self.error(node, where, f"{what} must be a mapping")
        if keys:
            node.check_keys(keys, what=where or None)
        return node

    @staticmethod
    def subject(where: str, key: str) -> str:
        return f"{where + ': ' if where else ''}key {quoted(key)}"

    def text(self, node: ConfigValue, where: str, key: str) -> str:
        return node.as_str(self.subject(where, key), nonempty=True)

    def flag(self, node: ConfigValue, where: str, key: str) -> bool:
        return node.as_bool(self.subject(where, key))

    def texts(self, node: ConfigValue, where: str, key: str) -> list[tuple[ConfigValue, str]]:
        """A string or a list of strings (each with its value, for its line)."""
        return [(item, self.text(item, where, key)) for item in node.one_or_many()]

    # -- the file ----------------------------------------------------------------------------

    def parse(self, root: ConfigValue) -> LaunchFile:
        if isinstance(root, ConfigScalar) and root.value is None:
            raise self.error(root, "", "key 'nodes' missing (the file is empty)")
        fields = self.mapping(root, "", "a launch file", _TOP_KEYS)
        variables = declared(fields.get("arguments"), self.given)
        top = {name: value if name in ("arguments", "groups") else substitute(value, variables)
               for name, value in fields.items()}
        launch = LaunchFile(self.path, given=dict(self.given),
                            lines={k: fields.key_of(k).line for k in fields})
        if (value := top.get("transport")) is not None:
            launch.transport = self.text(value, "", "transport")
            if launch.transport not in ("local", "zenoh", "dds"):
                raise self.error(value, "", f"key 'transport': {quoted(launch.transport)} is not "
                                 "local, zenoh or dds")
        if "zenoh" in top:
            self.zenoh(fields, top["zenoh"], launch)
        if (value := top.get("machines")) is not None:
            self.machines(value, launch)
        if (value := top.get("parameters")) is not None:
            for item, name in self.texts(value, "", "parameters"):
                launch.parameters.merge(self.parameter_file(item, "", name))
        entries: list[tuple[ConfigValue, str]] = []
        if (nodes := top.get("nodes")) is not None:
            if not isinstance(nodes, ConfigList) or not nodes.items:
                raise self.error(nodes, "", "key 'nodes': must be a list of node entries")
            entries += [(item, "/") for item in nodes]
        if (groups := top.get("groups")) is not None:
            entries += self.groups(groups, variables)
        if not entries:
            raise self.error(fields, "", "key 'nodes' missing (or 'groups' of them)")
        default = next((m.name for m in launch.machines.values() if m.default), None)
        launch.nodes = [self.entry(item, index, launch, default, pushed)
                        for index, (item, pushed) in enumerate(entries, 1)]
        self.check_together(launch)
        return launch

    def groups(self, value: ConfigValue, variables: dict[str, str]
               ) -> list[tuple[ConfigValue, str]]:
        """The node entries of ``groups``, each group's ``instances`` times (1 unless given),
        with ``$(var instance)`` its number, and the namespace each pushes onto its node
        entries (ROS 2's ``<group>`` with ``<push_ros_namespace>``)."""
        if not isinstance(value, ConfigList) or not value.items:
            raise self.error(value, "", "key 'groups': must be a list of groups")
        found: list[tuple[ConfigValue, str]] = []
        for number, group in enumerate(value, 1):
            where = f"group #{number}"
            fields = self.mapping(group, where, "a group", _GROUP_KEYS)
            count = 1
            if (instances := fields.get("instances")) is not None:
                count = substitute(instances, variables).as_int(f"{where}: key 'instances'")
                if not 1 <= count <= MAX_INSTANCES:
                    raise self.error(instances, where, f"key 'instances': {count} is not 1 to "
                                     f"{MAX_INSTANCES}")
            nodes = fields.require("nodes", where)
            if not isinstance(nodes, ConfigList) or not nodes.items:
                raise self.error(nodes, where, "key 'nodes': must be a list of node entries")
            for instance in range(1, count + 1):
                here = {**variables, INSTANCE: str(instance)}
                namespace = "/"
                if (namespace_node := fields.get("namespace")) is not None:
                    namespace_node = substitute(namespace_node, here)
                    namespace = self.text(namespace_node, where, "namespace")
                    try:
                        namespace = node_namespace(namespace)
                    except NameValidationError as exc:
                        raise self.error(namespace_node, where,
                                         f"key 'namespace': {_summary(exc)}") from None
                found += [(substitute(item, here), namespace) for item in nodes]
        return found

    def zenoh(self, fields: ConfigMapping, value: ConfigValue, launch: LaunchFile) -> None:
        if launch.transport != "zenoh":
            raise self.error(fields.key_of("zenoh"), "", "key 'zenoh': endpoints need "
                             "transport: zenoh")
        zenoh = self.mapping(value, "zenoh", "key 'zenoh'", _ZENOH_KEYS)
        for name, endpoints in zenoh.items():
            empty = (isinstance(endpoints, ConfigScalar) and endpoints.value is None) or (
                isinstance(endpoints, ConfigList) and not endpoints.items)
            found = [] if empty else self.texts(endpoints, "zenoh", name)
            for item, endpoint in found:
                if not _ENDPOINT.fullmatch(endpoint):
                    raise self.error(item, "zenoh", f"key {quoted(name)}: {quoted(endpoint)} "
                                     "is not a Zenoh endpoint such as tcp/127.0.0.1:7447")
            getattr(launch, name).extend(endpoint for _, endpoint in found)

    def machines(self, node: ConfigValue, launch: LaunchFile) -> None:
        machines = self.mapping(node, "", "key 'machines'", ())
        for name, value in machines.items():
            key = machines.key_of(name)
            where = f"machine {quoted(name)}"
            fields = self.mapping(value, where, "a machine", _MACHINE_KEYS)
            if "address" not in fields:
                raise self.error(key, where, "key 'address' missing")
            flag = fields.get("default")
            default = flag is not None and self.flag(flag, where, "default")
            if default and (other := next((m for m in launch.machines.values() if m.default),
                                          None)):
                raise self.error(fields.key_of("default"), where, "key 'default': only one "
                                 f"machine can be the default ({quoted(other.name)} is)")
            launch.machines[name] = Machine(
                name, self.text(fields.require("address"), where, "address"), default,
                key.line)

    def parameter_file(self, node: ConfigValue, where: str, name: str) -> ParameterOverrides:
        path = self.directory / name
        try:
            found = path.is_file()
        except (OSError, ValueError):  # a name too long for the file system
            found = False
        if not found:
            looked = path if len(name) <= 80 else f"it in {path.parent}"
            raise self.error(node, where, f"key 'parameters': file {quoted(name)} not found "
                             f"(looked for {looked})")
        try:
            return ParameterOverrides.from_file(path, limits=self.limits)
        except ParameterError as exc:
            raise self.error(node, where, f"key 'parameters': {exc}") from None

    # -- one entry ---------------------------------------------------------------------------

    def entry(self, item: ConfigValue, index: int, launch: LaunchFile,
              default_machine: str | None, pushed: str = "/") -> NodeEntry:
        where = f"node #{index}"
        fields = self.mapping(item, where, "a node entry", ())
        name_node = fields.require("name", where)
        name = self.text(name_node, where, "name")
        where = f"node {quoted(name, 40)}"  # quoted: a long name is cut (it is said twice)
        try:
            check_node_name(name)
        except NameValidationError as exc:  # one line, as every launch file error
            raise self.error(name_node, where, f"key 'name': {_summary(exc)}") from None
        if "node" in fields and "exec" in fields:
            raise self.error(fields.key_of("exec"), where, "key 'exec': give 'node' or "
                             "'exec', not both")
        if "node" not in fields and "exec" not in fields:
            raise self.error(fields, where, "key 'node' missing (module:Class), or 'exec' (a "
                             "command)")
        allowed = _EXEC_KEYS if "exec" in fields else _NODE_KEYS
        for key in fields:
            if key not in allowed:
                message = (f"key {quoted(key)} is for node entries, not exec ones"
                           if key in _NODE_KEYS else unknown_key(key, allowed))
                raise self.error(fields.key_of(key), where, message)
        entry = NodeEntry(name, line=fields.line,
                          lines={k: fields.key_of(k).line for k in fields})
        if (command := fields.get("exec")) is not None:
            entry.command = self.command(command, where, launch)
            entry.process = ""
        else:
            self.node_fields(entry, fields, where, pushed)
        if (machine_node := fields.get("machine")) is not None:
            entry.machine = self.text(machine_node, where, "machine")
            if entry.machine not in launch.machines:
                raise self.error(machine_node, where, f"key 'machine': no machine "
                                 f"{quoted(entry.machine)} (machines: "
                                 f"{', '.join(launch.machines) or 'none'})")
        else:
            entry.machine = default_machine
        if (required := fields.get("required")) is not None:
            entry.required = self.flag(required, where, "required")
        self.entry_fields.append(fields)
        return entry

    def node_fields(self, entry: NodeEntry, fields: ConfigMapping, where: str,
                    pushed: str = "/") -> None:
        """A node entry's own keys; ``pushed`` is its group's namespace, which a relative
        namespace (or none) goes under, as ROS 2's ``push_ros_namespace`` does."""
        value = fields.require("node", where)
        entry.node = self.text(value, where, "node")
        if not _CLASS_PATH.fullmatch(entry.node):
            raise self.error(value, where, f"key 'node': {quoted(entry.node)} is not module:Class "
                             "(e.g. servolab.middleware.demo_nodes:Talker)")
        if pushed != "/":
            entry.namespace = pushed
        if (namespace_node := fields.get("namespace")) is not None:
            namespace = self.text(namespace_node, where, "namespace")
            if pushed != "/" and not namespace.startswith("/"):
                namespace = f"{pushed}/{namespace}"
            try:
                entry.namespace = node_namespace(namespace, entry.name)
            except NameValidationError as exc:
                raise self.error(namespace_node, where,
                                 f"key 'namespace': {_summary(exc)}") from None
        if (process := fields.get("process")) is not None:
            entry.process = self.text(process, where, "process")
            if not _PROCESS_NAME.fullmatch(entry.process):
                raise self.error(process, where, f"key 'process': {quoted(entry.process)} is not a "
                                 "name (letters, digits, '_', '.', '-')")
        if (remappings := fields.get("remappings")) is not None:
            remaps = self.mapping(remappings, where, "key 'remappings'", ())
            for source, target_node in remaps.items():
                target = self.text(target_node, where, "remappings")
                try:
                    resolve_name(source, entry.namespace, entry.name)
                    resolve_name(target, entry.namespace, entry.name)
                except NameValidationError as exc:
                    raise self.error(target_node, where,
                                     f"key 'remappings': {_summary(exc)}") from None
                entry.remappings[source] = target
        if (parameters := fields.get("parameters")) is not None:
            for item in parameters.one_or_many():
                if isinstance(item, ConfigMapping):
                    self.flatten(item, "", entry.parameters, where)
                elif isinstance(item, ConfigScalar):
                    name = self.text(item, where, "parameters")
                    overrides = self.parameter_file(item, where, name)
                    entry.parameters.update(overrides.for_node(entry.fully_qualified_name))
                else:
                    raise self.error(item, where, "key 'parameters': must be a mapping, a "
                                     "file, or a list of them")

    def flatten(self, node: ConfigMapping, prefix: str, out: dict[str, Any],
                where: str) -> None:
        """Nested mappings become dotted names, as in a ROS 2 parameter file."""
        for name, value in node.items():
            if isinstance(value, ConfigMapping):
                self.flatten(value, f"{prefix}{name}.", out, where)
                continue
            data = value.plain()
            try:
                type_of(data)
            except ParameterError:
                raise self.error(value, where, f"key 'parameters': {clip(prefix + name)}: "
                                 f"{quoted(data)} is not a parameter value (bool, int, float, "
                                 "str or a list of one of them)") from None
            out[f"{prefix}{name}"] = data

    def command(self, node: ConfigValue, where: str, launch: LaunchFile) -> list[str]:
        argv: list[str] = []
        if isinstance(node, ConfigScalar):
            try:
                argv = shlex.split(node.text)
            except ValueError as exc:  # an unclosed quote
                raise self.error(node, where, f"key 'exec': {exc}") from None
        elif isinstance(node, ConfigList) and all(isinstance(item, ConfigScalar)
                                                  for item in node):
            argv = [item.text for item in node if isinstance(item, ConfigScalar)]  # as typed
        if not argv:
            raise self.error(node, where, "key 'exec': must be a command (a list of "
                             "arguments, or a string)")
        for arg in argv:
            rest = arg.replace(ZENOH_ENDPOINT, "")
            if "$(" in rest:
                raise self.error(node, where, f"key 'exec': unknown substitution in {quoted(arg)} "
                                 f"(only {ZENOH_ENDPOINT})")
            if rest != arg and launch.transport != "zenoh":
                raise self.error(node, where, f"key 'exec': {ZENOH_ENDPOINT} needs "
                                 "transport: zenoh")
        return argv

    # -- across entries ----------------------------------------------------------------------

    def check_together(self, launch: LaunchFile) -> None:
        seen: dict[str, NodeEntry] = {}
        machine_of: dict[str, NodeEntry] = {}
        processes: set[tuple[str, str | None]] = set()
        for entry, fields in zip(launch.nodes, self.entry_fields, strict=True):
            where = f"node {quoted(entry.name)}"
            fqn = entry.fully_qualified_name
            if fqn in seen:
                raise self.error(fields.key_of("name"), where, f"key 'name': duplicate name "
                                 f"{fqn} (also on line {seen[fqn].lines['name']})")
            seen[fqn] = entry
            if entry.is_exec:
                key = "exec"
            else:
                key = "machine" if "machine" in fields and "process" not in fields \
                    else "process"
            at: ConfigValue = fields.key_of(key) if key in fields else fields
            processes.add((entry.process or f"exec {entry.name}", entry.machine))
            if len(processes) > 1 and launch.transport == "local":
                raise self.error(at, where, f"key {quoted(key)}: a second process needs "
                                 "transport: zenoh (transport is local)")
            if not entry.is_exec:
                first = machine_of.setdefault(entry.process, entry)
                if first.machine != entry.machine:
                    at = fields.key_of("process") if "process" in fields else fields
                    raise self.error(at, where, f"key 'process': process {quoted(entry.process)} "
                                     f"has nodes on machines {_machine(first.machine)} and "
                                     f"{_machine(entry.machine)}; give them different "
                                     "processes")


def _summary(exc: NameValidationError) -> str:
    """The error's one-line summary, quoting at most ECHO_WIDTH characters of the name."""
    return f"invalid {exc.kind} {quoted(exc.name)}: {exc.reason} (index {exc.index})"


def _machine(name: str | None) -> str:
    return repr(name) if name is not None else "(none)"


# -- checks before anything starts -----------------------------------------------------------


def import_node_class(launch: LaunchFile, entry: NodeEntry) -> type[Node]:
    """The class a node entry names, or a one-line :class:`LaunchError` saying why not."""
    assert entry.node is not None
    module_name, _, attribute = entry.node.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        if exc.name and (module_name + ".").startswith(exc.name + "."):
            raise launch.error(entry, "node", f"no module named {quoted(exc.name)}") from None
        raise launch.error(entry, "node", f"importing {quoted(module_name)} failed: "
                           f"{one_line(exc)}") from None
    except Exception as exc:  # the module itself is broken: say how, in one line
        raise launch.error(entry, "node", f"importing {quoted(module_name)} failed: "
                           f"{one_line(exc)}") from None
    found: Any = module
    for part in attribute.split("."):
        found = getattr(found, part, None)
        if found is None:
            raise launch.error(entry, "node", f"module {quoted(module_name)} has no class "
                               f"{quoted(attribute)}")
    if not (isinstance(found, type) and issubclass(found, Node)):
        raise launch.error(entry, "node", f"{entry.node} is not a Node subclass")
    return found


@dataclass(frozen=True)
class NodeCall:
    """How a launch builds an entry's node class: ``args`` and ``kwargs`` for the class, and
    whether the class has rclpy's shape (``rclpy``: its ``__init__`` takes a node name, not
    a context, and it reaches servolab's :class:`Node` through ``super().__init__(name,
    namespace=..., parameter_overrides=...)``)."""

    args: tuple[Any, ...]
    kwargs: dict[str, Any]
    rclpy: bool


def _takes_context(cls: type[Node]) -> bool:
    """Whether the class's ``__init__`` takes a context first, as servolab's nodes do (the
    base :class:`Node` takes a context or, rclpy's shape, a name: it counts as servolab's)."""
    if cls.__init__ is Node.__init__:
        return True
    params = list(inspect.signature(cls.__init__).parameters.values())[1:]
    first = params[0] if params else None
    if first is None or first.kind not in (inspect.Parameter.POSITIONAL_ONLY,
                                           inspect.Parameter.POSITIONAL_OR_KEYWORD):
        return False
    annotation = first.annotation if isinstance(first.annotation, str) else \
        getattr(first.annotation, "__name__", "")
    return first.name in ("context", "ctx") or "Context" in str(annotation)


def node_call(launch: LaunchFile, entry: NodeEntry, cls: type[Node]) -> NodeCall:
    """The arguments a launch builds ``entry``'s node with, or a one-line error at its
    ``node`` key if the class cannot be built from a launch file.

    A servolab node class takes ``(context, name, namespace, *, parameter_overrides,
    remappings)``. An rclpy-shaped one (``__init__(self)``, or ``__init__(self, node_name,
    *, namespace=None, ...)`` as rclpy's ``Node``) is given the entry's name as its first
    positional argument if it needs one and ``namespace`` if it takes it; the context, the
    entry's name, namespace, parameters and remappings reach the node through
    :func:`launched_class` whatever the class passes on (as ``ros2 launch``'s ``__node``,
    ``__ns`` remappings and parameter files do)."""
    if _takes_context(cls):
        return NodeCall((entry.name, entry.namespace),
                        {"parameter_overrides": entry.parameters,
                         "remappings": entry.remappings}, rclpy=False)
    signature = inspect.signature(cls)
    params = list(signature.parameters.values())
    positional = [p for p in params if p.kind in (inspect.Parameter.POSITIONAL_ONLY,
                                                  inspect.Parameter.POSITIONAL_OR_KEYWORD)]
    required = [p for p in positional if p.default is inspect.Parameter.empty]
    args: tuple[Any, ...] = (entry.name,) if required or (
        positional and positional[0].name in ("node_name", "name")) else ()
    kwargs: dict[str, Any] = {}
    if "namespace" in signature.parameters and (not positional or
                                                positional[0].name != "namespace"):
        kwargs["namespace"] = entry.namespace
    try:
        signature.bind(*args, **kwargs)
    except TypeError as exc:
        raise launch.error(entry, "node", f"{entry.node} cannot be built by a launch file: "
                           f"{exc} (a node class takes (context, name, namespace, ...) as "
                           "servolab's, or (node_name, *, namespace=...) as rclpy's)") from None
    return NodeCall(args, kwargs, rclpy=True)


#: The attribute a launched class carries its launch's context in (:func:`launched_class`).
LAUNCH_CONTEXT = "_servolab_launch_context"


def launched_class(cls: type[Node], context: Any, entry: NodeEntry) -> type[Node]:
    """``cls`` with the launch's context, and the entry's name, namespace, parameters and
    remappings, put under it: a subclass whose method resolution order reaches servolab's
    :class:`Node` through one more class, which replaces what the node class passes on
    (``super().__init__("talker")``, rclpy's shape, or a context and a name) with the
    launch's, as ``ros2 launch`` renames a node whatever name its code gives. Parameter
    values the class itself passes (a mapping, or rclpy ``Parameter`` objects) win over the
    launch file's, as rclpy's ``parameter_overrides`` win over its command line's."""

    def init(self: Node, *args: Any, **kwargs: Any) -> None:
        del args  # the class's name, namespace (or context): the launch's replace them
        params = dict(entry.parameters)
        params.update(_as_values(kwargs.get("parameter_overrides")))
        remaps = dict(entry.remappings)
        remaps.update(kwargs.get("remappings") or {})
        Node.__init__(self, context, entry.name, entry.namespace, parameter_overrides=params,
                      remappings=remaps)

    # the launch's context, for an rclpy-shaped class whose own __init__ runs first and would
    # otherwise open the process's default context, which nothing then closes
    under = type("LaunchEntry", (Node,), {"__init__": init, "__module__": __name__,
                                          LAUNCH_CONTEXT: context})
    return type(cls.__name__, (cls, under), {"__module__": cls.__module__,
                                            "__qualname__": cls.__qualname__})


def _as_values(overrides: Any) -> dict[str, Any]:
    """Parameter values from a mapping, or from rclpy ``Parameter`` objects (``.name``,
    ``.value``)."""
    if not overrides:
        return {}
    if isinstance(overrides, Mapping):
        return dict(overrides)
    return {p.name: p.value for p in overrides}


def check_entries(launch: LaunchFile, entries: Sequence[NodeEntry]) -> None:
    """Import every node class (and check that a launch can build it) and look up every
    command of ``entries``, so that a typo stops the launch before any process starts rather
    than after some did."""
    for entry in entries:
        if not entry.is_exec:
            node_call(launch, entry, import_node_class(launch, entry))
        elif entry.command[0] != "servolab" and shutil.which(entry.command[0]) is None:
            raise launch.error(entry, "exec", f"command {quoted(entry.command[0])} not found")


def one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {clip(text[0], 160)}" if text else type(exc).__name__
