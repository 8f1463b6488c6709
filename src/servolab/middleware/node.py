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

import inspect
import logging
import threading
from collections import deque
from collections.abc import Callable, Mapping
from concurrent.futures import Future
from concurrent.futures import TimeoutError as FutureTimeout
from typing import TYPE_CHECKING, Any

from .errors import MessageError, ParameterError, ServiceError
from .executor import Timer
from .messages import ServiceType
from .parameters import (
    Parameter,
    SetParametersResult,
    coerce,
    from_parameter_value,
    list_names,
    to_parameter_value,
    type_of,
)
from .rmw_zenoh import check_node_name, node_namespace
from .rmw_zenoh import fully_qualified_name as resolve_name
from .transport import MessageInfo, NodeInfo

if TYPE_CHECKING:
    from .context import Context

#: Node loggers are ``<prefix><fully qualified name>``: ``servolab.node/robot/talker``.
LOGGER_PREFIX = "servolab.node"


class Publisher:
    """Publishes messages of one type on one topic."""

    def __init__(self, node: Node, type_name: str, topic: str, depth: int, *,
                 reliable: bool = True) -> None:
        self.node = node
        self.type_name = type_name
        self.topic = topic
        self._inner = node.context.transport.advertise(node.info, topic, type_name, depth,
                                                       reliable=reliable)

    def publish(self, msg: Any) -> None:
        if getattr(msg, "__msgtype__", None) != self.type_name:
            raise MessageError(f"{self.topic} carries {self.type_name}, not "
                               f"{getattr(msg, '__msgtype__', type(msg).__name__)}")
        self._inner.publish(msg)

    def publish_serialized(self, cdr: bytes) -> None:
        """Publish CDR bytes of this publisher's type as they are (bag playback)."""
        self._inner.publish_serialized(cdr)

    def destroy(self) -> None:
        self._inner.close()


class Subscription:
    """Calls ``callback(msg)`` (or ``callback(msg, info)``) for each message on a topic.

    Up to ``depth`` messages wait for the executor (ROS's KEEP_LAST); when more arrive, the
    oldest are dropped and counted in :attr:`dropped`. ``depth=0`` keeps all (KEEP_ALL), which
    is what a recorder needs. ``raw=True`` hands the callback the CDR bytes.

    The executor holds one piece of work per message waiting, not per message received: a
    KEEP_LAST(depth) subscription never has more than ``depth`` callbacks pending, however
    fast messages arrive, and callbacks keep the order in which messages arrived.
    """

    def __init__(self, node: Node, type_name: str, topic: str, callback: Callable[..., Any],
                 depth: int, raw: bool) -> None:
        if depth < 0:
            raise ValueError(f"queue depth must be >= 0, got {depth}")
        self.node = node
        self.type_name = type_name
        self.topic = topic
        self.raw = raw
        self.dropped = 0
        self.received = 0
        self._callback = callback
        self._with_info = _takes_two(callback)
        self._queue: deque[tuple[Any, MessageInfo]] = deque(maxlen=depth or None)
        self._lock = threading.Lock()
        self._takes = 0  # _take calls queued in the executor
        self._executor = node.context.executor
        self._inner = node.context.transport.subscribe(node.info, topic, type_name, depth,
                                                       self._deliver, raw=raw)

    def _deliver(self, data: Any, info: MessageInfo) -> None:
        with self._lock:
            if self._queue.maxlen is not None and len(self._queue) == self._queue.maxlen:
                self.dropped += 1
            self._queue.append((data, info))
            self.received += 1
            if self._takes >= len(self._queue):
                return  # a message was dropped: its queued _take will take this one
            self._takes += 1
        self._executor.submit(self._take)

    @property
    def pending(self) -> int:
        """Messages waiting for the callback (at most ``depth`` unless KEEP_ALL)."""
        return len(self._queue)

    def drain(self) -> int:
        """Run the callback for every message still queued (a recorder stopping keeps what
        had already arrived); returns how many."""
        n = 0
        while self._queue:
            self._take(from_executor=False)
            n += 1
        return n

    def _take(self, from_executor: bool = True) -> None:
        with self._lock:
            if from_executor:
                self._takes -= 1
            if not self._queue:
                return  # drained while waiting
            data, info = self._queue.popleft()
        if not self.raw and isinstance(data, bytes | memoryview):
            data = self.node.context.types.deserialize(data, self.type_name)
        if self._with_info:
            self._callback(data, info)
        else:
            self._callback(data)

    def destroy(self) -> None:
        self._inner.close()


class Service:
    """Answers requests: ``handler(request, response) -> response``, as in rclpy."""

    def __init__(self, node: Node, srv: ServiceType, name: str,
                 handler: Callable[[Any, Any], Any]) -> None:
        self.node = node
        self.srv = srv
        self.name = name
        self._handler = handler
        self._inner = node.context.transport.serve(node.info, name, srv, self._on_request)

    def _on_request(self, request: Any, reply: Callable[[Any], None]) -> None:
        executor = self.node.context.executor
        if executor.in_executor_thread or executor.is_shutdown:
            self._run(request, reply)  # a call from one of our own callbacks: answer now
        else:
            executor.submit(lambda: self._run(request, reply))

    def _run(self, request: Any, reply: Callable[[Any], None]) -> None:
        types = self.node.context.types
        try:
            if isinstance(request, bytes | memoryview):
                request = types.deserialize(request, self.srv.request)
            response = self._handler(request, types.default(self.srv.response))
            if getattr(response, "__msgtype__", None) != self.srv.response:
                raise ServiceError(f"handler of {self.name} returned {response!r}, not a "
                                   f"{self.srv.response}")
        except Exception as exc:  # the caller learns why; the node keeps running
            self.node.get_logger().error("service %s failed: %s", self.name, exc)
            reply(exc)
            return
        reply(response)

    def destroy(self) -> None:
        self._inner.close()


class Client:
    """Calls a service: ``call(request)`` blocks; ``call_async`` returns a Future."""

    def __init__(self, node: Node, srv: ServiceType, name: str) -> None:
        self.node = node
        self.srv = srv
        self.name = name

    def request(self, **fields: Any) -> Any:
        return self.node.context.types.from_value(self.srv.request, fields)

    def call(self, request: Any | None = None, timeout: float = 5.0) -> Any:
        """The response, waiting up to ``timeout`` s. When no other thread spins the
        executor, this one does while it waits, so a server in this process can answer."""
        future = self.call_async(request, timeout)
        executor = self.node.context.executor
        if not executor.spinning_elsewhere:
            executor.spin_until(future.done, timeout)
        try:
            return future.result(timeout=0 if future.done() else timeout)
        except FutureTimeout:
            raise ServiceError(f"service {self.name} did not answer within "
                               f"{timeout:g} s") from None

    def call_async(self, request: Any | None = None, timeout: float = 5.0) -> Future[Any]:
        request = self.request() if request is None else request
        if getattr(request, "__msgtype__", None) != self.srv.request:
            raise MessageError(f"{self.name} takes a {self.srv.request}, not "
                               f"{getattr(request, '__msgtype__', type(request).__name__)}")
        return self.node.context.transport.call(self.name, self.srv, request, timeout)

    def wait_for_service(self, timeout: float = 5.0) -> bool:
        clock = self.node.context.clock
        end = clock.now() + timeout
        while True:
            if any(e.kind == "SS" and e.name == self.name
                   for e in self.node.context.transport.graph(0.2)):
                return True
            if clock.now() >= end:
                return False
            clock.sleep(0.05)


class Rate:
    """Keeps a loop at ``hz``, like ``ros::Rate``: :meth:`sleep` waits until the next tick.

    While it waits it runs the node's callbacks (unless another thread spins the executor),
    so a ROS 1-style loop needs no ``spinOnce``. Ticks are on a fixed schedule; a loop that
    falls a whole period behind starts a new schedule instead of bursting to catch up.
    """

    def __init__(self, node: Node, hz: float) -> None:
        if not hz > 0:
            raise ValueError(f"rate must be > 0 Hz, got {hz!r}")
        self.period = 1.0 / hz
        self._executor = node.context.executor
        self._clock = node.context.clock
        self._next = self._clock.now() + self.period

    def sleep(self) -> None:
        if self._executor.exception is not None:
            self._executor.raise_if_failed()  # the spin thread stopped on a callback's error
        now = self._clock.now()
        if now < self._next:
            if self._executor.spinning_elsewhere:
                self._clock.sleep(self._next - now)
            else:
                self._executor.spin_for(self._next - now)
            self._next += self.period
        else:
            missed = (now - self._next) // self.period + 1
            self._next += missed * self.period
            if self._next - now > self.period:
                self._next = now + self.period


class Node:
    """A named member of the graph; see the module docstring."""

    def __init__(self, context: Context, name: str, namespace: str = "/", *,
                 parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        check_node_name(name)
        self.context = context
        self.name = name
        self.namespace = node_namespace(namespace, name)
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
        self._logger = logging.getLogger(f"{LOGGER_PREFIX}{self.fully_qualified_name}")
        self._entities.append(context.transport.announce_node(self.info))
        context.add_node(self)
        self._parameter_services()

    # -- names and types ---------------------------------------------------------------------

    def resolve(self, name: str) -> str:
        """The fully qualified name of a topic or service, after remapping."""
        full = resolve_name(name, self.namespace, self.name)
        return self._remap.get(full, full)

    def _type_name(self, msg_type: str | type) -> str:
        name = msg_type if isinstance(msg_type, str) else getattr(msg_type, "__msgtype__", "")
        return self.context.types.check(name or repr(msg_type))

    def message(self, type_name: str, **fields: Any) -> Any:
        """A message with the given fields and every other field at its default."""
        return self.context.types.from_value(type_name, fields)

    # -- topics ------------------------------------------------------------------------------

    def create_publisher(self, msg_type: str | type, topic: str, depth: int = 10, *,
                         reliable: bool = True) -> Publisher:
        """A publisher keeping the last ``depth`` messages (0: all), RELIABLE by default or
        BEST_EFFORT with ``reliable=False``. As in rmw_zenoh, only RELIABLE with depth 0
        (KEEP_ALL) may make ``publish()`` wait for a slow subscriber."""
        pub = Publisher(self, self._type_name(msg_type), self.resolve(topic), depth,
                        reliable=reliable)
        self._entities.append(pub)
        return pub

    def create_subscription(self, msg_type: str | type, topic: str,
                            callback: Callable[..., Any], depth: int = 10, *,
                            raw: bool = False) -> Subscription:
        sub = Subscription(self, self._type_name(msg_type), self.resolve(topic), callback,
                           depth, raw)
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
        return self.context.clock.now()

    # -- services ----------------------------------------------------------------------------

    def create_service(self, srv_type: str, name: str,
                       handler: Callable[[Any, Any], Any]) -> Service:
        service = Service(self, self.context.types.service(srv_type), self.resolve(name),
                          handler)
        self._entities.append(service)
        return service

    def create_client(self, srv_type: str, name: str) -> Client:
        return Client(self, self.context.types.service(srv_type), self.resolve(name))

    # -- parameters --------------------------------------------------------------------------

    def declare_parameter(self, name: str, default: Any, *, description: str = "",
                          read_only: bool = False) -> Any:
        """Declare a parameter; returns its value (an override if one was given)."""
        if name in self._parameters:
            raise ParameterError(f"parameter {name} of {self.fully_qualified_name} is "
                                 "already declared")
        kind = type_of(default)
        value = coerce(name, kind, self._overrides.get(name, default))
        self._parameters[name] = Parameter(name, value, kind, description, read_only)
        return value

    def get_parameter(self, name: str) -> Any:
        return self._parameter(name).value

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
                {"name": p.name, "type": p.type, "description": p.description,
                 "read_only": p.read_only, "dynamic_typing": False}
                for p in (self._parameters[n] for n in request.names)]})

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
            names, prefixes = list_names(sorted(self._parameters), list(request.prefixes),
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

    def get_logger(self) -> logging.Logger:
        return self._logger

    def destroy(self) -> None:
        for entity in reversed(self._entities):
            if isinstance(entity, Timer):
                entity.cancel()
            elif hasattr(entity, "destroy"):
                entity.destroy()
            else:
                entity.close()
        self._entities.clear()
        self.context.remove_node(self)


def _takes_two(callback: Callable[..., Any]) -> bool:
    try:
        params = [p for p in inspect.signature(callback).parameters.values()
                  if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    except (TypeError, ValueError):
        return False
    return len(params) >= 2
