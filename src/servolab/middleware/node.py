"""Nodes: the unit of a robot's graph, with an API in the spirit of rclpy.

A node has a name and a namespace; it publishes and subscribes to topics, runs timers and
``Rate`` loops, declares parameters and offers services. It is built on a
:class:`~servolab.middleware.context.Context`, which holds the transport, the message types,
the clock and the executor, so the same node code runs in one process or across machines::

    with Context.open() as ctx:
        node = Node(ctx, "talker")
        pub = node.create_publisher("geometry_msgs/msg/Twist", "/cmd_vel")
        rate = node.create_rate(4.5)               # ros::Rate loop_rate(4.5) of seed 001
        while ctx.ok():
            pub.publish(node.message("geometry_msgs/msg/Twist", linear={"x": 0.1}))
            rate.sleep()                           # runs callbacks while it waits
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import TYPE_CHECKING, Any

from .client import Client
from .errors import ParameterError
from .executor import Timer
from .logger import NodeLogger
from .messages import ServiceType, time_of
from .names import check_node_name, node_namespace
from .names import fully_qualified_name as resolve_name
from .parameters import (
    Parameter,
    SetParametersResult,
    coerce,
    from_parameter_value,
    list_names,
    to_parameter_value,
    type_of,
)
from .publisher import Publisher
from .qos import QoSProfile, as_profile
from .rate import Rate
from .service import Service
from .subscription import Subscription
from .transport import LOGGER_PREFIX, NodeInfo

if TYPE_CHECKING:
    from .context import Context

__all__ = ["LOGGER_PREFIX", "Node"]


class Node:
    """A named member of the graph; see the module docstring."""

    def __init__(self, context: Context | str, name: str | None = None,
                 namespace: str | None = None, *,
                 parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        """``Node(context, "name")`` puts the node on a context you opened; rclpy's
        ``Node("name")`` (or ``Node("name", namespace="/robot")``) on the default context,
        which :func:`servolab.rclpy.init` opens (or the first such node, in-process)."""
        if isinstance(context, str):  # rclpy's shape: Node(node_name, *, namespace=...)
            if name is not None and namespace is None:
                name, namespace = context, name
            elif name is not None:
                raise TypeError("Node(name, namespace) takes a namespace once, not twice")
            else:
                name = context
            from .default_context import default_context
            context = default_context()
        if name is None:
            raise TypeError("Node(context, name): the node needs a name")
        check_node_name(name)
        self.context = context
        self.name = name
        self.namespace = node_namespace(namespace or "/", name)
        self.info = NodeInfo(name, self.namespace, context.next_node_id())
        self.fully_qualified_name = self.info.fully_qualified_name
        self._remap = {resolve_name(k, self.namespace, name): resolve_name(v, self.namespace, name)
                       for k, v in (remappings or {}).items()}
        self._overrides = dict(context.parameter_overrides.for_node(self.fully_qualified_name))
        self._overrides.update(parameter_overrides or {})
        self._parameters: dict[str, Parameter] = {}
        self._on_set: list[Callable[[str, Any], None]] = []
        self._on_set_parameters: list[Callable[[list[Parameter]], Any]] = []
        self._entities: list[Any] = []
        self._logger = NodeLogger(logging.getLogger(self.info.logger_name))
        self._entities.append(context.transport.announce_node(self.info))
        context.add_node(self)
        self._parameter_services()

    def get_name(self) -> str:
        return self.name

    def get_namespace(self) -> str:
        return self.namespace

    def get_fully_qualified_name(self) -> str:
        return self.fully_qualified_name

    # -- names and types ---------------------------------------------------------------------

    def resolve(self, name: str) -> str:
        """The fully qualified name of a topic or service, after remapping."""
        full = resolve_name(name, self.namespace, self.name)
        return self._remap.get(full, full)

    def _type_name(self, msg_type: str | type) -> str:
        name = msg_type if isinstance(msg_type, str) else getattr(msg_type, "__msgtype__", "")
        return self.context.types.check(name or repr(msg_type))

    def _service_type(self, srv_type: str | type) -> ServiceType:
        name = srv_type if isinstance(srv_type, str) else getattr(srv_type, "__srvtype__", "")
        return self.context.types.service(name or repr(srv_type))

    def message(self, type_name: str, **fields: Any) -> Any:
        """A message with the given fields and every other field at its default."""
        return self.context.types.from_value(type_name, fields)

    # -- topics ------------------------------------------------------------------------------

    def create_publisher(self, msg_type: str | type, topic: str,
                         qos_profile: QoSProfile | int = 10) -> Publisher:
        """A publisher with the given QoS: a :class:`~.qos.QoSProfile`, or a depth as in
        rclpy (KEEP_LAST of it, RELIABLE, VOLATILE; 0: KEEP_ALL). As in rmw_zenoh, only
        RELIABLE + KEEP_ALL may make ``publish()`` wait for a slow subscriber;
        TRANSIENT_LOCAL keeps the last ``depth`` messages for subscriptions that come later.
        ``msg_type`` is a type name (``"geometry_msgs/msg/Twist"``) or a message class."""
        pub = Publisher(self, self._type_name(msg_type), self.resolve(topic),
                        as_profile(qos_profile))
        self._entities.append(pub)
        return pub

    def create_subscription(self, msg_type: str | type, topic: str,
                            callback: Callable[..., Any], qos_profile: QoSProfile | int = 10,
                            *, raw: bool = False, with_info: bool = False,
                            run_on_arrival: bool = False) -> Subscription:
        """``callback(msg)`` for each message (``callback(msg, info)`` with
        ``with_info=True``; ``raw=True`` gives the CDR bytes). QoS as for publishers; a
        TRANSIENT_LOCAL subscription receives what TRANSIENT_LOCAL publishers kept.
        ``run_on_arrival=True``: over Zenoh, a message that finds the executor idle is run on
        the thread that received it, a thread wake-up sooner (:class:`Subscription`)."""
        sub = Subscription(self, self._type_name(msg_type), self.resolve(topic), callback,
                           as_profile(qos_profile), raw=raw, with_info=with_info,
                           run_on_arrival=run_on_arrival)
        self._entities.append(sub)
        return sub

    # -- time --------------------------------------------------------------------------------

    def create_timer(self, period: float, callback: Callable[[], Any]) -> Timer:
        timer = Timer(self.context.executor, period, callback)
        self._entities.append(timer)
        return timer

    def create_rate(self, hz: float) -> Rate:
        return Rate(self, hz)

    def now(self) -> float:
        """The context clock's reading in seconds: monotonic, for durations, timers and rates.
        A message's stamp is :meth:`stamp`, not this (it is not ROS time on a wall clock)."""
        return self.context.clock.now()

    def stamp(self, t: float | None = None) -> dict[str, int]:
        """A ``builtin_interfaces/msg/Time`` value (``header={"stamp": node.stamp()}``) of the
        clock reading ``t`` (default: now) in ROS time (:meth:`Context.ros_time
        <servolab.middleware.context.Context.ros_time>`): the one way every node of a
        context stamps, so two nodes' stamps compare, and rviz2, tf2 and ``ros2 bag`` date
        them as ROS would (the epoch's time in real time, simulated time beside ``/clock``).
        ``t`` is a reading of :meth:`now` taken earlier (a frame's capture time)."""
        return time_of(self.context.ros_time(t))

    # -- services ----------------------------------------------------------------------------

    def create_service(self, srv_type: str | type, name: str,
                       handler: Callable[[Any, Any], Any]) -> Service:
        """``handler(request, response) -> response``, as in rclpy; ``srv_type`` is a type
        name (``"std_srvs/srv/Trigger"``) or a service class."""
        service = Service(self, self._service_type(srv_type), self.resolve(name), handler)
        self._entities.append(service)
        return service

    def create_client(self, srv_type: str | type, name: str) -> Client:
        client = Client(self, self._service_type(srv_type), self.resolve(name))
        self._entities.append(client)
        return client

    # -- parameters --------------------------------------------------------------------------

    def declare_parameter(self, name: str, default: Any, *, description: str = "",
                          read_only: bool = False, kind: int | None = None) -> Parameter:
        """Declare a parameter; returns it as rclpy does (``.value`` is an override if one
        was given, else ``default``). ``kind`` (a ParameterType) types it where the default
        cannot say (``[]`` for a string array), as rclpy's descriptor does."""
        if name in self._parameters:
            raise ParameterError(f"parameter {name} of {self.fully_qualified_name} is "
                                 "already declared")
        kind = type_of(default) if kind is None else kind
        value = coerce(name, kind, self._overrides.get(name, default))
        self._parameters[name] = Parameter(name, value, kind, description, read_only)
        return replace(self._parameters[name])

    def get_parameter(self, name: str) -> Parameter:
        """The parameter (a copy: ``.value``, ``.type``), as rclpy's ``get_parameter``."""
        return replace(self._parameter(name))

    def get_parameters(self, names: list[str]) -> list[Parameter]:
        return [self.get_parameter(name) for name in names]

    def has_parameter(self, name: str) -> bool:
        return name in self._parameters

    def set_parameter(self, name: str, value: Any) -> None:
        """Change a parameter at run time; a refusal (read-only, wrong type, an on-set
        callback's veto) raises :class:`ParameterError` with the reason."""
        self._parameter(name)
        result = self.set_parameters_atomically({name: value})
        if not result.successful:
            raise ParameterError(result.reason)

    def set_parameters(self, values: Mapping[str, Any]) -> list[SetParametersResult]:
        """Set each parameter on its own (rclpy's ``Node.set_parameters``): one result each."""
        return [self.set_parameters_atomically({name: value}) for name, value in values.items()]

    def set_parameters_atomically(self, values: Mapping[str, Any]) -> SetParametersResult:
        """Set all of ``values`` or, if any is refused, none (rclpy's
        ``Node.set_parameters_atomically``); the result says which and why. On-set callbacks
        run once, with every new :class:`Parameter`."""
        undeclared = [name for name in values if name not in self._parameters]
        if undeclared:  # rclpy: ParameterNotDeclaredException, its text as the reason
            return SetParametersResult(
                False, f"Invalid access to undeclared parameter(s): {undeclared}")
        new: list[Parameter] = []
        for name, value in values.items():
            param = self._parameters[name]
            if param.read_only:  # rclpy's _apply_descriptor, word for word
                return SetParametersResult(False,
                                           f"Trying to set a read-only parameter: {name}.")
            if value is None:  # PARAMETER_NOT_SET: rclpy undeclares only dynamic ones
                return SetParametersResult(False, "Static parameter cannot be undeclared")
            try:
                value = coerce(name, param.type, value)
            except ParameterError as exc:
                return SetParametersResult(False, str(exc))
            new.append(Parameter(name, value, param.type, param.description, param.read_only))
        for callback in self._on_set_parameters:
            result = callback(list(new))
            if not hasattr(result, "successful"):
                return SetParametersResult(False, f"on-set-parameters callback {callback!r} "
                                           f"returned {result!r}, not a SetParametersResult")
            if not result.successful:
                return SetParametersResult(False, str(getattr(result, "reason", "")))
        for param in new:
            for old_style in self._on_set:
                try:
                    old_style(param.name, param.value)
                except ParameterError as exc:
                    return SetParametersResult(False, str(exc))
        for param in new:
            self._parameters[param.name].value = param.value
        return SetParametersResult(True, "")

    def add_on_set_parameters_callback(self, callback: Callable[[list[Parameter]], Any]) -> None:
        """rclpy's: ``callback(parameters)`` runs before a change with the new
        :class:`Parameter` s and returns a :class:`SetParametersResult` (or the
        ``rcl_interfaces`` message); ``successful=False`` refuses the whole set with its
        ``reason``. Like rclpy, the last added runs first."""
        self._on_set_parameters.insert(0, callback)

    def add_on_set_parameter_callback(self, callback: Callable[[str, Any], None]) -> None:
        """``callback(name, value)`` runs before a change; raising ParameterError refuses it."""
        self._on_set.append(callback)

    def parameters(self) -> dict[str, Any]:
        return {name: p.value for name, p in sorted(self._parameters.items())}

    def _parameter(self, name: str) -> Parameter:
        try:
            return self._parameters[name]
        except KeyError:
            known = ", ".join(sorted(self._parameters)) or "none"
            raise ParameterError(f"{self.fully_qualified_name} has no parameter {name!r} "
                                 f"(it has {known})") from None

    def _parameter_names(self) -> list[str]:
        """The names ``~/list_parameters`` answers, in its order (servolab's: sorted)."""
        return sorted(self._parameters)

    def _descriptor(self, name: str) -> Any:
        """What ``~/describe_parameters`` answers for a declared parameter: an
        ``rcl_interfaces/msg/ParameterDescriptor`` or its fields."""
        p = self._parameters[name]
        return {"name": p.name, "type": p.type, "description": p.description,
                "read_only": p.read_only, "dynamic_typing": False}

    def _parameter_services(self) -> None:
        """The rcl_interfaces services every ROS 2 node offers, so ``servolab param`` (and
        ``ros2 param`` over rmw_zenoh) can reach this node's parameters from anywhere."""
        types = self.context.types

        # Each handler answers as rclpy's ParameterService (rclpy/parameter_service.py) does
        # for a node that does not allow undeclared parameters: a name not declared makes
        # get / get_types / describe answer an empty list, and a set answer unsuccessful.

        def known(names: Any) -> bool:
            return all(n in self._parameters for n in names)

        def describe_parameters(request: Any, response: Any) -> Any:
            if not known(request.names):
                return response
            return types.from_value(response.__msgtype__, {"descriptors": [
                self._descriptor(n) for n in request.names]})

        def get_parameter_types(request: Any, response: Any) -> Any:
            if not known(request.names):
                return response
            return types.from_value(response.__msgtype__, {
                "types": [self._parameters[n].type for n in request.names]})

        def get_parameters(request: Any, response: Any) -> Any:
            if not known(request.names):
                return response
            response.values = [to_parameter_value(types, p.value, p.type)
                               for p in (self._parameters[n] for n in request.names)]
            return response

        def list_parameters(request: Any, response: Any) -> Any:
            names, prefixes = list_names(self._parameter_names(), list(request.prefixes),
                                         int(request.depth))
            return types.from_value(response.__msgtype__,
                                    {"result": {"names": names, "prefixes": prefixes}})

        def decoded(param: Any) -> tuple[str, Any] | SetParametersResult:
            try:
                return param.name, from_parameter_value(param.value)
            except ParameterError as exc:
                return SetParametersResult(False, str(exc))

        def set_one(param: Any) -> SetParametersResult:
            item = decoded(param)
            if isinstance(item, SetParametersResult):
                return item
            return self.set_parameters_atomically(dict([item]))

        def set_parameters(request: Any, response: Any) -> Any:
            results = [set_one(p) for p in request.parameters]
            return types.from_value(response.__msgtype__, {"results": [
                {"successful": r.successful, "reason": r.reason} for r in results]})

        def set_parameters_atomically(request: Any, response: Any) -> Any:
            items = [decoded(p) for p in request.parameters]
            refused = [i for i in items if isinstance(i, SetParametersResult)]
            result = refused[0] if refused else self.set_parameters_atomically(
                dict(i for i in items if not isinstance(i, SetParametersResult)))
            return types.from_value(response.__msgtype__, {"result": {
                "successful": result.successful, "reason": result.reason}})

        for srv, handler in (("DescribeParameters", describe_parameters),
                             ("GetParameterTypes", get_parameter_types),
                             ("GetParameters", get_parameters),
                             ("ListParameters", list_parameters),
                             ("SetParameters", set_parameters),
                             ("SetParametersAtomically", set_parameters_atomically)):
            snake = "".join(f"_{c.lower()}" if c.isupper() else c for c in srv).lstrip("_")
            self.create_service(f"rcl_interfaces/srv/{srv}", f"~/{snake}", handler)

    # -- logging and life --------------------------------------------------------------------

    def get_logger(self) -> NodeLogger:
        return self._logger

    def get_clock(self) -> Any:
        """The context's clock (wall time, or a simulation's): ``now()``, ``sleep()``."""
        return self.context.clock

    def own(self, entity: Any) -> Any:
        """Keep an entity made outside this node's ``create_*`` (an action's services,
        clients and topics) so that :meth:`destroy` and :meth:`destroy_entity` release it
        with the rest; returns it."""
        self._entities.append(entity)
        return entity

    def destroy_entity(self, entity: Any) -> bool:
        """Destroy one publisher, subscription, service, client or timer of this node (as
        rclpy's ``destroy_subscription`` and its kin); False if it is not this node's."""
        if entity not in self._entities:
            return False
        self._entities.remove(entity)
        self._release_entity(entity)
        return True

    @staticmethod
    def _release_entity(entity: Any) -> None:
        if isinstance(entity, Timer):
            entity.cancel()
        elif hasattr(entity, "destroy"):
            entity.destroy()
        else:
            entity.close()

    destroy_publisher = destroy_subscription = destroy_service = destroy_client = \
        destroy_timer = destroy_entity

    def destroy(self) -> None:
        for entity in reversed(self._entities):
            self._release_entity(entity)
        self._entities.clear()
        self.context.remove_node(self)

    def destroy_node(self) -> None:
        """rclpy's name for :meth:`destroy`."""
        self.destroy()

