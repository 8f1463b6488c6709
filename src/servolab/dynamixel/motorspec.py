"""Which emulated motors make up a bus: the short form and the YAML file.

Short form (command line): ``rx28:11-16,21-26`` or ``xm430-w210:1-3;xl430-w250:4``.

YAML file::

    protocol: 1          # optional: follows the models
    baudrate: 57142      # optional: each model's factory default
    motors:
      - {model: RX-28, ids: 11-16}
      - {model: RX-28, id: 21, position: 0.5}   # initial horn angle, rad

Errors name the file, the line and the field.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import yaml

from .errors import ConfigError
from .models import Model, model


@dataclass(frozen=True)
class MotorEntry:
    model: Model
    id: int
    position: float = 0.0


@dataclass(frozen=True)
class MotorSpec:
    """A bus of emulated motors: protocol, baud rate (None = factory default) and motors."""

    protocol: int
    baudrate: int | None
    motors: tuple[MotorEntry, ...]


def _ids(text: str, where: str) -> list[int]:
    ids: list[int] = []
    for part in str(text).split(","):
        part = part.strip()
        try:
            if "-" in part:
                a, b = (int(x) for x in part.split("-", 1))
                if a > b:
                    raise ValueError
                ids += range(a, b + 1)
            else:
                ids.append(int(part))
        except ValueError:
            raise ConfigError(f"{where}: {part!r} is not an ID or a range like 11-16") from None
    return ids


def _finish(entries: list[MotorEntry], protocol: int | None, baudrate: int | None,
            where: str) -> MotorSpec:
    if not entries:
        raise ConfigError(f"{where}: no motors")
    versions = {e.model.protocol for e in entries}
    if protocol is None:
        if len(versions) != 1:
            raise ConfigError(f"{where}: mixes protocol 1.0 and 2.0 models; a bus speaks one")
        protocol = versions.pop()
    bad = [e for e in entries if e.model.protocol != protocol]
    if bad:
        raise ConfigError(f"{where}: {bad[0].model.name} speaks protocol "
                          f"{bad[0].model.protocol}.0, the bus {protocol}.0")
    seen: set[int] = set()
    for e in entries:
        max_id = 253 if protocol == 1 else 252
        if not 0 <= e.id <= max_id:
            raise ConfigError(f"{where}: motor ID {e.id} is outside protocol {protocol}.0's "
                              f"range 0..{max_id}")
        if e.id in seen:
            raise ConfigError(f"{where}: motor ID {e.id} is listed twice; two motors with one ID "
                              "garble each other's answers (build such a bus in code to test it)")
        seen.add(e.id)
    if baudrate is not None:
        for e in entries:
            e.model.baud_register_for(baudrate)  # raises if the model cannot run at it
    return MotorSpec(protocol, baudrate, tuple(entries))


def parse_short(spec: str, *, protocol: int | None = None,
                baudrate: int | None = None) -> MotorSpec:
    """Parse the command-line form ``MODEL:IDS[;MODEL:IDS...]``."""
    groups = spec.replace(";", " ").split()
    if not groups:
        raise ConfigError("motor spec is empty; write e.g. 'rx28:11-16,21-26'")
    entries: list[MotorEntry] = []
    for group in groups:
        if ":" not in group:
            raise ConfigError(f"motor spec {group!r}: expected MODEL:IDS such as 'rx28:1-4'")
        name, ids = group.split(":", 1)
        m = model(name)
        entries += [MotorEntry(m, i) for i in _ids(ids, f"motor spec {group!r}")]
    return _finish(entries, protocol, baudrate, f"motor spec {spec!r}")


def load_yaml(path: str | Path, *, protocol: int | None = None,
              baudrate: int | None = None) -> MotorSpec:
    """Read a motor spec YAML file, naming file, line and field in every error."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read motor spec ({exc.strerror})") from None
    try:
        root = yaml.compose(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = f":{mark.line + 1}" if mark else ""
        raise ConfigError(f"{path}{line}: not valid YAML ({getattr(exc, 'problem', exc)})"
                          ) from None
    if not isinstance(root, yaml.MappingNode):
        raise ConfigError(f"{path}: expected a mapping with a 'motors' list")
    top = {k.value: v for k, v in root.value}
    for key in top:
        if key not in ("protocol", "baudrate", "motors"):
            raise ConfigError(f"{path}: unknown key {key!r} (use protocol, baudrate, motors)")

    def scalar(node: yaml.Node, field: str, kind: type) -> object:
        where = f"{path}:{node.start_mark.line + 1}: {field}"
        if not isinstance(node, yaml.ScalarNode):
            raise ConfigError(f"{where}: expected a single value")
        try:
            return kind(node.value)
        except ValueError:
            raise ConfigError(f"{where}: {node.value!r} is not a {kind.__name__}") from None

    if "protocol" in top:
        protocol = int(scalar(top["protocol"], "protocol", float))  # type: ignore[arg-type]
    if "baudrate" in top:
        baudrate = scalar(top["baudrate"], "baudrate", int)  # type: ignore[assignment]
    motors = top.get("motors")
    if not isinstance(motors, yaml.SequenceNode):
        raise ConfigError(f"{path}: 'motors' must be a list of {{model, id or ids}}")
    entries: list[MotorEntry] = []
    for item in motors.value:
        where = f"{path}:{item.start_mark.line + 1}"
        if not isinstance(item, yaml.MappingNode):
            raise ConfigError(f"{where}: a motor is a mapping like {{model: rx28, id: 1}}")
        fields = {k.value: v for k, v in item.value}
        unknown = set(fields) - {"model", "id", "ids", "position"}
        if unknown:
            raise ConfigError(f"{where}: unknown field {sorted(unknown)[0]!r} "
                              "(use model, id, ids, position)")
        if "model" not in fields or ("id" in fields) == ("ids" in fields):
            raise ConfigError(f"{where}: a motor needs 'model' and one of 'id' or 'ids'")
        try:
            m = model(str(scalar(fields["model"], "model", str)))
        except ConfigError as exc:
            raise ConfigError(f"{where}: model: {exc}") from None
        ids = ([int(scalar(fields["id"], "id", int))]  # type: ignore[arg-type]
               if "id" in fields else _ids(fields["ids"].value, f"{where}: ids"))
        position = float(scalar(fields["position"], "position", float)  # type: ignore[arg-type]
                         ) if "position" in fields else 0.0
        entries += [MotorEntry(m, i, position) for i in ids]
    return _finish(entries, protocol, baudrate, str(path))


def load(spec: str, *, protocol: int | None = None, baudrate: int | None = None) -> MotorSpec:
    """A spec from a YAML path (ending .yaml/.yml) or the short form."""
    if spec.endswith((".yaml", ".yml")):
        return load_yaml(spec, protocol=protocol, baudrate=baudrate)
    return parse_short(spec, protocol=protocol, baudrate=baudrate)
