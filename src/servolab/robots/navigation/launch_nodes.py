"""Seed 000's navigation as separate nodes, for launch files (``configs/navigation.launch.yaml``).

``servolab navigate`` runs every node in one process in the floor's simulated time, with one
goal. A ROS user runs them as move_base is run: the robot and its camera, the tracker, the
localiser and the navigator as nodes that may sit in different processes or on different
machines, and goals sent to the navigator on ``/goal_pose`` or ``/move_base_simple/goal`` while
it runs. The nodes here take their settings as ROS parameters (strings for files, as a launch
file writes them) and build the same nodes ``servolab navigate`` builds:

- :class:`NavigationFloor`: the scene's floor in real time with the base's motors emulated on
  it, the base node (``/cmd_vel`` in, ``/odom`` and ``/tf`` out), the floor's ``/ground_truth``
  and the synthetic overhead camera (``/overhead/image_raw``);
- :class:`OverheadTracker`: the tracker (``/map``, ``/tracker/pose``), calibrated from a file
  or, without one, on the scene's camera as ``servolab navigate`` calibrates it;
- :class:`Navigator`: the navigator with the costmap, DWA and move_base files, waiting for
  goals. The localiser is :class:`~servolab.robots.base.fusion_node.FusionNode` itself.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np

from ...middleware.context import Context
from ...middleware.node import Node
from .params import (
    DEFAULT_COSTMAP,
    DEFAULT_DWA,
    DEFAULT_MOVE_BASE,
    load_costmap,
    load_dwa,
    load_move_base,
    load_nav_scene,
)


def _file(node: Node, name: str, description: str) -> str | None:
    value = str(node.declare_parameter(name, "", description=description).value)
    return value or None


class NavigationFloor(Node):
    """The scene's floor (parameter ``scene``: a scene file, empty for the shipped one) in real
    time, with its robot's base emulated on it at the scene's start, and the nodes that belong
    to the floor: the base node, the ground truth and the overhead camera (``seed``: the
    camera noise's seed)."""

    def __init__(self, context: Context, name: str = "navigation_floor", namespace: str = "/",
                 *, parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        from ...sim.overhead_camera import OverheadCameraNode
        from ...sim.truth_node import GroundTruthNode
        from ..base.config import load as load_base
        from ..base.mobile_base import MobileBase
        from ..base.node import BaseNode

        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        scene = load_nav_scene(_file(self, "scene", "scene YAML; empty: the shipped one"))
        seed = int(self.declare_parameter("seed", 0, description="camera noise seed").value)
        self.base = MobileBase.emulated(load_base(scene.base), start=scene.start, seed=seed)
        assert self.base.floor is not None
        self.simulation = self.base.clock
        self.simulation.start_real_time()  # type: ignore[attr-defined]
        try:
            here = self.get_namespace()  # the launch entry's, as a launch namespaces a group
            self.nodes = [BaseNode(context, self.base, namespace=here),
                          GroundTruthNode(context, self.base.floor, namespace=here),
                          OverheadCameraNode(context, scene, self.base.floor, namespace=here,
                                             seed=seed)]
        except BaseException:
            self._release()
            raise

    def _release(self) -> None:
        try:
            self.base.stop()
        finally:
            self.simulation.stop_real_time()  # type: ignore[attr-defined]
            self.base.bus.close()

    def destroy(self) -> None:
        try:
            for node in self.nodes:
                node.destroy()
            super().destroy()
        finally:
            self._release()


class OverheadTracker(Node):
    """The overhead tracker with its calibration: ``calib`` (a file of ``servolab calibrate
    --floor``, with ``board_at`` ``[x, y, yaw]`` where its floor board lay) or, empty, the
    scene's camera calibrated on synthetic board images (``scene``, ``seed``); the map's
    cells at the costmap file's resolution (``costmap``)."""

    def __init__(self, context: Context, name: str = "overhead_tracker", namespace: str = "/",
                 *, parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        from ...vision.calibration import in_map
        from ...vision.calibration import load as load_calibration
        from .session import NavigationError, calibrate_synthetic, map_grid
        from .tracker_node import OverheadTrackerNode

        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        scene_file = _file(self, "scene", "scene YAML; empty: the shipped one")
        calib = _file(self, "calib", "calibration YAML with its floor; empty: calibrate the "
                      "scene's camera synthetically")
        costmap = _file(self, "costmap", "costmap_2d parameters; empty: seed 000's D.2")
        board = [float(v) for v in self.declare_parameter(
            "board_at", [0.0, 0.0, 0.0], description="x, y (m), yaw (rad) of the floor "
            "board of calib").value]
        seed = int(self.declare_parameter("seed", 0, description="calibration seed").value)
        scene = load_nav_scene(scene_file)
        if calib is not None:
            calibration, loaded = load_calibration(calib)
            if loaded is None:
                raise NavigationError(f"{calib}: has no floor extrinsics; calibrate with "
                                      "--floor IMAGE (a board lying on the floor)")
            floor = loaded
            board_at = (board[0], board[1], board[2]) if any(board) else \
                (loaded.board_at or (0.0, 0.0, 0.0))
        else:
            from .session import BOARD_AT

            self.get_logger().info("calibrating the overhead camera on synthetic board images")
            calibration, floor = calibrate_synthetic(scene, np.random.default_rng(seed))
            board_at = BOARD_AT
        extrinsics = in_map(dataclasses.replace(floor, board_at=board_at),
                            (board_at[0] * 1000.0, board_at[1] * 1000.0, board_at[2]))
        resolution = load_costmap(costmap or DEFAULT_COSTMAP).resolution
        self.tracker = OverheadTrackerNode(context, calibration, extrinsics,
                                           map_grid(scene, resolution),
                                           namespace=self.get_namespace())

    def destroy(self) -> None:
        self.tracker.destroy()
        super().destroy()


class Navigator(Node):
    """The navigator, waiting for goals on ``/goal_pose`` and ``/move_base_simple/goal``, with
    the ``costmap``, ``dwa`` and ``move_base`` files (empty: seed 000's) and the pose timeout
    of :data:`~.session.POSE_TIMEOUT_FRAMES` frames of a camera of ``camera_rate`` frames/s."""

    def __init__(self, context: Context, name: str = "navigator_launcher", namespace: str = "/",
                 *, parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        from ...planning.dwa import DwaConfig
        from .navigator import NavigatorNode, Patience
        from .session import POSE_TIMEOUT_FRAMES

        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        costmap = load_costmap(_file(self, "costmap", "costmap_2d parameters") or
                               DEFAULT_COSTMAP)
        move_base = load_move_base(_file(self, "move_base", "move_base parameters") or
                                   DEFAULT_MOVE_BASE)
        dwa = dataclasses.replace(
            DwaConfig.from_params(load_dwa(_file(self, "dwa", "DWA parameters") or DEFAULT_DWA)),
            controller_frequency=move_base.controller_frequency)
        rate = float(self.declare_parameter("camera_rate", 10.0, description="the overhead "
                                            "camera's frames/s").value)
        self.navigator = NavigatorNode(
            context, costmap=costmap, dwa=dwa,
            patience=Patience(move_base.planner_patience, move_base.controller_patience,
                              move_base.oscillation_timeout, move_base.oscillation_distance),
            recovery=move_base.behaviors(costmap.circumscribed_radius),
            planner_frequency=move_base.planner_frequency,
            pose_timeout=POSE_TIMEOUT_FRAMES / rate, namespace=self.get_namespace())

    def destroy(self) -> None:
        self.navigator.destroy()
        super().destroy()
