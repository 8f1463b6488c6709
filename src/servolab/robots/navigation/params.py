"""The ROS navigation parameter files of seed 000, read as a user already has them.

- :func:`load_costmap` reads a costmap_2d parameter file such as seed 000's Appendix D.2
  (turtlebot's ``costmap_common_params.yaml``, ``costmap_params.yaml`` shipped here): the robot's
  ``robot_radius`` or ``footprint`` (and ``footprint_padding``), the grid's ``resolution``, and
  the inflation layer's ``inflation_radius``, ``cost_scaling_factor``, ``inflate_unknown`` and
  ``enabled`` under ``inflation_layer:`` (or at the top level, where costmap_2d read them before
  Hydro; the layer's namespace wins when both are written).
- :func:`load_move_base` reads move_base's own parameters (turtlebot's
  ``move_base_params.yaml``, ``move_base_params.yaml`` shipped here): the controller and planner
  frequencies and patiences and the oscillation check.
- :func:`load_dwa` reads dwa_local_planner's parameters such as Appendix D.3
  (``dwa_params.yaml`` shipped here), at the top level as the seed prints them or under
  ``DWAPlannerROS:`` as ROS's files write them. Fields keep the names the file writes
  (``max_trans_vel``, ``max_rot_vel``, ``vtheta_samples``); the newer names dwa_local_planner
  also reads (``max_vel_trans``, ``max_vel_theta``, ``vth_samples``, ...) are read as the same
  fields, the newer winning when both are written (nav_core's warnRenamedParameter).

A value of the wrong kind (``robot_radius: big``) is refused as a :class:`NavParamsError`,
``file:line: key 'robot_radius': must be a finite number, not 'big'``, as is a value out of its
range. Keys servolab does not use -- the voxel obstacle layer and its observation sources,
``map_type``, debugging topics -- are not refused: their key paths (whole sections once) are
collected in ``ignored``, for the caller to report once. A key written twice with the same value
(the seed's ``obstacle_layer`` writes ``origin_z``, ``z_resolution`` and ``z_voxels`` twice, as
turtlebot's file does) is read once and noted in ``notes``; written twice with different values
it is refused naming both lines, as every servolab file is (ROS would silently keep the last).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import yaml

from ...configfile import (
    ConfigMapping,
    ConfigValue,
    load_text,
    nonnegative_float,
    positive_float,
    shipped,
)
from ...configfile import load as load_config
from ...errors import ConfigFileError
from ...limits import read_limited
from ...planning.costmap import footprint_distances, footprint_from_radius, pad_footprint
from ...planning.dwa import DwaConfig

if TYPE_CHECKING:
    from ...sim.scene import Scene

#: seed 000's parameter files, installed with this package: D.2's costmap, D.3's DWA and
#: turtlebot's move_base (``servolab robots show costmap_params`` prints one)
DEFAULT_COSTMAP = shipped(__package__ or "servolab.robots.navigation", "costmap_params.yaml")
DEFAULT_DWA = shipped(__package__ or "servolab.robots.navigation", "dwa_params.yaml")
DEFAULT_MOVE_BASE = shipped(__package__ or "servolab.robots.navigation", "move_base_params.yaml")


class NavParamsError(ConfigFileError):
    """A navigation parameter file (costmap or DWA) that cannot be used."""


# -- costmap -----------------------------------------------------------------------------------

#: costmap_2d's defaults (Costmap2D.cfg, InflationPlugin.cfg) for what a file does not write.
DEFAULT_RESOLUTION = 0.05
DEFAULT_FOOTPRINT_PADDING = 0.01
DEFAULT_INFLATION_RADIUS = 0.55
DEFAULT_COST_SCALING_FACTOR = 10.0
#: costmap_2d's robot_radius when neither it nor a footprint is given (Costmap2D.cfg).
DEFAULT_ROBOT_RADIUS = 0.46


@dataclass(frozen=True)
class CostmapParams:
    """What servolab uses of a costmap_2d parameter file. Exactly one of ``robot_radius`` and
    ``footprint`` is set (a footprint wins when a file writes both, as in costmap_2d)."""

    robot_radius: float | None = DEFAULT_ROBOT_RADIUS
    footprint: tuple[tuple[float, float], ...] | None = None
    footprint_padding: float = DEFAULT_FOOTPRINT_PADDING
    resolution: float = DEFAULT_RESOLUTION
    inflation_enabled: bool = True
    inflation_radius: float = DEFAULT_INFLATION_RADIUS
    cost_scaling_factor: float = DEFAULT_COST_SCALING_FACTOR
    inflate_unknown: bool = False
    track_unknown_space: bool = False
    path: str = field(default="", compare=False)
    #: key paths servolab does not use, whole sections once, in file order
    ignored: tuple[str, ...] = field(default=(), compare=False)
    #: remarks about the file that are not errors (a key written twice with one value)
    notes: tuple[str, ...] = field(default=(), compare=False)

    @property
    def footprint_polygon(self) -> tuple[tuple[float, float], ...]:
        """The padded footprint the layers see in costmap_2d: the given polygon, or the 16-gon
        of ``robot_radius``, padded by ``footprint_padding``."""
        base = (self.footprint if self.footprint is not None
                else footprint_from_radius(self.robot_radius or 0.0))
        padded = pad_footprint(base, self.footprint_padding)
        return tuple((float(x), float(y)) for x, y in padded)

    @property
    def inscribed_radius(self) -> float:
        """costmap_2d's inscribed radius of :attr:`footprint_polygon`
        (calculateMinAndMaxDistances)."""
        return footprint_distances(self.footprint_polygon)[0]

    @property
    def circumscribed_radius(self) -> float:
        return footprint_distances(self.footprint_polygon)[1]


_INFLATION_KEYS = ("enabled", "inflation_radius", "cost_scaling_factor", "inflate_unknown")
#: top-level keys servolab reads (the rest are ignored)
_COSTMAP_TOP = ("robot_radius", "footprint", "footprint_padding", "resolution",
                "inflation_radius", "cost_scaling_factor", "track_unknown_space",
                "inflation_layer")


def load_costmap(path: str | Path) -> CostmapParams:
    """Read a costmap_2d parameter file (see the module docstring)."""
    top, notes = _load(path, "costmap parameter file")
    return parse_costmap(top, str(path), notes)


def parse_costmap(top: ConfigValue, path: str = "", notes: tuple[str, ...] = ()) -> CostmapParams:
    """The costmap parameters of an already composed file."""
    m = _top_mapping(top, "a costmap parameter file")
    ignored: list[str] = []
    values: dict[str, object] = {}
    for name, value in m.items():
        if name not in _COSTMAP_TOP:
            ignored.append(value.key)
    radius = m.get("robot_radius")
    if radius is not None:
        values["robot_radius"] = positive_float(radius)
    footprint = m.get("footprint")
    if footprint is not None:
        values["footprint"] = _footprint(footprint)
        values["robot_radius"] = None
    for key in ("footprint_padding",):
        if (v := m.get(key)) is not None:
            values[key] = nonnegative_float(v)
    if (v := m.get("resolution")) is not None:
        values["resolution"] = positive_float(v)
    if (v := m.get("track_unknown_space")) is not None:
        values["track_unknown_space"] = v.as_bool()
    # pre-Hydro place first, then the layer's namespace over it
    sources: list[ConfigMapping] = [m]
    layer = m.get("inflation_layer")
    if layer is not None:
        inflation = layer.as_mapping()
        sources.append(inflation)
        for name, value in inflation.items():
            if name not in _INFLATION_KEYS:
                ignored.append(value.key)
        if (v := inflation.get("enabled")) is not None:
            values["inflation_enabled"] = v.as_bool()
        if (v := inflation.get("inflate_unknown")) is not None:
            values["inflate_unknown"] = v.as_bool()
    for source in sources:
        if (v := source.get("inflation_radius")) is not None:
            values["inflation_radius"] = nonnegative_float(v)
        if (v := source.get("cost_scaling_factor")) is not None:
            values["cost_scaling_factor"] = nonnegative_float(v)
    _check_some_known(m, sum(name in _COSTMAP_TOP for name in m),
                      "costmap_2d's parameters")
    return CostmapParams(**values, path=path, ignored=tuple(ignored),  # type: ignore[arg-type]
                         notes=notes)


def _footprint(value: ConfigValue) -> tuple[tuple[float, float], ...]:
    """A footprint as ROS takes it: a list of [x, y] pairs, or that list written as a string."""
    what = f"key {value.key!r}"
    items: list[ConfigValue]
    if isinstance(value.plain(), str):
        text = value.as_str()
        try:
            parsed = yaml.safe_load(text)
        except yaml.YAMLError:
            parsed = None
        if (not isinstance(parsed, list)
                or not all(isinstance(p, list) and len(p) == 2 and all(
                    isinstance(c, int | float) and not isinstance(c, bool) and math.isfinite(c)
                    for c in p) for p in parsed)):
            raise value.error(f"{what}: must be a list of [x, y] points, not {text!r}")
        points = [(float(p[0]), float(p[1])) for p in parsed]
    else:
        items = list(value.as_list(what))
        points = []
        for item in items:
            pair = item.as_list(f"key {item.key!r}")
            if len(pair) != 2:
                raise item.error(f"key {item.key!r}: a footprint point must be [x, y], "
                                 f"not {len(pair)} numbers")
            points.append((pair[0].as_float(), pair[1].as_float()))
    if len(points) < 3:
        raise value.error(f"{what}: a footprint needs at least three points, not {len(points)}")
    return tuple(points)


# -- DWA ---------------------------------------------------------------------------------------


#: dwa_local_planner's defaults (DWAPlanner.cfg) for what the planner uses
_PLANNER = DwaConfig()


@dataclass(frozen=True)
class DwaParams:
    """dwa_local_planner's parameters, named as seed 000's D.3 writes them; defaults are
    dwa_local_planner's (DWAPlanner.cfg). Velocities in m/s and rad/s, accelerations in m/s²
    and rad/s², times in s, distances in m, angles in rad. The defaults the planner shares are
    :class:`~servolab.planning.dwa.DwaConfig`'s, written there once."""

    max_vel_x: float = _PLANNER.max_vel_x
    min_vel_x: float = _PLANNER.min_vel_x
    max_vel_y: float = 0.1
    min_vel_y: float = -0.1
    max_trans_vel: float = _PLANNER.max_trans_vel
    min_trans_vel: float = _PLANNER.min_trans_vel
    trans_stopped_vel: float = _PLANNER.trans_stopped_vel
    max_rot_vel: float = _PLANNER.max_rot_vel
    min_rot_vel: float = _PLANNER.min_rot_vel
    rot_stopped_vel: float = _PLANNER.rot_stopped_vel
    acc_lim_x: float = _PLANNER.acc_lim_x
    acc_lim_y: float = 2.5
    acc_lim_theta: float = _PLANNER.acc_lim_theta
    yaw_goal_tolerance: float = _PLANNER.yaw_goal_tolerance
    xy_goal_tolerance: float = _PLANNER.xy_goal_tolerance
    latch_xy_goal_tolerance: bool = False
    sim_time: float = _PLANNER.sim_time
    sim_granularity: float = _PLANNER.sim_granularity
    angular_sim_granularity: float = _PLANNER.angular_sim_granularity
    vx_samples: int = _PLANNER.vx_samples
    vy_samples: int = 10
    vtheta_samples: int = _PLANNER.vtheta_samples
    path_distance_bias: float = _PLANNER.path_distance_bias
    goal_distance_bias: float = _PLANNER.goal_distance_bias
    occdist_scale: float = _PLANNER.occdist_scale
    twirling_scale: float = 0.0
    forward_point_distance: float = _PLANNER.forward_point_distance
    stop_time_buffer: float = _PLANNER.stop_time_buffer
    scaling_speed: float = 0.25
    max_scaling_factor: float = 0.2
    oscillation_reset_dist: float = _PLANNER.oscillation_reset_dist
    oscillation_reset_angle: float = 0.2
    controller_frequency: float = _PLANNER.controller_frequency
    holonomic_robot: bool = False
    path: str = field(default="", compare=False)
    ignored: tuple[str, ...] = field(default=(), compare=False)
    notes: tuple[str, ...] = field(default=(), compare=False)


_Reader = Callable[[ConfigValue], object]


def _any_float(value: ConfigValue) -> float:
    return value.as_float()


#: field -> how its value is read (and checked)
_DWA_FIELDS: dict[str, _Reader] = {
    "max_vel_x": _any_float, "min_vel_x": _any_float,
    "max_vel_y": _any_float, "min_vel_y": _any_float,
    "max_trans_vel": nonnegative_float, "min_trans_vel": nonnegative_float,
    "trans_stopped_vel": nonnegative_float,
    "max_rot_vel": nonnegative_float, "min_rot_vel": nonnegative_float,
    "rot_stopped_vel": nonnegative_float,
    "acc_lim_x": nonnegative_float, "acc_lim_y": nonnegative_float,
    "acc_lim_theta": nonnegative_float,
    "yaw_goal_tolerance": nonnegative_float,
    "xy_goal_tolerance": nonnegative_float,
    "latch_xy_goal_tolerance": lambda v: v.as_bool(),
    "sim_time": positive_float, "sim_granularity": positive_float,
    "angular_sim_granularity": positive_float,
    "vx_samples": lambda v: _count(v), "vy_samples": lambda v: _count(v),
    "vtheta_samples": lambda v: _count(v),
    "path_distance_bias": nonnegative_float,
    "goal_distance_bias": nonnegative_float,
    "occdist_scale": nonnegative_float, "twirling_scale": nonnegative_float,
    "forward_point_distance": _any_float,
    "stop_time_buffer": nonnegative_float,
    "scaling_speed": nonnegative_float,
    "max_scaling_factor": nonnegative_float,
    "oscillation_reset_dist": nonnegative_float,
    "oscillation_reset_angle": nonnegative_float,
    "controller_frequency": positive_float,
    "holonomic_robot": lambda v: v.as_bool(),
}
#: dwa_local_planner's newer names -> the field (the seed's, older name)
_DWA_RENAMED = {"max_vel_trans": "max_trans_vel", "min_vel_trans": "min_trans_vel",
                "max_vel_theta": "max_rot_vel", "min_vel_theta": "min_rot_vel",
                "theta_stopped_vel": "rot_stopped_vel", "vth_samples": "vtheta_samples"}
DWA_NAMESPACE = "DWAPlannerROS"


def load_dwa(path: str | Path) -> DwaParams:
    """Read dwa_local_planner's parameters (see the module docstring)."""
    top, notes = _load(path, "DWA parameter file")
    return parse_dwa(top, str(path), notes)


def parse_dwa(top: ConfigValue, path: str = "", notes: tuple[str, ...] = ()) -> DwaParams:
    """The DWA parameters of an already composed file."""
    m = _top_mapping(top, "a DWA parameter file")
    ignored: list[str] = []
    namespaced = m.get(DWA_NAMESPACE)
    if namespaced is not None:
        ignored.extend(value.key for name, value in m.items() if name != DWA_NAMESPACE)
        m = namespaced.as_mapping()
    values: dict[str, object] = {}
    renamed: dict[str, object] = {}
    for name, value in m.items():
        if name in _DWA_FIELDS:
            values[name] = _DWA_FIELDS[name](value)
        elif name in _DWA_RENAMED:
            target = _DWA_RENAMED[name]
            renamed[target] = _DWA_FIELDS[target](value)
        else:
            ignored.append(value.key)
    values.update(renamed)  # the newer name wins, as warnRenamedParameter lets it
    _check_some_known(m, len(values), "dwa_local_planner's parameters")
    params = DwaParams(**values, path=path, ignored=tuple(ignored),  # type: ignore[arg-type]
                       notes=notes)
    for low, high in (("min_vel_x", "max_vel_x"), ("min_vel_y", "max_vel_y"),
                      ("min_trans_vel", "max_trans_vel"), ("min_rot_vel", "max_rot_vel")):
        if getattr(params, low) > getattr(params, high):
            where = m.get(low) or m.get(high) or m
            raise where.error(f"{low} {getattr(params, low):g} is above {high} "
                              f"{getattr(params, high):g}")
    if params.max_vel_x < params.min_trans_vel:
        where = m.get("max_vel_x") or m.get("min_trans_vel") or m
        raise where.error(
            f"max_vel_x {params.max_vel_x:g} is below min_trans_vel {params.min_trans_vel:g}: "
            "dwa_local_planner drops every sample slower than min_trans_vel that does not also "
            "turn at min_rot_vel (generateTrajectory), so the robot could never drive straight; "
            "raise max_vel_x or lower min_trans_vel")
    return params


# -- move_base ---------------------------------------------------------------------------------

#: move_base's defaults for what a file does not write: the values move_base.cpp's constructor
#: reads with ``param()``. Not MoveBase.cfg's, which says 5.0 for controller_patience: move_base
#: keeps its first reconfigure callback's values as defaults only (``if (!setup_) ... return``),
#: so 15.0 is what runs.
DEFAULT_CONTROLLER_FREQUENCY = 20.0


@dataclass(frozen=True)
class RecoveryBehavior:
    """One of move_base's ``recovery_behaviors``: its ``name``, its plugin ``type`` and, for a
    ClearCostmapRecovery, the ``reset_distance`` (m): the side of the square around the robot
    whose cells are kept, everything outside cleared."""

    name: str
    type: str
    reset_distance: float = 3.0


#: the recovery plugins servolab runs (ros-planning/navigation clear_costmap_recovery,
#: rotate_recovery)
CLEAR_COSTMAP_RECOVERY = "clear_costmap_recovery/ClearCostmapRecovery"
ROTATE_RECOVERY = "rotate_recovery/RotateRecovery"
RECOVERY_TYPES = (CLEAR_COSTMAP_RECOVERY, ROTATE_RECOVERY)


@dataclass(frozen=True)
class MoveBaseParams:
    """What of move_base's own parameters shapes servolab's loop. Frequencies in Hz, times in s,
    distances in m. The controller frequency matters beyond move_base: DWAPlannerROS takes its
    ``sim_period`` (the time its acceleration limits may act over) as 1 / controller_frequency
    through searchParam, so a DWA file means different motion under a different move_base."""

    controller_frequency: float = DEFAULT_CONTROLLER_FREQUENCY
    #: 0 plans only when a goal arrives (or the controller gives up)
    planner_frequency: float = 0.0
    #: 0 never checks for oscillation
    oscillation_timeout: float = 0.0
    oscillation_distance: float = 0.5
    controller_patience: float = 15.0
    planner_patience: float = 5.0
    #: move_base's recovery parameters, by its names and with its defaults
    recovery_behavior_enabled: bool = True
    clearing_rotation_allowed: bool = True
    conservative_reset_dist: float = 3.0
    #: ``recovery_behaviors`` as the file lists them; None: move_base's default four
    recovery_behaviors: tuple[RecoveryBehavior, ...] | None = None
    path: str = field(default="", compare=False)
    ignored: tuple[str, ...] = field(default=(), compare=False)
    notes: tuple[str, ...] = field(default=(), compare=False)

    def behaviors(self, circumscribed_radius: float) -> tuple[RecoveryBehavior, ...]:
        """The recovery behaviours move_base runs, in order: the file's list, or
        ``loadDefaultRecoveryBehaviors``'s: conservative_reset (clear the costmap beyond
        ``conservative_reset_dist``), rotate_recovery (if ``clearing_rotation_allowed``),
        aggressive_reset (clear beyond 4 x the circumscribed radius), rotate_recovery again.
        None at all when ``recovery_behavior_enabled`` is false."""
        if not self.recovery_behavior_enabled:
            return ()
        if self.recovery_behaviors is not None:
            return self.recovery_behaviors
        rotate = (RecoveryBehavior("rotate_recovery", ROTATE_RECOVERY),) \
            if self.clearing_rotation_allowed else ()
        return (RecoveryBehavior("conservative_reset", CLEAR_COSTMAP_RECOVERY,
                                 self.conservative_reset_dist), *rotate,
                RecoveryBehavior("aggressive_reset", CLEAR_COSTMAP_RECOVERY,
                                 4.0 * circumscribed_radius), *rotate)

    @property
    def sim_period(self) -> float:
        """The control period DWA plans one acceleration step over, s."""
        return 1.0 / self.controller_frequency


_MOVE_BASE_FIELDS: dict[str, _Reader] = {
    "controller_frequency": positive_float,
    "planner_frequency": nonnegative_float,
    "oscillation_timeout": nonnegative_float,
    "oscillation_distance": nonnegative_float,
    "controller_patience": nonnegative_float,
    "planner_patience": nonnegative_float,
    "recovery_behavior_enabled": lambda v: v.as_bool(),
    "clearing_rotation_allowed": lambda v: v.as_bool(),
    "conservative_reset_dist": nonnegative_float,
}


def load_move_base(path: str | Path) -> MoveBaseParams:
    """Read move_base's parameter file (turtlebot's ``move_base_params.yaml``); planner plugin
    names, recovery behaviours and the like are listed in ``ignored``: servolab's loop has one
    global and one local planner of its own."""
    top, notes = _load(path, "move_base parameter file")
    return parse_move_base(top, str(path), notes)


def parse_move_base(top: ConfigValue, path: str = "",
                    notes: tuple[str, ...] = ()) -> MoveBaseParams:
    """The move_base parameters of an already composed file."""
    m = _top_mapping(top, "a move_base parameter file")
    values: dict[str, object] = {}
    ignored: list[str] = []
    listed = m.get("recovery_behaviors")
    behaviors = None if listed is None else _recovery_behaviors(m, listed)
    named = set() if behaviors is None else {b.name for b in behaviors}
    for name, value in m.items():
        if name in _MOVE_BASE_FIELDS:
            values[name] = _MOVE_BASE_FIELDS[name](value)
        elif name not in named and name != "recovery_behaviors":
            ignored.append(value.key)
    if behaviors is not None:
        values["recovery_behaviors"] = behaviors
    _check_some_known(m, len(values) + sum(name.startswith("base_") for name in m),
                      "move_base's parameters")
    return MoveBaseParams(**values, path=path, ignored=tuple(ignored),  # type: ignore[arg-type]
                          notes=notes)


#: the parameters each recovery plugin reads in its own namespace (clear_costmap_recovery.cpp,
#: rotate_recovery.cpp); servolab uses reset_distance, the others are accepted as ROS's
_RECOVERY_KEYS = {
    CLEAR_COSTMAP_RECOVERY: frozenset({"reset_distance", "layer_names", "force_updating",
                                       "affected_maps", "invert_area_to_clear"}),
    ROTATE_RECOVERY: frozenset({"frequency", "sim_granularity"}),
}


def _recovery_behaviors(m: ConfigMapping, listed: ConfigValue) -> tuple[RecoveryBehavior, ...]:
    """``recovery_behaviors: [{name: N, type: T}, ...]`` with each one's parameters under its
    name (``N: {reset_distance: 3.0}``), as move_base's loadRecoveryBehaviors reads them."""
    behaviors: list[RecoveryBehavior] = []
    for item in listed.as_list("a list of {name, type}"):
        entry = item.as_mapping("a recovery behaviour {name, type}")
        entry.check_keys(("name", "type"), required=("name", "type"),
                         what="a recovery behaviour")
        name_value, type_value = entry.require("name"), entry.require("type")
        name, kind = name_value.as_str(nonempty=True), type_value.as_str(nonempty=True)
        if kind not in RECOVERY_TYPES:
            raise type_value.error(f"recovery type {kind!r} is not one servolab runs "
                                   f"({', '.join(RECOVERY_TYPES)})")
        if any(b.name == name for b in behaviors):
            raise name_value.error(f"recovery behaviour {name!r} is listed twice; move_base "
                                   "refuses duplicate names")
        # read and kept, though a map the camera redraws every frame makes it moot
        # (servolab.robots.navigation.recovery)
        reset_distance = 3.0
        own = m.get(name)
        if own is not None:
            known = _RECOVERY_KEYS[kind]
            for key, value in own.as_mapping(f"{name}'s parameters").items():
                if key == "reset_distance" and kind == CLEAR_COSTMAP_RECOVERY:
                    reset_distance = nonnegative_float(value)
                elif key not in known:
                    raise value.error(f"{name}: {key!r} is not a parameter of {kind} "
                                      f"({', '.join(sorted(known))})")
        behaviors.append(RecoveryBehavior(name, kind, reset_distance))
    return tuple(behaviors)


# -- shared ------------------------------------------------------------------------------------


def _check_some_known(m: ConfigMapping, known: int, what: str) -> None:
    """A file of the wrong kind (a scene where DWA's parameters were meant) would otherwise
    run on defaults with every key "ignored": refuse a file that sets none of ours."""
    if known == 0 and len(m):
        first = ", ".join(list(m)[:4])
        raise m.error(f"none of {what} is in this file (its keys: {first}); is it the "
                      "right file?")


def _top_mapping(top: ConfigValue, what: str) -> ConfigMapping:
    if top.plain() is None:
        raise top.error(f"empty file: expected {what}")
    return top.as_mapping(what)


def _count(value: ConfigValue) -> int:
    number = value.as_int()
    if number < 1:
        raise value.error(f"key {value.key!r}: must be at least 1, not {number}")
    return number


def _load(path: str | Path, what: str) -> tuple[ConfigValue, tuple[str, ...]]:
    """Compose the file through servolab.configfile, reading a key written twice with the same
    value once (and noting it); every other error is configfile's."""
    try:  # no larger than any YAML file (servolab.limits): refused unread, as configfile does
        data = read_limited(path, "yaml_mb", what, lambda m: NavParamsError(path, 0, "", m))
        text = data.decode("utf-8-sig")
    except (OSError, UnicodeDecodeError):
        return load_config(path, what=what, error=NavParamsError), ()  # its error
    text, notes = _drop_equal_duplicates(text)
    return load_text(text, str(path), error=NavParamsError), notes


def _drop_equal_duplicates(text: str) -> tuple[str, tuple[str, ...]]:
    """Blank the repeats of keys written again with the same scalar value (lines kept, so
    every line number stays the file's)."""
    try:
        root = yaml.compose(text, Loader=yaml.SafeLoader)
    except (yaml.YAMLError, RecursionError):
        return text, ()  # configfile says what is wrong
    if root is None:
        return text, ()
    spans: list[tuple[int, int]] = []
    notes: list[str] = []

    def walk(node: yaml.Node, key: str, depth: int) -> None:
        if depth > 100:
            return
        if isinstance(node, yaml.SequenceNode):
            for index, item in enumerate(node.value):
                walk(item, f"{key}[{index}]", depth + 1)
        elif isinstance(node, yaml.MappingNode):
            seen: dict[str, tuple[yaml.Node, yaml.Node]] = {}
            for key_node, value_node in node.value:
                name = str(key_node.value) if isinstance(key_node, yaml.ScalarNode) else ""
                child = f"{key}.{name}" if key else name
                first = seen.get(name)
                if (first is not None and isinstance(value_node, yaml.ScalarNode)
                        and isinstance(first[1], yaml.ScalarNode)
                        and (first[1].tag, first[1].value) == (value_node.tag, value_node.value)
                        and key_node.start_mark.line == value_node.end_mark.line):
                    spans.append((key_node.start_mark.index, value_node.end_mark.index))
                    notes.append(f"key {child!r} is written twice with the same value "
                                 f"(lines {first[0].start_mark.line + 1} and "
                                 f"{key_node.start_mark.line + 1}): read once")
                    continue
                if first is None:
                    seen[name] = (key_node, value_node)
                walk(value_node, child, depth + 1)

    walk(root, "", 0)
    for start, end in sorted(spans, reverse=True):
        text = text[:start] + " " * (end - start) + text[end:]
    return text, tuple(notes)


@dataclass(frozen=True)
class Planning:
    """The three parameter files a navigation runs on, read and checked together: the
    costmap, DWA with move_base's ``controller_frequency`` as its period (DWAPlanner finds it
    by ``searchParam``), move_base, and a line for each file naming the keys servolab does
    not use."""

    costmap: CostmapParams
    dwa: DwaConfig
    move_base: MoveBaseParams
    ignored: tuple[str, ...]


def load_planning(costmap: str | Path | None = None, dwa: str | Path | None = None,
                  move_base: str | Path | None = None) -> Planning:
    """The costmap, DWA and move_base files (None: seed 000's and turtlebot's, shipped)."""
    from dataclasses import replace

    costmap_params = load_costmap(costmap or DEFAULT_COSTMAP)
    dwa_params = load_dwa(dwa or DEFAULT_DWA)
    move_base_params = load_move_base(move_base or DEFAULT_MOVE_BASE)
    ignored = tuple(f"{loaded.path}: not used by servolab: {', '.join(loaded.ignored)}"
                    for loaded in (costmap_params, dwa_params, move_base_params)
                    if loaded.ignored)
    dwa_config = replace(DwaConfig.from_params(dwa_params),
                         controller_frequency=move_base_params.controller_frequency)
    return Planning(costmap_params, dwa_config, move_base_params, ignored)


def load_nav_scene(path: str | Path | None = None) -> Scene:
    """The simulated world ``servolab navigate`` drives in: the file at ``path`` (default
    :data:`servolab.sim.scene.DEFAULT_SCENE`), its robot's ``base`` looked for beside it,
    then among the shipped bases."""
    from ...sim.scene import DEFAULT_SCENE, load_scene
    from ..base.config import SHIPPED_DIR

    return load_scene(path or DEFAULT_SCENE, base_search=[SHIPPED_DIR])
