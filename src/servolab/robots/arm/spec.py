"""What ``servolab arm`` needs to know of an arm, found in the robot's own files.

Every fact comes from a file a ROS 2 arm already has, in this order:

- **the controllers file** (ros2_control): the arm's controller is the one
  ``joint_trajectory_controller/JointTrajectoryController`` (if there are several, the one
  named ``arm_controller``, else the one asked for), and its ``joints`` are the arm's joints;
  the gripper's is the one gripper action controller (``position_controllers/``,
  ``effort_controllers/`` or ``parallel_gripper_action_controller/GripperActionController``),
  with its ``joint``;
- **the SRDF** (MoveIt's, when the plug-in shows one as ``NAME.srdf``): the tool link is its
  end effector's ``parent_link`` (else a ``<chain tip_link>`` of the group holding the arm's
  joints), "home" is the arm group's ``home`` state, and the gripper's ``open`` and
  ``close`` states its two ends;
- **MoveIt's joint_limits.yaml** (``NAME.joint_limits``): each joint's ``max_velocity``,
  ``max_acceleration`` and ``max_jerk``, and the default scaling factors;
- **the URDF**: the joints' position and velocity limits, and the chain's links.

What no file says is chosen so, and ``servolab arm`` prints where each fact came from:

- the chain's **base** is the first arm joint's parent link (the frame ``move --pose`` and
  ``pick`` coordinates are in); its **tip**, without an SRDF, the link fixed (through fixed
  joints only) below the last arm joint's child that is farthest from it, or that child
  itself: ROS's ``end_effector_link`` / ``tool0`` convention;
- **home**, without an SRDF, every joint at 0 (clamped into its limits);
- the gripper, without an SRDF, **opens** toward its joint's upper limit and closes toward the
  lower one (ROBOTIS's convention: positive opens);
- accelerations and jerks, without a joint_limits file, :data:`DEFAULT_ACCELERATION` and
  :data:`DEFAULT_JERK` (GUESSES, stated once: a small arm's gentle figures).
"""

from __future__ import annotations

import itertools
import math
import xml.etree.ElementTree as ET
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import RobotValueError

if TYPE_CHECKING:
    from ...kinematics.chain import Chain
    from ...trajectories.timing import MoveLimits
    from ..description import Description
    from ..plugin import RobotPlugin

ARM_TYPE = "joint_trajectory_controller/JointTrajectoryController"
BROADCASTER_TYPE = "joint_state_broadcaster/JointStateBroadcaster"
GRIPPER_COMMAND = "control_msgs/action/GripperCommand"
PARALLEL_GRIPPER_COMMAND = "control_msgs/action/ParallelGripperCommand"
#: the gripper controllers servolab runs, and the action each serves on ``~/gripper_cmd``
GRIPPER_TYPES = {
    "position_controllers/GripperActionController": GRIPPER_COMMAND,
    "effort_controllers/GripperActionController": GRIPPER_COMMAND,
    "parallel_gripper_action_controller/GripperActionController": PARALLEL_GRIPPER_COMMAND,
}
#: a joint's acceleration (rad/s², m/s²) and jerk (/s³) limits when no joint_limits file
#: states them: GUESSES for a small arm of Dynamixels, gentle rather than fast
DEFAULT_ACCELERATION = 5.0
DEFAULT_JERK = 50.0
#: the names a tool link goes by, preferred among several fixed leaves
TOOL_NAMES = ("end_effector", "tool", "tcp", "ee")


@dataclass(frozen=True)
class Gripper:
    """The gripper's controller (name, the action type it serves), its joint, the joint's
    position when open and when closed (m or rad), and its effort limit (N or N m, the URDF's,
    None when it gives none)."""

    controller: str
    action: str
    joint: str
    opened: float
    closed: float
    effort: float | None


@dataclass(frozen=True)
class ArmSpec:
    """One arm, as ``servolab arm`` drives it (see the module docstring for where each fact
    comes from; ``origins`` says it for this arm: fact -> the file or the rule)."""

    robot: str
    urdf: str
    source: str
    controllers: Path
    controller: str
    joints: tuple[str, ...]
    base: str
    tip: str
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    home: tuple[float, ...]
    velocity: tuple[float, ...]
    acceleration: tuple[float, ...]
    jerk: tuple[float, ...]
    velocity_scaling: float = 1.0
    acceleration_scaling: float = 1.0
    gripper: Gripper | None = None
    default_model: str | None = None
    origins: Mapping[str, str] = field(default_factory=dict)
    #: the joint_state_broadcaster of the controllers file (None: it has none)
    broadcaster: str | None = None

    @property
    def spawn(self) -> tuple[str, ...]:
        """The controllers an arm brought up here runs: the broadcaster, the arm's, the
        gripper's."""
        return tuple(c for c in (self.broadcaster, self.controller,
                                 self.gripper.controller if self.gripper else None) if c)

    @property
    def action(self) -> str:
        """The arm controller's FollowJointTrajectory action."""
        return f"/{self.controller}/follow_joint_trajectory"

    def limits(self, speed: float | None = None) -> MoveLimits:
        """The timing limits, scaled (``speed``: the velocity factor, default the file's)."""
        from ...trajectories.timing import MoveLimits

        return MoveLimits(self.velocity, self.acceleration, self.jerk).scaled(
            self.velocity_scaling if speed is None else speed, self.acceleration_scaling)

    def chain(self) -> Chain:
        """The kinematic chain base -> tip (MuJoCo's kinematics of the URDF)."""
        from ...kinematics.chain import Chain
        from ..description import Description

        chain = Chain(Description.from_urdf(self.urdf, self.source).mjcf("firmware"),
                      self.base, self.tip)
        if chain.joint_names != self.joints:
            raise RobotValueError(
                f"{self.source}: the chain {self.base} -> {self.tip} moves "
                f"{', '.join(chain.joint_names)}, not {self.controller}'s joints "
                f"{', '.join(self.joints)}")
        return chain

    def check_joints(self, q: tuple[float, ...] | list[float], what: str) -> tuple[float, ...]:
        """``q`` (one number a joint) within the joint limits, or one line naming the joint."""
        if len(q) != len(self.joints):
            raise RobotValueError(f"{what}: {len(self.joints)} joint positions "
                                  f"({', '.join(self.joints)}), got {len(q)}")
        for name, value, low, high in zip(self.joints, q, self.lower, self.upper, strict=True):
            if not math.isfinite(value):
                raise RobotValueError(f"{what}: {name} must be a finite number of radians")
            if not low - 1e-9 <= value <= high + 1e-9:
                raise RobotValueError(f"{what}: {name} {value:g} rad is outside its limits "
                                      f"[{low:g}, {high:g}]")
        return tuple(float(v) for v in q)


# -- reading the files ------------------------------------------------------------------------

def _shown_text(shown: Mapping[str, Any], key: str) -> tuple[str, str] | None:
    """(text, name) of a file a plug-in shows, or None."""
    found = shown.get(key)
    if found is None:
        return None
    if isinstance(found, Path):
        return found.read_text(encoding="utf-8"), found.name
    return str(found()), key


def _types(parameters: Any) -> dict[str, str]:
    """Each controller of the controllers file and its type."""
    manager = parameters.for_node("/controller_manager")
    return {key[:-len(".type")]: str(value) for key, value in manager.items()
            if key.endswith(".type")}


def _controllers(parameters: Any, source: str, controller: str | None
                 ) -> tuple[str, tuple[str, ...], tuple[str, str, str] | None]:
    """(arm controller, its joints, (gripper controller, its action, its joint) or None)."""
    types = _types(parameters)
    arms = sorted(name for name, kind in types.items() if kind == ARM_TYPE)
    if controller is not None:
        if types.get(controller) != ARM_TYPE:
            raise RobotValueError(f"{source}: no {ARM_TYPE} named {controller!r}; "
                                  f"its trajectory controllers: {', '.join(arms) or 'none'}")
        arm = controller
    elif len(arms) == 1:
        arm = arms[0]
    elif "arm_controller" in arms:
        arm = "arm_controller"
    elif not arms:
        raise RobotValueError(f"{source}: no {ARM_TYPE}: servolab arm moves an arm through "
                              "one (ros2_control's arm_controller)")
    else:
        raise RobotValueError(f"{source}: {len(arms)} trajectory controllers "
                              f"({', '.join(arms)}): name the arm's with --controller")
    joints = parameters.for_node(f"/{arm}").get("joints")
    if not isinstance(joints, list) or not joints or not all(isinstance(j, str) for j in joints):
        raise RobotValueError(f"{source}: {arm} names no joints (its 'joints' parameter)")
    grippers = sorted(name for name, kind in types.items() if kind in GRIPPER_TYPES)
    gripper = None
    if grippers:
        name = "gripper_controller" if "gripper_controller" in grippers else grippers[0]
        joint = parameters.for_node(f"/{name}").get("joint")
        if not isinstance(joint, str) or not joint:
            raise RobotValueError(f"{source}: {name} names no joint (its 'joint' parameter)")
        gripper = (name, GRIPPER_TYPES[types[name]], joint)
    return arm, tuple(joints), gripper


@dataclass(frozen=True)
class Srdf:
    """What servolab reads of MoveIt's SRDF: each group's joints and chains, the named
    states (group, name) -> {joint: value}, and the end effectors' parent links."""

    groups: Mapping[str, tuple[tuple[str, ...], tuple[tuple[str, str], ...]]]
    states: Mapping[tuple[str, str], Mapping[str, float]]
    tool_links: tuple[str, ...]

    @classmethod
    def parse(cls, text: str, source: str) -> Srdf:
        try:
            root = ET.fromstring(text)
        except ET.ParseError as error:
            raise RobotValueError(f"{source}: not an SRDF ({error})") from None
        groups: dict[str, tuple[tuple[str, ...], tuple[tuple[str, str], ...]]] = {}
        for group in root.iter("group"):
            name = group.get("name", "")
            joints = tuple(j.get("name", "") for j in group.findall("joint"))
            chains = tuple((c.get("base_link", ""), c.get("tip_link", ""))
                           for c in group.findall("chain"))
            groups[name] = (joints, chains)
        states: dict[tuple[str, str], dict[str, float]] = {}
        for state in root.iter("group_state"):
            values: dict[str, float] = {}
            for joint in state.findall("joint"):
                text_value = joint.get("value", "")
                try:
                    values[joint.get("name", "")] = float(text_value)
                except ValueError:
                    raise RobotValueError(
                        f"{source}: group_state {state.get('name')!r}: joint "
                        f"{joint.get('name')!r} has value {text_value!r}, not a number"
                    ) from None
            states[(state.get("group", ""), state.get("name", ""))] = values
        tools = tuple(e.get("parent_link", "") for e in root.iter("end_effector")
                      if e.get("parent_link"))
        return cls(groups, states, tools)

    def group_of(self, joint: str, description: Description) -> str | None:
        """The group holding ``joint``: named in it, or on one of its chains (the URDF's
        joints from the chain's tip up to its base)."""
        parent_joint = {j.child: j for j in description.joints}
        for name, (joints, chains) in self.groups.items():
            if joint in joints:
                return name
            for base, tip in chains:
                link = tip
                while link != base and (above := parent_joint.get(link)) is not None:
                    if above.name == joint:
                        return name
                    link = above.parent
        return None

    def state(self, group: str | None, names: tuple[str, ...]) -> Mapping[str, float] | None:
        for name in names:
            found = self.states.get((group or "", name))
            if found is not None:
                return found
        return None


def _joint_limits(text: str, source: str, joints: tuple[str, ...]
                  ) -> tuple[dict[str, dict[str, float]], dict[str, float]]:
    """MoveIt's joint_limits.yaml: {joint: {max_velocity, max_acceleration, max_jerk}} for
    those it enables (``has_*_limits``), and the default scaling factors."""
    from ...configfile import load_text

    top = load_text(text, source).as_mapping()
    scaling: dict[str, float] = {}
    for key in ("default_velocity_scaling_factor", "default_acceleration_scaling_factor"):
        value = top.get(key)
        if value is not None:
            factor = value.as_float()
            if not 0 < factor <= 1:
                raise value.error(f"{key} must be in (0, 1], not {factor:g}")
            scaling[key] = factor
    found: dict[str, dict[str, float]] = {}
    section = top.get("joint_limits")
    if section is None:
        return found, scaling
    for joint, entry in section.as_mapping().items():
        if joint not in joints:
            continue
        limits = entry.as_mapping()
        values: dict[str, float] = {}
        for kind in ("velocity", "acceleration", "jerk"):
            enabled = limits.get(f"has_{kind}_limits")
            value = limits.get(f"max_{kind}")
            if enabled is not None and enabled.as_bool() and value is not None:
                number = value.as_float()
                if number <= 0:
                    raise value.error(f"max_{kind} must be > 0, not {number:g}")
                values[kind] = number
        found[joint] = values
    return found, scaling


def _check_serial(description: Description, joints: tuple[str, ...], arm: str,
                  source: str) -> None:
    """``joints`` are one serial chain listed from the base to the tool: each below the one
    before it through fixed joints only (an arm, not two legs under one controller)."""
    parent_joint = {j.child: j for j in description.joints}

    def above(name: str) -> list[str]:
        """The movable joints above ``name``, nearest first."""
        found, link = [], description.joint(name).parent
        while (joint := parent_joint.get(link)) is not None:
            if joint.kind != "fixed":
                found.append(joint.name)
            link = joint.parent
        return found

    by_depth = sorted(joints, key=lambda j: len(above(j)))
    for before, after in itertools.pairwise(by_depth):
        if not above(after) or above(after)[0] != before:
            raise RobotValueError(
                f"{source}: {arm}'s joints are not one serial chain ({after} is not right "
                f"below {before}): servolab arm moves an arm, one chain from its base to its "
                "tool")
    if tuple(by_depth) != joints:
        raise RobotValueError(f"{source}: {arm} lists its joints out of the chain's order; "
                              f"servolab arm takes them base to tool ({', '.join(by_depth)})")


def _chain_links(description: Description, joints: tuple[str, ...]) -> tuple[str, str, str]:
    """(base, tip without an SRDF, how the tip was chosen) from the URDF's tree."""
    first, last = description.joint(joints[0]), description.joint(joints[-1])
    # the fixed leaves below the last joint's child, with their depth
    leaves: list[tuple[int, str]] = []

    def walk(link: str, depth: int) -> None:
        fixed = [j for j in description.children(link) if j.kind == "fixed"]
        if not fixed and depth:
            leaves.append((depth, link))
        for joint in fixed:
            walk(joint.child, depth + 1)

    walk(last.child, 0)
    if not leaves:
        return first.parent, last.child, f"{last.name}'s child link (no link fixed below it)"
    named = [(d, n) for d, n in leaves if any(t in n.lower() for t in TOOL_NAMES)]
    _depth, tip = max(named or leaves)
    return first.parent, tip, f"the link fixed below {last.name}'s child"


def load_spec(robot: str, urdf: str, source: str, controllers: Path,
              shown: Mapping[str, Any], *, controller: str | None = None,
              default_model: str | None = None) -> ArmSpec:
    """The arm of a robot from its files (see the module docstring); ``shown`` are the
    files its plug-in shows (``NAME.srdf``, ``NAME.joint_limits``)."""
    from ...middleware.parameters import ParameterOverrides
    from ..description import Description

    parameters = ParameterOverrides.from_file(controllers)
    arm, joints, gripper_found = _controllers(parameters, controllers.name, controller)
    description = Description.from_urdf(urdf, source)
    origins: dict[str, str] = {"controller": f"{controllers.name} ({ARM_TYPE})"}
    for name in joints:
        joint = description.joint(name)
        if joint.kind not in ("revolute", "prismatic", "continuous"):
            raise RobotValueError(f"{source}: {arm}'s joint {name} is {joint.kind}: an arm "
                                  "joint turns or slides")
    _check_serial(description, joints, arm, source)
    srdf_file = _shown_text(shown, f"{robot}.srdf")
    srdf = Srdf.parse(*srdf_file) if srdf_file else None
    base, tip, how = _chain_links(description, joints)
    origins["base"] = f"{joints[0]}'s parent link ({source})"
    origins["tip"] = f"{how} ({source})"
    arm_group = srdf.group_of(joints[0], description) if srdf else None
    if srdf is not None and srdf_file is not None:
        tools = [t for t in srdf.tool_links if t]
        chains = srdf.groups.get(arm_group or "", ((), ()))[1]
        if tools:
            tip, origins["tip"] = tools[0], f"the end effector's parent_link ({srdf_file[1]})"
        elif chains:
            tip, origins["tip"] = chains[0][1], f"the arm group's chain ({srdf_file[1]})"
    lower, upper, velocity = [], [], []
    for name in joints:
        joint = description.joint(name)
        lower.append(-math.inf if joint.lower is None or joint.kind == "continuous"
                     else joint.lower)
        upper.append(math.inf if joint.upper is None or joint.kind == "continuous"
                     else joint.upper)
        velocity.append(joint.velocity if joint.velocity else math.nan)
    home = [min(max(0.0, lo), hi) for lo, hi in zip(lower, upper, strict=True)]
    origins["home"] = "every joint at 0, within its limits (no SRDF home state)"
    if srdf is not None and srdf_file is not None:
        state = srdf.state(arm_group, ("home",))
        if state is not None:
            missing = [j for j in joints if j not in state]
            if missing:
                raise RobotValueError(f"{srdf_file[1]}: the home state gives no "
                                      f"{', '.join(missing)}")
            home = [state[j] for j in joints]
            origins["home"] = f"the '{arm_group}' group's home state ({srdf_file[1]})"
    acceleration = [DEFAULT_ACCELERATION] * len(joints)
    jerk = [DEFAULT_JERK] * len(joints)
    origins["limits"] = (f"velocity: {source}; acceleration {DEFAULT_ACCELERATION:g}, jerk "
                         f"{DEFAULT_JERK:g}: servolab's defaults (no joint_limits file)")
    scaling: dict[str, float] = {}
    limits_file = _shown_text(shown, f"{robot}.joint_limits")
    if limits_file is not None:
        stated, scaling = _joint_limits(*limits_file, joints)
        for i, name in enumerate(joints):
            given = stated.get(name, {})
            velocity[i] = min(velocity[i], given["velocity"]) if "velocity" in given and \
                math.isfinite(velocity[i]) else given.get("velocity", velocity[i])
            acceleration[i] = given.get("acceleration", acceleration[i])
            jerk[i] = given.get("jerk", jerk[i])
        origins["limits"] = f"{limits_file[1]} and {source}'s velocities"
    for name, value in zip(joints, velocity, strict=True):
        if not (math.isfinite(value) and value > 0):
            raise RobotValueError(f"{source}: joint {name} states no velocity limit (its "
                                  "<limit velocity>), which the timing needs")
    gripper = None
    if gripper_found is not None:
        gripper = _gripper(description, gripper_found, srdf, srdf_file, origins)
    return ArmSpec(robot, urdf, source, controllers, arm, joints, base, tip, tuple(lower),
                   tuple(upper), tuple(home), tuple(velocity), tuple(acceleration),
                   tuple(jerk),
                   scaling.get("default_velocity_scaling_factor", 1.0),
                   scaling.get("default_acceleration_scaling_factor", 1.0),
                   gripper, default_model, origins,
                   next((n for n, t in sorted(_types(parameters).items())
                         if t == BROADCASTER_TYPE), None))


def _gripper(description: Description, found: tuple[str, str, str], srdf: Srdf | None,
             srdf_file: tuple[str, str] | None, origins: dict[str, str]) -> Gripper:
    name, action, joint_name = found
    joint = description.joint(joint_name)
    if joint.lower is None or joint.upper is None:
        raise RobotValueError(f"the gripper joint {joint_name} has no limits to open and "
                              "close to")
    opened, closed = joint.upper, joint.lower
    origins["gripper"] = (f"{name} on {joint_name}: opens to its upper limit, closes to its "
                          "lower (no SRDF open and close states)")
    if srdf is not None and srdf_file is not None:
        group = srdf.group_of(joint_name, description)
        open_state = srdf.state(group, ("open", "opened"))
        close_state = srdf.state(group, ("close", "closed"))
        if open_state and joint_name in open_state and close_state \
                and joint_name in close_state:
            opened, closed = open_state[joint_name], close_state[joint_name]
            origins["gripper"] = (f"{name} on {joint_name}: the '{group}' group's open and "
                                  f"close states ({srdf_file[1]})")
    return Gripper(name, action, joint_name, opened, closed, joint.effort)


def arm_spec(robot: str | None = None, *, controller: str | None = None,
             entry: Callable[[str], RobotPlugin] | None = None) -> ArmSpec:
    """The arm of the robot named ``robot`` (a plug-in with a URDF and a controllers file);
    None: the robot that says it is ``servolab arm``'s default (``RobotPlugin.default_for``)."""
    if robot is None:
        from ..registry import default_robot

        robot = default_robot("arm")
    if entry is None:
        from ..registry import entry as registry_entry

        entry = registry_entry
    plugin = entry(robot)
    if plugin.description is None:
        raise RobotValueError(f"robot {plugin.name} has no URDF: servolab arm moves an arm "
                              "from its URDF and its controllers file")
    shown = plugin.shown_files()
    files = [v for k, v in shown.items() if k.endswith(".controllers") and isinstance(v, Path)]
    if not files:
        raise RobotValueError(f"robot {plugin.name} has no controllers file: servolab arm "
                              "moves an arm through its ros2_control controllers")
    return load_spec(plugin.name, plugin.description(), f"{plugin.name}.urdf", files[0], shown,
                     controller=controller, default_model=plugin.default_model)
