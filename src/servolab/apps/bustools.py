"""The Dynamixel commands: ``sim``, ``scan``, ``read`` and ``write``.

Each function takes plain values (already parsed by the CLI), does the work, prints for a person
and returns what it found, so tests and other code can call it without a shell.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Iterable, Sequence
from typing import TextIO

from ..dynamixel import units
from ..dynamixel.bus import Bus, PingResult
from ..dynamixel.emulator import build_emulator
from ..dynamixel.errors import ConfigError
from ..dynamixel.motorspec import MotorSpec
from ..dynamixel.ports import PtyServer
from ..runs import RunFolder
from ..signals import on_stop_signals, raise_keyboard_interrupt

#: Baud rates the Dynamixel Wizard offers, per protocol, most common first.
COMMON_BAUDS = {
    1: [57600, 1_000_000, 115_200, 500_000, 400_000, 250_000, 200_000, 9_600],
    2: [57600, 1_000_000, 115_200, 2_000_000, 3_000_000, 4_000_000, 9_600],
}


def sim(spec: MotorSpec, *, run: RunFolder, link: str | None = None,
        stdout: TextIO = sys.stdout, stderr: TextIO = sys.stderr,
        duration: float | None = None) -> dict[str, object]:
    """Serve emulated motors on a pseudo-terminal until Ctrl-C / SIGTERM (or ``duration`` s).

    The device path is the first line on stdout, so scripts can read it."""
    emulator = build_emulator(spec)
    baud = spec.baudrate or spec.motors[0].model.baud_from_register(
        spec.motors[0].model.register("baud_rate").default or 0)
    server = PtyServer(emulator, baud, link=link)
    print(server.device, file=stdout, flush=True)
    names = sorted({e.model.name for e in spec.motors})
    ids = ",".join(str(e.id) for e in spec.motors)
    print(f"servolab sim: {len(spec.motors)} emulated {'/'.join(names)} (IDs {ids}) on "
          f"protocol {spec.protocol}.0 at {baud} bps on {server.device}"
          f"{f' (link {link})' if link else ''}; Ctrl-C stops", file=stderr, flush=True)
    started = time.monotonic()
    with on_stop_signals(raise_keyboard_interrupt), server:
        try:
            while duration is None or time.monotonic() - started < duration:
                time.sleep(0.2)
        except KeyboardInterrupt:
            pass
    figures = {"device": server.device, "protocol": spec.protocol, "baudrate": baud,
               "motors": [{"id": e.id, "model": e.model.name} for e in spec.motors],
               "instructions_received": emulator.instructions_seen,
               "served_s": round(time.monotonic() - started, 3)}
    run.write_summary(figures)
    print(f"servolab sim: stopped after {emulator.instructions_seen} instructions; "
          f"summary in {run.path}", file=stderr, flush=True)
    return figures


def scan(device: str, *, protocols: Sequence[int], baudrates: Sequence[int] | None,
         ids: Iterable[int] | None, run: RunFolder | None = None,
         stdout: TextIO = sys.stdout, stderr: TextIO = sys.stderr) -> list[tuple[int,
                                                                          PingResult]]:
    """Ping every ID at every baud rate on each protocol and list what answers, like the
    Dynamixel Wizard's scan."""
    found: list[tuple[int, PingResult]] = []
    id_list = list(ids) if ids is not None else None
    for version in protocols:
        rates = list(baudrates) if baudrates else COMMON_BAUDS[version]
        with Bus.open(device, protocol=version, baudrate=rates[0], retries=0) as bus:
            last = [-1]

            live = stderr.isatty()

            def progress(baud: int, motor_id: int, version: int = version,
                         last: list[int] = last, live: bool = live) -> None:
                if live:  # one line that counts up, for a person watching
                    print(f"\rscanning protocol {version}.0 at {baud} bps: ID {motor_id:>3}",
                          end="", file=stderr, flush=True)
                elif baud != last[0]:
                    print(f"scanning protocol {version}.0 at {baud} bps ...", file=stderr,
                          flush=True)
                last[0] = baud

            ids_here = id_list if id_list is not None else range(bus.proto.max_id + 1)
            found += [(version, r) for r in bus.scan(ids_here, rates, progress=progress)]
            if live:
                print(file=stderr)
    print(f"{'ID':>4}  {'model':<12} {'number':>6}  {'firmware':>8}  {'protocol':>8}  "
          f"{'baud':>8}", file=stdout)
    for version, r in found:
        print(f"{r.id:>4}  {r.model_name:<12} {r.model_number:>6}  {r.firmware!s:>8}  "
              f"{version}.0{'':>5}  {r.baudrate:>8}", file=stdout)
    print(f"{len(found)} motor(s) found", file=stdout, flush=True)
    if run is not None:
        run.write_summary({"device": device, "found": [
            {"id": r.id, "model": r.model_name, "model_number": r.model_number,
             "firmware": r.firmware, "protocol": v, "baudrate": r.baudrate}
            for v, r in found]})
    return found


def _open(device: str, protocol: int, baudrate: int, model: str | None,
          motor_id: int) -> Bus:
    bus = Bus.open(device, protocol=protocol, baudrate=baudrate)
    if model is not None:
        bus.declare(motor_id, model)
    return bus


def read(device: str, motor_id: int, names: Sequence[str], *, protocol: int, baudrate: int,
         raw: bool = False, model: str | None = None,
         stdout: TextIO = sys.stdout) -> dict[str, float | int]:
    """Read registers of one motor and print each in SI units (and raw)."""
    with _open(device, protocol, baudrate, model, motor_id) as bus:
        m = bus.model_of(motor_id)
        for name in names:
            m.register(name)  # unknown names fail before anything is sent
        values = bus.read(motor_id, list(names), raw=True)
        assert isinstance(values, dict)
        out: dict[str, float | int] = {}
        for name in names:
            reg = m.register(name)
            si = units.to_si(m, reg, int(values[name]))
            out[name] = values[name] if raw else si
            unit = units.KINDS.get(reg.unit, "")
            if raw:
                print(f"{name} = {values[name]}", file=stdout)
            else:
                print(f"{name} = {_fmt(si)}{' ' + unit if unit else ''} (raw {values[name]})",
                      file=stdout)
        return out


def write(device: str, motor_id: int, name: str, value: str, *, protocol: int, baudrate: int,
          raw: bool = False, model: str | None = None, stdout: TextIO = sys.stdout) -> int:
    """Write one register of one motor (SI units unless ``raw``); returns the raw value."""
    number = parse_value(value, name)
    with _open(device, protocol, baudrate, model, motor_id) as bus:
        m = bus.model_of(motor_id)
        reg = m.register(name)
        if not reg.writable:
            raise ConfigError(f"{m.name} {name} is read-only")
        if raw and not number.is_integer():
            raise ConfigError(f"{m.name} {name}: raw value {value!r} is not an integer")
        raw_value = int(number) if raw else units.from_si(m, reg, number)
        if raw:
            reg.check(raw_value, m)
        bus.write(motor_id, name, raw_value, raw=True)
        print(f"motor {motor_id} ({m.name}): {name} <- {value} (raw {raw_value})", file=stdout)
        return raw_value


def parse_value(text: str, name: str) -> float:
    words = {"on": 1.0, "off": 0.0, "true": 1.0, "false": 0.0}
    if text.lower() in words:
        return words[text.lower()]
    try:
        return float(text)
    except ValueError:
        raise ConfigError(f"{name}: value {text!r} is not a number") from None


def _fmt(value: float) -> str:
    return f"{value:.6g}" if isinstance(value, float) else str(value)
