"""ROS 2 message and service classes to import as rclpy code imports them::

    from servolab.interfaces.std_msgs.msg import String          # from std_msgs.msg import String
    from servolab.interfaces.std_srvs.srv import SetBool         # from std_srvs.srv import SetBool

    msg = String()                  # every field at its default, as in rclpy
    msg.data = "hello"
    req = SetBool.Request(data=True)

Each name is looked up when imported, among the types servolab knows (every ROS 2 Jazzy
interface that rosbags ships, plus dynamixel_msgs); an unknown one is an ImportError naming
it. A class builds the same message objects the rest of servolab uses (rosbags' dataclasses,
checked field by field): ``String(data=1)`` is an error naming the field, and
``isinstance(msg, String)`` is true for any ``std_msgs/msg/String``.

The modules are made on import by a finder for the ``servolab.interfaces.<package>.msg`` /
``.srv`` names, since listing several hundred types as files would only repeat what rosbags
already holds.
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import sys
import types as pytypes
from collections.abc import Sequence
from typing import Any

from servolab.middleware.default_context import default_types
from servolab.middleware.errors import MessageError


class MessageClass(type):
    """The metaclass of the classes here: calling one builds a message; ``isinstance``
    matches by ROS type name."""

    __msgtype__: str

    def __call__(cls, **fields: Any) -> Any:
        return default_types().from_value(cls.__msgtype__, fields)

    def __instancecheck__(cls, instance: Any) -> bool:
        return getattr(instance, "__msgtype__", None) == cls.__msgtype__


def message_class(type_name: str) -> type:
    """The class for ``pkg/msg/Name`` (or a service's ``pkg/srv/Name_Request``), with the
    type's constants as class attributes, as rosidl's (``GoalStatus.STATUS_SUCCEEDED``)."""
    short = type_name.rsplit("/", 1)[-1]
    known = default_types()
    known.load_package_of(type_name)
    constants = {name: value for name, _kind, value in known.store.fielddefs[type_name][0]}
    return MessageClass(short, (), {"__msgtype__": type_name, "__module__": __name__,
                                    "__doc__": f"The ROS 2 message {type_name}.",
                                    **constants})


def service_class(type_name: str) -> type:
    """The class for ``pkg/srv/Name``: ``Name.Request`` and ``Name.Response`` build the
    request and response, as rosidl's generated service classes do."""
    short = type_name.rsplit("/", 1)[-1]
    return type(short, (), {"__srvtype__": type_name, "__module__": __name__,
                            "Request": message_class(f"{type_name}_Request"),
                            "Response": message_class(f"{type_name}_Response"),
                            "__doc__": f"The ROS 2 service {type_name}."})


def action_class(type_name: str) -> type:
    """The class for ``pkg/action/Name``, as rosidl generates it: ``Name.Goal``,
    ``Name.Result`` and ``Name.Feedback`` build the three parts, and ``Name.Impl`` holds the
    services and messages an action is made of on the wire (``SendGoalService``,
    ``GetResultService``, ``FeedbackMessage``; ``CancelGoalService`` and
    ``GoalStatusMessage`` where action_msgs' are known)."""
    short = type_name.rsplit("/", 1)[-1]
    known = default_types()
    known.load_package_of(type_name)
    parts: dict[str, Any] = {
        "SendGoalService": service_class(f"{type_name}_SendGoal"),
        "GetResultService": service_class(f"{type_name}_GetResult"),
        "FeedbackMessage": message_class(f"{type_name}_FeedbackMessage")}
    for attribute, name, make in (
            ("CancelGoalService", "action_msgs/srv/CancelGoal", service_class),
            ("GoalStatusMessage", "action_msgs/msg/GoalStatusArray", message_class)):
        known.load_package_of(name)
        if name in known.store.fielddefs:
            parts[attribute] = make(name)
    impl = type("Impl", (), {"__module__": __name__, **parts})
    return type(short, (), {"__actiontype__": type_name, "__module__": __name__,
                            "Goal": message_class(f"{type_name}_Goal"),
                            "Result": message_class(f"{type_name}_Result"),
                            "Feedback": message_class(f"{type_name}_Feedback"),
                            "Impl": impl,
                            "__doc__": f"The ROS 2 action {type_name}."})


class _Kind(pytypes.ModuleType):
    """``servolab.interfaces.<package>.msg`` (or ``.srv``): classes made on first use."""

    def __init__(self, name: str, package: str, kind: str) -> None:
        super().__init__(name)
        self._package = package
        self._kind = kind

    def __getattr__(self, short: str) -> type:
        if short.startswith("__"):
            raise AttributeError(short)
        type_name = f"{self._package}/{self._kind}/{short}"
        known = default_types()
        try:
            if self._kind == "srv":
                known.service(type_name)
                cls = service_class(type_name)
            elif self._kind == "action":
                if not known.is_action(type_name):
                    raise MessageError(f"unknown action type {type_name!r}")
                cls = action_class(type_name)
            else:
                known.check(type_name)
                cls = message_class(type_name)
        except MessageError:
            raise AttributeError(f"servolab knows no {self._kind} type {type_name}") from None
        setattr(self, short, cls)
        return cls


class _Finder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Makes ``servolab.interfaces.<package>`` and ``….<package>.<msg|srv|action>`` on
    import."""

    def find_spec(self, fullname: str, path: Sequence[str] | None,
                  target: pytypes.ModuleType | None = None,
                  ) -> importlib.machinery.ModuleSpec | None:
        parts = fullname.split(".")
        if parts[:2] != ["servolab", "interfaces"] or len(parts) not in (3, 4):
            return None
        if len(parts) == 4 and parts[3] not in ("msg", "srv", "action"):
            return None
        package = parts[2]
        if not default_types().has_package(package):
            return None  # an ImportError: no such interface package
        return importlib.machinery.ModuleSpec(fullname, self, is_package=len(parts) == 3)

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> pytypes.ModuleType:
        parts = spec.name.split(".")
        if len(parts) == 4:
            return _Kind(spec.name, parts[2], parts[3])
        module = pytypes.ModuleType(spec.name)
        module.__path__ = []
        return module

    def exec_module(self, module: pytypes.ModuleType) -> None:
        pass


if not any(isinstance(f, _Finder) for f in sys.meta_path):
    sys.meta_path.append(_Finder())
