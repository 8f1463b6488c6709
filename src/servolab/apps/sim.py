"""``servolab sim``: emulated motors on a pseudo-terminal, for programs that open a serial port.

:func:`sim` takes plain values (already parsed), prints for a person and returns what it saw,
so tests and other code can call it without a shell. The Dynamixel layer is imported inside
the functions, so that ``servolab --help`` does not load it.
"""

from __future__ import annotations

import argparse
import os
import sys
import threading
import time
from typing import TYPE_CHECKING, TextIO

from .arguments import add_out, baud, protocol
from .registry import Command

if TYPE_CHECKING:
    from ..dynamixel.emulator import Emulator
    from ..dynamixel.motorspec import MotorSpec
    from ..dynamixel.ports import PtyServer
    from ..robots.plugin import ServedRobot
    from ..runs import RunFolder
    from ..sim import Simulation


#: The niceness ``servolab sim`` asks for: above the programs a lab PC runs at 0.
HARDWARE_NICENESS = -10


def hardware_priority() -> int | None:
    """Raise this process's scheduling priority to :data:`HARDWARE_NICENESS` where the OS
    allows it (root, or CAP_SYS_NICE); returns the niceness set, or None.

    Emulated motors stand in for hardware, which no busy CPU slows down: a real RX-28 answers
    after its return delay whatever the PC is doing. At the default priority, a machine whose
    every core is busy (a camera, a viewer, a test suite) can hold the emulator's answers back
    for longer than the driver's timeout, which a real bus never does. Without the right to
    raise it, nothing changes."""
    try:
        os.setpriority(os.PRIO_PROCESS, 0, HARDWARE_NICENESS)
    except (OSError, AttributeError):  # not allowed (EACCES/EPERM), or no such call here
        return None
    return os.getpriority(os.PRIO_PROCESS, 0)


def sim(spec: MotorSpec, *, run: RunFolder, link: str | None = None,
        stdout: TextIO = sys.stdout, stderr: TextIO = sys.stderr,
        duration: float | None = None, raise_priority: bool = False,
        echo: bool = False, served: ServedRobot | None = None) -> dict[str, object]:
    """Serve emulated motors on a pseudo-terminal until Ctrl-C / SIGTERM (or ``duration`` s).

    The motors live in a :class:`~servolab.sim.Simulation` that runs in real time on its own
    thread, so they move whether or not the client talks. The device path is the first line
    on stdout, so scripts can read it. ``raise_priority`` (the command's own process only:
    it stays raised) runs the emulator at :func:`hardware_priority` and serves the pty from a
    real-time thread where the OS allows (:class:`~servolab.dynamixel.ports.PtyServer`'s
    ``realtime``): on a busy machine the OS then wakes it on time to hand each reply over.
    ``echo`` serves the motors as an adapter that echoes would
    (:class:`~servolab.dynamixel.ports.EchoingDevice`). The summary says how late the
    replies were handed over (``reply_lateness``, after their modelled wire time).

    ``served``: a robot's (``servolab sim --robot NAME``, :class:`~servolab.robots.plugin.
    ServedRobot`): when it brings a world, the motors (``spec``, the robot's) move it, stepped
    in real time beside the bus (Armstrong in MuJoCo), and the summary adds what the robot
    reports of it (whether and when the biped fell)."""
    from ..dynamixel.ports import EchoingDevice, PtyServer
    from ..signals import on_stop_signals, raise_keyboard_interrupt

    simulation, emulator, physics = _place(spec, served)
    niceness = hardware_priority() if raise_priority else None
    _start_real_time(simulation, raise_priority)
    server = PtyServer(EchoingDevice(emulator) if echo else emulator, spec.motor_baudrate,
                       link=link, clock=simulation, lock=simulation.lock,
                       realtime=raise_priority)
    started = time.monotonic()
    with on_stop_signals(raise_keyboard_interrupt), server:
        print(server.device, file=stdout, flush=True)   # once it serves
        print(_banner(spec, server, link=link, echo=echo, served=served, niceness=niceness),
              file=stderr, flush=True)
        try:
            while duration is None or time.monotonic() - started < duration:
                time.sleep(0.2)
        except KeyboardInterrupt:
            pass
    simulation.stop_real_time()
    figures: dict[str, object] = {
        "device": server.device, "protocol": spec.protocol, "baudrate": spec.motor_baudrate,
        "motors": [{"id": e.id, "model": e.model.name} for e in spec.motors],
        "instructions_received": emulator.instructions_seen,
        "served_s": round(time.monotonic() - started, 3),
        "physics_steps": simulation.steps, "nice": niceness,
        "realtime": server.realtime, "echo": echo,
        "reply_lateness": server.reply_lateness(),
        "replies_lost": server.replies_lost,
        "reply_bytes_unread": server.bytes_overflowed}
    if served is not None and served.report is not None:
        figures.update(served.report(physics, run.file("physics.png"), simulation.now()))
    run.write_summary(figures)
    print(f"servolab sim: stopped after {emulator.instructions_seen} instructions; "
          f"summary in {run.path}", file=stderr, flush=True)
    return figures


def _place(spec: MotorSpec, served: ServedRobot | None) -> tuple[Simulation, Emulator, object]:
    """The motors in their simulation: the robot's world when it brings one (its physics is
    the third value), else a simulation of the motors alone."""
    from ..dynamixel.emulator import build_emulator
    from ..sim import Simulation

    if served is not None and served.place is not None:
        return served.place(build_emulator(spec))
    simulation = Simulation()
    return simulation, simulation.add_emulator(build_emulator(spec)), None


def _start_real_time(simulation: Simulation, raise_priority: bool) -> None:
    """Start the simulation's thread. It takes the scheduling of the thread that starts it:
    with ``raise_priority``, real time just below the pty server's, so that it never sits
    preempted by an ordinary process while it holds the motors' lock or the GIL the server
    waits for. This thread goes back to ordinary scheduling at once."""
    from ..dynamixel.ports import REALTIME_PRIORITY, realtime_thread

    me = threading.get_native_id()
    if raise_priority and realtime_thread(me, REALTIME_PRIORITY - 1):
        try:
            simulation.start_real_time()
        finally:
            os.sched_setscheduler(me, os.SCHED_OTHER, os.sched_param(0))
    else:
        simulation.start_real_time()


def _banner(spec: MotorSpec, server: PtyServer, *, link: str | None, echo: bool,
            served: ServedRobot | None, niceness: int | None) -> str:
    """The line that says what is served, where, and how."""
    names = sorted({e.model.name for e in spec.motors})
    ids = ",".join(str(e.id) for e in spec.motors)
    raised = [f"nice {niceness}"] if niceness is not None else []
    raised += ["replies from a real-time thread"] if server.realtime else []
    how = ", ".join(raised)
    return (f"servolab sim: {len(spec.motors)} emulated {'/'.join(names)} (IDs {ids}) on "
            f"{_protocols(spec.protocol)} at {spec.motor_baudrate} bps on {server.device}"
            f"{f' (link {link})' if link else ''}"
            f"{', echoing every byte sent' if echo else ''}"
            f"{f', {served.what}' if served is not None and served.what else ''}"
            f"{f', at raised priority ({how})' if how else ''}; "
            "Ctrl-C stops")

def _add_arguments(p: argparse.ArgumentParser) -> None:
    which = p.add_mutually_exclusive_group(required=True)
    which.add_argument("--motors", metavar="SPEC",
                       help="'rx28:11-16,21-26', 'xm430-w210:100-102', or a YAML file")
    which.add_argument("--robot", metavar="NAME",
                       help="a robot's motors (servolab robots lists them), in its world when "
                       "it has one: 'armstrong' is the biped's 20 RX-28 at 57142 bps driving it "
                       "in MuJoCo (servolab walk --port PTY walks it; the summary says whether "
                       "it fell)")
    p.add_argument("--pty", action="store_true", required=True,
                   help="serve on a pseudo-terminal (prints its path on the first line)")
    p.add_argument("--link", metavar="PATH", help="also make PATH a symlink to the pty")
    p.add_argument("--baud", type=baud, help="motors' baud rate (default: factory default)")
    p.add_argument("--protocol", type=protocol, help="1 or 2 (default: the models')")
    p.add_argument("--echo", action="store_true",
                   help="echo every byte the client sends, as a half-duplex RS-485 adapter "
                   "without echo suppression (or TX and RX tied) does")
    add_out(p)


def _protocols(version: int | None) -> str:
    return "protocols 1.0 and 2.0 (a mixed bus)" if version is None else f"protocol {version}.0"


def _run(args: argparse.Namespace) -> int:
    from ..dynamixel import motorspec
    from ..runs import RunFolder

    served = None
    if args.robot:
        from ..errors import UsageError
        from ..robots.registry import entry

        if args.protocol:
            raise UsageError(f"--protocol: --robot {args.robot} brings its own bus")
        served = entry(args.robot).serve(args.baud)
        spec = served.spec
    else:
        spec = motorspec.load(args.motors, protocol=args.protocol, baudrate=args.baud)
    sim(spec, run=RunFolder.create("sim", args.out), link=args.link, raise_priority=True,
        echo=args.echo, served=served)
    return 0


COMMAND = Command(
    name="sim", group="bus", help="serve emulated motors on a pseudo-terminal",
    description="Serve emulated motors on a pseudo-terminal until Ctrl-C. The pty's path is "
    "the first line printed; give it to --port of scan, read and write, or to any program "
    "that opens a serial port.",
    examples=("servolab sim --pty --motors rx28:11-16 --link /tmp/dxl",
              "servolab sim --pty --robot armstrong   # the biped in MuJoCo, in real time",
              "servolab scan --port /tmp/dxl --protocol 1   # in another terminal"),
    add_arguments=_add_arguments, run=_run)
