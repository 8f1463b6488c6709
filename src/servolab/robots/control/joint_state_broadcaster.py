"""``joint_state_broadcaster/JointStateBroadcaster``, as ros2_controllers' (Jazzy) behaves.

Claims no command interface and reads state interfaces: every one (``joints`` and
``interfaces`` both empty, the default) or each of ``joints`` x ``interfaces``. Each update
it publishes

- ``/joint_states`` (sensor_msgs/JointState; ``~/joint_states`` with ``use_local_topics``):
  every joint that has a position state interface, with its velocity and effort (NaN where a
  joint has none, while another joint has one; an empty array where no joint has any);
- ``/dynamic_joint_states`` (control_msgs/DynamicJointState): every state interface read,
  by joint.

``map_interface_to_joint_state.position`` (and ``.velocity``, ``.effort``) name another
interface to publish in that field, as the original's parameters do.
"""

from __future__ import annotations

import math
from typing import Any

from .controller import (
    ALL,
    INDIVIDUAL,
    ControllerError,
    ControllerInterface,
    InterfaceConfiguration,
)
from .hardware import EFFORT, POSITION, VELOCITY


class JointStateBroadcaster(ControllerInterface):
    TYPE = "joint_state_broadcaster/JointStateBroadcaster"

    def on_init(self) -> None:
        self.joints = self.strings("joints", required=False)
        self.interfaces = self.strings("interfaces", required=False)
        self.use_local_topics = bool(self.parameter("use_local_topics", False))
        self.mapping = {field: str(self.parameter(f"map_interface_to_joint_state.{field}",
                                                  field))
                        for field in (POSITION, VELOCITY, EFFORT)}

    def state_interface_configuration(self) -> InterfaceConfiguration:
        if not self.joints and not self.interfaces:
            return InterfaceConfiguration(ALL)
        if not self.joints or not self.interfaces:
            raise ControllerError(f"{self.name}: give both 'joints' and 'interfaces', or "
                                  "neither (all of them)")
        return InterfaceConfiguration(INDIVIDUAL, tuple(f"{j}/{i}" for j in self.joints
                                                        for i in self.interfaces))

    def on_configure(self) -> None:
        self.state_interface_configuration()
        # relative, as joint_state_broadcaster.cpp's topic_name_prefix ("~/" or ""): in a
        # namespaced controller manager they are the robot's (/robot1/joint_states)
        prefix = "~/" if self.use_local_topics else ""
        self.joint_states = self.node.create_publisher("sensor_msgs/msg/JointState",
                                                       prefix + "joint_states", 10)
        self.dynamic = self.node.create_publisher("control_msgs/msg/DynamicJointState",
                                                  prefix + "dynamic_joint_states", 10)

    def on_activate(self) -> None:
        by_joint: dict[str, dict[str, Any]] = {}
        for handle in self.state_interfaces:
            by_joint.setdefault(handle.prefix, {})[handle.interface] = handle
        self._by_joint = by_joint
        position = self.mapping[POSITION]
        #: joints that go in /joint_states: those with a (mapped) position
        self._joints = [j for j, h in by_joint.items() if position in h]
        self._fields = {field: self.mapping[field] for field in (POSITION, VELOCITY, EFFORT)
                        if any(self.mapping[field] in by_joint[j] for j in self._joints)}

    def update(self, time: float, period: float) -> bool:
        node = self.node
        stamp = node.stamp(time)
        header = node.message("std_msgs/msg/Header", stamp=stamp, frame_id="")
        arrays: dict[str, list[float]] = {}
        for field, interface in self._fields.items():
            arrays[field] = [h[interface].get_value() if interface in h else math.nan
                             for h in (self._by_joint[j] for j in self._joints)]
        self.joint_states.publish(node.message(
            "sensor_msgs/msg/JointState", header=header, name=list(self._joints),
            position=arrays.get(POSITION, []), velocity=arrays.get(VELOCITY, []),
            effort=arrays.get(EFFORT, [])))
        values = [node.message("control_msgs/msg/InterfaceValue", interface_names=list(h),
                               values=[handle.get_value() for handle in h.values()])
                  for h in self._by_joint.values()]
        self.dynamic.publish(node.message(
            "control_msgs/msg/DynamicJointState", header=header,
            joint_names=list(self._by_joint), interface_values=values))
        return True
