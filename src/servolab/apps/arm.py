"""``servolab arm ACTION``: move an arm as a student expects — home, to joint angles or a tool
pose, the gripper open or closed, a pick and place — each move one ``FollowJointTrajectory``
goal through the arm's ros2_control controller, timed by ruckig.

The command only parses; :mod:`servolab.robots.arm` finds the arm in the robot's files,
checks what is asked (a pose out of reach is refused in one line before anything moves),
brings the arm up (or joins a running ``servolab control run`` with ``--connect``), and
leaves the run folder: bag, plot, summary.json. SI units: metres, radians, newtons.
"""

from __future__ import annotations

import argparse

from .arguments import PORT_HELP, add_out, finite_float, nonnegative_int
from .registry import Command


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--robot", default=None, metavar="NAME",
                   help="an arm's robot: a plug-in or robot folder with a URDF and a "
                   "controllers file holding a joint_trajectory_controller (default: the "
                   "arm that says it is arm's default; servolab robots lists them)")
    p.add_argument("--controller", default=None, metavar="NAME",
                   help="the arm's joint_trajectory_controller, when the controllers file "
                   "has several (default: the only one, or arm_controller)")
    p.add_argument("--world", choices=("emulated", "mujoco", "robot"), default=None,
                   help="where the arm brought up here moves: its motors alone, its URDF "
                   "in MuJoCo, or the robot's own world (default: its own world if it has "
                   "one, as the OpenMANIPULATOR-X's table with boxes, else its motors)")
    p.add_argument("--port", default=None, metavar="PORT",
                   help="real motors: " + PORT_HELP + " (default: emulated motors)")
    p.add_argument("--connect", action="append", default=[], metavar="ENDPOINT",
                   help="join an arm already running under 'servolab control run ROBOT "
                   "--listen ENDPOINT' over Zenoh (e.g. tcp/127.0.0.1:7447) instead of "
                   "bringing it up here")
    p.add_argument("--domain-id", type=int, default=None, metavar="N",
                   help="with --connect: the ROS domain id (default: $ROS_DOMAIN_ID or 0)")
    p.add_argument("--speed", type=finite_float, default=None, metavar="FRACTION",
                   help="the joints' speed limits scaled by this, in (0, 1] (default: the "
                   "robot's joint_limits file's default_velocity_scaling_factor, else 1)")
    add_out(p)


#: each action's help line and description
ACTIONS = {
    "home": ("the arm to its home pose (the SRDF's 'home')",
             "Move the arm to its home pose: the SRDF's home state of the arm group, else every "
             "joint at 0."),
    "move": ("the arm to joint angles or a tool pose",
             "Move the arm to joint angles (--joints, rad, one a joint of its controller) or to "
             "a tool position (--pose X Y Z, m, in the chain's base frame), the tool's pitch "
             "below the horizontal free or given (--pitch, rad). A pose out of reach is refused "
             "in one line before anything moves."),
    "gripper": ("open or close the gripper",
                "Open or close the gripper through its gripper action controller: to the "
                "SRDF's open or close state, else the gripper joint's upper or lower limit. "
                "Closing on something ends stalled: holding it."),
    "pick": ("pick an object up and place it, in MuJoCo",
             "Pick and place in MuJoCo (a grasp needs physics): an object of the robot's world "
             "put near the pick point X Y (as a hand would: within 3 mm, square to the fingers "
             "within 10°, drawn from --seed), grasped from above, lifted, carried, lowered at "
             "the place point and let go. Judged from the object's pose in MuJoCo: "
             "summary.json says placed (within 1 cm), placement_error_m and the failure "
             "(unreachable, missed, slipped, misplaced, aborted)."),
}
EFFORT_HELP = ("the gripper goal's max_effort (N for a prismatic gripper; default: the gripper "
               "joint's URDF effort limit). A position gripper controller passes it through, "
               "as ros2_controllers' does; an effort one caps its squeeze")


def _add_arguments(parser: argparse.ArgumentParser) -> None:
    actions = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    parsers = {name: actions.add_parser(name, help=text, description=description)
               for name, (text, description) in ACTIONS.items()}
    p = parsers["move"]
    target = p.add_mutually_exclusive_group(required=True)
    target.add_argument("--joints", type=finite_float, nargs="+", metavar="J",
                        help="joint angles (rad), in the controller's joint order")
    target.add_argument("--pose", type=finite_float, nargs=3, metavar=("X", "Y", "Z"),
                        help="the tool point's position (m, the arm's base frame)")
    p.add_argument("--pitch", type=finite_float, default=None, metavar="RAD",
                   help="with --pose: the tool's pitch below the horizontal (rad; 1.5708 "
                   "points it straight down)")
    parsers["gripper"].add_argument("how", choices=("open", "close"))
    p = parsers["pick"]
    p.add_argument("x", type=finite_float, metavar="X", help="the pick point (m)")
    p.add_argument("y", type=finite_float, metavar="Y")
    p.add_argument("--place", type=finite_float, nargs=2, required=True, metavar=("X", "Y"),
                   help="the place point (m)")
    p.add_argument("--seed", type=nonnegative_int, default=0, metavar="S",
                   help="where a hand puts the object near the pick point (default 0)")
    p.add_argument("--render", action="store_true",
                   help="also draw each stage of the pick as MuJoCo saw it, in pick.png in "
                   "the run folder (needs OpenGL: EGL, or MUJOCO_GL=osmesa)")
    for name in ("gripper", "pick"):
        parsers[name].add_argument("--effort", type=finite_float, default=None, metavar="N",
                                   help=EFFORT_HELP)
    for p in parsers.values():
        _common(p)


def _run(args: argparse.Namespace) -> int:
    from ..errors import UsageError
    from ..middleware.transport import environment_domain_id
    from ..robots.arm.run import ArmRequest, Where, arm_command
    from ..robots.arm.spec import arm_spec

    if getattr(args, "pitch", None) is not None and not getattr(args, "pose", None):
        raise UsageError("--pitch is the tool's pitch at a --pose: give --pose X Y Z with it")
    request = ArmRequest(
        args.action,
        joints=tuple(args.joints) if getattr(args, "joints", None) else None,
        pose=tuple(args.pose) if getattr(args, "pose", None) else None,
        pitch=getattr(args, "pitch", None), gripper=getattr(args, "how", None),
        effort=getattr(args, "effort", None),
        pick=(args.x, args.y) if args.action == "pick" else None,
        place=tuple(args.place) if args.action == "pick" else None,
        seed=getattr(args, "seed", 0), speed=args.speed,
        render=getattr(args, "render", False))
    where = Where(world=args.world, port=args.port, connect=tuple(args.connect),
                  domain_id=environment_domain_id() if args.domain_id is None
                  else args.domain_id)
    spec = arm_spec(args.robot, controller=args.controller)
    arm_command(spec, request, where, out=args.out)
    return 0


COMMAND = Command(
    name="arm", group="robots",
    help="move an arm: home, to joints or a pose, the gripper, pick and place",
    description="Move an arm through its ros2_control controllers as MoveIt would: each move "
    "one FollowJointTrajectory goal to its joint_trajectory_controller, timed time-optimally "
    "within the joints' velocity, acceleration and jerk limits (ruckig); the gripper through "
    "its gripper action controller. The arm is brought up here (in its own world by default; "
    "--port for real motors) or joined with --connect. Every run leaves its run folder: the "
    "bag of /joint_states and the goals, arm.png (commanded against measured) and "
    "summary.json.",
    examples=(
        "servolab arm home",
        "servolab arm move --joints 0.5 -0.3 0.2 0.6",
        "servolab arm move --pose 0.2 0.05 0.1 --pitch 0.8",
        "servolab arm gripper close",
        "servolab arm pick 0.2 0.0 --place 0.15 0.12",
        "servolab arm home --connect tcp/127.0.0.1:7447   # to servolab control run ... "
        "--listen tcp/127.0.0.1:7447"),
    add_arguments=_add_arguments, run=_run)
