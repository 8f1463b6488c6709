"""``servolab teleop``: leader–follower teleoperation of two arms, recorded as episodes.

The command only parses; :mod:`servolab.robots.teleop.run` runs the arms (the loop, the stops
and the bag's schema are :mod:`servolab.robots.teleop`'s).
"""

from __future__ import annotations

import argparse

from .arguments import PORT_HELP, add_out, nonnegative_float, nonnegative_int, positive_float
from .registry import Command


def _episodes(text: str) -> int:
    value = nonnegative_int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text}: at least one episode")
    return value


def _add_arguments(p: argparse.ArgumentParser) -> None:
    from ..robots.teleop import EMULATED, WORLDS

    p.add_argument("--robot", metavar="NAME", default=None,
                   help="the arm (both, unless --leader-robot): any robot whose URDF names "
                   "its Dynamixels in a <ros2_control> block (default: the arm that says it "
                   "is teleop's default; servolab robots lists them)")
    p.add_argument("--leader-robot", metavar="NAME",
                   help="the leader's robot when it is another one (joints copied by name)")
    p.add_argument("--leader", metavar="PORT", default=EMULATED,
                   help=f"the leader's port: {PORT_HELP}; default {EMULATED}: emulated here, "
                   "moved by a scripted hand (served alone: servolab sim --pty --robot "
                   "ARM_leader, the arm's leader plug-in)")
    p.add_argument("--follower", metavar="PORT", default=EMULATED,
                   help=f"the follower's port; default {EMULATED}: emulated here, in --world")
    p.add_argument("--world", choices=WORLDS, default="robot",
                   help="an emulated follower's world: its robot's own (default: the arm on "
                   "its table in MuJoCo), its URDF in MuJoCo, or its motors alone")
    p.add_argument("--seconds", type=positive_float, default=10.0, metavar="S",
                   help="each episode's length (default 10)")
    p.add_argument("--episodes", type=_episodes, default=1, metavar="N",
                   help="episodes to record (default 1)")
    p.add_argument("--reset", type=nonnegative_float, default=2.0, metavar="S",
                   help="seconds between two episodes, to put the scene back (default 2)")
    p.add_argument("--rate", type=nonnegative_float, default=0.0, metavar="HZ",
                   help="cycles a second (default 0: as fast as the wires allow)")
    p.add_argument("--seed", type=nonnegative_int, default=0,
                   help="the scripted hand's seed (episode k: seed + k; default 0)")
    p.add_argument("--no-camera", action="store_true",
                   help="record no images of the follower's MuJoCo world")
    p.add_argument("--real-time", action="store_true",
                   help="emulated arms: at the wall clock's pace (default: as fast as the "
                   "computer allows, in virtual time)")
    add_out(p)


def _run(args: argparse.Namespace) -> int:
    from ..robots.teleop.hand import Episodes
    from ..robots.teleop.loop import LoopOptions
    from ..robots.teleop.run import TeleopRequest, prepare, run_teleop
    from ..runs import RunFolder

    request = TeleopRequest(
        robot=args.robot, leader_robot=args.leader_robot, leader=args.leader,
        follower=args.follower, world=args.world,
        episodes=Episodes(args.seconds, args.episodes, args.reset), seed=args.seed,
        camera=not args.no_camera, real_time=args.real_time,
        options=LoopOptions(rate=args.rate))
    prepared = prepare(request)  # the arms and their joints, before a run folder is made
    with RunFolder.create("teleop", args.out) as run:
        run_teleop(run, prepared)
    return 0


COMMAND = Command(
    name="teleop", group="robots",
    help="leader–follower teleoperation of two arms, recorded as episodes",
    description="A person moves the leader arm by hand (torque off); the follower copies it "
    "joint by joint, as fast as the wires allow, and every episode is recorded to an MCAP bag "
    "(both arms' joint states, the commands, camera images of a MuJoCo follower). On any stop "
    "(the end, Ctrl-C, a leader that stops answering) the follower holds where it is. By "
    "default two emulated arms: the follower on its table in MuJoCo, the leader moved by a "
    "scripted hand. The bag's topics and episodes: python -m pydoc servolab.robots.teleop",
    examples=("servolab teleop --seconds 10 --episodes 3",
              "servolab teleop --leader /dev/ttyUSB0 --follower /dev/ttyUSB1 --episodes 5",
              "servolab teleop --world emulated --no-camera --out runs/teleop-test"),
    add_arguments=_add_arguments, run=_run)
