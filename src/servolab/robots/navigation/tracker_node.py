"""The overhead camera's two products for navigation (seed 000): the map and the robot's pose.

:class:`OverheadTrackerNode` takes each ``mono8`` frame on ``/overhead/image_raw`` and, through
the camera's calibration (intrinsics, distortion and the floor plane's extrinsics), gives

- ``/tracker/pose`` (``geometry_msgs/msg/PoseStamped``, frame ``map``): the robot's marker found
  on the floor, position and heading (m, rad), the frame's stamp, what the fusion node takes as
  the seed's TLD tracker;
- ``/map`` (``nav_msgs/msg/OccupancyGrid``, frame ``map``, TRANSIENT_LOCAL as map_server
  latches it): the floor's cells, 100 where the image is darker than ``threshold`` (an obstacle,
  or a cell the camera does not see: unknown is not free), 0 elsewhere; published on the first
  frame and again only when a cell changed, so a planner repairs only for real changes.

A frame of the wrong encoding or size is refused (logged) and changes nothing. The topic
names are relative: in a namespace (``/robot1``) they are the robot's (``/robot1/map``); the
frame ``map`` is the floor's, every robot's.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from ...middleware.context import Context
from ...middleware.node import Node
from ...middleware.qos import DurabilityPolicy, QoSProfile
from ...vision.calibration import CameraCalibration, FloorExtrinsics
from ...vision.overhead import FloorGrid, FloorSampler, find_robot
from ..errors import RobotValueError

IMAGE = "sensor_msgs/msg/Image"
POSE = "geometry_msgs/msg/PoseStamped"
OCCUPANCY_GRID = "nav_msgs/msg/OccupancyGrid"
MAP_FRAME = "map"
#: map_server's default ``occupied_thresh`` 0.65, as the grid's 0..100 scale
OCCUPIED_THRESHOLD = 65
#: map_server's QoS for /map: a late subscriber still gets the map
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


class OverheadTrackerNode(Node):
    """See the module docstring. Parameter: ``threshold`` (grey level, 75)."""

    def __init__(self, context: Context, calibration: CameraCalibration,
                 extrinsics: FloorExtrinsics, grid: FloorGrid, name: str = "overhead_tracker",
                 namespace: str = "/", *, parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        self.threshold = float(self.declare_parameter(
            "threshold", 75.0, description="grey level below which a cell is occupied").value)
        if not (math.isfinite(self.threshold) and 0 < self.threshold <= 255):
            raise RobotValueError(f"overhead tracker: threshold {self.threshold!r} must be a grey "
                                  "level in (0, 255]")
        self.calibration, self.extrinsics, self.grid = calibration, extrinsics, grid
        self.sampler = FloorSampler(calibration, extrinsics, grid)
        #: the occupancy last published, [row, col] = [y, x]
        self.occupancy: npt.NDArray[np.bool_] | None = None
        self.maps_published = 0
        self.sightings = 0
        self.misses = 0
        self.pose = self.create_publisher(POSE, "tracker/pose", 10)
        self.map = self.create_publisher(OCCUPANCY_GRID, "map", LATCHED)
        self.create_subscription(IMAGE, "overhead/image_raw", self._on_image, 2)

    def _image(self, msg: Any) -> npt.NDArray[np.uint8] | None:
        width, height = self.calibration.image_size
        if msg.encoding != "mono8":
            self.get_logger().error(f"image refused: encoding {msg.encoding!r}, expected "
                                    "'mono8'")
            return None
        data = np.asarray(msg.data, dtype=np.uint8)
        if (msg.width, msg.height) != (width, height) or msg.step != width \
                or data.size != width * height:
            self.get_logger().error(
                f"image refused: {msg.width}x{msg.height} (step {msg.step}, {data.size} bytes),"
                f" but the calibration is for {width}x{height}")
            return None
        return data.reshape(height, width)

    def _on_image(self, msg: Any) -> None:
        image = self._image(msg)
        if image is None:
            return
        header = {"stamp": msg.header.stamp, "frame_id": MAP_FRAME}
        sighting = find_robot(image, self.calibration, self.extrinsics)
        if sighting is None:
            self.misses += 1
        else:
            self.sightings += 1
            self.pose.publish(self.message(POSE, header=header, pose={
                "position": {"x": sighting.x, "y": sighting.y},
                "orientation": {"z": math.sin(sighting.yaw / 2),
                                "w": math.cos(sighting.yaw / 2)}}))
        occupancy = self.sampler.occupancy(image, self.threshold, previous=self.occupancy)
        if self.occupancy is not None and np.array_equal(occupancy, self.occupancy):
            return
        self.occupancy = occupancy
        rows, cols = occupancy.shape
        self.map.publish(self.message(OCCUPANCY_GRID, header=header, info={
            "map_load_time": msg.header.stamp, "resolution": self.grid.resolution,
            "width": cols, "height": rows,
            "origin": {"position": {"x": self.grid.origin[0], "y": self.grid.origin[1]},
                       "orientation": {"w": 1.0}}},
            data=np.where(occupancy, 100, 0).astype(np.int8).reshape(-1)))
        self.maps_published += 1


def occupancy_of(msg: Any) -> tuple[npt.NDArray[np.bool_], float, tuple[float, float]]:
    """An OccupancyGrid as ``(occupied [row, col], resolution, origin (x, y))``.

    A cell of :data:`OCCUPIED_THRESHOLD` or more is occupied, and so is an unknown one (-1),
    as a planner that does not plan through unknown space has it. A grid whose data does not
    fill ``width x height``, whose resolution is not a positive number, or whose origin is
    rotated, is refused with a ValueError."""
    info = msg.info
    width, height = int(info.width), int(info.height)
    data = np.asarray(msg.data, dtype=np.int8)
    if data.size != width * height:
        raise RobotValueError(f"map refused: {data.size} cells for {width}x{height}")
    resolution = float(info.resolution)
    if not (math.isfinite(resolution) and resolution > 0):
        raise RobotValueError(f"map refused: resolution {resolution!r} must be > 0 m")
    q = info.origin.orientation
    if abs(float(q.z)) > 1e-6 or abs(float(q.x)) > 1e-6 or abs(float(q.y)) > 1e-6:
        raise RobotValueError("map refused: a rotated origin is not supported")
    origin = (float(info.origin.position.x), float(info.origin.position.y))
    cells = data.reshape(height, width)
    occupied = (cells >= OCCUPIED_THRESHOLD) | (cells < 0)
    return occupied, resolution, origin
