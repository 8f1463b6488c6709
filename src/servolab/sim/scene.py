"""The synthetic world ``servolab navigate`` drives in: a floor seen by an overhead camera,
obstacles (some appearing mid-run) and the robot's start, read from one YAML file
(``nav_scene.yaml`` beside this module; metres, radians, seconds).

Why a scene file: the navigation loop is tested against known truth, as the calibration is
(:mod:`servolab.vision.synthetic`). The camera written here is the truth a calibration must
recover, the obstacles the truth the costmap must find, and an obstacle with ``appear_at`` is
the one the seed's loop must notice and replan around. The renderer works in millimetres, as
OpenCV's calibration does; this module converts (:meth:`Scene.floor_scene`,
:meth:`SceneCamera.floor_pose`).

Everything that would make a run meaningless is refused when the file is read, at the line of
the key at fault, as a :class:`NavSceneError`: a camera that cannot see the whole floor (plus
:data:`VIEW_MARGIN`), a robot starting in an obstacle or off the floor, a missing base file.

A scene may also take its static obstacles from a ROS map_server map (``map: office.yaml``,
relative to the scene file; read by :func:`servolab.vision.map_file.load_map`), so that a
user's map can be driven on in simulation: its origin and resolution place it in the floor
frame, and its solid cells (:class:`MapObstacle`) are walls the clearance and the camera see.
A mistake inside the map file is that file's own one-line error (a
:class:`~servolab.vision.map_file.MapFileError` at its ``file:line``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, TypeAlias

import cv2
import numpy as np
import numpy.typing as npt

from ..configfile import (
    ConfigMapping,
    ConfigValue,
    nonnegative_float,
    positive_float,
    shipped,
)
from ..configfile import load as load_config
from ..errors import ConfigFileError
from ..vision.errors import VisionValueError
from ..vision.map_file import OccupancyMap, load_map
from ..vision.synthetic import Circle, FloatArray, FloorScene, PinholeCamera, RobotMarker
from .errors import SimulationError

#: how thick the arena's walls are (m), drawn just outside the floor
WALL_THICKNESS = 0.1


class NavSceneError(ConfigFileError, SimulationError):
    """A navigation scene file that cannot be used."""


#: How far beyond the floor the camera must see, m: a robot at the edge still shows whole.
VIEW_MARGIN = 0.25
#: Spacing of the points checked along the margin's edges, m (distortion bends them).
_VIEW_STEP = 0.05


@dataclass(frozen=True)
class SceneCamera:
    """The synthetic overhead camera: intrinsics in pixels, position in m in the floor frame
    (z up), ``noise_std`` in grey levels, ``rate`` in frames per second."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    distortion: tuple[float, float, float, float, float]
    position: tuple[float, float, float]
    look_at: tuple[float, float]
    noise_std: float = 0.0
    rate: float = 10.0

    def pinhole(self) -> PinholeCamera:
        return PinholeCamera(self.fx, self.fy, self.cx, self.cy, self.width, self.height,
                             self.distortion)

    def rotation(self) -> FloatArray:
        """Floor frame to camera frame: z along the optical axis towards ``look_at``, image
        'up' along the floor's +y as nearly as the tilt allows, so that a student sees the
        floor as drawn on paper (x right, y up). Straight down this is diag(1, -1, -1)."""
        centre = np.array(self.position, dtype=np.float64)
        target = np.array([*self.look_at, 0.0])
        z = target - centre
        z /= np.linalg.norm(z)
        down = np.array([0.0, -1.0, 0.0]) - z * (-z[1])  # image down: floor -y, across z
        norm = float(np.linalg.norm(down))
        if norm < 1e-9:
            raise SimulationError("the camera looks along the floor's y axis: no image 'up'")
        y = down / norm
        x = np.cross(y, z)
        return np.stack([x, y, z])

    def floor_pose(self) -> tuple[FloatArray, FloatArray]:
        """``(rvec, tvec)`` in mm, floor frame to camera frame, as
        :func:`~servolab.vision.synthetic.render_floor` takes it."""
        rotation = self.rotation()
        rvec, _ = cv2.Rodrigues(rotation)
        tvec = -rotation @ (np.array(self.position, dtype=np.float64) * 1000.0)
        return np.asarray(rvec, dtype=np.float64).reshape(3), tvec


@dataclass(frozen=True)
class CircleObstacle:
    """A round obstacle: centre and radius, m; ``appear_at`` s after the start, or None for
    there from the start."""

    x: float
    y: float
    radius: float
    appear_at: float | None = None

    def clearance(self, x: float, y: float) -> float:
        return math.hypot(x - self.x, y - self.y) - self.radius


@dataclass(frozen=True)
class BoxObstacle:
    """An axis-aligned box: ``(x, y)`` its corner nearest the origin, ``width`` along x,
    ``depth`` along y, m."""

    x: float
    y: float
    width: float
    depth: float
    appear_at: float | None = None

    def clearance(self, x: float, y: float) -> float:
        x1, y1 = self.x + self.width, self.y + self.depth
        dx = max(self.x - x, 0.0, x - x1)
        dy = max(self.y - y, 0.0, y - y1)
        if dx > 0 or dy > 0:
            return math.hypot(dx, dy)
        return -min(x - self.x, x1 - x, y - self.y, y1 - y)

    def corners(self) -> FloatArray:
        x1, y1 = self.x + self.width, self.y + self.depth
        return np.array([[self.x, self.y], [x1, self.y], [x1, y1], [self.x, y1]])


@dataclass(frozen=True, eq=False)
class MapObstacle:
    """The solid cells of a map_server map as one static obstacle.

    A cell is solid when costmap_2d's static layer would make it lethal (100) **or** leave it
    unknown (-1): a world must decide what is there, and a place the map does not know is no
    floor to drive onto (the planner does not enter it either). The cells are squares of
    ``resolution`` m, cell ``(col, row)`` covering ``x`` from ``origin[0] + col * resolution``;
    row 0 at the origin's y (the map frame, as
    :class:`~servolab.vision.map_file.OccupancyMap` has it)."""

    solid: npt.NDArray[np.bool_]
    resolution: float
    origin: tuple[float, float]
    path: str = ""
    appear_at: None = None

    @classmethod
    def of(cls, occupancy_map: OccupancyMap) -> MapObstacle:
        lethal, unknown = occupancy_map.lethal_and_unknown()
        return cls(lethal | unknown, occupancy_map.resolution, occupancy_map.xy,
                   occupancy_map.path)

    @cached_property
    def _trees(self) -> tuple[Any, Any]:
        """KD-trees of the solid cells' centres and of the others' (with a ring of free cells
        round the map: off the map is floor), built once, for :meth:`clearance`."""
        from scipy.spatial import cKDTree  # type: ignore[import-untyped]

        padded = np.pad(self.solid, 1, constant_values=False)
        rows, cols = np.indices(padded.shape)
        centres = np.column_stack([
            self.origin[0] + (cols.ravel() - 1 + 0.5) * self.resolution,
            self.origin[1] + (rows.ravel() - 1 + 0.5) * self.resolution])
        solid = padded.ravel()
        return (cKDTree(centres[solid]) if solid.any() else None,
                cKDTree(centres[~solid]))

    def clearance(self, x: float, y: float) -> float:
        """Distance, m, from ``(x, y)`` to the nearest solid cell (a square), exact; inside
        one, minus the distance to the nearest cell that is not solid (or the map's edge)."""
        solid_tree, free_tree = self._trees
        if solid_tree is None:
            return math.inf
        outside = _nearest_square(free_tree, x, y, self.resolution)
        inside = _nearest_square(solid_tree, x, y, self.resolution)
        return inside if inside > 0 else -outside

    def rectangles(self) -> tuple[tuple[float, float, float, float], ...]:
        """The solid cells as few axis-aligned rectangles ``(x, y, width, depth)`` m: runs along
        each row, a run stacked onto the same run of the row below. Drawn as polygons, cells
        one by one would cost the renderer thousands of polygons a frame."""
        return _rectangles(self.solid, self.resolution, self.origin)


def _nearest_square(tree: Any, x: float, y: float, resolution: float) -> float:
    """The distance from ``(x, y)`` to the nearest of the squares centred on ``tree``'s
    points: the nearest centre is at most half a diagonal further than the nearest square,
    so the squares within that of it are all that can be nearest."""
    half = resolution / 2
    nearest, _ = tree.query((x, y))
    candidates = tree.data[tree.query_ball_point((x, y), nearest + half * math.sqrt(2.0)
                                                 + 1e-12)]
    dx = np.maximum(np.abs(candidates[:, 0] - x) - half, 0.0)
    dy = np.maximum(np.abs(candidates[:, 1] - y) - half, 0.0)
    return float(np.min(np.hypot(dx, dy)))


def _rectangles(solid: npt.NDArray[np.bool_], resolution: float, origin: tuple[float, float],
                ) -> tuple[tuple[float, float, float, float], ...]:
    done: list[tuple[int, int, int, int]] = []  # (col0, row0, col1, row1), ends exclusive
    open_runs: dict[tuple[int, int], int] = {}  # (col0, col1) -> row0 of the run still growing
    for row in range(solid.shape[0] + 1):
        runs: set[tuple[int, int]] = set()
        if row < solid.shape[0]:
            line = np.concatenate([[False], solid[row], [False]]).astype(np.int8)
            edges = np.flatnonzero(np.diff(line))
            runs = {(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)}
        for run in [r for r in open_runs if r not in runs]:
            done.append((run[0], open_runs.pop(run), run[1], row))
        for run in runs:
            open_runs.setdefault(run, row)
    x0, y0 = origin
    return tuple((x0 + c0 * resolution, y0 + r0 * resolution, (c1 - c0) * resolution,
                  (r1 - r0) * resolution) for c0, r0, c1, r1 in sorted(done))


Obstacle: TypeAlias = CircleObstacle | BoxObstacle
#: what :meth:`Scene.obstacles_at` gives: the listed obstacles, the walls and the map
Present: TypeAlias = CircleObstacle | BoxObstacle | MapObstacle


@dataclass(frozen=True)
class Scene:
    """A navigation scene: the floor ``[0, width] x [0, depth]`` m, its camera, the robot's
    base configuration file and start ``(x, y, yaw)``, and the obstacles."""

    width: float
    depth: float
    camera: SceneCamera
    base: Path
    start: tuple[float, float, float]
    robot_radius: float
    obstacles: tuple[Obstacle, ...] = ()
    path: str = field(default="", compare=False)
    #: the arena's walls, :data:`WALL_THICKNESS` thick just outside the floor's edges (a robot
    #: on an open floor could leave the camera's view; a real arena has a border)
    walls: bool = True
    #: the static obstacles of the scene's ``map:`` file, if it names one
    static_map: MapObstacle | None = field(default=None, compare=False)

    @cached_property
    def _map_polygons(self) -> tuple[FloatArray, ...]:
        """The map's solid cells as the renderer's polygons (mm), made once."""
        if self.static_map is None:
            return ()
        return tuple(np.array([[x, y], [x + w, y], [x + w, y + d], [x, y + d]]) * 1000.0
                     for x, y, w, d in self.static_map.rectangles())

    def wall_boxes(self) -> tuple[BoxObstacle, ...]:
        """The four walls, if the floor has them."""
        if not self.walls:
            return ()
        w, d, t = self.width, self.depth, WALL_THICKNESS
        return (BoxObstacle(-t, -t, w + 2 * t, t), BoxObstacle(-t, d, w + 2 * t, t),
                BoxObstacle(-t, 0.0, t, d), BoxObstacle(w, 0.0, t, d))

    def obstacles_at(self, t: float) -> tuple[Present, ...]:
        """The obstacles present ``t`` s after the start, the walls and the map included."""
        fixed: tuple[Present, ...] = self.wall_boxes()
        if self.static_map is not None:
            fixed += (self.static_map,)
        return fixed + tuple(
            o for o in self.obstacles if o.appear_at is None or o.appear_at <= t)

    def clearance(self, x: float, y: float, t: float) -> float:
        """Distance, m, from ``(x, y)`` to the nearest obstacle present at ``t`` (negative
        inside one, infinite when none is present)."""
        return min((o.clearance(x, y) for o in self.obstacles_at(t)), default=math.inf)

    def floor_scene(self, t: float,
                    robot: tuple[float, float, float] | None = None) -> FloorScene:
        """What the camera sees at ``t`` with the robot at ``(x, y, yaw)`` (m, rad), in the
        renderer's mm."""
        present = self.obstacles_at(t)
        circles = tuple(Circle(o.x * 1000.0, o.y * 1000.0, o.radius * 1000.0)
                        for o in present if isinstance(o, CircleObstacle))
        polygons = tuple(o.corners() * 1000.0 for o in present if isinstance(o, BoxObstacle))
        polygons += self._map_polygons
        marker = None
        if robot is not None:
            marker = RobotMarker(robot[0] * 1000.0, robot[1] * 1000.0, robot[2],
                                 self.robot_radius * 1000.0)
        return FloorScene(polygons=polygons, circles=circles, robot=marker)


# -- loading -----------------------------------------------------------------------------------


#: the scene ``servolab navigate`` drives in by default, installed with this package
DEFAULT_SCENE = shipped(__package__ or "servolab.sim", "nav_scene.yaml")


def load_scene(path: str | Path, base_search: Sequence[Path] = ()) -> Scene:
    """Read and check a scene file (see the module docstring). The robot's ``base`` file is
    looked for beside the scene, then in each of ``base_search`` (the robots layer passes the
    folder of its shipped bases: this world does not know the robots)."""
    top = load_config(path, what="navigation scene file", error=NavSceneError)
    if top.plain() is None:
        raise top.error("empty file: expected a navigation scene")
    m = top.as_mapping("a navigation scene file")
    m.check_keys(("floor", "camera", "robot", "obstacles", "map"),
                 required=("floor", "camera", "robot"))
    floor = m.require("floor").as_mapping()
    floor.check_keys(("width", "depth", "walls"), required=("width", "depth"))
    width = positive_float(floor.require("width"))
    depth = positive_float(floor.require("depth"))
    walls = walls_value.as_bool() if (walls_value := floor.get("walls")) is not None else True
    camera_map = m.require("camera").as_mapping()
    camera = _camera(camera_map)
    _check_view(camera, camera_map, width, depth)

    obstacles: list[Obstacle] = []
    listed = m.get("obstacles")
    if listed is not None and listed.plain() is not None:
        for item in listed.as_list():
            obstacles.append(_obstacle(item, width, depth))

    robot = m.require("robot").as_mapping()
    robot.check_keys(("base", "x", "y", "yaw", "radius"), required=("base", "x", "y", "radius"))
    base = _base_file(robot.require("base"), [Path(path).parent, *base_search])
    x_value, y_value = robot.require("x"), robot.require("y")
    start_x, start_y = x_value.as_float(), y_value.as_float()
    for value, number, size in ((x_value, start_x, width), (y_value, start_y, depth)):
        if not 0.0 <= number <= size:
            raise value.error(f"key {value.key!r}: the robot starts off the floor "
                              f"({number:g} m is outside [0, {size:g}] m)")
    yaw = yaw_value.as_float() if (yaw_value := robot.get("yaw")) is not None else 0.0
    radius = positive_float(robot.require("radius"))
    static_map = None
    if (map_value := m.get("map")) is not None:
        static_map = MapObstacle.of(load_map(_beside(map_value, Path(path).parent, "map")))
    scene = Scene(width, depth, camera, base, (start_x, start_y, yaw), radius,
                  tuple(obstacles), str(path), walls, static_map)
    named: list[tuple[str, Present]] = [(f"obstacles[{i}]", o)
                                         for i, o in enumerate(scene.obstacles)]
    named += [("the floor's wall", o) for o in scene.wall_boxes()]
    if static_map is not None:
        named.append((f"a solid cell of the map {static_map.path}", static_map))
    for name, obstacle in named:
        clearance = obstacle.clearance(start_x, start_y)
        if obstacle in scene.obstacles_at(0.0) and clearance <= radius:
            raise x_value.error(
                f"key {x_value.key!r}: the robot's start ({start_x:g}, {start_y:g}) is "
                f"{clearance:.3g} m from {name} (present at t=0), not more than "
                f"the robot's radius {radius:g} m")
    return scene


def _numbers(value: ConfigValue, count: int, what: str) -> tuple[float, ...]:
    items = value.as_list()
    if len(items) != count:
        raise value.error(f"key {value.key!r}: must be {count} numbers ({what}), "
                          f"not {len(items)}")
    return tuple(item.as_float() for item in items)


_CAMERA_KEYS = ("width", "height", "fx", "fy", "cx", "cy", "distortion", "position",
                "look_at", "noise_std", "rate")


def _camera(m: ConfigMapping) -> SceneCamera:
    m.check_keys(_CAMERA_KEYS, required=("width", "height", "fx", "fy", "cx", "cy",
                                         "position", "look_at"))
    sizes = []
    for name in ("width", "height"):
        value = m.require(name)
        pixels = value.as_int()
        if pixels <= 0:
            raise value.error(f"key {value.key!r}: must be > 0, not {pixels}")
        sizes.append(pixels)
    fx, fy = positive_float(m.require("fx")), positive_float(m.require("fy"))
    cx, cy = m.require("cx").as_float(), m.require("cy").as_float()
    distortion = (0.0, 0.0, 0.0, 0.0, 0.0)
    if (written := m.get("distortion")) is not None:
        k1, k2, p1, p2, k3 = _numbers(written, 5, "k1, k2, p1, p2, k3")
        distortion = (k1, k2, p1, p2, k3)
    position_value = m.require("position")
    px, py, pz = _numbers(position_value, 3, "x, y, z in m")
    if pz <= 0:
        raise position_value.error(f"key {position_value.key!r}: the camera must be above "
                                   f"the floor (z > 0), not z = {pz:g}")
    look_value = m.require("look_at")
    lx, ly = _numbers(look_value, 2, "x, y in m on the floor")
    if math.hypot(lx - px, ly - py) >= pz:
        raise look_value.error(f"key {look_value.key!r}: the camera must look down, more "
                               f"than 45 degrees below the horizon")
    noise = nonnegative_float(v) if (v := m.get("noise_std")) is not None else 0.0
    rate = positive_float(v) if (v := m.get("rate")) is not None else 10.0
    return SceneCamera(sizes[0], sizes[1], fx, fy, cx, cy, distortion, (px, py, pz),
                       (lx, ly), noise, rate)


def _check_view(camera: SceneCamera, m: ConfigMapping, width: float, depth: float) -> None:
    """Refuse a camera that does not see the floor plus :data:`VIEW_MARGIN` whole, naming the
    margin corner nearest the first point that falls outside the image."""
    lo_x, lo_y = -VIEW_MARGIN, -VIEW_MARGIN
    hi_x, hi_y = width + VIEW_MARGIN, depth + VIEW_MARGIN
    corners = np.array([[lo_x, lo_y], [hi_x, lo_y], [hi_x, hi_y], [lo_x, hi_y]])
    points: list[FloatArray] = []
    for a, b in zip(corners, np.roll(corners, -1, axis=0), strict=True):
        k = max(1, math.ceil(float(np.hypot(*(b - a))) / _VIEW_STEP))
        points.append(a + (b - a) * (np.arange(k)[:, None] / k))
    xy = np.vstack(points)
    rvec, tvec = camera.floor_pose()
    pinhole = camera.pinhole()
    where = m.require("position")
    try:
        uv = pinhole.project(np.column_stack([xy * 1000.0, np.zeros(len(xy))]), rvec, tvec)
    except VisionValueError:
        raise where.error("the camera does not see the floor: part of it is behind the "
                          "camera") from None
    outside = ((uv[:, 0] < 0) | (uv[:, 0] > camera.width - 1)
               | (uv[:, 1] < 0) | (uv[:, 1] > camera.height - 1))
    if outside.any():
        # the worst point: the one furthest outside the image
        over = np.maximum.reduce([-uv[:, 0], uv[:, 0] - (camera.width - 1),
                                  -uv[:, 1], uv[:, 1] - (camera.height - 1)])
        worst = int(np.argmax(over))
        corner = corners[int(np.argmin(np.hypot(*(corners - xy[worst]).T)))]
        raise where.error(
            f"the camera does not see the floor plus its {VIEW_MARGIN:g} m margin: near the "
            f"corner ({corner[0]:g}, {corner[1]:g}) m the point ({xy[worst][0]:.2f}, "
            f"{xy[worst][1]:.2f}) m falls at ({uv[worst][0]:.0f}, {uv[worst][1]:.0f}) px, "
            f"outside the {camera.width}x{camera.height} image (raise the camera or lower "
            "fx, fy)")


def _appear_at(m: ConfigMapping) -> float | None:
    value = m.get("appear_at")
    return nonnegative_float(value) if value is not None else None


def _obstacle(item: ConfigValue, width: float, depth: float) -> Obstacle:
    m = item.as_mapping()
    m.check_keys(("circle", "box", "appear_at"))
    shapes = [name for name in ("circle", "box") if name in m]
    if len(shapes) != 1:
        raise m.error(f"key {m.key!r}: an obstacle is one 'circle' or one 'box', "
                      f"not {len(shapes)}")
    shape = m.require(shapes[0]).as_mapping()
    appear = _appear_at(m)
    obstacle: Obstacle
    if shapes[0] == "circle":
        shape.check_keys(("x", "y", "radius"), required=("x", "y", "radius"))
        obstacle = CircleObstacle(shape.require("x").as_float(), shape.require("y").as_float(),
                                  positive_float(shape.require("radius")), appear)
        what = "centre"
    else:
        shape.check_keys(("x", "y", "width", "depth"), required=("x", "y", "width", "depth"))
        obstacle = BoxObstacle(shape.require("x").as_float(), shape.require("y").as_float(),
                               positive_float(shape.require("width")),
                               positive_float(shape.require("depth")), appear)
        what = "corner"
    for name, number, size in (("x", obstacle.x, width), ("y", obstacle.y, depth)):
        if not 0.0 <= number <= size:
            value = shape.require(name)
            raise value.error(f"key {value.key!r}: the obstacle's {what} is off the floor "
                              f"({number:g} m is outside [0, {size:g}] m)")
    return obstacle


def _beside(value: ConfigValue, directory: Path, what: str) -> Path:
    """A file the scene names, relative to the scene's folder unless absolute."""
    name = value.as_str(nonempty=True)
    given = Path(name)
    found = given if given.is_absolute() else directory / given
    if not found.is_file():
        raise value.error(f"key {value.key!r}: {what} file {name!r} not found (looked for "
                          f"{found})")
    return found


def _base_file(value: ConfigValue, directories: Sequence[Path]) -> Path:
    """The robot's base file: the first of ``directories`` that holds it."""
    name = value.as_str(nonempty=True)
    given = Path(name)
    candidates = [given] if given.is_absolute() else [d / given for d in directories]
    for candidate in candidates:
        if candidate.is_file():
            return candidate
    looked = " or ".join(str(c) for c in candidates)
    raise value.error(f"key {value.key!r}: base file {name!r} not found (looked for {looked})")
