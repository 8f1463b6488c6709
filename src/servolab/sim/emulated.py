"""Emulated buses in a simulation: what ``emu://`` opens.

``Bus.open("emu://rx28:11-16", baudrate=57142)`` lands in :func:`open_emulated_url` (the driver
finds it through :data:`servolab.dynamixel.ports.URL_SCHEMES` and never imports the emulator):
it builds the motors of the spec, puts them in a :class:`~.simulation.Simulation` — the one
given as ``simulation=``, or a new one of their own — and wires a
:class:`~servolab.dynamixel.ports.MemoryPort` to them on the simulation's clock.

The URL is ``emu://SPEC[?OPTION=VALUE&...]``. SPEC is the short form of
:mod:`servolab.dynamixel.motorspec` (``rx28:11-16,21-26``, ``xm430-w210:1-3;xl430-w250:4``)
or the path of a motor-spec YAML file. Options: ``baud``, ``drop_rate``, ``corrupt_rate``,
``delay`` and ``seed`` (injected faults, see :class:`~servolab.dynamixel.emulator.Faults`).

Baud rates: the motors run at the URL's ``baud``, else at the YAML file's ``baudrate``, else
at the port's rate when one is given (so that they answer it), else at their factory rate;
the port runs at the rate given, else at the motors'. Each opening builds new motors: nothing
carries over from one ``emu://`` bus to the next.
"""

from __future__ import annotations

from urllib.parse import parse_qsl

from ..dynamixel import motorspec
from ..dynamixel.emulator import Emulator, Faults, build_emulator
from ..dynamixel.errors import ConfigError
from ..dynamixel.motorspec import MotorSpec
from ..dynamixel.ports import MemoryPort
from .simulation import Simulation

_FAULT_OPTIONS = ("drop_rate", "corrupt_rate", "delay", "seed")


def emulated_port(spec: str | MotorSpec, baudrate: int | None = None, *,
                  simulation: Simulation | None = None, faults: Faults | None = None,
                  protocol: int | None = None) -> MemoryPort:
    """A port wired to emulated motors in ``simulation`` (a new one if None).

    ``spec`` is a :class:`MotorSpec` or its short form / YAML path. The motors run at the
    spec's baud rate, else at ``baudrate``, else at their factory rate; the port runs at
    ``baudrate``, else at the motors' rate. The emulator is ``port.emulator``, the simulation
    ``port.clock``."""
    if isinstance(spec, str):
        spec = motorspec.load(spec, protocol=protocol, baudrate=baudrate)
    elif spec.baudrate is None and baudrate is not None:
        spec = spec.at_baudrate(baudrate)
    sim = simulation if simulation is not None else Simulation()
    emulator: Emulator = sim.add_emulator(build_emulator(spec, faults=faults))
    return port_to(emulator, sim, baudrate or spec.motor_baudrate)


def port_to(emulator: Emulator, simulation: Simulation, baudrate: int) -> MemoryPort:
    """Another port to an emulated bus already in ``simulation`` — e.g. a world's example,
    which keeps no driver of its own: ``Bus(port_to(sim.emulators[0], sim, 1_000_000))``."""
    if emulator not in simulation.emulators:
        raise ConfigError("port_to: this emulated bus is not in the simulation given")
    name = "emu://" + ",".join(f"{m.model.name}:{m.id}" for m in emulator.motors)
    return MemoryPort(emulator, baudrate, clock=simulation, name=name,
                      protocol=emulator.protocol.version, lock=simulation.lock)


def open_emulated_url(rest: str, baudrate: int | None, *,
                      simulation: Simulation | None = None,
                      faults: Faults | None = None, protocol: int | None = None) -> MemoryPort:
    """The ``emu://`` handler: ``rest`` is what follows ``emu://``; see the module docstring."""
    spec_text, _, query = rest.partition("?")
    if not spec_text:
        raise ConfigError("port 'emu://': name the motors, e.g. emu://rx28:11-16 or "
                          "emu://motors.yaml")
    options: dict[str, str] = {}
    try:
        pairs = parse_qsl(query, keep_blank_values=True, strict_parsing=bool(query))
    except ValueError:
        raise ConfigError(f"port 'emu://{rest}': options are KEY=VALUE joined by '&'"
                          ) from None
    for key, value in pairs:
        if key not in ("baud", *_FAULT_OPTIONS):
            raise ConfigError(f"port 'emu://{rest}': unknown option {key!r} (use baud, "
                              f"{', '.join(_FAULT_OPTIONS)})")
        if key in options:
            raise ConfigError(f"port 'emu://{rest}': option {key!r} is given twice")
        options[key] = value
    motor_baud = int(_number(options.pop("baud"), "baud", rest, int)) if "baud" in options \
        else None
    if options:
        if faults is not None:
            raise ConfigError(f"port 'emu://{rest}': faults given twice (URL and faults=)")
        faults = Faults(drop_rate=_number(options.get("drop_rate", "0"), "drop_rate", rest),
                        corrupt_rate=_number(options.get("corrupt_rate", "0"), "corrupt_rate",
                                             rest),
                        delay=_number(options.get("delay", "0"), "delay", rest),
                        seed=int(_number(options.get("seed", "0"), "seed", rest, int)))
    spec = motorspec.load(spec_text, protocol=protocol, baudrate=baudrate)
    if motor_baud is not None:
        spec = spec.at_baudrate(motor_baud)
    return emulated_port(spec, baudrate, simulation=simulation, faults=faults)


def _number(text: str, key: str, rest: str, kind: type[int] | type[float] = float) -> float:
    try:
        return kind(text)
    except ValueError:
        raise ConfigError(f"port 'emu://{rest}': option {key}={text!r} is not "
                          f"{'a whole number' if kind is int else 'a number'}") from None
