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

import difflib
import importlib
import re
import shlex
import shutil
import socket
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from .errors import LaunchError, MessageError, ParameterError
from .node import Node
from .parameters import ParameterOverrides, type_of
from .rmw_zenoh import check_node_name, node_namespace
from .rmw_zenoh import fully_qualified_name as resolve_name
from .transport import TransportOptions

#: The process group of a node entry that names none.
DEFAULT_PROCESS = "main"
#: In an ``exec`` entry, replaced by the Zenoh endpoint the launch's processes meet on, so a
#: command such as ``servolab bag record ... --connect $(zenoh_endpoint)`` can join them.
ZENOH_ENDPOINT = "$(zenoh_endpoint)"
#: How long the supervisor waits after SIGINT, and after SIGTERM, before the next signal.
STOP_TIMEOUT = 5.0

_TOP_KEYS = ("transport", "zenoh", "machines", "parameters", "nodes")
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
    lines: dict[str, int] = field(default_factory=dict, repr=False, compare=False)

    def error(self, entry: NodeEntry | None, key: str | None, message: str) -> LaunchError:
        """A one-line error at ``key`` of ``entry`` (or of the file's top level)."""
        lines = entry.lines if entry is not None else self.lines
        line = lines.get(key or "", entry.line if entry is not None else 1)
        where = f"node {entry.name!r}: " if entry is not None else ""
        what = f"key {key!r}: " if key else ""
        return LaunchError(f"{self.path}:{line}: {where}{what}{message}")

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
                raise LaunchError(f"{self.path}: no machine {machine!r} "
                                  f"(machines: {', '.join(self.machines) or 'none'})")
            return [e for e in self.nodes if e.machine == machine]
        return [e for e in self.nodes
                if e.machine is None or self.machines[e.machine].is_local]

    def transport_options(self, override: TransportOptions | None = None) -> TransportOptions:
        """The transport the nodes use: the file's, or the command line's ``override``
        (whose endpoints, when it has any, replace the file's)."""
        if override is None:
            return TransportOptions(self.transport, list(self.listen), list(self.connect))
        if override.kind == "local":
            if override.listen or override.connect:
                raise LaunchError("--listen and --connect need --transport zenoh")
            return TransportOptions("local", domain_id=override.domain_id)
        if override.kind != "zenoh":
            raise LaunchError(f"unknown transport {override.kind!r} (local or zenoh)")
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


def load_launch(path: str | Path) -> LaunchFile:
    """Read and check a launch file; errors are one :class:`LaunchError` line naming the
    file, line and key. Node classes are imported later, by :func:`check_entries`, because a
    machine need only have the classes of the nodes it runs."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise LaunchError(f"launch file {path}: {exc.strerror}") from None
    return _Parser(path).parse(text)


def _line(node: yaml.Node) -> int:
    return node.start_mark.line + 1


def _value(node: yaml.Node) -> Any:
    """The Python value of a composed YAML node (composing keeps the lines; this the types)."""
    return yaml.safe_load(yaml.serialize(node))


class _Parser:
    def __init__(self, path: Path) -> None:
        self.path = path
        self.directory = path.parent

    def error(self, node: yaml.Node | int, where: str, message: str) -> LaunchError:
        line = node if isinstance(node, int) else _line(node)
        return LaunchError(f"{self.path}:{line}: {where + ': ' if where else ''}{message}")

    def mapping(self, node: yaml.Node, where: str, what: str,
                keys: Sequence[str]) -> dict[str, tuple[yaml.Node, yaml.Node]]:
        """The key and value nodes of a mapping whose keys must be among ``keys``."""
        if not isinstance(node, yaml.MappingNode):
            raise self.error(node, where, f"{what} must be a mapping")
        fields: dict[str, tuple[yaml.Node, yaml.Node]] = {}
        for key, value in node.value:
            name = key.value if isinstance(key, yaml.ScalarNode) else None
            if not isinstance(name, str) or not name:
                raise self.error(key, where, "keys must be names")
            if name in fields:
                raise self.error(key, where, f"duplicate key {name!r} "
                                 f"(also on line {_line(fields[name][0])})")
            fields[name] = (key, value)
        for name, (key, _) in fields.items():
            if keys and name not in keys:
                raise self.error(key, where, _unknown_key(name, keys))
        return fields

    def text(self, node: yaml.Node, where: str, key: str) -> str:
        value = _value(node) if isinstance(node, yaml.ScalarNode) else None
        if not isinstance(value, str) or not value:
            raise self.error(node, where, f"key {key!r}: must be a non-empty string")
        return value

    def flag(self, node: yaml.Node, where: str, key: str) -> bool:
        value = _value(node) if isinstance(node, yaml.ScalarNode) else None
        if not isinstance(value, bool):
            raise self.error(node, where, f"key {key!r}: must be true or false")
        return value

    def texts(self, node: yaml.Node, where: str, key: str) -> list[tuple[yaml.Node, str]]:
        """A string or a list of strings (each with its node, for its line)."""
        items = node.value if isinstance(node, yaml.SequenceNode) else [node]
        return [(item, self.text(item, where, key)) for item in items]

    # -- the file ----------------------------------------------------------------------------

    def parse(self, text: str) -> LaunchFile:
        try:
            root = yaml.compose(text)
        except yaml.YAMLError as exc:
            mark = getattr(exc, "problem_mark", None)
            line = mark.line + 1 if mark is not None else 1
            problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
            context, context_mark = getattr(exc, "context", None), getattr(exc, "context_mark",
                                                                          None)
            if context and context_mark is not None and context_mark.line + 1 != line:
                problem += f"; {context} on line {context_mark.line + 1}"  # an unclosed [
            raise self.error(line, "", f"not valid YAML ({problem})") from None
        if root is None:
            raise self.error(1, "", "key 'nodes' missing (the file is empty)")
        fields = self.mapping(root, "", "a launch file", _TOP_KEYS)
        launch = LaunchFile(self.path, lines={k: _line(n) for k, (n, _) in fields.items()})
        if "transport" in fields:
            value = fields["transport"][1]
            launch.transport = self.text(value, "", "transport")
            if launch.transport not in ("local", "zenoh"):
                raise self.error(value, "", f"key 'transport': {launch.transport!r} is not "
                                 "local or zenoh")
        if "zenoh" in fields:
            self.zenoh(fields["zenoh"], launch)
        if "machines" in fields:
            self.machines(fields["machines"][1], launch)
        if "parameters" in fields:
            for item, name in self.texts(fields["parameters"][1], "", "parameters"):
                launch.parameters.merge(self.parameter_file(item, "", name))
        if "nodes" not in fields:
            raise self.error(root, "", "key 'nodes' missing")
        nodes = fields["nodes"][1]
        if not isinstance(nodes, yaml.SequenceNode) or not nodes.value:
            raise self.error(nodes, "", "key 'nodes': must be a list of node entries")
        default = next((m.name for m in launch.machines.values() if m.default), None)
        launch.nodes = [self.entry(item, index, launch, default)
                        for index, item in enumerate(nodes.value, 1)]
        self.check_together(launch)
        return launch

    def zenoh(self, fields: tuple[yaml.Node, yaml.Node], launch: LaunchFile) -> None:
        key, value = fields
        if launch.transport != "zenoh":
            raise self.error(key, "", "key 'zenoh': endpoints need transport: zenoh")
        for name, (_, endpoints) in self.mapping(value, "zenoh", "key 'zenoh'",
                                                 _ZENOH_KEYS).items():
            found = [] if _value(endpoints) in (None, []) else self.texts(endpoints, "zenoh",
                                                                           name)
            for item, endpoint in found:
                if not _ENDPOINT.fullmatch(endpoint):
                    raise self.error(item, "zenoh", f"key {name!r}: {endpoint!r} is not a "
                                     "Zenoh endpoint such as tcp/127.0.0.1:7447")
            getattr(launch, name).extend(endpoint for _, endpoint in found)

    def machines(self, node: yaml.Node, launch: LaunchFile) -> None:
        for name, (key, value) in self.mapping(node, "", "key 'machines'", ()).items():
            where = f"machine {name!r}"
            fields = self.mapping(value, where, "a machine", _MACHINE_KEYS)
            if "address" not in fields:
                raise self.error(key, where, "key 'address' missing")
            default = "default" in fields and self.flag(fields["default"][1], where, "default")
            if default and (other := next((m for m in launch.machines.values() if m.default),
                                          None)):
                raise self.error(fields["default"][0], where, "key 'default': only one "
                                 f"machine can be the default ({other.name!r} is)")
            launch.machines[name] = Machine(
                name, self.text(fields["address"][1], where, "address"), default, _line(key))

    def parameter_file(self, node: yaml.Node, where: str, name: str) -> ParameterOverrides:
        path = self.directory / name
        if not path.is_file():
            raise self.error(node, where, f"key 'parameters': file {name!r} not found "
                             f"(looked for {path})")
        try:
            return ParameterOverrides.from_file(path)
        except ParameterError as exc:
            raise self.error(node, where, f"key 'parameters': {exc}") from None

    # -- one entry ---------------------------------------------------------------------------

    def entry(self, item: yaml.Node, index: int, launch: LaunchFile,
              default_machine: str | None) -> NodeEntry:
        where = f"node #{index}"
        fields = self.mapping(item, where, "a node entry", ())
        if "name" not in fields:
            raise self.error(item, where, "key 'name' missing")
        name_node = fields["name"][1]
        name = self.text(name_node, where, "name")
        where = f"node {name!r}"
        try:
            check_node_name(name)
        except MessageError as exc:
            raise self.error(name_node, where, f"key 'name': {exc}") from None
        if "node" in fields and "exec" in fields:
            raise self.error(fields["exec"][0], where, "key 'exec': give 'node' or 'exec', "
                             "not both")
        if "node" not in fields and "exec" not in fields:
            raise self.error(item, where, "key 'node' missing (module:Class), or 'exec' (a "
                             "command)")
        allowed = _EXEC_KEYS if "exec" in fields else _NODE_KEYS
        for key, (key_node, _) in fields.items():
            if key not in allowed:
                message = (f"key {key!r} is for node entries, not exec ones"
                           if key in _NODE_KEYS else _unknown_key(key, allowed))
                raise self.error(key_node, where, message)
        entry = NodeEntry(name, line=_line(item),
                          lines={k: _line(n) for k, (n, _) in fields.items()})
        if "exec" in fields:
            entry.command = self.command(fields["exec"][1], where, launch)
            entry.process = ""
        else:
            self.node_fields(entry, fields, where)
        if "machine" in fields:
            machine_node = fields["machine"][1]
            entry.machine = self.text(machine_node, where, "machine")
            if entry.machine not in launch.machines:
                raise self.error(machine_node, where, f"key 'machine': no machine "
                                 f"{entry.machine!r} (machines: "
                                 f"{', '.join(launch.machines) or 'none'})")
        else:
            entry.machine = default_machine
        if "required" in fields:
            entry.required = self.flag(fields["required"][1], where, "required")
        return entry

    def node_fields(self, entry: NodeEntry, fields: dict[str, tuple[yaml.Node, yaml.Node]],
                    where: str) -> None:
        value = fields["node"][1]
        entry.node = self.text(value, where, "node")
        if not _CLASS_PATH.fullmatch(entry.node):
            raise self.error(value, where, f"key 'node': {entry.node!r} is not module:Class "
                             "(e.g. servolab.middleware.demo_nodes:Talker)")
        if "namespace" in fields:
            value = fields["namespace"][1]
            namespace = self.text(value, where, "namespace")
            try:
                entry.namespace = node_namespace(namespace, entry.name)
            except MessageError as exc:
                raise self.error(value, where, f"key 'namespace': {exc}") from None
        if "process" in fields:
            value = fields["process"][1]
            entry.process = self.text(value, where, "process")
            if not _PROCESS_NAME.fullmatch(entry.process):
                raise self.error(value, where, f"key 'process': {entry.process!r} is not a "
                                 "name (letters, digits, '_', '.', '-')")
        if "remappings" in fields:
            remaps = self.mapping(fields["remappings"][1], where, "key 'remappings'", ())
            for source, (_, target_node) in remaps.items():
                target = self.text(target_node, where, "remappings")
                try:
                    resolve_name(source, entry.namespace, entry.name)
                    resolve_name(target, entry.namespace, entry.name)
                except MessageError as exc:
                    raise self.error(target_node, where, f"key 'remappings': {exc}") from None
                entry.remappings[source] = target
        if "parameters" in fields:
            value = fields["parameters"][1]
            items = value.value if isinstance(value, yaml.SequenceNode) else [value]
            for item in items:
                if isinstance(item, yaml.MappingNode):
                    self.flatten(item, "", entry.parameters, where)
                elif isinstance(item, yaml.ScalarNode):
                    name = self.text(item, where, "parameters")
                    overrides = self.parameter_file(item, where, name)
                    entry.parameters.update(overrides.for_node(entry.fully_qualified_name))
                else:
                    raise self.error(item, where, "key 'parameters': must be a mapping, a "
                                     "file, or a list of them")

    def flatten(self, node: yaml.MappingNode, prefix: str, out: dict[str, Any],
                where: str) -> None:
        """Nested mappings become dotted names, as in a ROS 2 parameter file."""
        for name, (_, value) in self.mapping(node, where, "key 'parameters'", ()).items():
            if isinstance(value, yaml.MappingNode):
                self.flatten(value, f"{prefix}{name}.", out, where)
                continue
            data = _value(value)
            try:
                type_of(data)
            except ParameterError as exc:
                raise self.error(value, where, f"key 'parameters': {prefix}{name}: "
                                 f"{exc}") from None
            out[f"{prefix}{name}"] = data

    def command(self, node: yaml.Node, where: str, launch: LaunchFile) -> list[str]:
        if isinstance(node, yaml.ScalarNode):
            argv = shlex.split(str(node.value))
        elif isinstance(node, yaml.SequenceNode) and all(
                isinstance(item, yaml.ScalarNode) for item in node.value):
            argv = [str(item.value) for item in node.value]  # as typed: `5` stays "5"
        else:
            argv = []
        if not argv:
            raise self.error(node, where, "key 'exec': must be a command (a list of "
                             "arguments, or a string)")
        for arg in argv:
            rest = arg.replace(ZENOH_ENDPOINT, "")
            if "$(" in rest:
                raise self.error(node, where, f"key 'exec': unknown substitution in {arg!r} "
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
        for entry in launch.nodes:
            where = f"node {entry.name!r}"
            fqn = entry.fully_qualified_name
            if fqn in seen:
                raise self.error(entry.lines["name"], where, f"key 'name': duplicate name "
                                 f"{fqn} (also on line {seen[fqn].lines['name']})")
            seen[fqn] = entry
            if entry.is_exec:
                key = "exec"
            else:
                key = "machine" if "machine" in entry.lines and "process" not in entry.lines \
                    else "process"
            line = entry.lines.get(key, entry.line)
            processes.add((entry.process or f"exec {entry.name}", entry.machine))
            if len(processes) > 1 and launch.transport == "local":
                raise self.error(line, where, f"key {key!r}: a second process needs "
                                 "transport: zenoh (transport is local)")
            if not entry.is_exec:
                first = machine_of.setdefault(entry.process, entry)
                if first.machine != entry.machine:
                    raise self.error(entry.lines.get("process", entry.line), where,
                                     f"key 'process': process {entry.process!r} "
                                     f"has nodes on machines {_machine(first.machine)} and "
                                     f"{_machine(entry.machine)}; give them different "
                                     "processes")


def _machine(name: str | None) -> str:
    return repr(name) if name is not None else "(none)"


def _unknown_key(key: str, allowed: Sequence[str]) -> str:
    close = difflib.get_close_matches(key, allowed, n=1)
    return f"unknown key {key!r}" + (f" (did you mean {close[0]!r}?)" if close else "")


# -- checks before anything starts -----------------------------------------------------------


def import_node_class(launch: LaunchFile, entry: NodeEntry) -> type[Node]:
    """The class a node entry names, or a one-line :class:`LaunchError` saying why not."""
    assert entry.node is not None
    module_name, _, attribute = entry.node.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        if exc.name and (module_name + ".").startswith(exc.name + "."):
            raise launch.error(entry, "node", f"no module named {exc.name!r}") from None
        raise launch.error(entry, "node", f"importing {module_name!r} failed: "
                           f"{one_line(exc)}") from None
    except Exception as exc:  # the module itself is broken: say how, in one line
        raise launch.error(entry, "node", f"importing {module_name!r} failed: "
                           f"{one_line(exc)}") from None
    found: Any = module
    for part in attribute.split("."):
        found = getattr(found, part, None)
        if found is None:
            raise launch.error(entry, "node", f"module {module_name!r} has no class "
                               f"{attribute!r}")
    if not (isinstance(found, type) and issubclass(found, Node)):
        raise launch.error(entry, "node", f"{entry.node} is not a Node subclass")
    return found


def check_entries(launch: LaunchFile, entries: Sequence[NodeEntry]) -> None:
    """Import every node class and look up every command of ``entries``, so that a typo
    stops the launch before any process starts rather than after some did."""
    for entry in entries:
        if not entry.is_exec:
            import_node_class(launch, entry)
        elif entry.command[0] != "servolab" and shutil.which(entry.command[0]) is None:
            raise launch.error(entry, "exec", f"command {entry.command[0]!r} not found")


def one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0]}" if text else type(exc).__name__
