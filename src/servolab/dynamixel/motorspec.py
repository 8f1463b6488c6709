"""Which emulated motors make up a bus: the short form and the YAML file.

Short form (command line): ``rx28:11-16,21-26`` or ``xm430-w210:1-3;xl430-w250:4``.

YAML file::

    protocol: 1          # optional: follows the models
    baudrate: 57142      # optional: each model's factory default
    motors:
      - {model: RX-28, ids: 11-16}
      - {model: RX-28, id: 21, position: 0.5}   # initial horn angle, rad

Errors name the file, the line and the field (:class:`.errors.MotorSpecFileError`, read
by :mod:`servolab.configfile`, which also refuses a key given twice).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ..configfile import ConfigList, ConfigMapping, ConfigScalar, ConfigValue, suggest
from ..configfile import load as load_config
from ..errors import ServolabError
from . import units
from .errors import ConfigError, MotorSpecFileError
from .models import Model, model

_TOP_KEYS = ("protocol", "baudrate", "motors")
_MOTOR_KEYS = ("model", "id", "ids", "position")


@dataclass(frozen=True)
class MotorEntry:
    model: Model
    id: int
    position: float = 0.0


@dataclass(frozen=True)
class MotorSpec:
    """A bus of emulated motors: protocol (None: motors of both, each in its own, as a mixed
    bus has them), baud rate (None = factory default) and motors."""

    protocol: int | None
    baudrate: int | None
    motors: tuple[MotorEntry, ...]

    @property
    def motor_baudrate(self) -> int:
        """The rate the motors run at: the spec's, else the first model's factory default."""
        if self.baudrate is not None:
            return self.baudrate
        first = self.motors[0].model
        return first.baud_from_register(first.register("baud_rate").default or 0)

    def at_baudrate(self, baudrate: int) -> MotorSpec:
        """The same motors at ``baudrate``; ConfigError if a model cannot run at it."""
        for entry in self.motors:
            entry.model.baud_register_for(baudrate)
        return MotorSpec(self.protocol, baudrate, self.motors)


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


#: Makes the error of a check of the whole spec: ``index`` is the motor entry at fault (None:
#: the spec as a whole), so a file's error can point at that entry's line.
_Fail = Callable[[int | None, str], ServolabError]


def _finish(entries: list[MotorEntry], protocol: int | None, baudrate: int | None,
            fail: _Fail) -> MotorSpec:
    if not entries:
        raise fail(None, "no motors")
    versions = {e.model.protocol for e in entries}
    if protocol is None and len(versions) == 1:
        protocol = versions.pop()
    # protocol still None: a mixed bus, each motor on its own protocol (MixedBus drives it)
    for index, e in enumerate(entries):
        if protocol is not None and e.model.protocol != protocol:
            raise fail(index, f"{e.model.name} speaks protocol {e.model.protocol}.0, "
                       f"the bus {protocol}.0")
    seen: set[int] = set()
    for index, e in enumerate(entries):
        version = e.model.protocol
        max_id = 253 if version == 1 else 252
        if not 0 <= e.id <= max_id:
            raise fail(index, f"motor ID {e.id} is outside protocol {version}.0's "
                       f"range 0..{max_id}")
        if e.id in seen:
            raise fail(index, f"motor ID {e.id} is listed twice; two motors with one ID "
                       "garble each other's answers (build such a bus in code to test it)")
        seen.add(e.id)
    if baudrate is not None:
        for e in entries:
            e.model.baud_register_for(baudrate)  # raises if the model cannot run at it
    return MotorSpec(protocol, baudrate, tuple(entries))


def _prefixed(where: str) -> _Fail:
    """Errors of the short form: the spec itself names the place."""
    def fail(index: int | None, message: str) -> ServolabError:
        return ConfigError(f"{where}: {message}")
    return fail


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
    return _finish(entries, protocol, baudrate, _prefixed(f"motor spec {spec!r}"))


def load_yaml(path: str | Path, *, protocol: int | None = None,
              baudrate: int | None = None) -> MotorSpec:
    """Read a motor spec YAML file; every error is a :class:`MotorSpecFileError` naming the
    file, line and field. ``protocol`` and ``baudrate`` apply unless the file gives them."""
    root = load_config(path, what="motor spec", error=MotorSpecFileError)
    if not isinstance(root, ConfigMapping):
        raise root.error("expected a mapping with a 'motors' list")
    _check_keys(root, _TOP_KEYS, "key")
    if (value := root.get("protocol")) is not None:
        number = _float(value, "protocol")
        if number not in (1.0, 2.0):
            raise value.error(f"protocol: {number:g} is not 1 or 2")
        protocol = int(number)
    baud_value = root.get("baudrate")
    if baud_value is not None:
        baudrate = _int(baud_value, "baudrate")
    motors = root.get("motors")
    if not isinstance(motors, ConfigList):
        raise (motors if motors is not None else root).error(
            "'motors' must be a list of {model, id or ids}")
    entries: list[MotorEntry] = []
    origins: list[ConfigValue] = []  # the item of each entry, for its line
    for item in motors:
        if not isinstance(item, ConfigMapping):
            raise item.error("a motor is a mapping like {model: rx28, id: 1}")
        _check_keys(item, _MOTOR_KEYS, "field")
        if "model" not in item or ("id" in item) == ("ids" in item):
            raise item.error("a motor needs 'model' and one of 'id' or 'ids'")
        model_value = item.require("model")
        try:
            m = model(_text(model_value, "model"))
        except MotorSpecFileError:
            raise
        except ConfigError as exc:
            raise model_value.error(f"model: {exc}") from None
        if (id_value := item.get("id")) is not None:
            ids = [_int(id_value, "id")]
        else:
            ids_value = item.require("ids")
            try:
                ids = _ids(_text(ids_value, "ids"), "ids")
            except MotorSpecFileError:
                raise
            except ConfigError as exc:
                raise ids_value.error(str(exc)) from None
        position_value = item.get("position")
        position = _float(position_value, "position") if position_value is not None else 0.0
        if position_value is not None:
            try:  # an angle the motor could be sent to: within its goal_position range
                units.from_si(m, m.register("goal_position"), position)
            except ConfigError as exc:
                raise position_value.error(f"position: {exc}") from None
        entries += [MotorEntry(m, i, position) for i in ids]
        origins += [item] * len(ids)

    def fail(index: int | None, message: str) -> ServolabError:
        return (origins[index] if index is not None else motors).error(message)

    try:
        return _finish(entries, protocol, baudrate, fail)
    except MotorSpecFileError:
        raise
    except ConfigError as exc:  # a model cannot run at the baud rate: the file's, if it gave one
        if baud_value is None:
            raise
        raise baud_value.error(f"baudrate: {exc}") from None


def _text(value: ConfigValue, field: str) -> str:
    """A scalar as written (``model: 28`` is the text "28")."""
    if not isinstance(value, ConfigScalar):
        raise value.error(f"{field}: expected a single value")
    return value.text


def _int(value: ConfigValue, field: str) -> int:
    text = _text(value, field)
    try:
        return int(text)
    except ValueError:
        raise value.error(f"{field}: {text!r} is not a int") from None


def _check_keys(mapping: ConfigMapping, allowed: tuple[str, ...], word: str) -> None:
    """Refuse a key not in ``allowed``, suggesting the closest and listing them all."""
    for key in mapping:
        if key not in allowed:
            close = suggest(key, allowed)
            hint = f"did you mean {close!r}? " if close else ""
            raise mapping.key_of(key).error(f"unknown {word} {key!r} ({hint}use "
                                            f"{', '.join(allowed)})")


def _float(value: ConfigValue, field: str) -> float:
    text = _text(value, field)
    try:
        number = float(text)
    except ValueError:
        raise value.error(f"{field}: {text!r} is not a float") from None
    if not math.isfinite(number):
        raise value.error(f"{field}: {text!r} is not a finite number")
    return number


def load(spec: str, *, protocol: int | None = None, baudrate: int | None = None) -> MotorSpec:
    """A spec from a YAML path (ending .yaml/.yml) or the short form."""
    if spec.endswith((".yaml", ".yml")):
        return load_yaml(spec, protocol=protocol, baudrate=baudrate)
    return parse_short(spec, protocol=protocol, baudrate=baudrate)
