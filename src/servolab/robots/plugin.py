"""What a robot is to servolab: one :class:`RobotPlugin`, defined in the robot's own package or
folder and found by :mod:`.registry`, never listed by hand in a shared file.

A plug-in says what the robot is (name, one line), what it is on its bus (:class:`BusSummary`),
how to open it on emulated motors or on a port, what stopping does to its motors, which files a
user starts from (``servolab robots show``), its robot description (URDF), how ``servolab sim
--robot NAME --pty`` serves it (:class:`ServedRobot`: its motors, and the world they move when it
has one) and its Foxglove layout. Everything but the name, the summary, the bus, the opener and
the stop is optional, and every field that costs anything is a callable, so that listing the
robots imports none of them (as ``dm_control.suite`` lists domains without building them).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ..dynamixel.emulator import Emulator
    from ..dynamixel.motorspec import MotorSpec
    from ..middleware.view.layout import Layout
    from ..sim.simulation import Simulation

#: A file ``servolab robots show`` prints: shipped as a file, or written when asked (a URDF
#: written from a robot's one model).
ShownFile = Path | Callable[[], str]


def ranges(ids: tuple[int, ...]) -> str:
    """``11-16,21-26``: runs of consecutive IDs, as ``emu://`` URLs write them."""
    parts: list[str] = []
    start = previous = None
    for i in sorted(ids):
        if previous is not None and i == previous + 1:
            previous = i
            continue
        if start is not None:
            parts.append(f"{start}" if start == previous else f"{start}-{previous}")
        start = previous = i
    if start is not None:
        parts.append(f"{start}" if start == previous else f"{start}-{previous}")
    return ",".join(parts)


@dataclass(frozen=True)
class BusSummary:
    """What a robot is on its bus, for a listing and for emulating it: each motor's ID and
    model (a robot may mix models: an arm's wrist is often smaller than its shoulder), the
    protocol and the baud rate."""

    motors: tuple[tuple[int, str], ...]
    protocol: int
    baudrate: int

    @classmethod
    def of(cls, model: str, ids: tuple[int, ...], protocol: int, baudrate: int) -> BusSummary:
        """A bus of one model."""
        return cls(tuple((i, model) for i in ids), protocol, baudrate)

    @property
    def ids(self) -> tuple[int, ...]:
        return tuple(i for i, _ in self.motors)

    def model_of(self, motor_id: int) -> str:
        return dict(self.motors)[motor_id]

    def groups(self) -> list[tuple[str, tuple[int, ...]]]:
        """The models in the order they first appear, each with its IDs."""
        by_model: dict[str, list[int]] = {}
        for motor_id, model in self.motors:
            by_model.setdefault(model, []).append(motor_id)
        return [(model, tuple(ids)) for model, ids in by_model.items()]

    def motor_spec(self) -> MotorSpec:
        """These motors, emulated (:mod:`servolab.dynamixel.motorspec`): what ``servolab sim
        --robot NAME`` serves when the robot brings no world of its own."""
        from ..dynamixel.models import model
        from ..dynamixel.motorspec import MotorEntry, MotorSpec

        return MotorSpec(self.protocol, self.baudrate,
                         tuple(MotorEntry(model(name), i) for i, name in self.motors))

    def __str__(self) -> str:
        motors = " + ".join(
            f"{len(ids)} x {model} ({'IDs' if len(ids) > 1 else 'ID'} {ranges(ids)})"
            for model, ids in self.groups())
        return f"{motors}, Protocol {self.protocol:.1f}, {self.baudrate} bps"


@dataclass(frozen=True)
class ServedRobot:
    """What ``servolab sim --robot NAME --pty`` serves: the robot's emulated motors, and — when
    the robot has one — how to put them in their world (``place`` returns the simulation, the
    emulator as the world holds it, and the world) and what to report of the world at the end
    (``report(world, plot_path, now)``: figures for the summary)."""

    spec: MotorSpec
    place: Callable[[Emulator], tuple[Simulation, Emulator, Any]] | None = None
    report: Callable[[Any, Path, float], dict[str, Any]] | None = None
    #: what the world is, for the line ``servolab sim`` prints ("driving the biped in MuJoCo")
    what: str = ""


def _no_config() -> Path | None:
    return None


def _no_files() -> Mapping[str, ShownFile]:
    return {}


@dataclass(frozen=True)
class RobotPlugin:
    """One robot servolab can open, list, serve and show.

    ``open(port)`` gives the robot on emulated motors (``port=None``) or on the serial port or
    pyserial URL ``port``; the object it returns has ``bus`` and ``close()``. ``on_stop`` says
    what every end of a run does to the motors (:mod:`servolab.harness`). ``config`` is the
    robot's default configuration file; ``files`` any more files ``servolab robots show``
    prints; ``description`` the robot's URDF; ``served`` what ``servolab sim --robot`` serves
    (default: the motors of ``bus`` alone); ``layout`` its Foxglove layout. ``aliases`` are
    other names it answers to. ``origin`` says where it was found (set by the registry)."""

    name: str
    summary: str
    bus: Callable[[], BusSummary]
    open: Callable[[str | None], Any]
    on_stop: str
    config: Callable[[], Path | None] = _no_config
    files: Callable[[], Mapping[str, ShownFile]] = _no_files
    description: Callable[[], str] | None = None
    served: Callable[[int | None], ServedRobot] | None = None
    layout: Callable[[], Layout] | None = None
    aliases: tuple[str, ...] = ()
    #: the ``servolab`` commands that run this robot (``walk``), listed for the user; a
    #: command names its robot, nothing else outside the robot's package does
    commands: tuple[str, ...] = ()
    #: the commands that run this robot when no ``--robot`` is given (``arm``, ``teleop``):
    #: a plug-in says it is the default, no command names it (:func:`.registry.default_robot`)
    default_for: tuple[str, ...] = ()
    #: the Dynamixel model of motors its URDF's <ros2_control> block names none for
    #: (ROBOTIS's dialect names none): what ``servolab control run NAME`` takes without --model
    default_model: str | None = None
    origin: str = field(default="", compare=False)

    def load(self, port: str | None = None) -> Any:
        return self.open(port)

    def serve(self, baudrate: int | None = None) -> ServedRobot:
        """What ``servolab sim --robot`` serves, at ``baudrate`` (None: the robot's own)."""
        if self.served is not None:
            return self.served(baudrate)
        spec = self.bus().motor_spec()
        return ServedRobot(spec if baudrate is None else spec.at_baudrate(baudrate))

    def shown_files(self) -> dict[str, ShownFile]:
        """Every file ``servolab robots show`` prints for this robot, by the name it takes:
        the configuration under the robot's name, its URDF as ``NAME.urdf``, then the rest."""
        shown: dict[str, ShownFile] = {}
        config = self.config()
        if config is not None:
            shown[self.name] = config
        if self.description is not None:
            shown[f"{self.name}.urdf"] = self.description
        shown.update(self.files())
        return shown
