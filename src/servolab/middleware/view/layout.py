"""Foxglove / Lichtblick layout files: which panels a viewer opens, on which topics.

A layout is the JSON file Foxglove's "Import layout" reads (and Lichtblick, its fork): panel
configurations by id (``"3D!robot"``, ``"Plot!joints"``: the part before ``!`` is the panel
type) and a mosaic that splits the window between them. Its shape is the one the apps
export (``configById``, ``globalVariables``, ``userNodes``, ``playbackConfig``, ``layout``;
foxglove/studio's ``defaultLayout.ts``).

Panels here are small dataclasses that say what a robot's user looks at; :func:`layout`
arranges them, first panel on the left, the rest stacked on the right.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from servolab.errors import ServolabValueError


@dataclass(frozen=True)
class ThreeD:
    """The 3D panel: topics drawn in ``frame`` (the fixed frame), following ``follow``
    (a TF frame) when given. A ``std_msgs/String`` URDF topic is drawn as the robot."""

    id: str
    topics: Sequence[str]
    frame: str = "map"
    follow: str | None = None
    urdf_topic: str | None = None

    def config(self) -> dict[str, Any]:
        config: dict[str, Any] = {
            "followMode": "follow-pose" if self.follow else "follow-none",
            "followTf": self.follow or self.frame,
            "scene": {}, "transforms": {}, "publish": {}, "imageMode": {},
            "topics": {topic: {"visible": True} for topic in self.topics},
            "layers": {"grid": {"layerId": "foxglove.Grid", "visible": True,
                                "frameId": self.frame, "size": 10, "divisions": 20}},
        }
        if self.urdf_topic:
            config["layers"]["robot"] = {"layerId": "foxglove.Urdf", "sourceType": "topic",
                                         "topic": self.urdf_topic, "visible": True,
                                         "label": "robot"}
        return config

    @property
    def shown(self) -> list[str]:
        return [*self.topics, *([self.urdf_topic] if self.urdf_topic else [])]


@dataclass(frozen=True)
class Plot:
    """Values over time, each a Foxglove message path (``/joint_states.position[3]``)."""

    id: str
    paths: Sequence[str]
    title: str = ""

    def config(self) -> dict[str, Any]:
        return {"title": self.title, "paths": [
            {"value": path, "enabled": True, "timestampMethod": "receiveTime"}
            for path in self.paths],
            "showLegend": True, "legendDisplay": "floating", "xAxisVal": "timestamp",
            "isSynced": True}

    @property
    def shown(self) -> list[str]:
        return [path.split(".", 1)[0] for path in self.paths]


@dataclass(frozen=True)
class Image:
    """A camera image (``sensor_msgs/Image`` or ``CompressedImage``)."""

    id: str
    topic: str

    def config(self) -> dict[str, Any]:
        # imageMode.imageTopic for Foxglove 2 and Lichtblick; cameraTopic for older builds
        return {"imageMode": {"imageTopic": self.topic}, "cameraTopic": self.topic}

    @property
    def shown(self) -> list[str]:
        return [self.topic]


@dataclass(frozen=True)
class Raw:
    """A topic's latest message, field by field."""

    id: str
    topic: str

    def config(self) -> dict[str, Any]:
        return {"topicPath": self.topic}

    @property
    def shown(self) -> list[str]:
        return [self.topic]


Panel = ThreeD | Plot | Image | Raw
_TYPES = {ThreeD: "3D", Plot: "Plot", Image: "Image", Raw: "RawMessages"}


@dataclass(frozen=True)
class Layout:
    """A robot's layout: its name (``servolab view --layout NAME``), what it is for, and its
    panels, the first one the largest."""

    name: str
    description: str
    panels: Sequence[Panel] = field(default_factory=tuple)

    def topics(self) -> set[str]:
        """Every topic a panel shows (what a run must publish for the layout to fill)."""
        return {topic for panel in self.panels for topic in panel.shown}

    def to_json(self) -> dict[str, Any]:
        """The layout file's content."""
        if not self.panels:
            raise ServolabValueError(f"layout {self.name!r} has no panels")
        keys = [f"{_TYPES[type(panel)]}!{panel.id}" for panel in self.panels]
        if len(set(keys)) != len(keys):
            raise ServolabValueError(f"layout {self.name!r}: two panels share an id")
        return {
            "configById": {key: panel.config() for key, panel in zip(keys, self.panels,
                                                                      strict=True)},
            "globalVariables": {}, "userNodes": {}, "linkedGlobalVariables": [],
            "playbackConfig": {"speed": 1.0},
            "layout": _mosaic(keys),
        }


def _mosaic(keys: Sequence[str]) -> str | dict[str, Any]:
    """The first panel on the left (60 %), the others stacked on the right."""
    if len(keys) == 1:
        return keys[0]
    return {"direction": "row", "first": keys[0], "second": _column(keys[1:]),
            "splitPercentage": 60}


def _column(keys: Sequence[str]) -> str | dict[str, Any]:
    if len(keys) == 1:
        return keys[0]
    return {"direction": "column", "first": keys[0], "second": _column(keys[1:]),
            "splitPercentage": 100 / len(keys)}
