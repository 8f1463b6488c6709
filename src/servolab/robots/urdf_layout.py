"""The Foxglove / Lichtblick layout of a robot described by a URDF: the robot in 3D from its
``/robot_description`` and ``/tf``, and its Dynamixel joints' angles over time."""

from __future__ import annotations

import xml.etree.ElementTree as ET

from ..middleware.view.layout import Layout, Plot, ThreeD
from .dynamixel_system import DynamixelSystem


def root_link(urdf: str) -> str:
    """The URDF's root: the one link that is no joint's child (the /tf tree hangs from it)."""
    root = ET.fromstring(urdf)
    children = {c.get("link") for j in root.findall("joint") if (c := j.find("child")) is not None}
    roots = [name for link in root.findall("link")
             if (name := link.get("name", "")) not in children]
    return roots[0] if roots else "base_link"


def urdf_layout(name: str, urdf: str, system: DynamixelSystem) -> Layout:
    """``name``'s layout: its 3D model and a plot of its driven joints (in /joint_states'
    order, the ``<ros2_control>`` block's, as :class:`~.joint_state_node.JointStateNode`
    publishes them)."""
    joints = [j.name for j in system.joints]
    return Layout(name, f"{name}: the robot in 3D from its URDF and /tf, its joints' angles", (
        ThreeD("robot", ("/tf", "/tf_static"), frame=root_link(urdf),
               urdf_topic="/robot_description"),
        Plot("joints", [f"/joint_states.position[{i}]" for i in range(len(joints))],
             title=f"{', '.join(joints)} (rad)")))
