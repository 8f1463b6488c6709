"""``rclpy.node``: :class:`Node` with rclpy's shape (``rclpy/node.py``), on servolab's node.

It *is* servolab's node (:class:`servolab.middleware.node.Node`: its topics, services,
timers, parameter store and parameter services), with what an rclpy node has on top:

- rclpy's constructor: ``Node(node_name, *, context=None, cli_args=None, namespace=None,
  use_global_arguments=True, enable_rosout=True, start_parameter_services=True,
  parameter_overrides=None, allow_undeclared_parameters=False,
  automatically_declare_parameters_from_overrides=False)``, with ``--ros-args`` (``-p``,
  ``-r``, ``__node``, ``__ns``) from :func:`servolab.rclpy.init` and ``cli_args``;
- rclpy's parameter API and rules (``rclpy/node.py``): :class:`~servolab.rclpy.parameter.
  Parameter` objects, descriptors (read-only, types, integer and floating-point ranges,
  dynamic typing), pre-set / on-set / post-set callbacks, the exceptions of
  :mod:`servolab.rclpy.exceptions`, and a ``rcl_interfaces/msg/ParameterEvent`` on
  ``/parameter_events`` for each declare and set;
- ``get_clock()``: a :class:`~servolab.rclpy.clock.ROSClock` whose ``now()`` is a
  :class:`~servolab.rclpy.time.Time`; the ``use_sim_time`` parameter (``/clock``);
- its logger's records on ``/rosout`` (``rcl_interfaces/msg/Log``), as rcl's rosout
  handler publishes them;
- callback groups (``callback_group=`` on every ``create_*``) and graph queries
  (``count_publishers``, ``get_topic_names_and_types``, ``get_node_names``, ...).
"""

from __future__ import annotations

import importlib
import inspect
import logging
import math
import threading
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

from servolab.middleware import parameters as _p
from servolab.middleware.clock_node import CLOCK_QOS, CLOCK_TOPIC, CLOCK_TYPE
from servolab.middleware.errors import ParameterError
from servolab.middleware.names import fully_qualified_name as _resolve
from servolab.middleware.node import Node as _Node
from servolab.middleware.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from ._arguments import Global, RosArguments
from ._arguments import parse as _parse_arguments
from .callback_groups import CallbackGroup, MutuallyExclusiveCallbackGroup
from .client import Client
from .clock import ROSClock
from .exceptions import (
    InvalidParameterTypeException,
    InvalidParameterValueException,
    ParameterAlreadyDeclaredException,
    ParameterImmutableException,
    ParameterNotDeclaredException,
    ParameterUninitializedException,
)
from .parameter import PARAMETER_SEPARATOR_STRING, Parameter, from_stored
from .time import Time
from .timer import Timer as RosTimer
from .topic_endpoint_info import TopicEndpointInfo, TopicEndpointTypeEnum

if TYPE_CHECKING:
    from servolab.middleware.context import Context

#: rcl's rosout QoS (rcl/logging_rosout.c: depth 1000, reliable, transient local; servolab's
#: QoS has no lifespan, rcl's is 10 s)
ROSOUT_QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: rmw's qos_profile_parameter_events: depth 1000, reliable, volatile
PARAMETER_EVENTS_QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                                  durability=DurabilityPolicy.VOLATILE)
#: rcl_interfaces/msg/Log levels by Python level
_LOG_LEVELS = {logging.DEBUG: 10, logging.INFO: 20, logging.WARNING: 30, logging.ERROR: 40,
               logging.CRITICAL: 50}


def _msg(name: str) -> Any:
    return getattr(importlib.import_module("servolab.interfaces.rcl_interfaces.msg"), name)


def _result(successful: bool, reason: str = "") -> Any:
    return _msg("SetParametersResult")(successful=successful, reason=reason)


class _Rosout(logging.Handler):
    """Publishes a node logger's records on ``/rosout`` (rcl's rosout log handler)."""

    def __init__(self, node: Node) -> None:
        super().__init__()
        self.node = node
        self.publisher = node.create_publisher("rcl_interfaces/msg/Log", "/rosout", ROSOUT_QOS)
        self._inside = threading.local()

    def emit(self, record: logging.LogRecord) -> None:
        if getattr(self._inside, "yes", False) or self.node.context.closed:
            return
        self._inside.yes = True
        try:
            from servolab.middleware.node import LOGGER_PREFIX
            name = record.name.removeprefix(LOGGER_PREFIX).strip("/").replace("/", ".")
            level = max((v for k, v in _LOG_LEVELS.items() if k <= record.levelno), default=10)
            self.publisher.publish(_msg("Log")(
                stamp=self.node.get_clock().now().to_msg(), level=level, name=name,
                msg=record.getMessage(), file=record.pathname, function=record.funcName,
                line=record.lineno))
        except Exception:  # a log line must never break the node
            pass
        finally:
            self._inside.yes = False


class Node(_Node):
    """See the module docstring."""

    PARAM_REL_TOL = 1e-6

    def __init__(self, node_name: str | Context, *args: Any, context: Any = None,
                 cli_args: list[str] | None = None, namespace: str | None = None,
                 use_global_arguments: bool = True, enable_rosout: bool = True,
                 start_parameter_services: bool = True,
                 parameter_overrides: list[Parameter] | Mapping[str, Any] | None = None,
                 allow_undeclared_parameters: bool = False,
                 automatically_declare_parameters_from_overrides: bool = False,
                 enable_logger_service: bool = False,
                 remappings: Mapping[str, str] | None = None) -> None:
        if not isinstance(node_name, str):  # servolab's shape: Node(context, name[, ns])
            context, node_name, *rest = (node_name, *args)
            args = tuple(rest)
        if args:
            if namespace is not None or len(args) > 1:
                raise TypeError("Node(name, namespace) takes a namespace once, not twice")
            namespace = args[0]
        if context is None:  # a launch's node class carries the launch's; else the default
            from servolab.middleware.default_context import default_context
            from servolab.middleware.launch_file import LAUNCH_CONTEXT
            context = getattr(self, LAUNCH_CONTEXT, None) or default_context()
        arguments = RosArguments()
        if use_global_arguments:
            arguments.extend(Global.arguments)
        arguments.extend(_parse_arguments(cli_args))
        name = arguments.node_name(str(node_name))
        namespace = arguments.namespace(str(node_name), namespace)
        overrides: dict[str, Any] = {}
        if isinstance(parameter_overrides, Mapping):
            overrides.update(parameter_overrides)
        else:
            overrides.update({p.name: p._stored() for p in parameter_overrides or []})
        # rclpy's state, before servolab's node makes its entities
        self._default_callback_group: CallbackGroup = MutuallyExclusiveCallbackGroup()
        self._descriptors: dict[str, Any] = {}
        self._pre_set_parameters_callbacks: list[Callable[[list[Parameter]], Any]] = []
        self._post_set_parameters_callbacks: list[Callable[[list[Parameter]], None]] = []
        self._allow_undeclared_parameters = allow_undeclared_parameters
        self._parameter_event_publisher: Any = None
        self._rosout: _Rosout | None = None
        self._sim_time_subscription: Any = None
        self._clock = ROSClock.of(lambda: round(self.context.ros_time() * 1e9))
        remaps = dict(arguments.remappings(name))
        remaps.update(remappings or {})
        # the global -p's and the node's own; servolab's context adds its own overrides
        from servolab.middleware.names import node_namespace
        fqn = f"{node_namespace(namespace or '/', name).rstrip('/')}/{name}"
        given = arguments.overrides(fqn)
        given.update(overrides)
        super().__init__(context, name, namespace, parameter_overrides=given,
                         remappings=remaps)
        self._parameter_event_publisher = self.create_publisher(
            "rcl_interfaces/msg/ParameterEvent", "/parameter_events", PARAMETER_EVENTS_QOS)
        if enable_rosout:
            self._rosout = _Rosout(self)
            self._logger.logger.addHandler(self._rosout)
        if automatically_declare_parameters_from_overrides:
            self.declare_parameters("", [(n, v, _msg("ParameterDescriptor")())
                                         for n, v in self._overrides.items()],
                                    ignore_override=True)
        if not self.has_parameter("use_sim_time"):
            self.declare_parameter("use_sim_time", False)
        self._apply_sim_time(bool(self.get_parameter("use_sim_time").value))
        if not self.has_parameter("start_type_description_service"):
            # rclpy's TypeDescriptionService declares it (servolab offers no such service)
            self.declare_parameter("start_type_description_service", True,
                                   _msg("ParameterDescriptor")(read_only=True))

    # -- what rclpy's node holds --------------------------------------------------------------

    @property
    def default_callback_group(self) -> CallbackGroup:
        return self._default_callback_group

    def _of_kind(self, kind: type) -> list[Any]:
        return [e for e in self._entities if isinstance(e, kind)]

    @property
    def publishers(self) -> list[Any]:
        from servolab.middleware.publisher import Publisher
        return self._of_kind(Publisher)

    @property
    def subscriptions(self) -> list[Any]:
        from servolab.middleware.subscription import Subscription
        return self._of_kind(Subscription)

    @property
    def clients(self) -> list[Any]:
        return self._of_kind(Client)

    @property
    def services(self) -> list[Any]:
        from servolab.middleware.service import Service
        return self._of_kind(Service)

    @property
    def timers(self) -> list[RosTimer]:
        return self._of_kind(RosTimer)

    def get_clock(self) -> ROSClock:
        """The node's ROS clock: ``now()`` is a :class:`~servolab.rclpy.time.Time`."""
        return self._clock

    def _apply_sim_time(self, enabled: bool) -> None:
        """``use_sim_time``: the clock follows ``/clock`` (rclpy/time_source.py)."""
        self._clock._set_ros_time_is_active(enabled)
        if enabled and self._sim_time_subscription is None:
            def on_clock(msg: Any) -> None:
                now = Time.from_msg(msg.clock)
                self._clock.set_ros_time_override(now)
                for timer in self.timers:
                    timer._on_simulated_time(now.nanoseconds)
            self._sim_time_subscription = super().create_subscription(
                CLOCK_TYPE, CLOCK_TOPIC, on_clock, CLOCK_QOS)
        elif not enabled and self._sim_time_subscription is not None:
            self.destroy_entity(self._sim_time_subscription)
            self._sim_time_subscription = None

    # -- entities, with callback groups --------------------------------------------------------

    def _group(self, group: CallbackGroup | None, entity: Any = None) -> CallbackGroup:
        group = group or self._default_callback_group
        if getattr(group, "_submit", False) is None:
            group._submit = self.context.executor.submit  # type: ignore[attr-defined]
        if entity is not None:
            group.add_entity(entity)
        return group

    def create_publisher(self, msg_type: Any, topic: str, qos_profile: Any = 10,
                         *, callback_group: CallbackGroup | None = None,
                         event_callbacks: Any = None, qos_overriding_options: Any = None,
                         publisher_class: Any = None) -> Any:
        return super().create_publisher(msg_type, topic, qos_profile)

    def create_subscription(self, msg_type: Any, topic: str, callback: Callable[..., Any],
                            qos_profile: Any = 10, *,
                            callback_group: CallbackGroup | None = None,
                            event_callbacks: Any = None, qos_overriding_options: Any = None,
                            raw: bool = False, with_info: bool | None = None,
                            run_on_arrival: bool = False) -> Any:
        """As rclpy's: a callback that takes one argument gets the message, one that takes
        two gets the message and its :class:`~servolab.middleware.transport.MessageInfo`
        (rclpy/subscription.py tries one argument first). ``run_on_arrival`` is servolab's
        own (:class:`~servolab.middleware.subscription.Subscription`)."""
        if with_info is None:
            with_info = _takes_info(callback)
        group = self._group(callback_group)
        if with_info:
            def run_with_info(msg: Any, info: Any) -> None:
                group.dispatch(callback, msg, info)
            sub = super().create_subscription(msg_type, topic, run_with_info, qos_profile,
                                              raw=raw, with_info=True,
                                              run_on_arrival=run_on_arrival)
        else:
            def run(msg: Any) -> None:
                group.dispatch(callback, msg)
            sub = super().create_subscription(msg_type, topic, run, qos_profile, raw=raw,
                                              run_on_arrival=run_on_arrival)
        group.add_entity(sub)
        return sub

    def create_timer(self, timer_period_sec: float,  # type: ignore[override]
                     callback: Callable[[], Any],
                     callback_group: CallbackGroup | None = None, clock: Any = None,
                     autostart: bool = True) -> RosTimer:
        """rclpy's: ``timer.cancel()``, ``reset()``, ``is_canceled()``; ``autostart=False``
        makes a timer that waits for its first ``reset()``. The period is counted on the
        node's clock (``clock``): in simulated time while ``use_sim_time`` is true."""
        group = self._group(callback_group)
        timer = RosTimer(self.context.executor, timer_period_sec,
                         lambda: group.dispatch(callback), clock or self._clock,
                         autostart=autostart)
        group.add_entity(timer)
        self._entities.append(timer)
        return timer

    def create_service(self, srv_type: Any, srv_name: str,
                       callback: Callable[[Any, Any], Any], *, qos_profile: Any = None,
                       callback_group: CallbackGroup | None = None) -> Any:
        group = self._group(callback_group)
        service = super().create_service(srv_type, srv_name,
                                         lambda req, resp: group.run(callback, req, resp))
        group.add_entity(service)
        return service

    def create_client(self, srv_type: Any, srv_name: str, *, qos_profile: Any = None,
                      callback_group: CallbackGroup | None = None) -> Client:
        client = Client(self, self._service_type(srv_type), self.resolve(srv_name))
        self._group(callback_group, client)
        self._entities.append(client)
        return client

    # -- parameters, by rclpy's rules ----------------------------------------------------------

    def declare_parameter(self, name: str, value: Any = None,  # type: ignore[override]
                          descriptor: Any = None, ignore_override: bool = False) -> Parameter:
        """rclpy's: the value is the override if one was given, else ``value``; the
        descriptor's read-only, type and ranges apply from now on."""
        if value is None and descriptor is None:
            return self.declare_parameters("", [(name,)], ignore_override)[0]
        descriptor = _msg("ParameterDescriptor")() if descriptor is None else descriptor
        return self.declare_parameters("", [(name, value, descriptor)], ignore_override)[0]

    def declare_parameters(self, namespace: str, parameters: list[tuple[Any, ...]],
                           ignore_override: bool = False) -> list[Parameter]:
        """rclpy's: each ``(name,)``, ``(name, Parameter.Type)`` or ``(name, value,
        descriptor)``, as ``namespace.name``."""
        declared: list[Parameter] = []
        descriptors: dict[str, Any] = {}
        for index, item in enumerate(parameters):
            if not 1 <= len(item) <= 3:
                raise TypeError(f"Invalid parameter tuple length at index {index} in "
                                f"parameters list: {item}; expecting length between 1 and 3")
            name = item[0]
            if not isinstance(name, str):
                raise TypeError(f"First element {name} at index {index} in parameters list "
                                "is not a str.")
            if namespace:
                name = f"{namespace}.{name}"
            second = item[1] if len(item) > 1 else None
            descriptor = item[2] if len(item) > 2 else _msg("ParameterDescriptor")()
            if getattr(descriptor, "__msgtype__", "") != "rcl_interfaces/msg/ParameterDescriptor":
                raise TypeError(f"Third element {descriptor} at index {index} in parameters "
                                "list is not a ParameterDescriptor.")
            value: Any = None
            if len(item) == 1:
                descriptor.dynamic_typing = True
            if isinstance(second, Parameter.Type):
                if second is Parameter.Type.NOT_SET:
                    raise ValueError(f"Cannot declare parameter {{{name}}} as statically typed "
                                     "of type NOT_SET")
                if descriptor.dynamic_typing:
                    raise ValueError(f"When declaring parameter {{{name}}} passing a descriptor "
                                     "with`dynamic_typing=True` is not allowed when the "
                                     "parameter type is provided")
                descriptor.type = second.value
            else:
                value = second
                if not descriptor.dynamic_typing:
                    if getattr(value, "__msgtype__", "") == "rcl_interfaces/msg/ParameterValue":
                        descriptor.type = value.type
                    else:
                        descriptor.type = Parameter.Type.from_parameter_value(value).value
                    if descriptor.type == _p.NOT_SET:
                        raise ValueError("Cannot declare a statically typed parameter with "
                                         "default value of type PARAMETER_NOT_SET")
            if not ignore_override and name in self._overrides:
                value = self._overrides[name]
                if isinstance(value, bytes):
                    value = [bytes([b]) for b in value]
            declared.append(Parameter(name, value=value))
            descriptors[name] = descriptor
        already = [p.name for p in declared if p.name in self._parameters]
        if already:
            raise ParameterAlreadyDeclaredException(already)
        for param in declared:
            result = self._set_common([param], descriptors, allow_not_set_type=True)
            if not result.successful:
                if result.reason.startswith("Wrong parameter type"):
                    raise InvalidParameterTypeException(
                        param, Parameter.Type(descriptors[param.name].type).name)
                raise InvalidParameterValueException(param.name, param.value, result.reason)
        return [self._rclpy_parameter(p.name) for p in declared]

    def undeclare_parameter(self, name: str) -> None:
        if not self.has_parameter(name):
            raise ParameterNotDeclaredException(name)
        if self._descriptors[name].read_only:
            raise ParameterImmutableException(name)
        del self._parameters[name]
        del self._descriptors[name]

    def _rclpy_parameter(self, name: str) -> Parameter:
        stored = self._parameters[name]
        return from_stored(name, stored.type, stored.value)

    def get_parameter(self, name: str) -> Parameter:  # type: ignore[override]
        if self.has_parameter(name):
            param = self._rclpy_parameter(name)
            if param.type_ is not Parameter.Type.NOT_SET or self._descriptors[name].dynamic_typing:
                return param
            raise ParameterUninitializedException(name)
        if self._allow_undeclared_parameters:
            return Parameter(name, Parameter.Type.NOT_SET, None)
        raise ParameterNotDeclaredException(name)

    def get_parameters(self, names: list[str]) -> list[Parameter]:  # type: ignore[override]
        if not all(isinstance(name, str) for name in names):
            raise TypeError("All names must be instances of type str")
        return [self.get_parameter(name) for name in names]

    def get_parameter_or(self, name: str, alternative_value: Parameter | None = None) -> Parameter:
        if alternative_value is None:
            alternative_value = Parameter(name, Parameter.Type.NOT_SET)
        if not self.has_parameter(name) or self._parameters[name].type == _p.NOT_SET:
            return alternative_value
        return self._rclpy_parameter(name)

    def get_parameters_by_prefix(self, prefix: str) -> dict[str, Any]:
        if prefix:
            prefix = prefix + PARAMETER_SEPARATOR_STRING
        return {name[len(prefix):]: self._rclpy_parameter(name)
                for name in self._parameters if name.startswith(prefix)}

    def get_parameter_types(self, names: list[str]) -> list[Any]:
        if not all(isinstance(name, str) for name in names):
            raise TypeError("All names must be instances of type str")
        return [self.get_parameter_type(name) for name in names]

    def get_parameter_type(self, name: str) -> Any:
        """As rclpy's: the type's number for a declared parameter (``type_.value``),
        ``Parameter.Type.NOT_SET`` for an undeclared one if those are allowed."""
        if self.has_parameter(name):
            return self._parameters[name].type
        if self._allow_undeclared_parameters:
            return Parameter.Type.NOT_SET
        raise ParameterNotDeclaredException(name)

    def describe_parameter(self, name: str) -> Any:
        if not self.has_parameter(name):
            raise ParameterNotDeclaredException(name)
        return self._descriptors[name]

    def describe_parameters(self, names: list[str]) -> list[Any]:
        return [self.describe_parameter(name) for name in names]

    def list_parameters(self, prefixes: list[str], depth: int) -> Any:
        if depth < 0:
            raise ValueError("The depth must be greater than or equal to zero")
        names, found = _p.list_names(self._parameter_names(), list(prefixes), depth)
        return _msg("ListParametersResult")(names=names, prefixes=found)

    def _parameter_names(self) -> list[str]:
        """In the order they were declared, as rclpy lists them (servolab's node sorts)."""
        return list(self._parameters)

    def _descriptor(self, name: str) -> Any:
        """The descriptor as declared (ranges included), for ``~/describe_parameters``."""
        return self._descriptors[name]

    def set_parameters(self, parameter_list: Any) -> list[Any]:
        """rclpy's: one result per parameter (a ``SetParametersResult`` message), each set
        on its own; an undeclared one raises ParameterNotDeclaredException. (A mapping of
        names to values, servolab's shape, is taken too.)"""
        return [self.set_parameters_atomically([p]) for p in self._as_parameters(parameter_list)]

    def set_parameters_atomically(self, parameter_list: Any) -> Any:
        """rclpy's: all or none, with one result. A mapping of names to values (servolab's
        parameter services call this way) gives an unsuccessful result for an undeclared
        name instead of raising, as rclpy's parameter service answers."""
        if isinstance(parameter_list, Mapping):
            try:
                return self._set_atomically(self._as_parameters(parameter_list))
            except (ParameterNotDeclaredException, TypeError, ValueError) as exc:
                return _result(False, str(exc))
        return self._set_atomically(list(parameter_list))

    @staticmethod
    def _as_parameters(given: Any) -> list[Parameter]:
        if not isinstance(given, Mapping):
            return list(given)
        out = []
        for name, value in given.items():
            if isinstance(value, bytes):
                out.append(Parameter(name, Parameter.Type.BYTE_ARRAY,
                                     [bytes([b]) for b in value]))
            else:
                out.append(Parameter(name, value=value))
        return out

    def _set_atomically(self, parameter_list: list[Parameter]) -> Any:
        if self._pre_set_parameters_callbacks:
            modified: list[Parameter] = []
            for callback in self._pre_set_parameters_callbacks:
                modified.extend(callback(parameter_list))
            parameter_list = modified
            if not parameter_list:
                return _result(False, "parameter list cannot be empty, this might be due to "
                               "pre_set_parameters_callback modifying the original parameters "
                               "list.")
        if not all(isinstance(p, Parameter) for p in parameter_list):
            raise TypeError(f"parameter must be instance of type '{Parameter!r}'")
        undeclared = [p.name for p in parameter_list if p.name not in self._parameters]
        if undeclared and not self._allow_undeclared_parameters:
            # rclpy names the undeclared ones after the first: its any() has consumed the
            # generator up to it (rclpy/node.py, _check_undeclared_parameters)
            raise ParameterNotDeclaredException(undeclared[1:])
        return self._set_common(parameter_list)

    def _set_common(self, parameter_list: list[Parameter],
                    descriptors: dict[str, Any] | None = None,
                    allow_not_set_type: bool = False) -> Any:
        """rclpy's ``_set_parameters_atomically_common``: descriptors, on-set callbacks,
        store, ``/parameter_events``, post-set callbacks."""
        if descriptors is not None:
            result = self._apply_descriptors(parameter_list, descriptors, False)
        else:
            result = self._apply_descriptors(parameter_list, self._descriptors, True)
        if not result.successful:
            return result
        on_set: list[Callable[[list[Parameter]], Any]] = self._on_set_parameters  # type: ignore[assignment]
        for callback in on_set:
            result = callback(list(parameter_list))
            if not hasattr(result, "successful"):
                return _result(False, "Callback returned an invalid type")
            if not result.successful:
                return _result(False, str(getattr(result, "reason", "")))
        for param in parameter_list:
            for old_style in self._on_set:
                try:
                    old_style(param.name, param._stored())
                except ParameterError as exc:
                    return _result(False, str(exc))
        event = _msg("ParameterEvent")(node=self.fully_qualified_name)
        for param in parameter_list:
            if not allow_not_set_type and param.type_ is Parameter.Type.NOT_SET:
                event.deleted_parameters.append(param.to_parameter_msg())
                self._parameters.pop(param.name, None)
                self._descriptors.pop(param.name, None)
                continue
            if descriptors is not None:
                self._descriptors[param.name] = descriptors[param.name]
            elif param.name not in self._descriptors:
                self._descriptors[param.name] = _msg("ParameterDescriptor")(dynamic_typing=True)
            descriptor = self._descriptors[param.name]
            old = self._parameters.get(param.name)
            if old is None or old.type == _p.NOT_SET:
                event.new_parameters.append(param.to_parameter_msg())
            else:
                event.changed_parameters.append(param.to_parameter_msg())
            self._parameters[param.name] = _p.Parameter(
                param.name, param._stored(), param.type_.value, descriptor.description,
                descriptor.read_only)
            if param.name == "use_sim_time":
                self._apply_sim_time(bool(param.value))
        event.stamp = self._clock.now().to_msg()
        if self._parameter_event_publisher is not None:
            self._parameter_event_publisher.publish(event)
        for post in self._post_set_parameters_callbacks:
            post(list(parameter_list))
        return _result(True)

    def _apply_descriptors(self, parameter_list: list[Parameter], descriptors: dict[str, Any],
                           check_read_only: bool = True) -> Any:
        for param in parameter_list:
            if param.name in descriptors:
                result = self._apply_descriptor(param, descriptors[param.name], check_read_only)
                if not result.successful:
                    return result
        return _result(True)

    def _apply_descriptor(self, parameter: Parameter, descriptor: Any,
                          check_read_only: bool = True) -> Any:
        descriptor.name = parameter.name
        if check_read_only and descriptor.read_only:
            return _result(False, f"Trying to set a read-only parameter: {parameter.name}.")
        if descriptor.dynamic_typing:
            descriptor.type = parameter.type_.value
        elif self.has_parameter(parameter.name) and parameter.type_ is Parameter.Type.NOT_SET:
            return _result(False, "Static parameter cannot be undeclared")
        elif (parameter.type_ is not Parameter.Type.NOT_SET
              and parameter.type_.value != descriptor.type):
            return _result(False, "Wrong parameter type, expected "
                           f"'{Parameter.Type(descriptor.type)}' got '{parameter.type_}'")
        if parameter.type_ is Parameter.Type.INTEGER and len(descriptor.integer_range):
            return self._apply_integer_range(parameter, descriptor.integer_range[0])
        if parameter.type_ is Parameter.Type.DOUBLE and len(descriptor.floating_point_range):
            return self._apply_floating_point_range(parameter, descriptor.floating_point_range[0])
        return _result(True)

    @staticmethod
    def _apply_integer_range(parameter: Parameter, integer_range: Any) -> Any:
        low = min(integer_range.from_value, integer_range.to_value)
        high = max(integer_range.from_value, integer_range.to_value)
        value = parameter.value
        if value in (low, high):
            return _result(True)
        if not low < value < high:
            return _result(False, f"Parameter {parameter.name} out of range. Min: {low}, "
                           f"Max: {high}, value: {value}")
        if integer_range.step != 0 and (value - low) % integer_range.step != 0:
            return _result(False, f"The parameter value for {parameter.name} is not a valid "
                           f"step. Min: {low}, max: {high}, value: {value}, step: "
                           f"{integer_range.step}")
        return _result(True)

    def _apply_floating_point_range(self, parameter: Parameter, floating_range: Any) -> Any:
        low = min(floating_range.from_value, floating_range.to_value)
        high = max(floating_range.from_value, floating_range.to_value)
        value = parameter.value
        tol = self.PARAM_REL_TOL
        if math.isclose(value, low, rel_tol=tol) or math.isclose(value, high, rel_tol=tol):
            return _result(True)
        if not low < value < high:
            return _result(False, f"Parameter {parameter.name} out of range Min: {low}, "
                           f"Max: {high}, value: {value}")
        if floating_range.step != 0.0:
            steps = round((value - low) / floating_range.step)
            if not math.isclose(low + steps * floating_range.step, value, rel_tol=tol):
                return _result(False, f"The parameter value for {parameter.name} is not close "
                               f"enough to a valid step. Min: {low}, max: {high}, value: "
                               f"{value}, step: {floating_range.step}")
        return _result(True)

    def add_pre_set_parameters_callback(
            self, callback: Callable[[list[Parameter]], list[Parameter]]) -> None:
        """``callback(parameters) -> parameters`` before a set is checked (not on declare)."""
        self._pre_set_parameters_callbacks.insert(0, callback)

    def add_post_set_parameters_callback(
            self, callback: Callable[[list[Parameter]], None]) -> None:
        """``callback(parameters)`` after a set or declare succeeded."""
        if not callable(callback):
            raise TypeError("Callback must be callable, got {}", type(callback))
        self._post_set_parameters_callbacks.insert(0, callback)

    def remove_pre_set_parameters_callback(self, callback: Callable[..., Any]) -> None:
        self._pre_set_parameters_callbacks.remove(callback)

    def remove_on_set_parameters_callback(self, callback: Callable[..., Any]) -> None:
        self._on_set_parameters.remove(callback)

    def remove_post_set_parameters_callback(self, callback: Callable[..., Any]) -> None:
        self._post_set_parameters_callbacks.remove(callback)

    # -- the graph ---------------------------------------------------------------------------

    def _graph(self) -> list[Any]:
        """Every entity of the graph, one entry each (two subscriptions of one node to one
        topic count twice, as in rcl)."""
        return sorted(self.context.transport.graph(0.2))

    def _names_and_types(self, kinds: tuple[str, ...]) -> list[tuple[str, list[str]]]:
        found: dict[str, set[str]] = {}
        for e in self._graph():
            if e.kind in kinds:
                found.setdefault(e.name, set()).add(e.type_name)
        return [(name, sorted(types)) for name, types in sorted(found.items())]

    def get_topic_names_and_types(self, no_demangle: bool = False) -> list[tuple[str, list[str]]]:
        return self._names_and_types(("MP", "MS"))

    def get_service_names_and_types(self) -> list[tuple[str, list[str]]]:
        return self._names_and_types(("SS", "SC"))

    def _by_node(self, kind: str, node_name: str, node_namespace: str) -> list[
            tuple[str, list[str]]]:
        fqn = f"{node_namespace.rstrip('/')}/{node_name}"
        found: dict[str, set[str]] = {}
        for e in self._graph():
            if e.kind == kind and e.node == fqn:
                found.setdefault(e.name, set()).add(e.type_name)
        return [(name, sorted(types)) for name, types in sorted(found.items())]

    def get_publisher_names_and_types_by_node(self, node_name: str, node_namespace: str,
                                              no_demangle: bool = False) -> list[Any]:
        return self._by_node("MP", node_name, node_namespace)

    def get_subscriber_names_and_types_by_node(self, node_name: str, node_namespace: str,
                                               no_demangle: bool = False) -> list[Any]:
        return self._by_node("MS", node_name, node_namespace)

    def get_service_names_and_types_by_node(self, node_name: str,
                                            node_namespace: str) -> list[Any]:
        return self._by_node("SS", node_name, node_namespace)

    def get_client_names_and_types_by_node(self, node_name: str,
                                           node_namespace: str) -> list[Any]:
        return self._by_node("SC", node_name, node_namespace)

    def get_node_names_and_namespaces(self) -> list[tuple[str, str]]:
        out = []
        for e in self._graph():
            if e.kind == "NN":
                namespace, _, name = e.node.rpartition("/")
                out.append((name, namespace or "/"))
        return out

    def get_node_names(self) -> list[str]:
        return [name for name, _ in self.get_node_names_and_namespaces()]

    def get_fully_qualified_node_names(self) -> list[str]:
        return [e.node for e in self._graph() if e.kind == "NN"]

    def _count(self, kind: str, name: str) -> int:
        full = self.resolve(name)
        return sum(1 for e in self._graph() if e.kind == kind and e.name == full)

    def count_publishers(self, topic_name: str) -> int:
        return self._count("MP", topic_name)

    def count_subscribers(self, topic_name: str) -> int:
        return self._count("MS", topic_name)

    def count_clients(self, service_name: str) -> int:
        return self._count("SC", service_name)

    def count_services(self, service_name: str) -> int:
        return self._count("SS", service_name)

    def _info_by_topic(self, kind: str, topic_name: str, no_mangle: bool) -> list[
            TopicEndpointInfo]:
        full = topic_name if no_mangle else self.resolve(topic_name)
        endpoint = (TopicEndpointTypeEnum.PUBLISHER if kind == "MP"
                    else TopicEndpointTypeEnum.SUBSCRIPTION)
        out = []
        for e in self._graph():
            if e.kind == kind and e.name == full:
                namespace, _, name = e.node.rpartition("/")
                out.append(TopicEndpointInfo(node_name=name, node_namespace=namespace or "/",
                                             topic_type=e.type_name, endpoint_type=endpoint,
                                             qos_profile=e.qos))
        return out

    def get_publishers_info_by_topic(self, topic_name: str,
                                     no_mangle: bool = False) -> list[TopicEndpointInfo]:
        return self._info_by_topic("MP", topic_name, no_mangle)

    def get_subscriptions_info_by_topic(self, topic_name: str,
                                        no_mangle: bool = False) -> list[TopicEndpointInfo]:
        return self._info_by_topic("MS", topic_name, no_mangle)

    def resolve_topic_name(self, topic: str, *, only_expand: bool = False) -> str:
        return _resolve(topic, self.namespace, self.name) if only_expand else self.resolve(topic)

    def resolve_service_name(self, service: str, *, only_expand: bool = False) -> str:
        return self.resolve_topic_name(service, only_expand=only_expand)

    # -- life --------------------------------------------------------------------------------

    def destroy(self) -> None:
        if self._rosout is not None:
            self._logger.logger.removeHandler(self._rosout)
            self._rosout = None
        self._parameter_event_publisher = None
        super().destroy()


def _takes_info(callback: Callable[..., Any]) -> bool:
    """rclpy/subscription.py: one argument if the callback binds to one, else two."""
    try:
        signature = inspect.signature(callback)
    except (TypeError, ValueError):
        return False
    try:
        signature.bind(object())
        return False
    except TypeError:
        pass
    try:
        signature.bind(object(), object())
        return True
    except TypeError:
        return False


__all__ = ["Node"]
