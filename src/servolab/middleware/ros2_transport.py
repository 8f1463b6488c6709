"""The ROS 2 transport: servolab's nodes on an installed ROS 2's own middleware, through its
rclpy, so that every servolab entity is an entity of the rmw a stock ROS 2 uses.

Why it exists. servolab's DDS transport (:mod:`.dds_transport`) runs on Cyclone DDS and
meets Fast DDS (Jazzy's default) on topics and the graph, but a Fast DDS *client* matches a
reply to its request by the RTPS inline QoS ``related_sample_identity``, which Cyclone DDS's
API can neither read nor write: so a stock ROS 2's ``ros2 service call``, ``ros2 param`` or
action client never gets an answer from it. Writing RTPS by hand would copy a middleware.
Instead, where ROS 2 is installed (``source /opt/ros/jazzy/setup.bash``, or ``pip install
ros-jazzy-rclpy ros-jazzy-rmw-fastrtps-cpp`` and the message packages from the package
index), this transport opens a node of the rmw that ``RMW_IMPLEMENTATION`` names (Fast DDS,
Cyclone DDS or Zenoh) for each servolab node, and carries servolab's CDR bytes through it:
publishers publish the bytes as they are, subscriptions take them raw, and services take
requests and send replies through the rmw, whose request/reply correlation is the vendor's
own. (A request or response crosses between rclpy's object and servolab's through rclpy's
``serialize_message``, whose bytes run on past the message: see
:meth:`~.messages.MessageTypes.deserialize_start`; handlers get message objects.) A servolab
server answers a request when its handler replies, which may be later than the handler
returns (an action's ``get_result``): the request's header is kept until then.

What it needs: the Python types of every interface it carries, as the installation built
them (``std_srvs.srv.SetBool``, a lab's own packages once their workspace is sourced); a
type it does not have is refused in one line naming it. Discovery is the rmw's own
(``ROS_AUTOMATIC_DISCOVERY_RANGE``, ``ROS_STATIC_PEERS``), so ``--listen`` and ``--connect``
are refused.

The one place servolab reaches into rclpy's internals is :meth:`_ServolabExecutor._take_service`
(rclpy's executor answers a service with what its callback *returns*, so a reply that
comes later needs the request's header, which only the take gives).
"""

from __future__ import annotations

import contextlib
import importlib
import logging
import os
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future
from typing import Any

from .errors import ServiceError, TransportError
from .inbox import QueueInbox, Wake
from .messages import MessageTypes, ServiceType
from .qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from .transport import (
    Closeable,
    Declared,
    Endpoint,
    Handler,
    MessageInfo,
    NodeInfo,
    Transport,
    TransportOptions,
    TransportPublisher,
    wait_for,
)

log = logging.getLogger(__name__)

#: How long one turn of the spinning thread may wait before it looks whether to stop.
SPIN_PERIOD_S = 0.1
#: How long a graph listing made at once after opening lets discovery run first.
FIRST_GRAPH_S = 1.0

_NO_RCLPY = ("--transport ros2 runs on an installed ROS 2 and could not import its rclpy "
             "({reason}): source your ROS 2 (source /opt/ros/jazzy/setup.bash), or pip install "
             "ros-jazzy-rclpy ros-jazzy-rmw-fastrtps-cpp and the message packages you use")


def _rclpy() -> Any:
    """The installed rclpy, or a one-line error saying how to get it."""
    try:
        return importlib.import_module("rclpy")
    except ImportError as exc:
        raise TransportError(_NO_RCLPY.format(reason=exc)) from None


#: The parts of an action as rosidl_generator_py holds them: ``pkg/action/X_<part>`` is
#: ``pkg.action.X.<attribute>``.
_ACTION_PARTS = {"_SendGoal": "Impl.SendGoalService", "_GetResult": "Impl.GetResultService",
                 "_FeedbackMessage": "Impl.FeedbackMessage", "_Goal": "Goal",
                 "_Result": "Result", "_Feedback": "Feedback"}


def interface_class(type_name: str) -> Any:
    """The installed ROS 2's Python class of ``pkg/msg/Name`` or ``pkg/srv/Name``, or of an
    action's part (``pkg/action/Name_SendGoal``: ``pkg.action.Name.Impl.SendGoalService``)."""
    package, kind, name = type_name.split("/")
    path = [name]
    if kind == "action":
        for suffix, attribute in _ACTION_PARTS.items():
            if name.endswith(suffix):
                path = [name[:-len(suffix)], *attribute.split(".")]
                break
    try:
        found: Any = importlib.import_module(f"{package}.{kind}")
        for attribute in path:
            found = getattr(found, attribute)
        return found
    except (ImportError, AttributeError) as exc:
        raise TransportError(
            f"the installed ROS 2 has no Python type {type_name} ({exc}): install or build "
            f"its package ({package}) and source it, or use another transport") from None


def ros_qos(qos: QoSProfile) -> Any:
    """servolab's profile as rclpy's: the policies' values are rmw's own on both sides."""
    rclpy_qos = importlib.import_module("rclpy.qos")
    return rclpy_qos.QoSProfile(
        history=rclpy_qos.HistoryPolicy(int(qos.history)),
        depth=max(qos.depth, 1) if not qos.keep_all else 1,
        reliability=rclpy_qos.ReliabilityPolicy(int(qos.reliability)),
        durability=rclpy_qos.DurabilityPolicy(int(qos.durability)))


def servolab_qos(profile: Any) -> QoSProfile:
    """A discovered endpoint's rclpy profile as servolab's (unknown policies as rmw_zenoh's
    defaults resolve them)."""
    def policy(enum: Any, value: Any, default: Any) -> Any:
        try:
            return enum(int(value))
        except ValueError:
            return default
    history = policy(HistoryPolicy, profile.history, HistoryPolicy.KEEP_LAST)
    if history not in (HistoryPolicy.KEEP_LAST, HistoryPolicy.KEEP_ALL):
        history = HistoryPolicy.KEEP_LAST
    reliability = policy(ReliabilityPolicy, profile.reliability, ReliabilityPolicy.RELIABLE)
    if reliability not in (ReliabilityPolicy.RELIABLE, ReliabilityPolicy.BEST_EFFORT):
        reliability = ReliabilityPolicy.RELIABLE
    durability = policy(DurabilityPolicy, profile.durability, DurabilityPolicy.VOLATILE)
    if durability not in (DurabilityPolicy.VOLATILE, DurabilityPolicy.TRANSIENT_LOCAL):
        durability = DurabilityPolicy.VOLATILE
    keep_all = history is HistoryPolicy.KEEP_ALL
    return QoSProfile(history=history, depth=0 if keep_all else max(int(profile.depth), 1),
                      reliability=reliability, durability=durability)


def _executor_class() -> type:
    """rclpy's single-threaded executor, taking the requests of servolab's services itself."""
    executors = importlib.import_module("rclpy.executors")
    invalid_handle = importlib.import_module("rclpy.exceptions").InvalidHandle

    class _ServolabExecutor(executors.SingleThreadedExecutor):  # type: ignore[misc, name-defined]
        def __init__(self, context: Any) -> None:
            super().__init__(context=context)
            self.answers: dict[int, Callable[[Any, Any], None]] = {}

        def _take_service(self, srv: Any) -> Any:
            answer = self.answers.get(id(srv))
            if answer is None:
                return super()._take_service(srv)
            try:
                with srv.handle:
                    request, header = srv.handle.service_take_request(srv.srv_type.Request)
            except invalid_handle:
                return None
            if header is None:
                return None

            async def _execute() -> None:
                answer(request, header)
            return _execute

    return _ServolabExecutor


class Ros2Publisher(TransportPublisher):
    def __init__(self, transport: Ros2Transport, node: Any, publisher: Any,
                 type_name: str) -> None:
        self._serialize = transport.types.writer(type_name)
        self._node = node
        self._publisher = publisher

    def publish(self, msg: Any) -> None:
        self._publisher.publish(bytes(self._serialize(msg)))

    def publish_serialized(self, cdr: bytes) -> None:
        self._publisher.publish(bytes(cdr))

    def wait_for_subscription(self, timeout: float) -> bool:
        """The rmw's matched count: a subscription this publisher's offer reaches."""
        return wait_for(lambda: self._publisher.get_subscription_count() > 0, timeout)

    def close(self) -> None:
        with contextlib.suppress(Exception):  # the node went first
            self._node.destroy_publisher(self._publisher)



class Ros2Transport(Transport):
    """See the module docstring."""

    carries_bytes = True

    def __init__(self, types: MessageTypes, options: TransportOptions | None = None) -> None:
        super().__init__(types)
        self.options = options or TransportOptions(kind="ros2")
        if self.options.listen or self.options.connect:
            raise TransportError(
                "--listen and --connect are not the ROS 2 transport's: its rmw finds peers "
                "itself (ROS_AUTOMATIC_DISCOVERY_RANGE, ROS_STATIC_PEERS)")
        rclpy = _rclpy()
        self._rclpy = rclpy
        self._serialization = importlib.import_module("rclpy.serialization")
        self._node_class = importlib.import_module("rclpy.node").Node
        signals = importlib.import_module("rclpy.signals")
        self._context = rclpy.Context()
        rclpy.init(args=[], context=self._context, domain_id=self.options.domain_id,
                   signal_handler_options=signals.SignalHandlerOptions.NO)
        self._executor = _executor_class()(self._context)
        self._lock = threading.Lock()
        self._nodes: dict[int, Any] = {}
        self._clients: dict[tuple[str, str], Any] = {}
        #: calls still waiting for their answer (failed when the transport closes)
        self._calls: set[Future[Any]] = set()
        self._closed = False
        self._opened = time.monotonic()
        try:
            self._own = self._node(f"_servolab_{os.getpid()}_{id(self):x}", "/")
        except Exception:
            self._executor.shutdown()
            self._context.try_shutdown()
            raise
        self._spinner = threading.Thread(target=self._spin, daemon=True, name="ros2 transport")
        self._spinner.start()

    def _node(self, name: str, namespace: str) -> Any:
        node = self._node_class(
            name, namespace=namespace, context=self._context, use_global_arguments=False,
            enable_rosout=False, start_parameter_services=False)
        self._executor.add_node(node)
        return node

    def _spin(self) -> None:
        while not self._closed:
            try:
                self._executor.spin_once(timeout_sec=SPIN_PERIOD_S)
            except Exception as exc:
                if self._closed or not self._context.ok():
                    return
                log.error("the ROS 2 transport's executor: %s", exc)

    def _node_of(self, node: NodeInfo) -> Any:
        with self._lock:
            ros_node = self._nodes.get(node.node_id)
        if ros_node is None:
            raise TransportError(f"node {node.fully_qualified_name} is not announced")
        return ros_node

    # -- graph of nodes ----------------------------------------------------------------------

    def announce_node(self, node: NodeInfo) -> Closeable:
        ros_node = self._node(node.name, node.namespace)
        with self._lock:
            self._nodes[node.node_id] = ros_node

        def forget() -> None:
            with self._lock:
                self._nodes.pop(node.node_id, None)
                for key in [k for k, c in self._clients.items() if c[1] is ros_node]:
                    del self._clients[key]
            self._executor.remove_node(ros_node)
            ros_node.destroy_node()
        return Declared(forget)

    # -- topics ------------------------------------------------------------------------------

    def advertise(self, node: NodeInfo, topic: str, type_name: str,
                  qos: QoSProfile) -> Ros2Publisher:
        ros_node = self._node_of(node)
        publisher = ros_node.create_publisher(interface_class(type_name), topic, ros_qos(qos))
        return Ros2Publisher(self, ros_node, publisher, type_name)

    def subscribe(self, node: NodeInfo, topic: str, type_name: str, qos: QoSProfile,
                  wake: Wake, *, raw: bool = False) -> QueueInbox:
        ros_node = self._node_of(node)
        inbox = QueueInbox(qos.queue_depth, wake)

        def on_message(data: bytes, info: dict[str, int]) -> None:
            inbox.put(data, MessageInfo(
                int(info.get("source_timestamp", 0)),
                int(info.get("received_timestamp", 0)) or time.time_ns(),
                int(info.get("publication_sequence_number", 0) or 0)))

        subscription = ros_node.create_subscription(
            interface_class(type_name), topic, on_message, ros_qos(qos), raw=True)

        def close() -> None:
            with contextlib.suppress(Exception):  # the node went first
                ros_node.destroy_subscription(subscription)
        inbox.on_close(close)
        return inbox

    # -- services ----------------------------------------------------------------------------

    def serve(self, node: NodeInfo, name: str, srv: ServiceType, handler: Handler) -> Closeable:
        """An rmw service whose requests go to ``handler`` as CDR; its ``reply`` sends the
        response with the request's header whenever it comes, from any thread."""
        ros_node = self._node_of(node)
        srv_class = interface_class(srv.name)
        serialization = self._serialization
        invalid_handle = importlib.import_module("rclpy.exceptions").InvalidHandle

        def unreachable(request: Any, response: Any) -> Any:  # the executor answers instead
            raise AssertionError("servolab's executor takes this service's requests")

        service = ros_node.create_service(srv_class, name, unreachable)

        def answer(request: Any, header: Any) -> None:
            def reply(response: Any) -> None:
                if isinstance(response, Exception):
                    # rmw has no error reply: the client's wait ends at its timeout
                    log.error("service %s failed: %s", name, response)
                    return
                try:
                    cdr = bytes(self.types.serialize(response, srv.response))
                    service.send_response(
                        serialization.deserialize_message(cdr, srv_class.Response), header)
                except invalid_handle:
                    pass  # the service closed before its answer was ready
                except Exception as exc:  # the client went away (rclpy's RCLError), ...
                    log.warning("service %s: the answer could not be sent: %s", name, exc)

            try:
                handler(self.types.deserialize_start(
                    serialization.serialize_message(request), srv.request), reply)
            except Exception as exc:
                reply(exc)

        self._executor.answers[id(service)] = answer

        def close() -> None:
            with contextlib.suppress(Exception):  # the node went first
                ros_node.destroy_service(service)
            self._executor.answers.pop(id(service), None)
        return Declared(close)

    def declare_client(self, node: NodeInfo, name: str, srv: ServiceType) -> Closeable:
        """An rmw client of ``node``: the graph shows it, and calls to ``name`` use it."""
        ros_node = self._node_of(node)
        client = ros_node.create_client(interface_class(srv.name), name)
        key = (name, srv.name)
        with self._lock:
            self._clients.setdefault(key, (client, ros_node))

        def close() -> None:
            with self._lock:
                if self._clients.get(key, (None,))[0] is client:
                    del self._clients[key]
            with contextlib.suppress(Exception):  # the node went first
                ros_node.destroy_client(client)
        return Declared(close)

    def _client(self, name: str, srv: ServiceType) -> Any:
        key = (name, srv.name)
        with self._lock:
            held = self._clients.get(key)
            if held is None:
                held = self._clients[key] = (
                    self._own.create_client(interface_class(srv.name), name), self._own)
        return held[0]

    def call(self, name: str, srv: ServiceType, request: Any, timeout: float) -> Future[Any]:
        future: Future[Any] = Future()
        with self._lock:
            self._calls.add(future)
        future.add_done_callback(self._calls.discard)
        client = self._client(name, srv)
        srv_class = interface_class(srv.name)
        request_object = self._serialization.deserialize_message(
            bytes(self.types.serialize(request, srv.request)), srv_class.Request)

        def resolve(done: Any) -> None:
            if future.done():
                return
            try:
                cdr = self._serialization.serialize_message(done.result())
                future.set_result(self.types.deserialize_start(cdr, srv.response))
            except Exception as exc:
                future.set_exception(ServiceError(f"service {name}: bad response ({exc})"))

        def run() -> None:
            end = time.monotonic() + timeout
            try:
                if not client.wait_for_service(timeout_sec=timeout):
                    raise ServiceError(
                        f"no service {name} answered within {timeout:g} s (is its node "
                        "running, in the same ROS_DOMAIN_ID and discovery range?)")
                pending = client.call_async(request_object)
                pending.add_done_callback(resolve)
                try:
                    future.exception(timeout=max(0.0, end - time.monotonic()))
                except TimeoutError:
                    client.remove_pending_request(pending)
                    raise ServiceError(f"service {name} did not answer within the timeout") \
                        from None
            except Exception as exc:  # never leave the caller waiting
                if not future.done():
                    future.set_exception(exc if isinstance(exc, ServiceError)
                                         else ServiceError(f"service {name}: {exc}"))

        threading.Thread(target=run, daemon=True, name=f"call {name}").start()
        return future

    # -- graph -------------------------------------------------------------------------------

    def graph(self, timeout: float = 0.5) -> list[Endpoint]:
        """The rmw's graph, node by node; topics with the QoS their endpoints offer or ask.
        Soon after opening (a command that lists at once) discovery first gets up to
        :data:`FIRST_GRAPH_S`."""
        wait = min(timeout, FIRST_GRAPH_S) - (time.monotonic() - self._opened)
        if wait > 0:
            time.sleep(wait)
        own = self._own
        endpoints: list[Endpoint] = []
        qos_of: dict[tuple[str, str, str], QoSProfile] = {}

        def topic_qos(kind: str, topic: str, fqn: str) -> QoSProfile | None:
            if (kind, topic, fqn) not in qos_of:
                infos = (own.get_publishers_info_by_topic(topic) if kind == "MP"
                         else own.get_subscriptions_info_by_topic(topic))
                for info in infos:
                    owner = f"{info.node_namespace.rstrip('/')}/{info.node_name}"
                    qos_of.setdefault((kind, topic, owner), servolab_qos(info.qos_profile))
            return qos_of.get((kind, topic, fqn))

        for node_name, namespace in own.get_node_names_and_namespaces():
            fqn = f"{namespace.rstrip('/')}/{node_name}"
            endpoints.append(Endpoint("NN", fqn))
            listings = (
                ("MP", own.get_publisher_names_and_types_by_node),
                ("MS", own.get_subscriber_names_and_types_by_node),
                ("SS", own.get_service_names_and_types_by_node),
                ("SC", own.get_client_names_and_types_by_node),
            )
            for kind, listing in listings:
                try:
                    names_and_types = listing(node_name, namespace)
                except Exception:  # the node left between the two questions
                    continue
                for name, type_names in names_and_types:
                    for type_name in type_names:
                        qos = topic_qos(kind, name, fqn) if kind in ("MP", "MS") else None
                        endpoints.append(Endpoint(kind, fqn, name, type_name, qos))
        return endpoints

    def close(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
            nodes = [*self._nodes.values(), self._own]
            self._nodes.clear()
            self._clients.clear()
            waiting = list(self._calls)
        for future in waiting:  # nobody waits for an answer that cannot come any more
            with contextlib.suppress(Exception):  # answered meanwhile
                future.set_exception(ServiceError("the ROS 2 transport closed before the "
                                                  "answer came"))
        if threading.current_thread() is not self._spinner:
            self._spinner.join(5.0)
        for node in nodes:
            try:
                self._executor.remove_node(node)
                node.destroy_node()
            except Exception:  # already gone
                pass
        self._executor.shutdown()
        self._context.try_shutdown()


__all__ = ["Ros2Transport", "interface_class", "ros_qos", "servolab_qos"]
