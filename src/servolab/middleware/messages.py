"""ROS 2 message and service types, and their CDR bytes, through ``rosbags``.

servolab speaks ROS 2's own types so that its topics, bags and Zenoh payloads are what ROS 2
tools expect. The types come from the ``rosbags`` type store of ROS 2 Jazzy (std_msgs,
geometry_msgs, sensor_msgs, nav_msgs, tf2_msgs, diagnostic_msgs, rcl_interfaces, ...), plus
the types of the seeds' ROS 1 ``dynamixel_motor`` stack and a few services, registered here
from their ``.msg`` / ``.srv`` text. CDR serialization is code generated per type from rosbags'
type descriptions (:mod:`.fast_cdr`), checked byte for byte against rosbags' own.

A :class:`MessageTypes` is the one place that knows a type by name. It also turns the YAML
values a user types (``"{linear: {x: 0.1}, angular: {z: 0.5}}"``, as ``rostopic pub`` takes
them) into a message, checking every field, and a message back into plain values for
``topic echo``.
"""

from __future__ import annotations

import array
import difflib
import re
import struct
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import yaml
from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from .errors import MessageError
from .fast_cdr import FastCdr
from .interface_files import (
    InterfacePackage,
    environment_roots,
    field_defaults,
    find_packages,
    parse_default,
    read_package,
)
from .message_build import Builder, Slow, compile_builder

if TYPE_CHECKING:
    from rosbags.interfaces.typing import BaseDesc, FieldDesc, NameDesc

#: ``dynamixel_msgs`` of the ROS 1 ``dynamixel_motor`` stack (001 Figure 3.2), field for field.
#: ``MotorState`` is in the motor's raw units, as the original is; ``JointState`` is in radians.
DYNAMIXEL_MSGS = {
    "dynamixel_msgs/msg/MotorState": """\
float64 timestamp   # motor state is at this time
int32 id            # motor id
int32 goal          # commanded position (in encoder units)
int32 position      # current position (in encoder units)
int32 error         # difference between current and goal positions
int32 speed         # current speed (0.111 rpm per unit)
float64 load        # current load - ratio of applied torque over maximum torque
float64 voltage     # current voltage (V)
int32 temperature   # current temperature (degrees Celsius)
bool moving         # whether the motor is currently in motion
""",
    "dynamixel_msgs/msg/MotorStateList": "dynamixel_msgs/MotorState[] motor_states\n",
    "dynamixel_msgs/msg/JointState": """\
std_msgs/Header header
string name         # joint name
int32[] motor_ids   # motor ids controlling this joint
int32[] motor_temps # motor temperatures, same order as motor_ids
float64 goal_pos    # commanded position (in radians)
float64 current_pos # current joint position (in radians)
float64 error       # error between commanded and current positions (in radians)
float64 velocity    # current joint speed (in radians per second)
float64 load        # current load
bool is_moving      # is joint currently in motion
""",
}

#: ``turtlebot3_msgs`` (ROBOTIS-GIT/turtlebot3_msgs, msg/SensorState.msg): what a TurtleBot3
#: publishes on ``sensor_state``, the raw wheel encoder counts among it (seed 002 Listing 4).
TURTLEBOT3_MSGS = {
    "turtlebot3_msgs/msg/SensorState": """\
uint8 BUMPER_FORWARD = 1
uint8 BUMPER_BACKWARD = 2
uint8 CLIFF = 1
uint8 SONAR = 1
uint8 ILLUMINATION = 1
uint8 BUTTON0 = 1
uint8 BUTTON1 = 2
uint8 ERROR_LEFT_MOTOR = 1
uint8 ERROR_RIGHT_MOTOR = 2
uint8 TORQUE_ON = 1
uint8 TORQUE_OFF = 2
std_msgs/Header header
uint8 bumper
float32 cliff
float32 sonar
float32 illumination
uint8 led
uint8 button
bool torque
int32 left_encoder
int32 right_encoder
float32 battery
""",
}

#: The controller-manager services' request, the same in StartController and
#: RestartController (dynamixel_controllers/srv/StartController.srv, RestartController.srv).
_CONTROLLER_SPEC = """\
string port_name            # serial port that this controller is connected to
string package_path         # path to ROS package containing controller module
string module_name          # name of the controller module within that package
string class_name           # controller class name within that module
string controller_name      # path to controller config parameters on param server
string[] dependencies       # optional, list names of all controllers this controller depends on
"""
_SUCCESS_REASON = "bool success\nstring reason\n"

#: ``dynamixel_controllers`` of the ROS 1 ``dynamixel_motor`` stack, exactly as its ``.srv``
#: files define them (arebgun/dynamixel_motor, ``dynamixel_controllers/srv/*.srv``; the file
#: of each is named on its line): name -> (request text, response text). Each joint controller
#: offers the first six, the controller manager the last three. An empty response (``---``
#: with nothing after it) is ROS 2's empty message: one ``uint8
#: structure_needs_at_least_one_member``, as rosidl (and rosbags) make it.
DYNAMIXEL_SRVS = {
    # srv/SetSpeed.srv
    "dynamixel_controllers/srv/SetSpeed": ("float64 speed\n", ""),
    # srv/TorqueEnable.srv
    "dynamixel_controllers/srv/TorqueEnable": ("bool torque_enable\n", ""),
    # srv/SetComplianceSlope.srv: "See Dynamixel documentation for details"
    "dynamixel_controllers/srv/SetComplianceSlope": ("uint8 slope\n", ""),
    # srv/SetComplianceMargin.srv: "Range is 0 to 255, larger value = more error"
    "dynamixel_controllers/srv/SetComplianceMargin": ("uint8 margin\n", ""),
    # srv/SetCompliancePunch.srv: "See Dynamixel documentation for details"
    "dynamixel_controllers/srv/SetCompliancePunch": ("uint8 punch\n", ""),
    # srv/SetTorqueLimit.srv: "Set maximum motor torque in percenatge (0 - no torque to 1 -
    # maximum torque)" (sic: a fraction, not a percentage)
    "dynamixel_controllers/srv/SetTorqueLimit": ("float64 torque_limit\n", ""),
    # srv/StartController.srv
    "dynamixel_controllers/srv/StartController": (_CONTROLLER_SPEC, _SUCCESS_REASON),
    # srv/StopController.srv
    "dynamixel_controllers/srv/StopController": ("string controller_name\n", _SUCCESS_REASON),
    # srv/RestartController.srv
    "dynamixel_controllers/srv/RestartController": (_CONTROLLER_SPEC, _SUCCESS_REASON),
}

#: Services: name -> (request text, response text).
SERVICES = {
    **DYNAMIXEL_SRVS,
    # std_srvs
    "std_srvs/srv/Empty": ("", ""),
    "std_srvs/srv/Trigger": ("", "bool success\nstring message\n"),
    "std_srvs/srv/SetBool": ("bool data\n", "bool success\nstring message\n"),
    # rcl_interfaces: the parameter services every ROS 2 node offers.
    "rcl_interfaces/srv/ListParameters": (
        "uint64 DEPTH_RECURSIVE=0\nstring[] prefixes\nuint64 depth\n",
        "rcl_interfaces/ListParametersResult result\n"),
    "rcl_interfaces/srv/GetParameters": (
        "string[] names\n", "rcl_interfaces/ParameterValue[] values\n"),
    "rcl_interfaces/srv/SetParameters": (
        "rcl_interfaces/Parameter[] parameters\n",
        "rcl_interfaces/SetParametersResult[] results\n"),
    "rcl_interfaces/srv/SetParametersAtomically": (
        "rcl_interfaces/Parameter[] parameters\n",
        "rcl_interfaces/SetParametersResult result\n"),
    "rcl_interfaces/srv/DescribeParameters": (
        "string[] names\n", "rcl_interfaces/ParameterDescriptor[] descriptors\n"),
    "rcl_interfaces/srv/GetParameterTypes": ("string[] names\n", "uint8[] types\n"),
    # example_interfaces: the service of rmw_zenoh's design examples.
    "example_interfaces/srv/AddTwoInts": ("int64 a\nint64 b\n", "int64 sum\n"),
}

_INT_RANGES = {
    "int8": (-(2**7), 2**7 - 1), "uint8": (0, 2**8 - 1), "byte": (0, 255), "char": (0, 255),
    "int16": (-(2**15), 2**15 - 1), "uint16": (0, 2**16 - 1),
    "int32": (-(2**31), 2**31 - 1), "uint32": (0, 2**32 - 1),
    "int64": (-(2**63), 2**63 - 1), "uint64": (0, 2**64 - 1),
}
_FLOATS = {"float32", "float64"}
_DTYPES = {"bool": np.bool_, "byte": np.uint8, "char": np.uint8, "int8": np.int8,
           "uint8": np.uint8, "int16": np.int16, "uint16": np.uint16, "int32": np.int32,
           "uint32": np.uint32, "int64": np.int64, "uint64": np.uint64,
           "float32": np.float32, "float64": np.float64}


@dataclass(frozen=True)
class ServiceType:
    """A service's name and the names of its request and response message types."""

    name: str

    @property
    def request(self) -> str:
        return f"{self.name}_Request"

    @property
    def response(self) -> str:
        return f"{self.name}_Response"


def time_of(seconds: float) -> dict[str, int]:
    """A ``builtin_interfaces/msg/Time`` value of a time in seconds (a clock's ``now()``): whole
    seconds and the rest in nanoseconds, rounded once so that ``nanosec`` never reaches 1e9."""
    ns = round(seconds * 1e9)
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def seconds_of(stamp: Any) -> float:
    """The time in seconds of a ``builtin_interfaces/msg/Time`` (a message's ``header.stamp``),
    the inverse of :func:`time_of`."""
    return int(stamp.sec) + int(stamp.nanosec) * 1e-9


def canonical_name(name: str) -> str:
    """``pkg/msg/Name`` for ``pkg/Name`` (ROS 1 spelling) or ``pkg/msg/Name``."""
    parts = name.strip().split("/")
    if len(parts) == 2 and all(parts):
        return f"{parts[0]}/msg/{parts[1]}"
    return name.strip()


#: The interface packages servolab ships (what rosbags' store lacks: action_msgs' CancelGoal,
#: test_msgs' and example_interfaces' Fibonacci, ...), read as a lab's own are.
SHIPPED_INTERFACES = Path(__file__).resolve().parents[1] / "interfaces" / "packages"


class MessageTypes:
    """The message and service types servolab knows, and their CDR bytes.

    One instance per process is enough (building it parses every ``.msg`` text once); pass it
    to whatever needs it rather than reaching for a global.

    Beside rosbags' ROS 2 Jazzy types, servolab's own and the packages it ships
    (:data:`SHIPPED_INTERFACES`), it registers the interface packages found in
    ``interface_path`` (folders; by default those
    ``SERVOLAB_INTERFACE_PATH`` lists, as ROS reads ``AMENT_PREFIX_PATH``): a lab's own
    ``.msg``, ``.srv`` and ``.action`` files (:mod:`.interface_files`).
    """

    def __init__(self, extra_msgs: Mapping[str, str] | None = None, *,
                 interface_path: Iterable[str | Path] | None = None) -> None:
        self.store = get_typestore(Stores.ROS2_JAZZY)
        #: the store's CDR code, generated per type on first use (rosbags stays the oracle)
        self.cdr = FastCdr(self.store)
        self._readers: dict[str, Callable[[bytes | memoryview], Any]] = {}
        #: each type's RIHS01 hash, computed once: a type once known never changes, and every
        #: entity of a node announces its type's hash (benchmarks/fleet.py: rosbags' hashing
        #: was a third of making a node)
        self._hashes: dict[str, str] = {}
        #: per type, its fields' default values (from ``type name default`` lines), as plain
        #: values: rosbags' parser drops them
        self._defaults: dict[str, dict[str, Any]] = {}
        #: from_value's fast path per type (message_build); forgotten when types change
        self._builders: dict[str, Builder] = {}
        #: the shipped packages not read yet, by name: each is read and registered when one
        #: of its types is first asked for (:meth:`load_package_of`), since parsing all of
        #: them (control_msgs, controller_manager_msgs, ...) would add about half a second to
        #: every servolab process, most of which use none of them
        self._unread: dict[str, Path] = {folder.name: folder
                                         for folder in find_packages([SHIPPED_INTERFACES])}
        #: held while types are registered or listed: a shipped package is read on whichever
        #: thread first asks (an executor's, the DDS dispatcher's, the view's), and rosbags'
        #: store is plain dicts (re-entrant: registering one package may read another)
        self._registering = threading.RLock()
        self._reading: set[str] = set()   # the shipped packages being read now
        self._fix_service_event_info()
        self._register({})
        self.register_msgs(DYNAMIXEL_MSGS)
        self.register_msgs(TURTLEBOT3_MSGS)
        for name, (request, response) in SERVICES.items():
            self.register_service(name, request, response)
        if extra_msgs:
            self.register_msgs(extra_msgs)
        roots = environment_roots() if interface_path is None else list(interface_path)
        for folder in find_packages(roots):  # a lab's own: read now, so a bad file is an
            package = read_package(folder)    # error before anything moves
            self.load_package_of(f"{package.name}/")  # a shipped one of that name first
            self.register_package(package)

    # -- registering ------------------------------------------------------------------------

    def load_package_of(self, type_name: str) -> None:
        """Read and register the shipped package ``type_name`` belongs to (``pkg/...``), if it
        has not been yet; anything else is left as it is."""
        package = type_name.split("/", 1)[0]
        if package not in self._unread:
            return
        with self._registering:
            folder = self._unread.get(package)
            if folder is None or package in self._reading:
                return   # read meanwhile by another thread, or being read by this one
            self._reading.add(package)
            try:
                self.register_package(read_package(folder))
                del self._unread[package]   # only once all of it is there
            finally:
                self._reading.discard(package)

    def load_all(self) -> None:
        """Read every shipped package not read yet: for what lists every type."""
        for package in list(self._unread):
            self.load_package_of(f"{package}/")

    def has_package(self, package: str) -> bool:
        """Whether any type of ``package`` is known (shipped, read or not yet)."""
        with self._registering:
            return package in self._unread or any(n.startswith(f"{package}/")
                                                  for n in self.store.fielddefs)

    def is_action(self, name: str) -> bool:
        """Whether ``name`` (``pkg/action/Name``) is a known action type; reads its shipped
        package only, not every one (as :meth:`action_names` must)."""
        self.load_package_of(name)
        with self._registering:
            return name in self.store.fielddefs and f"{name}_SendGoal" in self.store.fielddefs

    def _register(self, types: Any) -> None:
        """Register types with the store, and check assignments to their fields
        (:func:`_field_setter`). rosbags makes one class per type for the whole process, so
        the check is on every user of that class in the process (rosbags' own reader too,
        which servolab calls only for what its generated code leaves to it), bound to the
        first :class:`MessageTypes` that registered it."""
        with self._registering:
            self.store.register(types)
            self._builders.clear()
            self._hashes.clear()   # a type that uses a newly registered one hashes anew
            for name, cls in self.store.types.items():
                if "__setattr__" not in vars(cls):
                    cls.__setattr__ = _field_setter(self, name)  # type: ignore[method-assign]

    def _fix_service_event_info(self) -> None:
        """rosbags 0.11 declares ``ServiceEventInfo.client_gid`` as ``char[16]``; ROS 2 Jazzy's
        ``service_msgs`` has ``uint8[16]``. With ``uint8`` the service type hashes equal
        rosidl's (rmw_zenoh's ``AddTwoInts`` example), so the key expressions match ROS 2's."""
        consts, fields = self.store.fielddefs["service_msgs/msg/ServiceEventInfo"]
        fields = [(n, (Nodetype.ARRAY, ((Nodetype.BASE, ("uint8", 0)), 16)))
                  if n == "client_gid" else (n, d) for n, d in fields]
        self.store.fielddefs["service_msgs/msg/ServiceEventInfo"] = (consts, fields)
        # and its char fields, which rosidl makes uint8 (std_msgs/Char, rmw_dds_common/Gid:
        # their hashes then equal rosidl's own, ros-jazzy-std-msgs' Char.json)
        fixed = _as_rosidl(dict(self.store.fielddefs))
        for name, definition in fixed.items():
            if definition != self.store.fielddefs[name]:
                self.store.fielddefs[name] = definition
        self._hashes.clear()

    def register_msgs(self, texts: Mapping[str, str]) -> None:
        """Register message types from their ``.msg`` text, keyed by ``pkg/msg/Name``."""
        types: dict[str, Any] = {}
        for name, text in texts.items():
            try:
                types.update(get_types_from_msg(text, canonical_name(name)))
            except Exception as exc:  # rosbags raises its own parser errors
                raise MessageError(f"message definition {name}: {exc}") from None
        self._check_references(types)
        self._register(_as_rosidl(types))
        for name, text in texts.items():
            self._keep_defaults(canonical_name(name), text)

    def _keep_defaults(self, name: str, text: str) -> None:
        """The default values ``text`` gives ``name``'s fields, each checked as a value of
        its field (a one-line :class:`MessageError` naming the field), as rosidl allows them:
        on numbers, bools, strings and their arrays."""
        written = field_defaults(text)
        if not written:
            return
        fields = dict(self.store.fielddefs[name][1])
        kept: dict[str, Any] = {}
        for field, raw in written.items():
            where = f"{name}.{field}"
            desc = fields.get(field)
            if desc is not None and desc[0] == Nodetype.BASE:
                base, sequence = desc[1][0], False
            elif desc is not None and desc[0] in (Nodetype.ARRAY, Nodetype.SEQUENCE) \
                    and desc[1][0][0] == Nodetype.BASE:
                base, sequence = desc[1][0][1][0], True
            else:
                raise MessageError(f"{where}: a default value ({raw}) is allowed on a number, "
                                   "bool or string field or an array of them")
            try:
                value = parse_default(base, raw, sequence)
            except MessageError as exc:
                raise MessageError(f"{where}: default {exc}") from None
            self._field(desc, value, f"{where} (its default)")
            kept[field] = value
        self._defaults[name] = kept
        self._builders.clear()  # a builder made before knew none of these defaults

    def register_service(self, name: str, request: str, response: str) -> ServiceType:
        """Register a service from its request and response text, as rosidl generates it:
        ``_Request``, ``_Response``, ``_Event`` and the service type itself (which only
        exists to give the service its RIHS01 hash)."""
        if name.count("/") != 2 or "/srv/" not in name:
            raise MessageError(f"service type {name!r} must be spelled pkg/srv/Name")
        package = name.split("/")[0]
        self._register_service(name, _absolute_types(request, package),
                               _absolute_types(response, package))
        return ServiceType(name)

    def register_action(self, name: str, goal: str, result: str, feedback: str) -> None:
        """Register an action from its goal, result and feedback text, expanded as rosidl
        expands it (rosidl_generator_type_description; checked against its ``.json`` for
        test_msgs/action/Fibonacci): ``_Goal``, ``_Result`` and ``_Feedback``; the
        ``_SendGoal`` service (goal id and goal; accepted and stamp), the ``_GetResult``
        service (goal id; status and result), the ``_FeedbackMessage`` (goal id and
        feedback); and the action type itself, whose fields name all six, for its hash."""
        if name.count("/") != 2 or "/action/" not in name:
            raise MessageError(f"action type {name!r} must be spelled pkg/action/Name")
        uuid = "unique_identifier_msgs/UUID goal_id\n"
        types: dict[str, Any] = {}
        package = name.split("/")[0]
        goal, result, feedback = (_absolute_types(t, package) for t in (goal, result, feedback))
        for type_name, text in ((f"{name}_Goal", goal), (f"{name}_Result", result),
                                (f"{name}_Feedback", feedback),
                                (f"{name}_FeedbackMessage",
                                 f"{uuid}{name}_Feedback feedback\n")):
            try:
                types.update(get_types_from_msg(text, type_name))
            except Exception as exc:  # rosbags raises its own parser errors
                raise MessageError(f"action definition {name}: {exc}") from None
        self._check_references(types, also=(f"{name}_Feedback",))
        self._register(_as_rosidl(types))
        for part, text in (("_Goal", goal), ("_Result", result), ("_Feedback", feedback)):
            self._keep_defaults(f"{name}{part}", text)
        self._register_service(f"{name}_SendGoal", f"{uuid}{name}_Goal goal\n",
                               "bool accepted\nbuiltin_interfaces/Time stamp\n")
        self._register_service(f"{name}_GetResult", uuid,
                               f"int8 status\n{name}_Result result\n")
        self._register(get_types_from_msg(
            f"{name}_Goal goal\n{name}_Result result\n{name}_Feedback feedback\n"
            f"{name}_SendGoal send_goal_service\n{name}_GetResult get_result_service\n"
            f"{name}_FeedbackMessage feedback_message\n", name))

    def _check_references(self, types: Mapping[str, Any], also: Iterable[str] = ()) -> None:
        """Every type ``types`` name is known (already, among themselves, or in ``also``),
        or a one-line error naming the type and what it uses: rosbags' ``.msg`` parser takes
        an unknown word for a type of the same package (``wstring``, which it does not
        support, becomes ``pkg/msg/wstring``)."""
        known = set(self.store.fielddefs) | set(types) | set(also)
        for name, (_, definition) in types.items():
            for field_name, desc in definition:
                for ref in _references(desc):
                    if ref not in known and ref.split("/", 1)[0] in self._unread:
                        self.load_package_of(ref)   # a shipped package this one uses
                        known |= set(self.store.fielddefs)
                    if ref not in known:
                        short = ref.rsplit("/", 1)[-1]
                        why = (" (wstring fields are not supported: rosbags' .msg parser does "
                               "not know them)" if short == "wstring" else "")
                        raise MessageError(f"{name}: field {field_name!r} uses {ref}, which is "
                                           f"not a known type{why}")

    def register_package(self, package: InterfacePackage) -> None:
        """Register a package's messages, services and actions read from its files
        (:func:`~.interface_files.read_package`); its messages first, all at once, so that
        they may use each other in any order."""
        try:
            self.register_msgs(package.msgs)
            for name, (request, response) in package.srvs.items():
                self.register_service(name, request, response)
            for name, (goal, result, feedback) in package.actions.items():
                self.register_action(name, goal, result, feedback)
        except MessageError as exc:
            raise MessageError(f"{package.file_of(str(exc))}: {exc}") from None

    def action_names(self) -> list[str]:
        """Every known action type name (``pkg/action/Name``), sorted."""
        self.load_all()
        with self._registering:
            return sorted(n for n in self.store.fielddefs
                          if "/action/" in n and f"{n}_SendGoal" in self.store.fielddefs)

    def _register_service(self, name: str, request: str, response: str) -> None:
        texts = {
            f"{name}_Request": request,
            f"{name}_Response": response,
            f"{name}_Event": (f"service_msgs/ServiceEventInfo info\n{name}_Request[<=1] request\n"
                              f"{name}_Response[<=1] response\n"),
            name: (f"{name}_Request request_message\n{name}_Response response_message\n"
                   f"{name}_Event event_message\n"),
        }
        types: dict[str, Any] = {}
        for type_name, text in texts.items():
            try:
                types.update(get_types_from_msg(text, type_name))
            except Exception as exc:  # rosbags raises its own parser errors
                raise MessageError(f"service definition {name}: {exc}") from None

        def srv(value: Any) -> Any:  # rosbags files pkg/srv/X under pkg/srv/msg/X
            if isinstance(value, str):
                return value.replace("/srv/msg/", "/srv/")
            if isinstance(value, tuple | list):
                return type(value)(srv(v) for v in value)
            return value

        types = {srv(k): srv(v) for k, v in types.items()}
        self._check_references(types)
        self._register(_as_rosidl(types))
        self._keep_defaults(f"{name}_Request", request)
        self._keep_defaults(f"{name}_Response", response)

    # -- looking up -------------------------------------------------------------------------

    def names(self) -> list[str]:
        """Every known message type name, sorted."""
        self.load_all()
        with self._registering:
            return sorted(n for n in self.store.fielddefs if "/msg/" in n)

    def service_names(self) -> list[str]:
        """Every known service type name (``pkg/srv/Name``), sorted."""
        self.load_all()
        with self._registering:
            return sorted(n for n in self.store.fielddefs
                          if "/srv/" in n and f"{n}_Request" in self.store.fielddefs)

    def service(self, name: str) -> ServiceType:
        """The service type of that name (``pkg/srv/Name``, or ``pkg/Name`` as ``ros2 service
        call`` also takes it), or a one-line :class:`MessageError` naming it, with a guess
        when one is near (the same name in another package, or a near spelling)."""
        given = name
        name = name.strip()
        parts = name.split("/")
        if len(parts) == 2 and all(parts):
            name = f"{parts[0]}/srv/{parts[1]}"
        self.load_package_of(name)
        if name in self.store.fielddefs and f"{name}_Request" in self.store.fielddefs:
            return ServiceType(name)
        known = self.service_names()
        short = name.rsplit("/", 1)[-1]
        hint = [n for n in known if n.rsplit("/", 1)[-1] == short]
        if not hint:
            by_short = {n.rsplit("/", 1)[-1]: n for n in known}
            hint = [n for n in difflib.get_close_matches(name, known, n=1, cutoff=0.8)]
            hint += [by_short[s] for s in difflib.get_close_matches(short, by_short, n=1)]
        if hint:
            also = f" (did you mean {hint[0]}?)"
        elif canonical_name(name) in self.store.fielddefs:
            also = " (that is a message type, not a service)"
        else:
            also = ""
        raise MessageError(f"unknown service type {given!r}{also}")

    def get(self, name: str) -> type:
        """The message class for ``pkg/msg/Name`` (or ``pkg/Name``)."""
        return self.store.types[self.check(name)]

    def check(self, name: str) -> str:
        """The canonical name of a known message type, or a one-line :class:`MessageError`."""
        full = canonical_name(name)
        self.load_package_of(full)
        if full not in self.store.fielddefs:
            hint = [n for n in self.names() if n.rsplit("/", 1)[-1] == full.rsplit("/", 1)[-1]]
            also = f" (did you mean {hint[0]}?)" if hint else ""
            raise MessageError(f"unknown message type {name!r}{also}")
        return full

    def type_of(self, msg: Any) -> str:
        name = getattr(msg, "__msgtype__", None)
        if not isinstance(name, str):
            raise MessageError(f"{type(msg).__name__} is not a ROS message")
        return name

    # -- bytes ------------------------------------------------------------------------------

    def serialize(self, msg: Any, name: str | None = None) -> bytes:
        """CDR (little-endian, with its 4-byte encapsulation header), as rmw and rosbag2 use:
        :mod:`.fast_cdr`'s code generated for the type, which writes rosbags' bytes (and
        leaves to rosbags whatever it does not take) several times faster."""
        name = name or self.type_of(msg)
        self.load_package_of(name)  # a message another MessageTypes built, of a package unread
        return self.cdr.serialize(msg, name)

    def writer(self, name: str) -> Callable[[Any], bytes]:
        """:meth:`serialize` for one type, as one function (what a publisher calls for every
        message it publishes)."""
        return self.cdr.writer(self.check(name))

    def deserialize(self, data: bytes | memoryview, name: str) -> Any:
        """The message of CDR bytes of either byte order, as rosbags builds it (through
        :mod:`.fast_cdr`), or a one-line :class:`MessageError`."""
        return self.reader(name)(data)

    def deserialize_start(self, data: bytes, name: str) -> Any:
        """The message at the start of little-endian CDR bytes that may run on past it:
        rmw_fastrtps' ``rmw_serialize`` (rclpy's ``serialize_message``) returns its size
        *estimate* as the length, with up to an alignment's slack per field of bytes it never
        wrote after the message, which a reader of the wire (rosbags, :meth:`deserialize`)
        rightly refuses. Read by rosbags' own code, which says where the message ends."""
        if len(data) < 4 or data[:2] != b"\x00\x01":
            raise MessageError(f"{len(data)} bytes are not little-endian CDR of {name}")
        msgdef = self.store.get_msgdef(self.check(name))
        try:
            message, _end = msgdef.deserialize_cdr_le(data[4:], 0, msgdef.cls, self.store)
        except (struct.error, UnicodeDecodeError, ValueError, IndexError) as exc:
            raise MessageError(f"{len(data)} bytes are not a CDR {name}: {exc}") from None
        return message

    def reader(self, name: str) -> Callable[[bytes | memoryview], Any]:
        """:meth:`deserialize` for one type, as one function (what a subscription calls for
        every message it receives)."""
        read = self._readers.get(name)
        if read is None:
            read = self._readers[name] = self.cdr.reader(self.check(name))
        return read

    def msgdef(self, name: str) -> str:
        """The ``ros2msg`` schema text (the type and every type it uses) that rosbag2 writes."""
        return self.store.generate_msgdef(self.check(name), ros_version=2)[0]

    def rihs01(self, name: str) -> str:
        """The REP-2016 type hash, ``RIHS01_<sha256>``."""
        found = self._hashes.get(name)
        if found is None:
            self.load_package_of(name)
            found = self._hashes[name] = self.store.hash_rihs01(name)
        return found

    @staticmethod
    def dds_name(name: str) -> str:
        """``geometry_msgs::msg::dds_::Twist_``: the type name DDS and rmw_zenoh use."""
        pkg, kind, short = name.split("/")
        return f"{pkg}::{kind}::dds_::{short}_"

    # -- values -----------------------------------------------------------------------------

    def default(self, name: str) -> Any:
        """A message as ROS constructs one: each field its definition's default value where
        the file gives one, else zero, empty or false."""
        return self.from_value(name, {})

    def from_yaml(self, name: str, text: str) -> Any:
        """A message from YAML, as ``rostopic pub`` takes it: a mapping of fields, a list of
        the fields in order, or a bare value for a one-field type (``Float64 1.5``)."""
        name = self.check(name)
        try:
            value = yaml.safe_load(text) if text.strip() else {}
        except yaml.YAMLError as exc:
            line = getattr(getattr(exc, "problem_mark", None), "line", None)
            where = f" (line {line + 1})" if line is not None else ""
            raise MessageError(f"values for {name} are not YAML{where}: {text!r}") from None
        try:
            return self.from_value(name, value)
        except MessageError as exc:
            raise MessageError(f"{name} {exc}") from None

    def builder(self, name: str) -> Builder:
        """The fast path of :meth:`from_value` for one type (:mod:`.message_build`), made
        once."""
        build = self._builders.get(name)
        if build is None:
            canonical = self.check(name)
            build = self._builders.get(canonical) or compile_builder(self, canonical)
            self._builders[canonical] = self._builders[name] = build
        return build

    def from_value(self, name: str, value: Any, path: str = "") -> Any:
        """A message of type ``name`` from plain values; every field is checked and a
        missing one takes its default. What the type's builder takes (:mod:`.message_build`)
        is built at once; anything else, and every error, takes the walk below, which names
        the field's path."""
        try:
            return self.builder(name)(value)
        except Slow:
            pass
        name = self.check(name)
        _, fields = self.store.fielddefs[name]
        given = getattr(value, "__msgtype__", None)
        if given is not None:
            if given != name:
                raise MessageError(f"{path or name}: a {given} where a {name} belongs")
            return value
        if not isinstance(value, Mapping):
            if isinstance(value, list) and len(value) == len(fields):
                value = {f: v for (f, _), v in zip(fields, value, strict=True)}
            elif len(fields) == 1:
                value = {fields[0][0]: value}
            else:
                raise MessageError(f"{path or name}: {value!r} is not a mapping of the fields of "
                                   f"{name} ({', '.join(f for f, _ in fields)})")
        known = {f for f, _ in fields}
        for key in value:
            if key not in known:
                raise MessageError(f"{_join(path, str(key))}: {name} has no field {key!r} "
                                   f"(it has {', '.join(sorted(known)) or 'none'})")
        kwargs = {}
        defaults = self._defaults.get(name, {})
        for field, desc in fields:
            where = _join(path, field)
            if field in value:
                kwargs[field] = self._field(desc, value[field], where)
            elif field in defaults:   # the .msg file's own default, as rosidl's classes have
                kwargs[field] = self._field(desc, defaults[field], where)
            else:
                kwargs[field] = self._field_default(desc, where)
        return _built(self.store.types[name], kwargs)

    # rosbags describes a field as (Nodetype, detail); what the detail is depends on the
    # Nodetype, so these branch on ``desc[0]``, which tells the type checker which one it is.
    def _field_default(self, desc: FieldDesc, where: str) -> Any:
        if desc[0] == Nodetype.BASE:
            base = desc[1][0]
            return "" if base in ("string", "wstring") else self._scalar(base, 0, where)
        if desc[0] == Nodetype.NAME:
            return self.from_value(desc[1], {}, where)
        if desc[0] == Nodetype.ARRAY:
            sub, count = desc[1]
            return self._field(desc, [self._element_default(sub, where)] * count, where)
        return self._field(desc, [], where)

    def _element_default(self, sub: BaseDesc | NameDesc, where: str) -> Any:
        return self._field_default(sub, where)

    def _field(self, desc: FieldDesc, value: Any, where: str) -> Any:
        if desc[0] == Nodetype.BASE:
            scalar = self._scalar(desc[1][0], value, where, desc[1][1])
            # a byte field holds its octet signed, as rosbags does; an array of them is uint8
            return _signed_octet(scalar) if desc[1][0] == "byte" else scalar
        if desc[0] == Nodetype.NAME:
            name = desc[1]
            if name == "builtin_interfaces/msg/Time" and value == "now":
                value = time_of(time.time_ns() * 1e-9)
            return self.from_value(name, value, where)
        kind = desc[0]
        sub, count = desc[1]
        if isinstance(value, bytes | bytearray | memoryview):
            value = np.frombuffer(value, dtype=np.uint8)
        elif isinstance(value, array.array):  # a sequence as rclpy holds it: its own numbers
            value = np.array(value)
        if isinstance(value, np.ndarray) and sub[0] == Nodetype.BASE and sub[1][0] in _DTYPES:
            return self._array(sub[1][0], value, kind, count, where)
        if isinstance(value, np.ndarray):
            value = value.tolist()
        if not isinstance(value, list):
            raise MessageError(f"{where}: {value!r} is not a list")
        if kind == Nodetype.ARRAY and len(value) != count:
            raise MessageError(f"{where}: needs exactly {count} values, got {len(value)}")
        if kind == Nodetype.SEQUENCE and count and len(value) > count:
            raise MessageError(f"{where}: holds at most {count} values, got {len(value)}")
        if sub[0] == Nodetype.BASE:  # numbers as they are: an array's dtype holds them
            items = [self._scalar(sub[1][0], v, f"{where}[{i}]", sub[1][1])
                     for i, v in enumerate(value)]
        else:
            items = [self._field(sub, v, f"{where}[{i}]") for i, v in enumerate(value)]
        if sub[0] == Nodetype.BASE and sub[1][0] in _DTYPES:
            return np.array(items, dtype=_DTYPES[sub[1][0]])
        return items

    def _assignment_checks(self, name: str) -> dict[str, Callable[[Any], Any]]:
        """Per field of ``name``, what checks and converts a value assigned to it."""
        constants, fields = self.store.fielddefs[name]
        checks = {field: self._assignment_check(desc, f"{name}.{field}")
                  for field, desc in fields}
        for constant, _kind, fixed in constants:  # rosbags' __init__ sets them as they are
            def keep(value: Any, constant: str = constant, fixed: Any = fixed) -> Any:
                if value != fixed:
                    raise MessageError(f"{name}.{constant} is a constant ({fixed!r})")
                return value
            checks[constant] = keep

        def msgtype(value: Any) -> Any:  # what rosbags' __init__ sets: the type's own name
            if value != name:
                raise MessageError(f"{name}.__msgtype__ is {name!r}, not {value!r}")
            return value
        checks["__msgtype__"] = msgtype
        return checks

    def _assignment_check(self, desc: Any, where: str) -> Callable[[Any], Any]:
        if desc[0] == Nodetype.BASE:
            kind, bound = desc[1]
            if kind in _FLOATS:
                def scalar(value: Any) -> Any:
                    return value if type(value) is float else self._scalar(kind, value, where)
                return scalar
            if kind == "byte":  # an octet: rosbags reads it signed, ROS writes 0..255
                def octet(value: Any) -> Any:
                    if isinstance(value, bool) or not isinstance(value, int | np.integer) \
                            or not -128 <= int(value) <= 255:
                        raise MessageError(f"{where}: {value!r} is not a byte (0..255)")
                    return _signed_octet(int(value))
                return octet
            return lambda value: self._scalar(kind, value, where, bound)
        if desc[0] == Nodetype.NAME:
            nested = desc[1]

            def message(value: Any) -> Any:
                if getattr(value, "__msgtype__", None) != nested:
                    raise MessageError(f"{where}: {value!r} is not a {nested}")
                return value
            return message
        kind = desc[0]
        sub, count = desc[1]
        element = sub[1][0] if sub[0] == Nodetype.BASE else ""
        code = _TYPECODES.get(element) if kind == Nodetype.SEQUENCE else None

        def sequence(value: Any) -> Any:
            if type(value) is np.ndarray and element in _DTYPES:
                if element == "byte" and value.dtype == np.int8:
                    return value  # byte[] as rosbags reads it: the same octets
                return self._array(element, value, kind, count, where)
            if code is not None and isinstance(value, array.array) \
                    and value.typecode == code and not (count and len(value) > count):
                return value
            if isinstance(value, str) or not isinstance(
                    value, list | tuple | array.array | np.ndarray | bytes | bytearray
                    | memoryview):
                raise MessageError(f"{where}: {value!r} is not a sequence")
            if not isinstance(value, bytes | bytearray | memoryview):
                value = list(value)
            checked = self._field(desc, value, where)
            if code is not None:
                return array.array(code, checked.tobytes())
            return checked
        return sequence

    @staticmethod
    def _array(element: str, value: np.ndarray, kind: Nodetype, count: int,
               where: str) -> np.ndarray:
        """A numeric array given as an array (an image's pixels): checked whole, not per item,
        so a 640x376 image costs one pass."""
        if value.ndim != 1:
            value = value.reshape(-1)
        if kind == Nodetype.ARRAY and len(value) != count:
            raise MessageError(f"{where}: needs exactly {count} values, got {len(value)}")
        if kind == Nodetype.SEQUENCE and count and len(value) > count:
            raise MessageError(f"{where}: holds at most {count} values, got {len(value)}")
        dtype = np.dtype(_DTYPES[element])
        if value.dtype == dtype:
            return value
        if element in _INT_RANGES and len(value):
            if value.dtype.kind not in "iub":
                raise MessageError(f"{where}: {value.dtype} values are not {element}")
            low, high = _INT_RANGES[element]
            if value.min() < low or value.max() > high:
                raise MessageError(f"{where}: values outside {element}'s range {low}..{high}")
        return value.astype(dtype)

    @staticmethod
    def _scalar(kind: str, value: Any, where: str, bound: int = 0) -> Any:
        if kind in ("string", "wstring"):
            if not isinstance(value, str):
                raise MessageError(f"{where}: {value!r} is not a string (quote it)")
            if bound and len(value) > bound:
                raise MessageError(f"{where}: {value!r} is longer than {bound} characters")
            return value
        if kind == "bool":
            if isinstance(value, bool):
                return value
            if isinstance(value, int) and value in (0, 1):
                return bool(value)
            raise MessageError(f"{where}: {value!r} is not a bool (true or false)")
        if kind in _FLOATS:
            if isinstance(value, bool) or not isinstance(value, int | float | np.floating
                                                             | np.integer):
                raise MessageError(f"{where}: {value!r} is not a {kind}")
            return float(value)
        if kind in _INT_RANGES:
            if isinstance(value, bool) or not isinstance(value, int | np.integer):
                raise MessageError(f"{where}: {value!r} is not an integer ({kind})")
            low, high = _INT_RANGES[kind]
            if kind == "byte":  # an octet as ROS writes it (0..255) or as rosbags holds it
                low = -128
            if not low <= int(value) <= high:
                raise MessageError(f"{where}: {value} is outside {kind}'s range {low}..{high}")
            return int(value)
        raise MessageError(f"{where}: unsupported field type {kind}")

    def repr_of(self, msg: Any) -> str:
        """A message as rclpy's generated classes show it (``repr``), which ``ros2 service
        call`` prints: ``dynamixel_controllers.srv.SetSpeed_Request(speed=0.5)``. As rosidl's
        Python repr does, it leaves out the one member of an empty message
        (``structure_needs_at_least_one_member``), shows a sequence of numbers as a list and a
        fixed array as numpy shows it."""
        name = self.type_of(msg)
        self.load_package_of(name)
        _, fields = self.store.fielddefs[name]
        if [f for f, _ in fields] == ["structure_needs_at_least_one_member"]:
            fields = []
        shown = [f"{f}={self._repr_field(desc, getattr(msg, f))}" for f, desc in fields]
        return f"{name.replace('/', '.')}({', '.join(shown)})"

    def _repr_field(self, desc: FieldDesc, value: Any) -> str:
        if desc[0] == Nodetype.BASE:
            return _repr_scalar(desc[1][0], value)
        if desc[0] == Nodetype.NAME:
            return self.repr_of(value)
        sub = desc[1][0]
        if (desc[0] == Nodetype.ARRAY and isinstance(value, np.ndarray)
                and value.dtype != np.bool_):
            return repr(value)  # rosidl keeps a fixed numeric array as a numpy array
        if sub[0] == Nodetype.NAME:
            return f"[{', '.join(self.repr_of(v) for v in value)}]"
        items = value.tolist() if isinstance(value, np.ndarray) else list(value)
        return f"[{', '.join(_repr_scalar(sub[1][0], v) for v in items)}]"

    def to_value(self, msg: Any) -> Any:
        """Plain values (dicts, lists, numbers, strings) for a message: what ``echo`` prints and
        what :meth:`from_value` takes back."""
        if hasattr(msg, "__msgtype__"):
            self.load_package_of(msg.__msgtype__)  # another MessageTypes may have built it
            _, fields = self.store.fielddefs[msg.__msgtype__]
            return {f: int(getattr(msg, f)) & 0xFF if _is_byte(desc)  # 0..255, as ROS says
                    else self.to_value(getattr(msg, f)) for f, desc in fields}
        if isinstance(msg, np.ndarray | array.array):
            return msg.tolist()
        if isinstance(msg, list | tuple):
            return [self.to_value(v) for v in msg]
        if isinstance(msg, np.generic):
            return msg.item()
        return msg


def _references(desc: Any) -> Iterator[str]:
    """The type names a rosbags field description refers to."""
    kind, rest = desc
    if kind == Nodetype.NAME:
        yield rest
    elif kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
        yield from _references(rest[0])


def _as_rosidl(types: dict[str, Any]) -> dict[str, Any]:
    """Parsed ``.msg`` types as rosidl makes them: a ``char`` field is a ``uint8`` (its
    ``.msg`` to ``.idl`` adapter says so, and the type hash follows: test_msgs/BasicTypes'
    ``char_value`` has type id 3, uint8, in rosidl's own type description)."""

    def fix(value: Any) -> Any:
        if isinstance(value, tuple) and len(value) == 2 and value[0] == "char" \
                and isinstance(value[1], int):
            return ("uint8", value[1])
        if isinstance(value, tuple | list):
            return type(value)(fix(v) for v in value)
        return value

    return {name: fix(definition) for name, definition in types.items()}


#: The primitive types of the ROS 2 interface language (rosidl), which no package qualifies.
_PRIMITIVES = frozenset({"bool", "byte", "char", "float32", "float64", "int8", "uint8",
                         "int16", "uint16", "int32", "uint32", "int64", "uint64", "string",
                         "wstring"})


def _absolute_types(text: str, package: str) -> str:
    """``text`` with every type named relative to its package spelled ``package/Name``:
    rosidl reads a bare ``Foo`` in a service or action as ``<package>/msg/Foo``, where rosbags
    would put it beside the part (``pkg/srv/msg/Foo``, ``pkg/action/Foo``)."""
    out = []
    for line in text.splitlines():
        body = line.split("#", 1)[0]
        stripped = body.strip()
        if not stripped:
            out.append(line)
            continue
        token = stripped.split()[0]
        base = re.split(r"[\[<]", token, maxsplit=1)[0]
        if "/" in base or base in _PRIMITIVES or base == "Header":
            out.append(line)
            continue
        at = line.index(token)
        out.append(line[:at] + f"{package}/{token}" + line[at + len(token):])
    return "\n".join(out) + ("\n" if text.endswith("\n") else "")


def _repr_scalar(kind: str, value: Any) -> str:
    if isinstance(value, np.generic):
        value = value.item()
    if kind == "byte":
        return repr(bytes([int(value) & 0xFF]))  # rosidl's byte is a bytes of length 1
    if kind == "bool":
        return repr(bool(value))
    if kind in _FLOATS:
        return repr(float(value))
    return repr(value)


def _is_byte(desc: Any) -> bool:
    return bool(desc[0] == Nodetype.BASE and desc[1][0] == "byte")


def _signed_octet(value: int) -> int:
    """A ``byte`` (an octet: ROS writes 0..255) as rosbags holds and packs it, signed: 200
    is -56, the value the same byte reads back as (rosbags' ``struct`` code ``b``). Kept
    unsigned, 128..255 would be accepted and then fail to serialize."""
    return value - 256 if value > 127 else value


def _join(path: str, field: str) -> str:
    return f"{path}.{field}" if path else field


def copy_message(msg: Any) -> Any:
    """A copy of a message that shares nothing mutable with it: nested messages, arrays and
    lists are copied, strings and numbers (immutable) shared. This is how in-process delivery
    keeps rclpy's value semantics (a publisher may change and republish the object it
    published) at a fraction of ``copy.deepcopy``'s cost (``benchmarks/middleware.py``)."""
    cls = type(msg)
    return _built(cls, {name: _copy_value(getattr(msg, name)) for name in _field_names(cls)})


def _built(cls: type, values: dict[str, Any]) -> Any:
    """A message of ``cls`` holding ``values`` (checked already, or copies of a message's):
    set as its dataclass ``__init__`` sets them (with rosbags' constants and ``__msgtype__``,
    which it sets too), without the checks assignments go through."""
    msg: Any = object.__new__(cls)
    held = msg.__dict__
    fixed = _FIXED.get(cls)
    if fixed is None:
        fixed = _FIXED[cls] = {f.name: f.default for f in fields(cls)
                               if f.name == "__msgtype__" or f.name.isupper()}
    held.update(fixed)
    held.update(values)
    return msg


#: Each message class's constants and ``__msgtype__`` with their values (a cache).
_FIXED: dict[type, dict[str, Any]] = {}


#: What an assignment to a primitive *sequence* makes of a list: rclpy's ``array.array``
#: of the element's type code (rosidl_generator_py), so that ``.append`` works as in rclpy.
_TYPECODES = {"int8": "b", "uint8": "B", "byte": "B", "char": "B", "int16": "h",
              "uint16": "H", "int32": "i", "uint32": "I", "int64": "q", "uint64": "Q",
              "float32": "f", "float64": "d"}


def _field_setter(types: MessageTypes, name: str) -> Callable[[Any, str, Any], None]:
    """The ``__setattr__`` of message class ``name``: as rclpy's generated properties do, an
    assignment is checked against the field's type, naming the field (a wrong type, an
    integer out of range, a fixed array of the wrong length, a field the type does not
    have), and converted: an int to a float field becomes a float, a list to a primitive
    sequence an ``array.array`` (rclpy's), to a fixed array a numpy array. So a message
    that publishes in one process publishes over every transport."""
    checks: dict[str, Callable[[Any], Any]] = {}
    set_field = object.__setattr__

    def __setattr__(self: Any, field: str, value: Any) -> None:
        check = checks.get(field)
        if check is None:
            if not checks:
                checks.update(types._assignment_checks(name))
            check = checks.get(field)
            if check is None:
                fields = sorted(f for f in checks if f != "__msgtype__" and not f.isupper())
                raise AttributeError(f"{name} has no field {field!r} (it has "
                                     f"{', '.join(fields) or 'none'})")
        set_field(self, field, check(value))
    return __setattr__


def _field_names(cls: type) -> tuple[str, ...]:
    names = _FIELD_NAMES.get(cls)
    if names is None:
        names = _FIELD_NAMES[cls] = tuple(f.name for f in fields(cls))
    return names


#: Each message class's field names (a cache: ``dataclasses.fields`` is slow per message).
_FIELD_NAMES: dict[type, tuple[str, ...]] = {}


def _copy_value(value: Any) -> Any:
    if hasattr(value, "__msgtype__"):
        return copy_message(value)
    if isinstance(value, np.ndarray):
        return value.copy()
    if isinstance(value, array.array):  # a list assigned to a sequence (rclpy's array.array)
        return array.array(value.typecode, value)
    if isinstance(value, list):
        return [_copy_value(v) for v in value]
    return value
