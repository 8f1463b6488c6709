"""``servolab arm``'s run: one thing asked of an arm (home, a move, the gripper, a pick and
place), recorded, judged and plotted in its run folder.

Where the arm is (:class:`Where`):

- brought up in this process (the default) from its URDF and controllers file, as
  ``servolab control run`` brings it up, with its broadcaster, arm and gripper controllers
  active: on emulated motors in the robot's own world (``world="robot"``: the
  OpenMANIPULATOR-X on its table in MuJoCo), in the bare URDF in MuJoCo (``"mujoco"``), on
  motors alone (``"emulated"``), all on simulated time, as fast as the computer allows; or on
  real motors on ``port`` (the wall clock);
- or joined (``connect``: Zenoh endpoints) to a ``servolab control run`` already running,
  whose controllers it drives through their actions as MoveIt would.

Everything asked is checked before anything is opened (:func:`prepare`): joints within their
limits, a pose within reach (the inverse kinematics of :mod:`servolab.kinematics.chain`), a
pick's every pose within reach. Afterwards the run folder holds:

- ``arm_bag/``: ``/joint_states``, the arm controller's ``controller_state``, each goal as
  sent (``/servolab_arm/trajectory``, ``/servolab_arm/gripper_command``) and, for a pick,
  the object's pose from MuJoCo (``/servolab_arm/object``);
- ``arm.png``: each joint commanded (the controller's reference) against measured;
- ``summary.json``: what was asked, each goal's status and the joints' final error; a pick's
  ``placed``, ``placement_error_m`` and ``failure``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from contextlib import ExitStack
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import RobotError, RobotValueError
from ..lifecycle import Step, Task, replaced, run_task
from .pick import FAILURES, SETTLE, PickJudge, PickPlan, by_hand, plan_pick, set_the_table
from .session import ArmLink, GripResult, MoveResult
from .spec import ArmSpec

if TYPE_CHECKING:
    from ...middleware.context import Context
    from ...middleware.view.run_view import ViewRequest
    from ...runs import RunFolder

Say = Callable[[str], None]
ACTIONS = ("home", "move", "gripper", "pick")
WORLDS = ("emulated", "mujoco", "robot")
POSE_TOPIC = "/servolab_arm/object"
POSE = "geometry_msgs/msg/PoseStamped"
#: the stages of a pick ``--render`` draws (the judge's), in order, with their labels
RENDERED = {"start": "1 put by hand", "closed": "2 grasped", "lifted": "3 lifted",
            "carried": "4 carried", "released": "5 released", "final": "6 at rest"}
#: the render's camera: this far (m) from a point this far (m) above the object's stages,
#: looking down this steeply (deg), so that the tool hides the object the least
RENDER_DISTANCE, RENDER_ABOVE, RENDER_ELEVATION = 0.6, 0.03, -45.0


@dataclass(frozen=True)
class ArmRequest:
    """What is asked: ``action`` (:data:`ACTIONS`) and its values, SI units (m, rad, N)."""

    action: str
    joints: tuple[float, ...] | None = None
    pose: tuple[float, float, float] | None = None
    pitch: float | None = None
    gripper: str | None = None
    effort: float | None = None
    pick: tuple[float, float] | None = None
    place: tuple[float, float] | None = None
    seed: int = 0
    speed: float | None = None
    #: a pick also drawn, as MuJoCo saw each stage, in ``pick.png`` (needs OpenGL)
    render: bool = False

    def figures(self) -> dict[str, Any]:
        shown: dict[str, Any] = {"action": self.action}
        for key in ("joints", "pose", "pitch", "gripper", "effort", "pick", "place", "speed"):
            value = getattr(self, key)
            if value is not None:
                shown[key] = list(value) if isinstance(value, tuple) else value
        if self.action == "pick":
            shown["seed"] = self.seed
        return shown


@dataclass(frozen=True)
class Where:
    """Where the arm is (see the module docstring): ``world`` for an arm brought up here
    (None: the robot's own world if it has one, else its motors alone), ``port`` for real
    motors, ``connect`` to join a running ``servolab control run`` (Zenoh endpoints)."""

    world: str | None = None
    port: str | None = None
    connect: tuple[str, ...] = ()
    domain_id: int = 0

    def label(self, world: str) -> str:
        if self.connect:
            return f"the arm served at {', '.join(self.connect)}"
        if self.port:
            return f"the motors on {self.port}"
        return {"emulated": "emulated motors", "mujoco": "emulated motors moving its URDF in "
                "MuJoCo", "robot": "emulated motors in its own world (MuJoCo)"}[world]


@dataclass
class Prepared:
    """A request checked against the arm: the joint targets of a move, a pick's plan."""

    request: ArmRequest
    world: str
    target: tuple[float, ...] | None = None
    plan: PickPlan | None = None
    ik: dict[str, Any] = field(default_factory=dict)


def own_world(robot: str) -> Any:
    """How the robot's plug-in puts its emulated motors in its own world, or None."""
    from ..registry import entry

    plugin = entry(robot)
    if plugin.served is None:
        return None
    return plugin.serve(None).place


def prepare(spec: ArmSpec, request: ArmRequest, where: Where) -> Prepared:
    """``request`` checked before anything is opened (see the module docstring): bad values
    and a pose out of reach are refused in one line."""
    if request.action not in ACTIONS:
        raise RobotValueError(f"no action {request.action!r}; there are {', '.join(ACTIONS)}")
    if request.speed is not None and not (math.isfinite(request.speed)
                                          and 0 < request.speed <= 1):
        raise RobotValueError(f"--speed {request.speed:g}: a fraction of the joints' speed "
                              "limits, in (0, 1]")
    if where.connect and where.port:
        raise RobotValueError("--connect joins an arm already running: --port is that "
                              "run's to give, not this one's")
    world = where.world
    if world is None:
        world = "robot" if not where.port and not where.connect and own_world(spec.robot) \
            else "emulated"
    if world not in WORLDS:
        raise RobotValueError(f"--world {world}: one of {', '.join(WORLDS)}")
    if world == "robot" and not where.port and not where.connect \
            and own_world(spec.robot) is None:
        raise RobotValueError(f"robot {spec.robot} has no world of its own; --world mujoco "
                              "moves its URDF in MuJoCo")
    prepared = Prepared(request, world)
    if request.action == "home":
        prepared.target = spec.check_joints(list(spec.home), "home")
    elif request.action == "move":
        if (request.joints is None) == (request.pose is None):
            raise RobotValueError("move takes --joints J1 ... or --pose X Y Z, one of them")
        if request.joints is not None:
            prepared.target = spec.check_joints(list(request.joints), "move --joints")
        else:
            prepared.target = _solve_pose(spec, request, prepared)
    elif request.action == "gripper":
        if spec.gripper is None:
            raise RobotValueError(f"robot {spec.robot} has no gripper controller in "
                                  f"{spec.controllers.name}")
        if request.gripper not in ("open", "close"):
            raise RobotValueError(f"gripper {request.gripper!r}: open or close")
        _check_effort(request)
    else:
        _prepare_pick(spec, request, where, prepared)
    return prepared


def _check_effort(request: ArmRequest) -> None:
    if request.effort is not None and not (math.isfinite(request.effort)
                                           and request.effort >= 0):
        raise RobotValueError(f"--effort {request.effort:g}: a force (N) or torque (N m) "
                              ">= 0")


def _solve_pose(spec: ArmSpec, request: ArmRequest, prepared: Prepared) -> tuple[float, ...]:
    assert request.pose is not None
    chain = spec.chain()
    solution = chain.solve_position(request.pose, np.array(spec.home), pitch=request.pitch)
    q = tuple(float(v) for v in solution.q)
    pose = chain.forward(solution.q)
    prepared.ik = {"q_rad": list(q), "position_error_m": solution.position_error,
                   "angle_error_rad": solution.angle_error,
                   "tool_m": pose[:3, 3].tolist(), "tool_pitch_rad": chain.pitch(pose)}
    return q


def _prepare_pick(spec: ArmSpec, request: ArmRequest, where: Where,
                  prepared: Prepared) -> None:
    if spec.gripper is None:
        raise RobotValueError(f"robot {spec.robot} has no gripper controller to pick with")
    if where.port or where.connect or prepared.world == "emulated":
        raise RobotValueError("pick is judged from the object's pose in MuJoCo, so it runs "
                              "the arm in MuJoCo here: --world robot (its own world, with "
                              "things to pick), not --port, --connect or --world emulated")
    if request.pick is None or request.place is None:
        raise RobotValueError("pick takes the pick point X Y and --place X Y (m)")
    _check_effort(request)
    if prepared.world != "robot":
        raise RobotValueError("pick needs a world with an object to pick: --world robot "
                              f"(robot {spec.robot}'s own)")
    prepared.plan = plan_pick(spec.chain(), request.pick, request.place,
                              _object_half_height(spec, request.pick, request.place),
                              spec.home)


def _object_half_height(spec: ArmSpec, pick: Sequence[float], place: Sequence[float]) -> float:
    """The half height of the first free body of the robot's own world (built once, without
    its motors, to read it), once the table is found under the pick and place points."""
    from .pick import WorldObject, check_support, free_bodies

    world = _bare_world(spec)
    found = free_bodies(world)
    if not found:
        raise RobotValueError(f"robot {spec.robot}'s world has no free object to pick")
    half_height = WorldObject(world, found[0]).half_height
    check_support(world, pick, "pick")
    check_support(world, place, "place")
    return half_height


def _bare_world(spec: ArmSpec) -> Any:
    """The robot's own world, its motors emulated, never stepped: what it holds."""
    from ...dynamixel.emulator import build_emulator
    from ..dynamixel_system import dynamixel_system

    place = own_world(spec.robot)
    system = dynamixel_system(spec.urdf, spec.source, default_model=spec.default_model)
    spec_motors = system.bus().motor_spec().at_baudrate(system.baudrate)
    _simulation, _emulator, world = place(build_emulator(spec_motors))
    return world


def arm_command(spec: ArmSpec, request: ArmRequest, where: Where, *, out: str | None = None,
                say: Say = print, run_root: str | None = None) -> dict[str, Any]:
    """``servolab arm``: ``request`` checked (refused in one line before anything is opened),
    then run in its run folder (``out``, else ``runs/arm-<timestamp>/``); the summary. A pick
    out of reach is refused too, and leaves a run folder whose summary names the failure
    (``unreachable``)."""
    from ...kinematics.chain import UnreachableError
    from ...runs import DEFAULT_ROOT, RunFolder
    from .pick import OffTableError

    root = run_root or DEFAULT_ROOT
    try:
        prepared = prepare(spec, request, where)
    except (UnreachableError, OffTableError) as error:
        if request.action == "pick":
            folder = RunFolder.create("arm", out, root)
            folder.write_summary({
                "robot": spec.robot, "asked": request.figures(), "placed": False,
                "placement_error_m": None, "failure_reason": str(error),
                "failure": "off_table" if isinstance(error, OffTableError) else "unreachable"})
        raise
    with RunFolder.create("arm", out, root) as folder:
        return run_arm(folder, spec, prepared, where, say=say)


def run_arm(run_folder: RunFolder, spec: ArmSpec, prepared: Prepared, where: Where, *,
            say: Say = print, view: ViewRequest | None = None) -> dict[str, Any]:
    """Do what ``prepared`` asks (see the module docstring); the summary."""
    task = ArmTask(run_folder, spec, prepared, where, say)
    return run_task(run_folder, task, view=view, say=say)


class ArmTask(Task):
    """An arm's part of the run (:func:`~servolab.robots.lifecycle.run_task`)."""

    name = "arm"

    def __init__(self, run_folder: RunFolder, spec: ArmSpec, prepared: Prepared,
                 where: Where, say: Say) -> None:
        self.run_folder, self.spec, self.prepared, self.where = run_folder, spec, prepared, where
        self.say = say
        self.request = request = prepared.request
        self.moves: list[MoveResult] = []
        self.grips: list[GripResult] = []
        self.judge: PickJudge | None = None
        self.link: ArmLink | None = None
        self.recorder: Any = None
        self.system: Any = None
        self.summary: dict[str, Any] = {
            "robot": spec.robot, "asked": request.figures(),
            "where": where.label(prepared.world),
            "world": None if where.connect or where.port else prepared.world,
            "arm": {"controller": spec.controller, "joints": list(spec.joints),
                    "base": spec.base, "tip": spec.tip,
                    "gripper": spec.gripper.controller if spec.gripper else None,
                    "origins": dict(spec.origins)}}
        if prepared.ik:
            self.summary["ik"] = prepared.ik
        if prepared.plan is not None:
            self.summary["plan"] = prepared.plan.figures()

    # -- opening ----------------------------------------------------------------------------

    def open(self, opened: ExitStack) -> None:
        if self.where.connect:
            from ...middleware.context import Context
            from ...middleware.transport import TransportOptions

            self.context = opened.enter_context(Context.open(TransportOptions(
                "zenoh", [], list(self.where.connect), self.where.domain_id)))
            return
        from ...middleware.parameters import ParameterOverrides
        from ..control.bringup import BringUpOptions, ControlSystem

        spec, world = self.spec, self.prepared.world
        place = own_world(spec.robot) if world == "robot" and not self.where.port else None
        self.system = opened.enter_context(ControlSystem(
            spec.urdf, spec.source, ParameterOverrides.from_file(spec.controllers),
            BringUpOptions(port=self.where.port, world=world, spawn=spec.spawn,
                           real_time=False, default_model=spec.default_model, place=place)))
        self.context = self.system.context

    def start(self) -> None:
        from ...middleware.recorder import Recorder

        self.link = link = ArmLink(self.context, self.spec, self.say)
        topics = link.topics()
        if self.prepared.plan is not None:
            self._table()
            topics[POSE_TOPIC] = POSE
        self.bag = replaced(self.run_folder.file("arm_bag"))
        self.recorder = Recorder(self.context, str(self.bag), list(topics), types=topics,
                                 quiet=True)
        self.began = self.context.clock.now()
        link.wait_ready()

    def _table(self) -> None:
        """The object put near the pick point as a hand would (:func:`~.pick.by_hand`,
        seeded), its pose published from MuJoCo at 20 Hz."""
        plan, world = self.prepared.plan, self.system.world
        assert plan is not None and self.link is not None
        x, y, yaw = by_hand(plan.pick, self.request.seed)
        self.target = set_the_table(world, (x, y), yaw)
        self.summary["object_put_m"] = [round(x, 6), round(y, 6)]
        self.summary["object_yaw_rad"] = round(yaw, 6)
        self.judge = PickJudge(self.target, plan)
        self.judge.saw("start")
        node = self.link.node
        publisher = node.create_publisher(POSE, POSE_TOPIC, 10)
        base = self.spec.base

        def publish() -> None:
            x, y, z = self.target.position()
            w, qx, qy, qz = (float(v) for v in world.data.xquat[self.target.body])
            stamp = self.context.ros_time()
            publisher.publish(node.message(POSE, header={
                "stamp": {"sec": int(stamp), "nanosec": int((stamp % 1) * 1e9)},
                "frame_id": base}, pose={"position": {"x": x, "y": y, "z": z},
                                         "orientation": {"x": qx, "y": qy, "z": qz, "w": w}}))

        node.create_timer(0.05, publish)

    def served(self) -> Context:
        return self.context

    def graph(self) -> Context:
        return self.context

    # -- running ----------------------------------------------------------------------------

    def run(self) -> None:
        request, link = self.request, self.link
        assert link is not None
        self.say(f"{self.spec.robot} on {self.where.label(self.prepared.world)}: "
                 f"{self.spec.controller} ({', '.join(self.spec.joints)}), tool "
                 f"{self.spec.tip} in {self.spec.base}'s frame")
        if request.action in ("home", "move"):
            assert self.prepared.target is not None
            self._move(request.action, self.prepared.target)
        elif request.action == "gripper":
            self._grip(str(request.gripper))
        else:
            self._pick()

    def _limits(self) -> Any:
        return self.spec.limits(self.request.speed)

    def _move(self, what: str, target: Sequence[float]) -> MoveResult:
        assert self.link is not None
        result = self.link.move(what, target, self._limits())
        self.moves.append(result)
        error = max((abs(e) for e in result.final_error), default=math.nan)
        self.say(f"{what}: {result.points} points over {result.planned_s:.2f} s -> "
                 f"{result.status}" + (f" ({result.error_string})" if result.error_string
                                       else "") + f"; final error {error:.4f} rad")
        return result

    def _grip(self, how: str) -> GripResult:
        gripper, link = self.spec.gripper, self.link
        assert gripper is not None and link is not None
        effort = self.request.effort
        if effort is None:
            effort = gripper.effort if gripper.effort is not None else 0.0
        position = gripper.opened if how == "open" else gripper.closed
        result = link.grip(f"gripper {how}", position, effort)
        self.grips.append(result)
        held = " (stalled: holding something)" if result.stalled else ""
        self.say(f"gripper {how} to {position:g}: {result.status}{held}; at rest at "
                 f"{result.settled_position:.4f} after {result.settled_s:.2f} s")
        return result

    def _pick(self) -> None:
        plan, judge, gripper = self.prepared.plan, self.judge, self.spec.gripper
        assert plan is not None and judge is not None and gripper is not None
        poses = plan.poses
        self.say(f"pick {self.target.name} at ({plan.pick[0]:.3f}, {plan.pick[1]:.3f}) m, "
                 f"place at ({plan.place[0]:.3f}, {plan.place[1]:.3f}) m, the tool "
                 f"{plan.pitch_deg:g}° down")

        def moved(what: str, pose: str) -> bool:
            result = self._move(what, poses[pose])
            if not result.succeeded:
                judge.fail("aborted", f"{what}: {result.status} {result.error_string}".strip())
            return result.succeeded

        self._grip("open")
        if not (moved("approach", "above_pick") and moved("descend", "grasp")):
            return self._back_off()
        closed = self._grip("close")
        judge.after_close(closed.settled_position, gripper.closed)
        if not moved("lift", "above_pick"):
            return self._back_off()
        judge.after_lift()
        if judge.failure is not None:
            return self._back_off()
        if not moved("carry", "above_place"):
            return self._back_off()
        judge.after_carry(plan.points["above_place"])
        if judge.failure is not None:
            return self._back_off()
        if not moved("lower", "release"):
            return self._back_off()
        self._grip("open")
        judge.saw("released")
        moved("retreat", "above_place")
        return None

    def _back_off(self) -> None:
        """After a failure: let go, and lift the tool clear."""
        assert self.link is not None
        self._grip("open")
        self._move("back off", self.spec.home)

    # -- the way out ------------------------------------------------------------------------

    def stop(self, ended: BaseException | None) -> list[Step]:
        if ended is None or self.link is None:
            return []
        link = self.link
        return [Step("cancelling the goal running", link.cancel)]

    def way_out(self, ended: BaseException | None) -> list[Step]:
        steps = []
        if self.judge is not None and self.link is not None:
            link = self.link
            steps.append(Step("letting the object settle", lambda: link.wait(
                lambda: False, SETTLE)))
            steps.append(Step("judging the pick", self._judge))
        if self.recorder is not None:
            recorder = self.recorder
            steps.append(Step("closing the bag", recorder.destroy))
        steps += [Step("summarising", self._summarise), Step("plotting", self._plot)]
        if self.request.render and self.judge is not None:
            steps.append(Step("rendering the pick", self._render))
        return steps

    def _render(self) -> None:
        """``pick.png``: the world at each stage the judge saw, from the front left of the
        table, looking at the middle of the pick and place points."""
        from ...sim.mujoco_video import looking_at, render_grid

        judge, world = self.judge, self.system.world
        assert judge is not None
        shown = [s for s in RENDERED if s in judge.scenes]
        x, y, z = (np.mean([judge.stages[s] for s in shown], axis=0)
                   + np.array([0.0, 0.0, RENDER_ABOVE]))
        path = render_grid(world.model, np.array([judge.scenes[s] for s in shown]),
                           self.run_folder.file("pick.png"),
                           labels=[RENDERED[s] for s in shown],
                           view=looking_at((x, y, z), RENDER_DISTANCE,
                                             elevation=RENDER_ELEVATION))
        self.summary["render"] = path.name

    def _judge(self) -> None:
        assert self.judge is not None
        self.summary.update(self.judge.verdict())

    def _summarise(self) -> None:
        joints = self.spec.joints
        summary = self.summary
        summary["moves"] = [m.figures(joints) for m in self.moves]
        summary["gripper_goals"] = [g.figures() for g in self.grips]
        last = self.moves[-1] if self.moves else None
        if last is not None:
            summary["status"] = last.status
            summary["final_error_rad"] = dict(zip(joints, last.final_error, strict=False))
            summary["max_final_error_rad"] = max((abs(e) for e in last.final_error),
                                                 default=None)
        if self.grips and self.request.action == "gripper":
            grip = self.grips[-1]
            summary["status"] = grip.status
            summary["gripper_final_error"] = grip.position - grip.settled_position \
                if math.isfinite(grip.settled_position) else None
        if self.context.clock.virtual and hasattr(self, "began"):
            summary["simulated_s"] = round(self.context.clock.now() - self.began, 3)
        if self.recorder is not None:
            summary["bag"] = str(self.bag)
            summary["recorded"] = dict(self.recorder.counts)

    def _plot(self) -> None:
        from .plot import plot_joints

        if self.link is None or not self.link.heard.states:
            return
        target = self.run_folder.file("arm.png")
        self.summary["plot"] = str(plot_joints(self.link.heard, self.spec, target,
                                               title=f"servolab arm {self.request.action}"))

    def verdict(self, ended: BaseException | None) -> None:
        if self.request.action == "pick":
            self.summary.setdefault("placed", False)
            if "failure" not in self.summary:
                self.summary["failure"] = "aborted"
            assert self.summary.get("failure") in (None, *FAILURES)

    def report(self, ended: BaseException | None) -> None:
        if ended is not None:
            return
        summary = self.summary
        if self.request.action == "pick":
            self.say(("placed" if summary.get("placed") else
                      f"not placed ({summary.get('failure')}: {summary.get('failure_reason')})")
                     + f": {(summary.get('placement_error_m') or math.nan) * 1000:.1f} mm from "
                     f"the place point; run folder {self.run_folder.path}")
            if not summary.get("placed"):
                raise RobotError(f"pick not placed: {summary.get('failure')}: "
                                 f"{summary.get('failure_reason')}")
            return
        self.say(f"run folder {self.run_folder.path}")
        failed = [m for m in self.moves if not m.succeeded]
        if failed:
            m = failed[0]
            raise RobotError(f"{m.what}: the goal ended {m.status}"
                             + (f" ({m.error_code}: {m.error_string})" if m.error_code else ""))
        bad = [g for g in self.grips if g.status != "SUCCEEDED" and not g.stalled]
        if bad:
            raise RobotError(f"{bad[0].what}: the goal ended {bad[0].status}")
