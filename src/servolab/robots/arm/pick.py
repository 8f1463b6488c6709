"""Pick and place: where the arm goes (planned before anything moves) and what the world says
happened (judged from MuJoCo's object pose, never from the commands).

**The plan** (:func:`plan_pick`). The object is grasped from above at its centre's height:
the tool point (the chain's tip) at the pick point, ``half_height`` up, and
:data:`APPROACH_HEIGHT` above it; the place is the same at the place point, released
:data:`DROP` above the table. The tool points down as steeply as the arm can reach all four
poses (the first of :data:`PITCHES` at which the inverse kinematics meets them; a
yaw-and-pitch arm such as the OpenMANIPULATOR-X points straight down only near its base), at
one pitch, so that the object is set down as it was picked up, flat (held at another pitch,
it would land on an edge and tip). Each pose is solved from the one before, so the arm keeps
one elbow the whole way. Any pose out of reach refuses the whole
pick, before anything moves (:class:`~servolab.kinematics.chain.UnreachableError`).

**The sequence**: open the gripper, go above the pick point, descend, close, lift, carry to
above the place point, lower, open, retreat up: one trajectory goal a move.

**The judgement** (:class:`PickJudge`), from the object's pose in MuJoCo at each stage:

- ``missed``: the fingers closed all the way (nothing between them), or the object did not
  rise with the lift;
- ``slipped``: it rose, but was not between the fingers any more above the place point;
- ``misplaced``: it was let go, but came to rest more than :data:`PLACED_WITHIN` from the
  place point (or not on the table);
- ``aborted``: a trajectory goal did not succeed (its status says why);
- ``unreachable``: refused before anything moved (the plan);
- ``off_table``: refused before anything moved, the pick or place point having nothing under
  it to rest the object on at the arm's base height (:func:`check_support`).

``placed`` is true when the object rests on the table within :data:`PLACED_WITHIN` of the
place point; ``placement_error_m`` is its centre's horizontal distance from it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import RobotValueError

if TYPE_CHECKING:
    from ...kinematics.chain import Chain

#: how high above the grasp the tool approaches and retreats (m)
APPROACH_HEIGHT = 0.06
#: how far above resting on the table the object is let go (m)
DROP = 0.002
#: the tool's pitches tried, steepest first (degrees below the horizontal)
PITCHES = (90.0, 75.0, 60.0, 45.0)
#: the judgement's bar: placed within this of the place point (m), as issue 47 asks
PLACED_WITHIN = 0.01
#: risen this much with the lift (m): held
LIFTED = 0.02
#: within this of the tool point horizontally above the place point (m): still held
HELD_WITHIN = 0.02
#: the fingers came this close to closed (m or rad): nothing between them
CLOSED_WITHIN = 1e-3
#: resting on the table: its centre within this of its half height (m)
RESTING_WITHIN = 0.005
#: how long the world settles after the last move before the object is judged (s)
SETTLE = 0.5
#: a hand puts the object this close to the pick point (m) and this square to the fingers
#: (degrees), at random (seeded): the arm is told the pick point, not where the object is
HAND_OFFSET = 0.003
HAND_YAW_DEG = 10.0
#: the failures a pick names
FAILURES = ("unreachable", "off_table", "missed", "slipped", "misplaced", "aborted")


@dataclass(frozen=True)
class PickPlan:
    """The joint positions of each pose of a pick, and where they are (m, base frame)."""

    pick: tuple[float, float]
    place: tuple[float, float]
    half_height: float
    #: the tool's pitch (degrees below the horizontal), the same at the pick and the place
    pitch_deg: float
    poses: dict[str, tuple[float, ...]]
    points: dict[str, tuple[float, float, float]]

    def figures(self) -> dict[str, Any]:
        return {"pick_m": list(self.pick), "place_m": list(self.place),
                "grasp_height_m": self.half_height, "pitch_deg": self.pitch_deg,
                "poses_rad": {k: [round(v, 6) for v in q] for k, q in self.poses.items()},
                "tool_points_m": {k: [round(v, 6) for v in p] for k, p in self.points.items()}}


def plan_pick(chain: Chain, pick: Sequence[float], place: Sequence[float],
              half_height: float, start: Sequence[float]) -> PickPlan:
    """The poses of a pick (see the module docstring), or
    :class:`~servolab.kinematics.chain.UnreachableError` naming the one out of reach."""
    for name, point in (("pick", pick), ("place", place)):
        if len(point) != 2 or not all(math.isfinite(v) for v in point):
            raise RobotValueError(f"the {name} point must be two finite numbers X Y (m)")
    grasp_z = half_height
    release_z = half_height + DROP
    targets = {"above_pick": (pick[0], pick[1], grasp_z + APPROACH_HEIGHT),
               "grasp": (pick[0], pick[1], grasp_z),
               "above_place": (place[0], place[1], release_z + APPROACH_HEIGHT),
               "release": (place[0], place[1], release_z)}
    from ...kinematics.chain import UnreachableError

    last: UnreachableError | None = None
    for pitch in PITCHES:   # one pitch for the whole pick: the object is set down as it was
        try:
            poses: dict[str, tuple[float, ...]] = {}
            q: Sequence[float] = start
            for name, where in (("above_pick", "pick"), ("grasp", "pick"),
                                ("above_place", "place"), ("release", "place")):
                what = (pick if where == "pick" else place)
                try:
                    q = tuple(float(v) for v in chain.solve_position(
                        targets[name], np.asarray(q, dtype=np.float64),
                        pitch=math.radians(pitch)).q)
                except UnreachableError as error:
                    raise UnreachableError(f"the {where} point ({what[0]:.3f}, {what[1]:.3f}) "
                                           f"m: {error}", error.nearest) from None
                poses[name] = q
        except UnreachableError as error:
            last = error
            continue
        return PickPlan((float(pick[0]), float(pick[1])), (float(place[0]), float(place[1])),
                        half_height, pitch, poses, targets)
    assert last is not None
    raise last


# -- the object in the world -------------------------------------------------------------------

class WorldObject:
    """A free body of a MuJoCo world (``world.model``, ``world.data``): the thing to pick.
    Its pose is read from MuJoCo; :meth:`put` sets it (at rest), :meth:`park` takes it out
    of the way (a metre under the table, held there against gravity)."""

    def __init__(self, world: Any, body: str) -> None:
        import mujoco

        self.world, self.name = world, body
        m = world.model
        self.body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body)
        if self.body < 0:
            raise RobotValueError(f"the world has no body {body!r}")
        joint = int(m.body_jntadr[self.body])
        if joint < 0 or int(m.jnt_type[joint]) != int(mujoco.mjtJoint.mjJNT_FREE):
            raise RobotValueError(f"body {body!r} is not free to pick up (no free joint)")
        self._qpos = int(m.jnt_qposadr[joint])
        self._dof = int(m.jnt_dofadr[joint])
        self.half_height = self._half_height()

    def _half_height(self) -> float:
        """How far its lowest point is below its centre, upright (m): its geoms' extent."""
        import mujoco

        m = self.world.model
        low = 0.0
        for g in range(m.ngeom):
            if int(m.geom_bodyid[g]) != self.body:
                continue
            kind, size, z = int(m.geom_type[g]), m.geom_size[g], float(m.geom_pos[g][2])
            extent = {int(mujoco.mjtGeom.mjGEOM_BOX): size[2],
                      int(mujoco.mjtGeom.mjGEOM_SPHERE): size[0],
                      int(mujoco.mjtGeom.mjGEOM_CYLINDER): size[1],
                      int(mujoco.mjtGeom.mjGEOM_CAPSULE): size[0] + size[1],
                      int(mujoco.mjtGeom.mjGEOM_ELLIPSOID): size[2]}.get(kind)
            if extent is None:
                raise RobotValueError(f"body {self.name!r}: a geom of a kind servolab cannot "
                                      "size (box, sphere, cylinder, capsule, ellipsoid)")
            low = max(low, float(extent) - z)
        if low <= 0:
            raise RobotValueError(f"body {self.name!r} has no geom to grasp")
        return low

    def position(self) -> tuple[float, float, float]:
        x, y, z = (float(v) for v in self.world.data.xpos[self.body])
        return x, y, z

    def upright(self) -> float:
        """The cosine of its tilt: 1 upright, 0 on its side."""
        return float(self.world.data.xmat[self.body][8])

    def put(self, x: float, y: float, z: float, yaw: float = 0.0) -> None:
        import mujoco

        d = self.world.data
        d.qpos[self._qpos:self._qpos + 7] = (x, y, z, math.cos(yaw / 2), 0.0, 0.0,
                                             math.sin(yaw / 2))
        d.qvel[self._dof:self._dof + 6] = 0.0
        mujoco.mj_forward(self.world.model, d)

    def park(self, slot: int) -> None:
        """Out of the way: a metre below the table, held there (a force against its weight,
        MuJoCo's ``xfrc_applied``), touching nothing."""
        m = self.world.model
        for g in range(m.ngeom):
            if int(m.geom_bodyid[g]) == self.body:
                m.geom_contype[g] = m.geom_conaffinity[g] = 0
        weight = -float(m.body_subtreemass[self.body]) * np.asarray(m.opt.gravity)
        self.world.data.xfrc_applied[self.body, :3] = weight
        self.put(0.5 * slot, 0.0, -1.0)


def free_bodies(world: Any) -> list[str]:
    """The bodies of the world with a free joint (what can be picked), in the model's order."""
    import mujoco

    m = world.model
    names = []
    for b in range(1, m.nbody):
        joint = int(m.body_jntadr[b])
        if joint >= 0 and int(m.jnt_type[joint]) == int(mujoco.mjtJoint.mjJNT_FREE):
            names.append(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b))
    return names


def support_height(world: Any, x: float, y: float) -> float | None:
    """The height (m) of the highest fixed surface of the world under (x, y): what an object
    put there rests on (a ray cast down on the world body's own geoms, a table's, not on the
    robot nor on what lies there); None where nothing is."""
    import mujoco

    m, d = world.model, world.data
    mujoco.mj_kinematics(m, d)
    start, down = np.array([x, y, 10.0]), np.array([0.0, 0.0, -1.0])
    hits = [float(mujoco.mju_rayGeom(d.geom_xpos[g], d.geom_xmat[g], m.geom_size[g], start,
                                     down, int(m.geom_type[g])))
            for g in range(m.ngeom) if int(m.geom_bodyid[g]) == 0]
    found = [h for h in hits if h >= 0]
    return 10.0 - min(found) if found else None


def check_support(world: Any, point: Sequence[float], what: str) -> None:
    """Refuse a pick or place point where nothing holds the object at the arm's base height
    (the table's top, z = 0): it would fall, or the arm would set it in the air."""
    height = support_height(world, float(point[0]), float(point[1]))
    if height is None or abs(height) > RESTING_WITHIN:
        there = "nothing" if height is None else f"a surface at z = {height:.3f} m"
        raise OffTableError(f"the {what} point ({point[0]:.3f}, {point[1]:.3f}) m is off the "
                            f"table: {there} under it, where the object must rest at z = 0")


class OffTableError(RobotValueError):
    """A pick or place point with nothing to rest the object on."""


def by_hand(pick: Sequence[float], seed: int) -> tuple[float, float, float]:
    """Where a hand puts the object for a pick at ``pick``: within :data:`HAND_OFFSET` of it
    and turned within :data:`HAND_YAW_DEG` of square to the fingers (the arm's azimuth), as
    drawn from ``seed``: (x, y, yaw in rad)."""
    rng = np.random.default_rng(seed)
    radius = HAND_OFFSET * math.sqrt(float(rng.uniform()))
    angle = float(rng.uniform(0.0, 2.0 * math.pi))
    yaw = math.atan2(pick[1], pick[0]) + math.radians(float(rng.uniform(-HAND_YAW_DEG,
                                                                         HAND_YAW_DEG)))
    return (float(pick[0]) + radius * math.cos(angle), float(pick[1]) + radius * math.sin(angle),
            yaw)


def set_the_table(world: Any, pick: Sequence[float], yaw: float) -> WorldObject:
    """The first free body of the world put at ``pick`` (x, y), resting on the table and
    turned by ``yaw`` (rad: a box's faces are square to the fingers at the arm's azimuth);
    the others parked out of the way."""
    found = free_bodies(world)
    if not found:
        raise RobotValueError("the world has no free object to pick (a body with a free "
                              "joint): run pick in the robot's own world (--world robot)")
    target = WorldObject(world, found[0])
    for slot, name in enumerate(found[1:], start=1):
        WorldObject(world, name).park(slot)
    target.put(float(pick[0]), float(pick[1]), target.half_height, yaw)
    return target


# -- the judgement -----------------------------------------------------------------------------

@dataclass
class PickJudge:
    """What the world showed at each stage of a pick, and the verdict; ``scenes`` keeps the
    whole world's ``qpos`` at each stage, for a picture of the pick (``servolab arm pick
    --render``)."""

    target: WorldObject
    plan: PickPlan
    stages: dict[str, list[float]] = field(default_factory=dict)
    scenes: dict[str, np.ndarray] = field(default_factory=dict)
    failure: str | None = None
    reason: str = ""

    def saw(self, stage: str) -> tuple[float, float, float]:
        where = self.target.position()
        self.stages[stage] = [round(v, 6) for v in where]
        self.scenes[stage] = np.array(self.target.world.data.qpos, dtype=float)
        return where

    def fail(self, failure: str, reason: str) -> None:
        if self.failure is None:
            self.failure, self.reason = failure, reason

    def after_close(self, settled: float, closed: float) -> None:
        """The fingers came to rest at ``settled``; within :data:`CLOSED_WITHIN` of
        ``closed``, the gripper's closed position, nothing is between them."""
        self.saw("closed")
        if abs(settled - closed) < CLOSED_WITHIN:
            self.fail("missed", f"the fingers closed to {settled:.4f} with nothing between "
                      "them")

    def after_lift(self) -> None:
        z = self.saw("lifted")[2]
        rose = z - self.target.half_height
        if rose < LIFTED:
            self.fail("missed", f"the object rose {rose * 1000:.1f} mm with a "
                      f"{APPROACH_HEIGHT * 1000:.0f} mm lift: not held")

    def after_carry(self, tool: Sequence[float]) -> None:
        x, y, z = self.saw("carried")
        off = math.hypot(x - tool[0], y - tool[1])
        if off > HELD_WITHIN or z - self.target.half_height < LIFTED:
            self.fail("slipped", f"above the place point the object was {off * 1000:.1f} mm "
                      f"from the tool and {(z - self.target.half_height) * 1000:.1f} mm up: "
                      "it slipped out on the way")

    def verdict(self) -> dict[str, Any]:
        x, y, z = self.saw("final")
        error = math.hypot(x - self.plan.place[0], y - self.plan.place[1])
        resting = abs(z - self.target.half_height) <= RESTING_WITHIN
        placed = resting and error <= PLACED_WITHIN   # the world's say, whatever was seen
        if not placed:
            self.fail("misplaced", f"it came to rest {error * 1000:.1f} mm from the place "
                      "point" + ("" if resting else f", {z * 1000:.1f} mm up (not resting on "
                                 "the table)"))
        return {"placed": placed, "placement_error_m": round(error, 6),
                "failure": None if placed else self.failure,
                "failure_reason": None if placed else self.reason,
                "object": self.target.name, "object_final_m": [round(v, 6) for v in (x, y, z)],
                "object_upright_cos": round(self.target.upright(), 4),
                "object_stages_m": self.stages}
