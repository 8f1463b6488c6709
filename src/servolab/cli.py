"""The ``servolab`` command. It only parses arguments and calls into :mod:`servolab.apps`.

Errors in what the user typed come back as one line naming the bad value, exit status 2;
errors on the bus (no answer, a motor's error bits) as one line, exit status 1.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from . import __version__
from .dynamixel.errors import ConfigError, DynamixelError
from .middleware.errors import MiddlewareError, ServiceError


def _int_range(text: str) -> range:
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


def _protocol(text: str) -> int:
    if text in ("1", "1.0"):
        return 1
    if text in ("2", "2.0"):
        return 2
    raise argparse.ArgumentTypeError(f"protocol {text!r} is not 1 or 2")


def _baud(text: str) -> int:
    try:
        value = int(float(text))
    except ValueError:
        raise argparse.ArgumentTypeError(f"baud rate {text!r} is not a number") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"baud rate {text!r} must be positive")
    return value


def _add_out(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", metavar="DIR", help="run folder for summary.json and plots "
                   "(default: runs/<command>-<timestamp>/)")


def _add_port(p: argparse.ArgumentParser, *, default_baud: int | None = 57600) -> None:
    p.add_argument("--port", required=True, metavar="DEV",
                   help="serial device: /dev/ttyUSB0, COM3, or the pty 'servolab sim' printed")
    p.add_argument("--protocol", type=_protocol, default=2, help="1 or 2 (default 2)")
    if default_baud is not None:
        p.add_argument("--baud", type=_baud, default=default_baud,
                       help=f"baud rate (default {default_baud}: factory default of X-series, "
                       "and within 1 %% of the RX-28's 57142)")


def _add_transport(p: argparse.ArgumentParser, default: str = "zenoh") -> None:
    p.add_argument("--transport", choices=["local", "zenoh"], default=default,
                   help=f"local: this process only; zenoh: other processes and machines "
                   f"(default {default})")
    p.add_argument("--listen", action="append", default=[], metavar="ENDPOINT",
                   help="Zenoh endpoint to listen on, e.g. tcp/0.0.0.0:7447 (repeatable)")
    p.add_argument("--connect", action="append", default=[], metavar="ENDPOINT",
                   help="Zenoh endpoint to connect to, e.g. tcp/robot.local:7447")
    p.add_argument("--domain-id", type=int, default=None, metavar="N",
                   help="ROS domain id (default: $ROS_DOMAIN_ID or 0)")


def _add_graph_commands(sub: argparse._SubParsersAction) -> None:
    topic = sub.add_parser("topic", help="list, echo, publish and time topics").add_subparsers(
        dest="action", required=True, metavar="ACTION")
    p = topic.add_parser("list", help="topics in the graph")
    p.add_argument("-t", "--show-types", action="store_true")
    p.add_argument("-v", "--verbose", action="store_true")
    _add_transport(p)
    p = topic.add_parser("echo", help="print a topic's messages as YAML")
    p.add_argument("topic")
    p.add_argument("--type", dest="type_name", help="message type (default: from the graph)")
    p.add_argument("--count", type=int, default=0, help="stop after N messages")
    p.add_argument("--no-arr", action="store_true", help="abbreviate long arrays")
    _add_transport(p)
    p = topic.add_parser("pub", help="publish YAML values, as rostopic pub")
    p.add_argument("topic")
    p.add_argument("type_name", metavar="TYPE", help="e.g. geometry_msgs/msg/Twist")
    p.add_argument("values", metavar="VALUES", nargs="?", default="",
                   help="YAML, e.g. \"{linear: {x: 0.1}, angular: {z: 0.5}}\"")
    p.add_argument("--rate", type=float, default=1.0, help="Hz; 0: as fast as possible")
    p.add_argument("--count", type=int, default=0, help="publish N times (default: forever)")
    p.add_argument("--once", action="store_const", const=1, dest="count")
    _add_transport(p)
    p = topic.add_parser("hz", help="measure a topic's rate")
    p.add_argument("topic")
    p.add_argument("--type", dest="type_name")
    p.add_argument("--window", type=int, default=100)
    _add_transport(p)

    param = sub.add_parser("param", help="list, get and set node parameters").add_subparsers(
        dest="action", required=True, metavar="ACTION")
    p = param.add_parser("list", help="parameters of every node, or of one")
    p.add_argument("node", nargs="?")
    _add_transport(p)
    p = param.add_parser("get", help="one parameter's value")
    p.add_argument("node")
    p.add_argument("name")
    _add_transport(p)
    p = param.add_parser("set", help="change a parameter (the value is YAML)")
    p.add_argument("node")
    p.add_argument("name")
    p.add_argument("value")
    _add_transport(p)

    bag = sub.add_parser("bag", help="record, play and inspect MCAP bags").add_subparsers(
        dest="action", required=True, metavar="ACTION")
    p = bag.add_parser("record", help="record topics to an MCAP bag (rosbag2 layout)")
    p.add_argument("topics", nargs="+", metavar="TOPIC")
    p.add_argument("-o", "--output", required=True, metavar="PATH", help="bag folder to create")
    p.add_argument("--type", dest="types", action="append", default=[], metavar="TOPIC:TYPE",
                   help="type of a topic not yet in the graph, e.g. /cmd_vel:geometry_msgs/"
                   "msg/Twist")
    _add_transport(p)
    p = bag.add_parser("play", help="publish a bag's messages at its own (or a scaled) rate")
    p.add_argument("path")
    p.add_argument("--rate", type=float, default=1.0, help="speed factor; 0: as fast as "
                   "possible")
    p.add_argument("--topics", nargs="+", metavar="TOPIC")
    _add_transport(p)
    p = bag.add_parser("info", help="topics, types, counts and duration of a bag")
    p.add_argument("path")

    p = sub.add_parser("launch", help="start the nodes of a launch file")
    p.add_argument("file")
    p.add_argument("--machine", help="start this machine's nodes (default: this host's)")
    p.add_argument("--process", help=argparse.SUPPRESS)
    _add_transport(p, default="")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="servolab", description="Build, simulate and run robots of Dynamixel servos.")
    parser.add_argument("--version", action="version", version=f"servolab {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("demo", help="a short tour on emulated motors (what 'make demo' runs)")
    _add_out(p)

    p = sub.add_parser("sim", help="serve emulated motors on a pseudo-terminal")
    p.add_argument("--motors", required=True, metavar="SPEC",
                   help="'rx28:11-16,21-26', 'xm430-w210:100-102', or a YAML file")
    p.add_argument("--pty", action="store_true", required=True,
                   help="serve on a pseudo-terminal (prints its path on the first line)")
    p.add_argument("--link", metavar="PATH", help="also make PATH a symlink to the pty")
    p.add_argument("--baud", type=_baud, help="motors' baud rate (default: factory default)")
    p.add_argument("--protocol", type=_protocol, help="1 or 2 (default: the models')")
    _add_out(p)

    p = sub.add_parser("scan", help="find motors on a port (ID, model, firmware)")
    p.add_argument("--port", required=True, metavar="DEV", help="serial device or pty")
    p.add_argument("--baud", type=_baud, nargs="+", metavar="B",
                   help="baud rates to try (default: the common ones)")
    p.add_argument("--protocol", type=_protocol, action="append",
                   help="1 or 2; repeat for both (default: both)")
    p.add_argument("--ids", type=_int_range, metavar="A-B", help="ID range (default: all)")
    _add_out(p)

    p = sub.add_parser("read", help="read registers of one motor (SI units)")
    _add_port(p)
    p.add_argument("--id", type=int, required=True, dest="motor_id")
    p.add_argument("--model", help="skip the PING that learns the model")
    p.add_argument("--raw", action="store_true", help="print raw register values")
    p.add_argument("registers", nargs="+", metavar="REGISTER", help="e.g. present_position")

    p = sub.add_parser("write", help="write one register of one motor (SI units)")
    _add_port(p)
    p.add_argument("--id", type=int, required=True, dest="motor_id")
    p.add_argument("--model", help="skip the PING that learns the model")
    p.add_argument("--raw", action="store_true", help="VALUE is a raw register value")
    p.add_argument("register", metavar="REGISTER")
    p.add_argument("value", metavar="VALUE")

    _add_graph_commands(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        if args.command in ("topic", "param", "bag", "launch"):
            from .apps import graphcli

            return graphcli.dispatch(args)
        return _dispatch(args)
    except MiddlewareError as exc:
        name = f"{args.command} {getattr(args, 'action', '')}".strip()
        bad_input = not isinstance(exc, ServiceError)
        print(f"servolab {name}: error: {exc}", file=sys.stderr)
        return 2 if bad_input else 1
    except ConfigError as exc:
        print(f"servolab {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except DynamixelError as exc:
        print(f"servolab {args.command}: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"servolab {args.command}: interrupted", file=sys.stderr)
        return 130


def _dispatch(args: argparse.Namespace) -> int:
    from .apps import bustools
    from .runs import RunFolder

    if args.command == "demo":
        from .apps import demo

        demo.run(RunFolder.create("demo", args.out))
    elif args.command == "sim":
        from .dynamixel import motorspec

        spec = motorspec.load(args.motors, protocol=args.protocol, baudrate=args.baud)
        bustools.sim(spec, run=RunFolder.create("sim", args.out), link=args.link)
    elif args.command == "scan":
        found = bustools.scan(args.port, protocols=args.protocol or [1, 2],
                              baudrates=args.baud, ids=args.ids,
                              run=RunFolder.create("scan", args.out))
        return 0 if found else 1
    elif args.command == "read":
        bustools.read(args.port, args.motor_id, args.registers, protocol=args.protocol,
                      baudrate=args.baud, raw=args.raw, model=args.model)
    elif args.command == "write":
        bustools.write(args.port, args.motor_id, args.register, args.value,
                       protocol=args.protocol, baudrate=args.baud, raw=args.raw,
                       model=args.model)
    return 0


if __name__ == "__main__":
    sys.exit(main())
