"""``servolab plan`` end to end on small generated images (written with cv2.imwrite): the cost
without inflation is the length in cells, the path avoids obstacles, inflation keeps the path
away from walls, and every bad input is refused in one line with a non-zero exit."""

from __future__ import annotations

import json
import math
from pathlib import Path

import cv2
import numpy as np
import pytest

from servolab.cli import main
from servolab.planning.costmap import traversal_costs
from tests.clirun import servolab

SQRT2 = math.sqrt(2.0)


def _image(tmp_path: Path, image: np.ndarray, name: str = "map.png") -> Path:
    path = tmp_path / name
    assert cv2.imwrite(str(path), image)
    return path


def _plan(tmp_path: Path, image: Path, *args: str, out: str = "run") -> dict[str, object]:
    folder = tmp_path / out
    assert main(["plan", "--map", str(image), *args, "--out", str(folder)]) == 0
    assert (folder / "plan.png").stat().st_size > 5_000
    return json.loads((folder / "summary.json").read_text())  # type: ignore[no-any-return]


def _refused(capsys: pytest.CaptureFixture[str], out: Path, *args: str,
             status: int = 2) -> str:
    """The one-line message of a refused ``servolab plan`` (bad input: exit status 2; no
    path: 1); no run folder is left."""
    assert main(["plan", *args, "--out", str(out)]) == status
    assert not out.exists(), "a refused plan left a run folder"
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    return err.strip()


def test_without_inflation_the_cost_is_the_length_in_cells(tmp_path: Path) -> None:
    image = _image(tmp_path, np.full((30, 40), 255, np.uint8))
    straight = _plan(tmp_path, image, "--start", "2", "5", "--goal", "32", "5",
                     "--no-inflation", out="straight")
    assert straight["cost"] == pytest.approx(30.0)
    assert straight["cells"] == 31 and straight["inflation"] is False
    path = np.array(straight["path"])
    assert path[0].tolist() == [2, 5] and path[-1].tolist() == [32, 5]  # [x, y]
    assert np.all(path[:, 1] == 5)
    diagonal = _plan(tmp_path, image, "--start", "0", "0", "--goal", "20", "20",
                     "--no-inflation", out="diagonal")
    assert diagonal["cost"] == pytest.approx(20 * SQRT2)
    assert diagonal["length_cells"] == pytest.approx(20 * SQRT2)
    mixed = _plan(tmp_path, image, "--start", "1", "2", "--goal", "31", "12",
                  "--no-inflation", out="mixed")
    assert mixed["cost"] == pytest.approx(10 * SQRT2 + 20)  # octile distance


def _corridor_map() -> np.ndarray:
    """A 60 x 100 room with a wall across it (x 48..51) open only near the top (y 1..8) and
    in a wide gap at the bottom (y 30..58)."""
    image = np.full((60, 100), 255, np.uint8)
    image[0, :] = image[-1, :] = 0
    image[:, 0] = image[:, -1] = 0
    image[9:30, 48:52] = 0
    return image


def test_the_path_avoids_obstacles(tmp_path: Path) -> None:
    image = _corridor_map()
    summary = _plan(tmp_path, _image(tmp_path, image), "--start", "10", "15", "--goal",
                    "90", "15", "--no-inflation")
    path = np.array(summary["path"])
    assert np.all(image[path[:, 1], path[:, 0]] == 255), "the path crosses a dark pixel"
    steps = np.abs(np.diff(path, axis=0))
    assert np.all(steps.max(axis=1) == 1)  # 8-connected, no jump
    # the cost is the path's own length, and longer than the straight line through the wall
    assert summary["cost"] == pytest.approx(summary["length_cells"])
    assert summary["cost"] > 80.0


def test_inflation_keeps_the_path_away_from_walls(tmp_path: Path) -> None:
    image = _corridor_map()
    mapfile = _image(tmp_path, image)
    bare = _plan(tmp_path, mapfile, "--start", "10", "15", "--goal", "90", "15",
                 "--no-inflation", out="bare")
    inflated = _plan(tmp_path, mapfile, "--start", "10", "15", "--goal", "90", "15",
                     out="inflated")
    assert inflated["inflation"] is True
    assert inflated["cost"] > bare["cost"]
    assert inflated["path"] != bare["path"]
    # seed 000's file: 0.05 m cells, robot_radius 0.20 (+0.01 padding): no path cell is within
    # the inscribed radius (about 4 cells) of a dark pixel; the bare path grazes the wall.
    from scipy import ndimage  # type: ignore[import-untyped]

    clearance = ndimage.distance_transform_edt(image > 127)
    bare_path, inflated_path = np.array(bare["path"]), np.array(inflated["path"])
    assert clearance[bare_path[:, 1], bare_path[:, 0]].min() <= 1.5
    assert clearance[inflated_path[:, 1], inflated_path[:, 0]].min() > 4.0
    assert inflated["resolution_m"] == pytest.approx(0.05)
    assert "obstacle_layer" in inflated["ignored"]  # ROS keys servolab does not use
    # the 8-cell opening at the top is too narrow for the inflated robot: it goes below
    assert inflated_path[:, 1].max() > 30


def test_the_cost_mapping() -> None:
    costs = traversal_costs(np.array([0, 50, 252, 253, 254], dtype=np.uint8))
    assert costs[:3] == pytest.approx([1.0, 1.8, 1.0 + 0.8 * 252 / 50])
    assert np.all(np.isinf(costs[3:]))


def test_bad_input_is_refused_in_one_line(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    image = _corridor_map()
    mapfile = str(_image(tmp_path, image))
    ends = ["--start", "10", "15", "--goal", "90", "15"]
    refused = tmp_path / "refused"

    def refuse(*args: str) -> str:
        return _refused(capsys, refused, "--map", mapfile, *args)

    message = _refused(capsys, refused, "--map", str(tmp_path / "missing.png"), *ends)
    assert "missing.png" in message and "does not exist" in message
    garbage = tmp_path / "garbage.png"
    garbage.write_bytes(b"not an image")
    message = _refused(capsys, refused, "--map", str(garbage), *ends)
    assert "garbage.png" in message and "cannot be read" in message
    message = refuse("--start", "100", "15", "--goal", "90", "15")
    assert message.startswith("servolab plan: error: start (100, 15) is outside the map")
    message = refuse("--start", "10", "15", "--goal", "5", "-1")
    assert message.startswith("servolab plan: error: goal (5, -1) is outside the map")
    message = refuse("--start", "10", "15", "--goal", "49", "20")
    assert message.startswith("servolab plan: error: goal (49, 20) is inside an obstacle")
    message = refuse("--start", "0", "0", "--goal", "90", "15",
                       "--no-inflation")
    assert message.startswith("servolab plan: error: start (0, 0) is inside an obstacle")
    message = refuse("--start", "10", "15", "--goal", "46", "20")
    assert message.startswith("servolab plan: error: goal (46, 20) is within the robot's "
                              "inscribed")
    bad_params = tmp_path / "bad.yaml"
    bad_params.write_text("robot_radius: big\n")
    message = refuse(*ends, "--params", str(bad_params))
    assert "bad.yaml:1" in message and "robot_radius" in message
    # no path, a closed wall: not bad input but a plan that failed, exit status 1
    closed = image.copy()
    closed[:, 48:52] = 0
    message = _refused(capsys, refused, "--map", str(_image(tmp_path, closed, "closed.png")), *ends,
                       "--no-inflation", status=1)
    assert message.startswith("servolab plan: NoPath: no path from start (10, 15) to goal "
                              "(90, 15)")
    # with inflation, the 8-cell opening is closed too when the gap below is
    narrow = image.copy()
    narrow[30:59, 48:52] = 0
    message = _refused(capsys, refused, "--map", str(_image(tmp_path, narrow, "narrow.png")), *ends,
                       status=1)
    assert "no path" in message and "--no-inflation" in message
    # on an image the ends are cells: a coordinate that is not a whole number, exit 2
    message = refuse("--start", "1.5", "2", "--goal", "3", "4")
    assert message == ("servolab plan: error: --start 1.5 2: on a map image the ends are cells "
                       "(whole numbers); metres need a map_server map.yaml")


@pytest.mark.slow
def test_the_command_line_exit_codes(tmp_path: Path) -> None:
    mapfile = str(_image(tmp_path, _corridor_map()))
    ok = servolab("plan", "--map", mapfile, "--start", "10", "15", "--goal", "90", "15", "--out",
                  str(tmp_path / "ok"), timeout=60)
    assert ok.returncode == 0, ok.stderr
    assert "ignored keys of" in ok.stdout and "obstacle_layer" in ok.stdout
    assert (tmp_path / "ok" / "summary.json").exists()
    bad = servolab("plan", "--map", mapfile, "--start", "10", "15", "--goal", "49", "20",
                   timeout=60)
    assert bad.returncode == 2  # bad input
    assert bad.stderr.strip().splitlines() == [
        "servolab plan: error: goal (49, 20) is inside an obstacle (a pixel darker than 128 in "
        f"'{mapfile}')"]


@pytest.mark.parametrize(("extra", "says"), [
    (["--no-inflation", "--resolution", "0.02"], "not used with --no-inflation"),
    (["--threshold", "300"], "--threshold 300 must be a gray level"),
])
def test_options_that_cannot_apply_are_refused(tmp_path: Path, extra: list[str],
                                               says: str) -> None:
    image = tmp_path / "map.png"
    cv2.imwrite(str(image), np.full((20, 20), 255, np.uint8))
    result = servolab("plan", "--map", str(image), "--start", "1", "1", "--goal", "18", "18",
                      *extra, "--out", str(tmp_path / "run"), timeout=120)
    assert result.returncode == 2
    assert says in result.stderr and result.stderr.strip().count("\n") == 0


def test_a_plan_stopped_while_it_writes_leaves_its_summary(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """Ctrl-C while the plot is drawn: exit status 130, and summary.json says what the run
    had (the path) and what ended it."""
    from servolab.robots.navigation import plan as plan_module

    def stopped(*args: object, **kwargs: object) -> Path:
        raise KeyboardInterrupt

    monkeypatch.setattr(plan_module, "plot_plan", stopped)
    image = _image(tmp_path, np.full((20, 20), 255, np.uint8))
    out = tmp_path / "run"
    assert main(["plan", "--map", str(image), "--start", "1", "1", "--goal", "18", "18",
                 "--no-inflation", "--out", str(out)]) == 130
    assert capsys.readouterr().err == "servolab plan: stopped by SIGINT\n"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["interrupted"] == "SIGINT"
    assert summary["cost"] == pytest.approx(17 * SQRT2) and "plot" not in summary


# -- map_server maps (map.yaml) ----------------------------------------------------------------

MAPS = Path(__file__).resolve().parents[2] / "data" / "maps"


def _map_yaml(tmp_path: Path, image: np.ndarray, *, origin: str = "[-1.5, 2.0, 0.0]",
              resolution: float = 0.1) -> Path:
    """A map.yaml as map_saver writes one (ROS wiki map_server), beside its PNG."""
    assert cv2.imwrite(str(tmp_path / "room.png"), image)
    path = tmp_path / "room.yaml"
    path.write_text(f"image: room.png\nresolution: {resolution}\norigin: {origin}\n"
                    "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    return path


def _room() -> np.ndarray:
    """30 x 20 free cells (map_saver's 254) with two blocks (0) at the image's bottom corners,
    which a reader without map_server's row flip would put under the ends (both in its top
    row 2); a wall across the middle (x 14..15) open in a gap near the bottom (image rows
    13..18), and unknown (205) at its top (image rows 0..3), the straight way across."""
    image = np.full((20, 30), 254, np.uint8)
    image[14:20, 0:6] = 0
    image[14:20, 24:30] = 0
    image[:, 14:16] = 0
    image[13:19, 14:16] = 254  # the gap
    image[0:4, 14:16] = 205  # unknown: not to be crossed
    return image


def test_a_map_yaml_plans_in_metres_with_its_origin_and_resolution(tmp_path: Path) -> None:
    """origin (-1.5, 2.0) and 0.1 m cells: the ends fall in Costmap2D::worldToMap's cells,
    counted from the map's bottom row (image_loader.cpp flips the image; ROS wiki: the origin
    is the lower-left pixel). Ignoring the origin puts the start off the map, ignoring the
    resolution (0.05) the goal, and ignoring the flip puts both ends in the blocks."""
    mapfile = _map_yaml(tmp_path, _room())
    summary = _plan(tmp_path, mapfile, "--start", "-1.25", "3.75", "--goal", "1.15", "3.75",
                    "--no-inflation")
    assert summary["start_cell"] == [2, 17] and summary["goal_cell"] == [26, 17]
    assert summary["start"] == [-1.25, 3.75] and summary["goal"] == [1.15, 3.75]
    path = np.array(summary["path"])
    assert path[0].tolist() == [2, 17] and path[-1].tolist() == [26, 17]
    assert summary["path_m"][0] == pytest.approx([-1.25, 3.75])
    assert summary["path_m"][-1] == pytest.approx([1.15, 3.75])
    assert (summary["resolution_m"], summary["origin"]) == (0.1, [-1.5, 2.0, 0.0])
    # only free cells: the image's pixel of map cell (x, y) is (x, 19 - y); unknown is not
    # free, so the path goes down through the gap, not straight across the unknown cells
    image = _room()
    assert np.all(image[19 - path[:, 1], path[:, 0]] == 254)
    crossing = path[(path[:, 0] >= 14) & (path[:, 0] <= 15)]
    assert np.all((19 - crossing[:, 1] >= 13) & (19 - crossing[:, 1] <= 18))
    assert summary["unknown_cells"] == 8
    assert summary["cost"] > 30  # straight across the unknown cells: 24
    assert summary["length_m"] == pytest.approx(summary["length_cells"] * 0.1)


def test_a_map_yaml_inflates_at_the_maps_resolution(tmp_path: Path) -> None:
    """costmap_2d's static layer gives the costmap the map's resolution: seed 000's file says
    0.05 m, the map 0.1 m, so the robot's inscribed radius (0.21 m) is 2.1 cells here."""
    from scipy import ndimage  # type: ignore[import-untyped]

    from servolab.robots.navigation.plan import load_map_problem, plan

    problem = load_map_problem(_map_yaml(tmp_path, _room()), (-1.25, 3.75), (1.15, 3.75))
    assert problem.resolution == 0.1 and problem.params is not None
    assert (problem.start, problem.goal) == ((2, 17), (26, 17))
    _, path = plan(problem)
    assert problem.unknown is not None
    clearance = ndimage.distance_transform_edt(~problem.occupied)
    assert clearance[path[:, 1], path[:, 0]].min() > 2.1
    assert not (problem.occupied | problem.unknown)[path[:, 1], path[:, 0]].any()


def test_the_hand_written_map_plans_between_the_right_cells() -> None:
    """tests/data/maps/asymmetric.yaml (origin (-1.5, 2.0), 0.1 m): from its bottom-left free
    cell round the obstacle to the free cell above it, without inflation."""
    from servolab.robots.navigation.plan import load_map_problem, plan

    problem = load_map_problem(MAPS / "asymmetric.yaml", (-1.35, 2.05), (-1.05, 2.35),
                               inflation=False)
    assert (problem.start, problem.goal) == ((1, 0), (4, 3))
    cost, path = plan(problem)
    assert path[0].tolist() == [1, 0] and path[-1].tolist() == [4, 3]
    assert cost == pytest.approx(2 + 2 * SQRT2)  # (1,0) (2,0)... round the L at (2..3, 2..3)


def test_map_yaml_ends_off_the_map_or_not_free_are_refused(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    mapfile = str(_map_yaml(tmp_path, _room()))
    refused = tmp_path / "refused"

    def refuse(*args: str) -> str:
        return _refused(capsys, refused, "--map", mapfile, *args)

    message = refuse("--start", "-1.6", "3.75", "--goal", "1.15", "3.75")
    assert message == (f"servolab plan: error: start (-1.6, 3.75) m is outside the map "
                       f"'{mapfile}', which covers x -1.5..1.5 m, y 2..4 m (30 x 20 cells of "
                       "0.1 m)")
    message = refuse("--start", "-1.25", "3.75", "--goal", "1.15", "2.35")
    assert message.startswith("servolab plan: error: goal (1.15, 2.35) m is in an occupied cell "
                              "(cell (26, 3) from the origin, pixel (26, 16) of ")
    message = refuse("--start", "-0.05", "3.75", "--goal", "1.15", "3.75", "--no-inflation")
    assert message.startswith("servolab plan: error: start (-0.05, 3.75) m is in unknown space")
    message = refuse("--start", "-0.25", "3.15", "--goal", "1.15", "3.75")
    assert message.startswith("servolab plan: error: start (-0.25, 3.15) m is within the "
                              "robot's inscribed radius")
    message = refuse("--start", "-1.25", "3.75", "--goal", "1.15", "3.75", "--threshold", "100")
    assert message == (f"servolab plan: error: --threshold is for a map image; {mapfile} gives "
                       "occupied_thresh and free_thresh")
    bad = tmp_path / "bad.yaml"
    bad.write_text(Path(mapfile).read_text().replace("resolution: 0.1", "resolution: fine"))
    message = _refused(capsys, refused, "--map", str(bad), "--start", "0", "3", "--goal", "1",
                       "3")
    assert message == (f"servolab plan: error: {bad}:2: key 'resolution': must be a finite "
                       "number, not 'fine'")
