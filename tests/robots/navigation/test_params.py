"""Seed 000's ROS navigation parameter files (Appendix D.2 costmap, D.3 DWA) read as written:
the seed's values, a wrong type refused at its line, unused keys listed as ignored."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from servolab.errors import ConfigFileError
from servolab.robots.navigation.params import (
    DEFAULT_COSTMAP,
    DEFAULT_DWA,
    DEFAULT_MOVE_BASE,
    CostmapParams,
    DwaParams,
    MoveBaseParams,
    NavParamsError,
    load_costmap,
    load_dwa,
    load_move_base,
)
from servolab.sim.scene import DEFAULT_SCENE

ROOT = Path(__file__).resolve().parents[3]
COSTMAP, DWA, MOVE_BASE = DEFAULT_COSTMAP, DEFAULT_DWA, DEFAULT_MOVE_BASE  # package data


def _line_of(path: Path, text: str) -> int:
    for number, line in enumerate(path.read_text().splitlines(), 1):
        if line.strip().startswith(text):
            return number
    raise AssertionError(f"{text!r} not in {path}")


def test_d2_costmap_loads_with_the_seeds_values() -> None:
    params = load_costmap(COSTMAP)
    assert (params.robot_radius, params.footprint, params.inflation_radius,
            params.cost_scaling_factor, params.inflation_enabled) == (0.20, None, 0.40, 12.0,
                                                                       True)
    # costmap_2d's defaults for what D.2 does not write
    assert (params.resolution, params.footprint_padding) == (0.05, 0.01)
    assert params.ignored == ("max_obstacle_height", "map_type", "obstacle_layer",
                              "static_layer")
    assert [n.split("'")[1] for n in params.notes] == [
        "obstacle_layer.origin_z", "obstacle_layer.z_resolution", "obstacle_layer.z_voxels"]
    # the 16-gon of 0.20 m padded by 0.01 m: between r·cos(π/16) and that plus the padding·√2
    assert 0.2 * math.cos(math.pi / 16) < params.inscribed_radius < (
        0.2 * math.cos(math.pi / 16) + 0.01 * math.sqrt(2))


def test_d3_dwa_loads_with_the_seeds_values() -> None:
    p = load_dwa(DWA)
    assert (p.max_vel_x, p.min_vel_x, p.max_vel_y, p.min_vel_y) == (0.15, 0.0, 0.0, 0.0)
    assert (p.max_trans_vel, p.min_trans_vel, p.trans_stopped_vel) == (0.15, 0.1, 0.1)
    assert (p.max_rot_vel, p.min_rot_vel, p.rot_stopped_vel) == (1.5, 0.4, 0.4)
    assert (p.acc_lim_x, p.acc_lim_theta, p.acc_lim_y) == (1.0, 2.0, 0.0)
    assert (p.yaw_goal_tolerance, p.xy_goal_tolerance) == (0.3, 0.15)
    assert (p.sim_time, p.vx_samples, p.vy_samples, p.vtheta_samples) == (1.0, 6, 1, 20)
    assert (p.path_distance_bias, p.goal_distance_bias, p.occdist_scale) == (64.0, 24.0, 0.8)
    assert (p.forward_point_distance, p.stop_time_buffer) == (0.325, 0.2)
    assert (p.scaling_speed, p.max_scaling_factor, p.oscillation_reset_dist) == (0.10, 0.2,
                                                                                 0.05)
    assert p.latch_xy_goal_tolerance is False  # commented out in D.3
    assert p.ignored == ("publish_traj_pc", "publish_cost_grid_pc", "global_frame_id")


def test_wrong_type_refused_with_its_line(tmp_path: Path) -> None:
    bad = tmp_path / "costmap.yaml"
    bad.write_text(COSTMAP.read_text().replace("cost_scaling_factor: 12.0",
                                               "cost_scaling_factor: steep"))
    with pytest.raises(NavParamsError) as info:
        load_costmap(bad)
    line = _line_of(bad, "cost_scaling_factor:")
    assert str(info.value) == (f"{bad}:{line}: key 'inflation_layer.cost_scaling_factor': "
                               "must be a finite number, not 'steep'")
    assert isinstance(info.value, ConfigFileError) and info.value.line == line

    bad = tmp_path / "dwa.yaml"
    bad.write_text(DWA.read_text().replace("vx_samples: 6", "vx_samples: 6.5"))
    with pytest.raises(NavParamsError) as info:
        load_dwa(bad)
    line = _line_of(bad, "vx_samples:")
    assert str(info.value) == f"{bad}:{line}: key 'vx_samples': must be an integer, not 6.5"

    bad.write_text(DWA.read_text().replace("sim_time: 1.0", "sim_time: true"))
    with pytest.raises(NavParamsError, match=rf":{_line_of(bad, 'sim_time')}: key 'sim_time'"):
        load_dwa(bad)


def test_out_of_range_and_different_duplicates_refused(tmp_path: Path) -> None:
    bad = tmp_path / "costmap.yaml"
    bad.write_text("robot_radius: -0.2\n")
    with pytest.raises(NavParamsError, match=r":1: key 'robot_radius': must be > 0"):
        load_costmap(bad)
    bad.write_text("robot_radius: 0.2\nrobot_radius: 0.3\n")
    with pytest.raises(NavParamsError, match=r":2: duplicate key 'robot_radius' \(first on "
                       r"line 1"):
        load_costmap(bad)
    bad.write_text("min_vel_x: 0.5\nmax_vel_x: 0.2\n")
    with pytest.raises(NavParamsError, match=r":1: min_vel_x 0.5 is above max_vel_x 0.2"):
        load_dwa(bad)


def test_ros_layouts_footprint_and_renamed_keys(tmp_path: Path) -> None:
    f = tmp_path / "costmap.yaml"
    f.write_text("footprint: [[-0.2, -0.1], [0.2, -0.1], [0.2, 0.1], [-0.2, 0.1]]\n"
                 "footprint_padding: 0.0\nresolution: 0.025\ninflation_radius: 0.3\n"
                 "observation_sources: scan\n")
    params = load_costmap(f)
    assert params.robot_radius is None and params.resolution == 0.025
    assert params.inscribed_radius == pytest.approx(0.1)
    assert params.inflation_radius == 0.3 and params.ignored == ("observation_sources",)
    f.write_text('footprint: "[[-0.2, -0.1], [0.2, -0.1], [0.2, 0.1]]"\n')
    assert load_costmap(f).footprint == ((-0.2, -0.1), (0.2, -0.1), (0.2, 0.1))
    f.write_text("footprint: [[0.2, 0.1], [0.2]]\n")
    with pytest.raises(NavParamsError, match=r":1: key 'footprint\[1\]': a footprint point"):
        load_costmap(f)

    d = tmp_path / "dwa.yaml"
    d.write_text("DWAPlannerROS:\n  max_rot_vel: 1.0\n  max_vel_theta: 2.0\n"
                 "  vth_samples: 7\n  voxel_debug: true\nrecovery_behaviors: []\n")
    dwa = load_dwa(d)
    assert (dwa.max_rot_vel, dwa.vtheta_samples) == (2.0, 7)
    assert dwa.ignored == ("recovery_behaviors", "DWAPlannerROS.voxel_debug")


def test_defaults_are_costmap_2d_and_dwa_local_planner_defaults() -> None:
    assert CostmapParams().inflation_radius == 0.55
    assert CostmapParams().cost_scaling_factor == 10.0
    assert DwaParams().sim_time == 1.7 and DwaParams().vx_samples == 3


def test_turtlebot_move_base_loads_with_its_values() -> None:
    p = load_move_base(MOVE_BASE)
    assert (p.controller_frequency, p.controller_patience) == (5.0, 3.0)
    assert (p.planner_frequency, p.planner_patience) == (1.0, 5.0)
    assert (p.oscillation_timeout, p.oscillation_distance) == (10.0, 0.2)
    assert p.sim_period == pytest.approx(0.2)
    assert p.ignored == ("shutdown_costmaps", "base_global_planner", "base_local_planner")
    assert len(p.notes) == 1 and "'base_global_planner' is written twice" in p.notes[0]


def test_move_base_defaults_are_move_bases() -> None:
    # move_base.cpp's param() defaults (controller_patience 15, not MoveBase.cfg's 5)
    assert MoveBaseParams() == MoveBaseParams(controller_frequency=20.0, planner_frequency=0.0,
                                              oscillation_timeout=0.0,
                                              oscillation_distance=0.5,
                                              controller_patience=15.0, planner_patience=5.0)


def test_d3_dwa_can_start_the_robot_only_at_turtlebots_controller_frequency() -> None:
    """Why the move_base file ships: at the 20 Hz default D.3's window from rest lies below its
    minimum speeds, at turtlebot's 5 Hz it reaches them."""
    from dataclasses import replace

    from servolab.planning.dwa import DwaConfig, dynamic_window

    dwa = load_dwa(DWA)
    config = DwaConfig.from_params(dwa)
    for frequency, starts in ((MoveBaseParams().controller_frequency, False),
                              (load_move_base(MOVE_BASE).controller_frequency, True)):
        (_, v_hi), (_, w_hi) = dynamic_window(0.0, 0.0,
                                              replace(config, controller_frequency=frequency))
        assert (v_hi >= dwa.min_trans_vel or w_hi >= dwa.min_rot_vel) is starts, frequency


def test_move_base_bad_values_refused_at_their_line(tmp_path: Path) -> None:
    bad = tmp_path / "move_base.yaml"
    for old, new, message in (
            ("controller_frequency: 5.0", "controller_frequency: 0",
             "key 'controller_frequency': must be > 0, not 0"),
            ("controller_frequency: 5.0", "controller_frequency: fast",
             "key 'controller_frequency': must be a finite number, not 'fast'"),
            ("planner_frequency: 1.0", "planner_frequency: -1.0",
             "key 'planner_frequency': must be >= 0, not -1"),
            ("oscillation_distance: 0.2", "oscillation_distance: [0.2]",
             "key 'oscillation_distance': must be a finite number, not a list"),
            ("planner_patience: 5.0", "planner_patience: true",
             "key 'planner_patience': must be a finite number, not true")):
        bad.write_text(MOVE_BASE.read_text().replace(old, new))
        with pytest.raises(NavParamsError) as info:
            load_move_base(bad)
        line = _line_of(bad, new.split(":")[0] + ":")
        assert str(info.value) == f"{bad}:{line}: {message}"
    bad.write_text("")
    with pytest.raises(NavParamsError, match="empty file: expected a move_base parameter file"):
        load_move_base(bad)


def test_move_bases_default_recovery_behaviours() -> None:
    """move_base.cpp loadDefaultRecoveryBehaviors: conservative_reset (ClearCostmapRecovery at
    conservative_reset_dist, 3.0 m), rotate_recovery, aggressive_reset (at 4 x the
    circumscribed radius), rotate_recovery; no rotations without clearing_rotation_allowed,
    none at all without recovery_behavior_enabled."""
    from servolab.robots.navigation.params import CLEAR_COSTMAP_RECOVERY, ROTATE_RECOVERY

    behaviors = MoveBaseParams().behaviors(0.25)
    assert [(b.name, b.type) for b in behaviors] == [
        ("conservative_reset", CLEAR_COSTMAP_RECOVERY), ("rotate_recovery", ROTATE_RECOVERY),
        ("aggressive_reset", CLEAR_COSTMAP_RECOVERY), ("rotate_recovery", ROTATE_RECOVERY)]
    assert (behaviors[0].reset_distance, behaviors[2].reset_distance) == (3.0, 1.0)
    no_turns = MoveBaseParams(clearing_rotation_allowed=False).behaviors(0.25)
    assert [b.name for b in no_turns] == ["conservative_reset", "aggressive_reset"]
    assert MoveBaseParams(recovery_behavior_enabled=False).behaviors(0.25) == ()


def test_recovery_behaviors_read_from_the_file_and_checked(tmp_path: Path) -> None:
    """A move_base file's own recovery_behaviors list ({name, type}) with each one's
    parameters under its name, as move_base's loadRecoveryBehaviors reads them."""
    good = tmp_path / "move_base.yaml"
    good.write_text("controller_frequency: 5.0\nrecovery_behaviors:\n"
                    "  - {name: near, type: clear_costmap_recovery/ClearCostmapRecovery}\n"
                    "  - {name: spin, type: rotate_recovery/RotateRecovery}\n"
                    "near: {reset_distance: 1.5, layer_names: [obstacle_layer]}\n"
                    "spin: {frequency: 20.0}\n")
    params = load_move_base(good)
    assert [(b.name, b.reset_distance) for b in params.behaviors(0.2)] == [("near", 1.5),
                                                                          ("spin", 3.0)]
    assert params.ignored == ()
    bad = tmp_path / "bad.yaml"
    for text, message in (
            ("recovery_behaviors:\n  - {name: x, type: move_slow_and_clear/MoveSlowAndClear}\n",
             ":3: recovery type 'move_slow_and_clear/MoveSlowAndClear' is not one servolab "),
            ("recovery_behaviors:\n  - {name: x, kind: rotate_recovery/RotateRecovery}\n",
             ":3: a recovery behaviour: unknown key 'kind'"),
            ("recovery_behaviors:\n  - {name: x, type: rotate_recovery/RotateRecovery}\n"
             "x: {reset_distance: 1.0}\n",
             ":4: x: 'reset_distance' is not a parameter of rotate_recovery/RotateRecovery "
             "(frequency, sim_granularity)"),
            ("recovery_behaviors:\n  - {name: x, type: rotate_recovery/RotateRecovery}\n"
             "  - {name: x, type: rotate_recovery/RotateRecovery}\n",
             ":4: recovery behaviour 'x' is listed twice")):
        bad.write_text("controller_frequency: 5.0\n" + text)
        with pytest.raises(NavParamsError) as info:
            load_move_base(bad)
        assert str(info.value).startswith(str(bad)) and message in str(info.value)


def test_a_dwa_file_that_could_never_drive_is_refused(tmp_path: Path) -> None:
    """max_vel_x below min_trans_vel: dwa_local_planner's generateTrajectory drops every
    sample slower than min_trans_vel that does not also turn at min_rot_vel, so the robot
    could never drive straight (issue 30: such a file was accepted and never drove)."""
    bad = tmp_path / "dwa.yaml"
    bad.write_text(DWA.read_text().replace("max_vel_x: 0.15", "max_vel_x: 0.05"))
    with pytest.raises(NavParamsError) as info:
        load_dwa(bad)
    line = _line_of(bad, "max_vel_x:")
    assert str(info.value).startswith(f"{bad}:{line}: max_vel_x 0.05 is below min_trans_vel "
                                      "0.1")


@pytest.mark.parametrize(("loader", "path", "what"), [
    (load_dwa, "nav_scene.yaml", "dwa_local_planner's"),
    (load_costmap, "dwa_params.yaml", "costmap_2d's"),
    ("move_base", "costmap_params.yaml", "move_base's"),
])
def test_a_file_of_the_wrong_kind_is_refused(loader: object, path: str, what: str) -> None:
    """Every key of a wrong file would be 'ignored' and the run would use the defaults."""
    from servolab.robots.navigation.params import load_move_base

    load = load_move_base if loader == "move_base" else loader
    with pytest.raises(NavParamsError, match=f"none of {what} parameters is in this file"):
        load(DEFAULT_SCENE if path == "nav_scene.yaml" else DEFAULT_COSTMAP.parent / path)  # type: ignore[operator]
