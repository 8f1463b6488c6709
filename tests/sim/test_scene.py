"""The navigation scene file: the shipped scene, the camera's pose convention, obstacles in time,
clearance, and every bad input refused at its line."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from servolab.errors import ConfigFileError
from servolab.robots.base.config import SHIPPED_DIR
from servolab.sim.scene import (
    DEFAULT_SCENE,
    BoxObstacle,
    CircleObstacle,
    NavSceneError,
    load_scene,
)

ROOT = Path(__file__).resolve().parents[2]
#: the loader's checks are tested on a small scene of the tests' own
SCENE = ROOT / "tests" / "data" / "nav_scene_small.yaml"
SHIPPED = DEFAULT_SCENE
BASES = [SHIPPED_DIR]  # the scene's base among the shipped bases, as servolab navigate looks


def _line_of(path: Path, text: str) -> int:
    for number, line in enumerate(path.read_text().splitlines(), 1):
        if text in line and not line.lstrip().startswith("#"):
            return number
    raise AssertionError(f"{text!r} not in {path}")


def test_shipped_scene_loads_with_its_values() -> None:
    s = load_scene(SHIPPED, BASES)
    assert (s.width, s.depth, s.start, s.robot_radius) == (4.0, 3.0, (0.6, 0.6, 0.0), 0.18)
    assert (s.camera.position, s.camera.look_at) == ((1.95, 1.45, 3.2), (2.0, 1.5))
    assert s.base == SHIPPED_DIR / "base_seed000.yaml"
    assert s.obstacles == (CircleObstacle(2.0, 1.4, 0.3), BoxObstacle(1.0, 2.1, 0.4, 0.9),
                           CircleObstacle(2.75, 1.8, 0.15, 6.0))


def test_the_test_scene_loads_with_its_values() -> None:
    s = load_scene(SCENE, BASES)
    assert (s.width, s.depth, s.start, s.robot_radius) == (3.0, 2.0, (0.4, 0.4, 0.0), 0.18)
    c = s.camera
    assert (c.width, c.height, c.fx, c.fy, c.cx, c.cy) == (640, 480, 420.0, 420.0, 321.0, 238.5)
    assert c.distortion == (-0.1, 0.03, 0.0, 0.0, 0.0)
    assert (c.position, c.look_at, c.noise_std, c.rate) == ((1.45, 0.95, 2.5), (1.5, 1.0),
                                                             2.0, 10.0)
    assert s.base == SHIPPED_DIR / "base_seed000.yaml"
    assert s.obstacles == (CircleObstacle(1.5, 1.0, 0.25), BoxObstacle(0.8, 1.4, 0.3, 0.6),
                           CircleObstacle(2.2, 1.35, 0.12, 4.0))


def test_floor_pose_centres_look_at_and_puts_floor_y_up() -> None:
    camera = replace(load_scene(SCENE, BASES).camera, distortion=(0.0,) * 5)
    rvec, tvec = camera.floor_pose()
    pinhole = camera.pinhole()
    look = np.array([[1500.0, 1000.0, 0.0]])
    uv = pinhole.project(look, rvec, tvec)[0]
    assert abs(uv[0] - camera.cx) < 0.01 and abs(uv[1] - camera.cy) < 0.01
    ahead = pinhole.project(np.array([[1500.0, 1500.0, 0.0], [2000.0, 1000.0, 0.0]]), rvec, tvec)
    assert ahead[0, 1] < uv[1] - 50 and abs(ahead[0, 0] - uv[0]) < 5   # +y: image top
    assert ahead[1, 0] > uv[0] + 50 and abs(ahead[1, 1] - uv[1]) < 5   # +x: image right
    straight = replace(camera, position=(1.5, 1.0, 2.0))
    assert np.allclose(straight.rotation(), np.diag([1.0, -1.0, -1.0]))
    assert np.allclose(straight.floor_pose()[1], [-1500.0, 1000.0, 2000.0])


def test_obstacles_appear_at_their_time() -> None:
    s = load_scene(SCENE, BASES)
    walls = s.wall_boxes()
    assert len(walls) == 4
    assert s.obstacles_at(0.0) == walls + s.obstacles[:2]
    assert s.obstacles_at(3.99) == walls + s.obstacles[:2]
    assert s.obstacles_at(4.0) == walls + s.obstacles
    floor = s.floor_scene(5.0, (0.4, 0.4, 0.5))
    assert [c.radius for c in floor.circles] == [250.0, 120.0]
    assert np.allclose(floor.polygons[4], [[800, 1400], [1100, 1400], [1100, 2000],
                                           [800, 2000]])
    assert floor.robot is not None and (floor.robot.x, floor.robot.radius) == (400.0, 180.0)
    assert len(s.floor_scene(0.0).circles) == 1 and s.floor_scene(0.0).robot is None


def test_the_walls_border_the_floor_and_can_be_left_out(tmp_path: Path) -> None:
    s = load_scene(SCENE, BASES)
    # just inside the floor's edges, a wall is as far as the point is from the edge
    assert s.clearance(3.0 - 0.05, 1.7, 0.0) == pytest.approx(0.05)
    assert s.clearance(0.7, 0.02, 0.0) == pytest.approx(0.02)
    assert s.clearance(-0.05, 1.7, 0.0) < 0  # inside the wall
    text = SCENE.read_text().replace("floor: {width: 3.0, depth: 2.0}",
                                     "floor: {width: 3.0, depth: 2.0, walls: false}")
    assert "walls: false" in text
    open_floor = tmp_path / "open.yaml"
    open_floor.write_text(text)
    (tmp_path / "base_seed000.yaml").write_text((SHIPPED_DIR / "base_seed000.yaml").read_text())
    assert load_scene(open_floor, BASES).obstacles_at(0.0) == s.obstacles[:2]


def test_clearance_against_hand_computed_values() -> None:
    s = load_scene(SCENE, BASES)
    # circle (1.5, 1.0) r 0.25: from (1.5, 0.6) 0.4 - 0.25 (the wall at y = 0 is 0.6 away);
    # at its centre -0.25
    assert s.clearance(1.5, 0.6, 0.0) == pytest.approx(0.15)
    assert s.clearance(1.5, 1.0, 0.0) == pytest.approx(-0.25)
    # box [0.8, 1.1] x [1.4, 2.0]: from (0.5, 1.0) the corner at (0.3, 0.4) -> 0.5
    box = s.obstacles[1]
    assert box.clearance(0.5, 1.0) == pytest.approx(0.5)
    assert box.clearance(0.95, 1.5) == pytest.approx(-0.1)  # inside, 0.1 from y = 1.4
    assert box.clearance(1.2, 1.7) == pytest.approx(0.1)    # beside its x = 1.1 face
    # the late circle counts only once it is there: (2.2, 1.0) is 0.35 - 0.12 from it
    assert s.clearance(2.2, 1.0, 0.0) == pytest.approx(math.hypot(0.7, 0.0) - 0.25)
    assert s.clearance(2.2, 1.0, 4.0) == pytest.approx(0.23)


@pytest.mark.parametrize(("old", "new", "at", "message"), [
    ("depth: 2.0}", "depht: 2.0}", "floor:",
     "unknown key 'floor.depht' (did you mean 'depth'?)"),
    ("fx: 420.0", "fx: wide", "fx:", "key 'camera.fx': must be a finite number, not 'wide'"),
    ("fx: 420.0", "fx: -420.0", "fx:", "key 'camera.fx': must be > 0, not -420"),
    ("width: 3.0,", "width: 0,", "floor:", "key 'floor.width': must be > 0, not 0"),
    ("radius: 0.25", "radius: 0.0", "radius: 0.0", "key 'obstacles[0].circle.radius': must"),
    ("width: 0.3, depth: 0.6", "width: 0.3, depth: -0.6", "box:",
     "key 'obstacles[1].box.depth': must be > 0, not -0.6"),
    ("x: 2.2", "x: 3.1", "x: 3.1", "key 'obstacles[2].circle.x': the obstacle's centre is off"),
    ("box: {x: 0.8, y: 1.4", "box: {x: 0.8, y: -0.1", "box:",
     "key 'obstacles[1].box.y': the obstacle's corner is off the floor"),
    ("  x: 0.4\n  y: 0.4", "  x: 1.5\n  y: 0.9", "  x: 1.5",
     "key 'robot.x': the robot's start (1.5, 0.9) is -0.15 m from obstacles[0] (present at "
     "t=0), not more than the robot's radius 0.18 m"),
    ("  x: 0.4\n  y: 0.4", "  x: 1.5\n  y: 0.6", "  x: 1.5",
     "key 'robot.x': the robot's start (1.5, 0.6) is 0.15 m from obstacles[0]"),
    ("  y: 0.4", "  y: 2.5", "  y: 2.5", "key 'robot.y': the robot starts off the floor"),
    ("base: base_seed000.yaml", "base: no_such_base.yaml", "base:",
     "key 'robot.base': base file 'no_such_base.yaml' not found"),
    ("fx: 420.0", "fx: 600.0", "position:",
     "the camera does not see the floor plus its 0.25 m margin: near the corner"),
    ("[-0.1, 0.03, 0.0, 0.0, 0.0]", "[-0.1, 0.03, 0.0, 0.0]", "distortion:",
     "key 'camera.distortion': must be 5 numbers (k1, k2, p1, p2, k3), not 4"),
    ("rate: 10.0", "rate: 0", "rate:", "key 'camera.rate': must be > 0, not 0"),
    ("noise_std: 2.0", "noise_sd: 2.0", "noise_sd", "unknown key 'camera.noise_sd'"),
])
def test_bad_input_refused_at_its_line(tmp_path: Path, old: str, new: str, at: str,
                                       message: str) -> None:
    bad = tmp_path / "scene.yaml"
    text = SCENE.read_text()
    assert old in text
    bad.write_text(text.replace(old, new, 1))
    with pytest.raises(NavSceneError) as info:
        load_scene(bad, BASES)
    assert str(info.value).startswith(f"{bad}:{_line_of(bad, at)}: {message}")
    assert "\n" not in str(info.value) and isinstance(info.value, ConfigFileError)


def test_a_start_beside_an_obstacle_that_appears_later_is_allowed(tmp_path: Path) -> None:
    f = tmp_path / "scene.yaml"
    f.write_text(SCENE.read_text().replace("  x: 0.4", "  x: 2.2").replace("  y: 0.4",
                                                                         "  y: 1.2"))
    assert load_scene(f, BASES).start[:2] == (2.2, 1.2)
    (tmp_path / "mybase.yaml").write_text("base: {}\n")
    f.write_text(SCENE.read_text().replace("base_seed000.yaml", "mybase.yaml"))
    assert load_scene(f).base == tmp_path / "mybase.yaml"  # beside the scene file first


# -- a scene whose walls come from a map_server map --------------------------------------------


def _map_scene(tmp_path: Path, start: str = "  x: 0.4\n  y: 0.4") -> Path:
    """The test scene with ``map: walls.yaml`` beside it: 0.1 m cells from the floor's corner,
    an L of occupied cells (x 2.0..2.5 m, y 0.2..0.5 m, then x 2.0..2.2 m up to y 1.0 m) and
    one unknown cell (x 0.5..0.6 m, y 1.5..1.6 m), written by map_saver's rules."""
    from servolab.vision.map_file import save_map

    grid = np.zeros((20, 30), np.int8)  # [row, col], row 0 at y = 0
    grid[2:5, 20:25] = 100
    grid[5:10, 20:22] = 100
    grid[15, 5] = -1
    save_map(tmp_path / "walls", grid, 0.1, (0.0, 0.0))
    text = SCENE.read_text().replace("  x: 0.4\n  y: 0.4", start)
    scene = tmp_path / "scene.yaml"
    scene.write_text(text + "map: walls.yaml\n")
    return scene


def test_a_map_files_solid_cells_are_obstacles(tmp_path: Path) -> None:
    """The map's occupied cells (and unknown ones: no floor to drive onto) are squares the
    clearance measures exactly and the camera sees dark; few rectangles draw them."""
    from servolab.vision.synthetic import OBSTACLE, render_floor

    s = load_scene(_map_scene(tmp_path), BASES)
    walls = s.static_map
    assert walls is not None and walls.path == str(tmp_path / "walls.yaml")
    assert walls in s.obstacles_at(0.0) and s.obstacles == load_scene(SCENE, BASES).obstacles
    assert walls.clearance(2.25, 0.1) == pytest.approx(0.1)  # below the L's foot (y 0.2)
    assert walls.clearance(2.7, 0.6) == pytest.approx(math.hypot(0.2, 0.1))  # its corner
    assert walls.clearance(2.25, 0.35) == pytest.approx(-0.15)  # inside, 0.15 from free cells
    assert walls.clearance(0.55, 1.55) == pytest.approx(-0.05)  # the unknown cell
    assert walls.clearance(0.55, 1.8) == pytest.approx(0.2)
    assert s.clearance(2.7, 0.6, 0.0) == pytest.approx(math.hypot(0.2, 0.1))
    assert np.allclose(sorted(walls.rectangles()), [(0.5, 1.5, 0.1, 0.1), (2.0, 0.2, 0.5, 0.3),
                                                    (2.0, 0.5, 0.2, 0.5)])
    camera = s.camera.pinhole()
    rvec, tvec = s.camera.floor_pose()
    image = render_floor(camera, rvec, tvec, s.floor_scene(0.0))
    points = np.array([[2.25, 0.35, 0.0], [2.1, 0.85, 0.0], [0.55, 1.55, 0.0],
                       [2.35, 0.75, 0.0], [0.8, 0.8, 0.0]]) * 1000.0
    u, v = np.round(camera.project(points, rvec, tvec)).astype(int).T
    assert image[v, u].tolist()[:3] == [OBSTACLE] * 3  # the L (both arms), the unknown cell
    assert min(image[v, u].tolist()[3:]) > 150  # free floor beside them


def test_a_start_in_a_solid_map_cell_or_a_missing_map_is_refused(tmp_path: Path) -> None:
    bad = _map_scene(tmp_path, "  x: 2.1\n  y: 0.7")
    with pytest.raises(NavSceneError, match=r":\d+: key 'robot.x': the robot's start \(2.1, "
                       r"0.7\) is -0.1 m from a solid cell of the map .*walls.yaml"):
        load_scene(bad, BASES)
    bad.write_text(bad.read_text().replace("map: walls.yaml", "map: nowhere.yaml"))
    with pytest.raises(NavSceneError) as info:
        load_scene(bad, BASES)
    assert str(info.value) == (f"{bad}:{_line_of(bad, 'map:')}: key 'map': map file "
                               f"'nowhere.yaml' not found (looked for {tmp_path / 'nowhere.yaml'})")
