"""Arguments more than one command takes, written once so they read the same everywhere.

The ``add_*`` functions add options to a command's parser; the value parsers (``int_range``,
``protocol``, ``baud``, ``namespace``) turn text into values or raise
:class:`argparse.ArgumentTypeError`, which argparse prints as ``servolab COMMAND: error: ...``
with exit status 2.
Imported by every command module when ``servolab --help`` runs, so only the standard library
and the middleware's exception classes are imported at the top.
"""

from __future__ import annotations

import argparse
import math
import os
from typing import TYPE_CHECKING

from servolab.middleware.errors import TransportError
from servolab.middleware.transports import TRANSPORTS

if TYPE_CHECKING:
    from servolab.middleware.transport import TransportOptions

PORT_HELP = ("serial device (/dev/ttyUSB0, COM3), the pty 'servolab sim' printed, "
             "emu://MODEL:IDS for emulated motors (e.g. emu://rx28:11-16), or a pyserial URL: "
             "spy://DEVICE?file=LOG logs every byte, socket://HOST:PORT and "
             "rfc2217://HOST:PORT reach a serial server")


# -- value parsers ------------------------------------------------------------------------------

def int_range(text: str) -> range:
    """``"12"`` or ``"0-252"``, both ends included, as the Dynamixel Wizard writes ID ranges."""
    try:
        if "-" in text:
            a, b = (int(x) for x in text.split("-", 1))
        else:
            a = b = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an ID or a range like 0-252"
                                         ) from None
    if a > b:
        raise argparse.ArgumentTypeError(f"range {text!r} runs backwards")
    return range(a, b + 1)


def protocol(text: str) -> int:
    """``1`` or ``2``; ``1.0`` and ``2.0`` too, as the e-Manual names them."""
    if text in ("1", "1.0"):
        return 1
    if text in ("2", "2.0"):
        return 2
    raise argparse.ArgumentTypeError(f"protocol {text!r} is not 1 or 2")


def baud(text: str) -> int:
    """A positive baud rate; ``1e6`` is accepted for 1000000."""
    try:
        value = int(float(text))
    except ValueError:
        raise argparse.ArgumentTypeError(f"baud rate {text!r} is not a number") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"baud rate {text!r} must be positive")
    return value


def namespace(text: str) -> str:
    """A robot's namespace, completed and checked as ``rcl_node_init`` does a node's (rmw's
    rules): ``robot1`` or ``/robot1`` is ``/robot1``, ``/`` (or nothing) the root; a bad one
    is refused in one line naming it and the rule it breaks."""
    from servolab.limits import quoted
    from servolab.middleware.errors import NameValidationError
    from servolab.middleware.names import node_namespace

    try:
        return node_namespace(text)
    except NameValidationError as exc:
        raise argparse.ArgumentTypeError(f"{quoted(text)}: {exc.reason}; give one such as "
                                         "/robot1") from None


# -- options ------------------------------------------------------------------------------------

def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None


def finite_float(text: str) -> float:
    """An argparse type: a finite number (``nan`` and ``inf`` are refused, naming them)."""
    value = _number(text)
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text} must be a finite number")
    return value


def positive_float(text: str) -> float:
    """An argparse type: a finite number > 0."""
    value = _number(text)
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"{text} must be a number > 0")
    return value


def nonnegative_float(text: str) -> float:
    """An argparse type: a finite number >= 0 (a rate where 0 means as fast as possible)."""
    value = _number(text)
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"{text} must be a number >= 0")
    return value


def positive_int(text: str) -> int:
    """An argparse type: a whole number >= 1 (days, a count that cannot be none)."""
    value = nonnegative_int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text} must be 1 or more")
    return value


def nonnegative_int(text: str) -> int:
    """An argparse type: a whole number >= 0 (a seed, a count)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text} must be 0 or more")
    return value


def add_out(p: argparse.ArgumentParser) -> None:
    """``--out DIR``, the run folder of a command that leaves one (see :mod:`servolab.runs`)."""
    p.add_argument("--out", metavar="DIR", help="run folder for summary.json and plots "
                   "(default: runs/<command>-<timestamp>/)")


#: ``--log-level`` names, as ``ros2 run ... --ros-args --log-level`` takes them
LOG_LEVELS = ("debug", "info", "warn", "error", "fatal")
#: where a launch's children find the level their parent was given
LOG_LEVEL_ENV = "SERVOLAB_LOG_LEVEL"


def add_log_level(p: argparse.ArgumentParser) -> None:
    p.add_argument("--log-level", choices=LOG_LEVELS, default=None,
                   help="the nodes' log level (default info: the controller manager says "
                   "which motors it found, as seed 001 Figure 3.1 shows)")


def log_level(args: argparse.Namespace) -> int:
    """The ``logging`` level ``--log-level`` asks for (else ``$SERVOLAB_LOG_LEVEL``, else
    info), set on servolab's loggers and handed to child processes through the
    environment."""
    import logging

    name = args.log_level or os.environ.get(LOG_LEVEL_ENV, "") or "info"
    if name not in LOG_LEVELS:
        name = "info"
    os.environ[LOG_LEVEL_ENV] = name
    level: int = {"warn": logging.WARNING, "fatal": logging.CRITICAL}.get(
        name, getattr(logging, name.upper()))
    logging.getLogger("servolab").setLevel(level)
    return level


def add_namespace(p: argparse.ArgumentParser, what: str = "the robot's nodes") -> None:
    """``--namespace NS``: where a robot's nodes and topics go, so that many robots share one
    graph, as ROS 2 multi-robot setups run them (``ros2 launch ... namespace:=robot1``): its
    topics in the namespace (``/robot1/cmd_vel``), its tf frames prefixed (``robot1/odom``) on
    the shared ``/tf``. The root (the default) gives the names of a robot alone."""
    p.add_argument("--namespace", type=namespace, default="/", metavar="NS",
                   help=f"the namespace of {what}, e.g. /robot1: its topics go under it and "
                   "its tf frames take its name as a prefix (robot1/odom) (default: /, the "
                   "names of a robot alone)")


def add_port(p: argparse.ArgumentParser) -> None:
    """``--port``: a device path or a URL (servolab's ``emu://`` or any of pyserial's); which
    one is for :meth:`Bus.open` to tell."""
    p.add_argument("--port", required=True, metavar="PORT", help=PORT_HELP)


def add_bus(p: argparse.ArgumentParser, *, default_baud: int = 57600) -> None:
    """``--port``, ``--protocol`` and ``--baud`` of a command that talks to motors on one bus.

    ``--protocol`` defaults to None: an emulated bus speaks its models' protocol and a serial
    port 2.0, so the default is the port's to decide, not the parser's.
    """
    add_port(p)
    p.add_argument("--protocol", type=protocol, default=None, metavar="{1,2}",
                   help="1 or 2 (default: an emulated bus's models' protocol, else 2)")
    p.add_argument("--baud", type=baud, default=default_baud,
                   help=f"baud rate (default {default_baud}: factory default of X-series, "
                   "and within 1 %% of the RX-28's 57142)")


def add_motor(p: argparse.ArgumentParser) -> None:
    """``--id`` (as ``motor_id``) and ``--model`` of a command that addresses one motor."""
    p.add_argument("--id", type=int, required=True, dest="motor_id", metavar="ID",
                   help="the motor's ID")
    p.add_argument("--model", help="the motor's model, e.g. rx28; skips the PING that learns "
                   "it")


def add_transport(p: argparse.ArgumentParser, default: str = "zenoh") -> None:
    """``--transport``, ``--listen``, ``--connect`` and ``--domain-id`` of a command that joins
    the graph; ``default`` "" leaves the choice to the command (a launch file has its own)."""
    shown = default or "the launch file's"
    p.add_argument("--transport", choices=list(TRANSPORTS), default=default,
                   help="local: this process only; zenoh: other processes and machines "
                   "(rmw_zenoh's layout); dds: a ROS 2 system on DDS, as Fast DDS and Cyclone "
                   "DDS lay it out; ros2: the rmw of an installed ROS 2, through its rclpy "
                   f"(answers every ROS 2 client) (default: {shown})")
    p.add_argument("--listen", action="append", default=[], metavar="ENDPOINT",
                   help="Zenoh endpoint to listen on, e.g. tcp/0.0.0.0:7447 (repeatable)")
    p.add_argument("--connect", action="append", default=[], metavar="ENDPOINT",
                   help="Zenoh endpoint to connect to, e.g. tcp/robot.local:7447; over DDS a "
                   "peer's host or address (as ROS_STATIC_PEERS)")
    p.add_argument("--domain-id", type=int, default=None, metavar="N",
                   help="ROS domain id (default: $ROS_DOMAIN_ID or 0)")


def transport_options(args: argparse.Namespace, default: str = "zenoh") -> TransportOptions:
    """The options :func:`add_transport` added, checked, as the middleware takes them."""
    from servolab.middleware.transport import TransportOptions, environment_domain_id

    domain = environment_domain_id() if args.domain_id is None else args.domain_id
    if not 0 <= domain <= 232:
        raise TransportError(f"--domain-id {domain} is outside 0..232")
    kind = args.transport or default
    return TransportOptions(kind, list(args.listen), list(args.connect), domain)
