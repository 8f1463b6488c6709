"""The service types of ROS ``dynamixel_controllers`` and the ``diagnostic_msgs`` types
``/diagnostics`` carries: defined as the originals are, and through CDR and back."""

from __future__ import annotations

import pytest
from rosbags.typesys import Stores, get_typestore

from servolab.middleware.errors import MessageError
from servolab.middleware.messages import DYNAMIXEL_SRVS, MessageTypes

TYPES = MessageTypes()

#: Field name and type of each request and response, as arebgun/dynamixel_motor's
#: ``dynamixel_controllers/srv/<Name>.srv`` files give them (an empty part is ROS 2's empty
#: message, whose one member rosidl adds).
EMPTY = [("structure_needs_at_least_one_member", "uint8")]
SPEC = [("port_name", "string"), ("package_path", "string"), ("module_name", "string"),
        ("class_name", "string"), ("controller_name", "string"), ("dependencies", "string[]")]
SUCCESS = [("success", "bool"), ("reason", "string")]
SRV_FILES = {
    "SetSpeed": ([("speed", "float64")], EMPTY),
    "TorqueEnable": ([("torque_enable", "bool")], EMPTY),
    "SetComplianceSlope": ([("slope", "uint8")], EMPTY),
    "SetComplianceMargin": ([("margin", "uint8")], EMPTY),
    "SetCompliancePunch": ([("punch", "uint8")], EMPTY),
    "SetTorqueLimit": ([("torque_limit", "float64")], EMPTY),
    "StartController": (SPEC, SUCCESS),
    "StopController": ([("controller_name", "string")], SUCCESS),
    "RestartController": (SPEC, SUCCESS),
}

#: A request and a response of each, with every field away from its default.
VALUES = {
    "SetSpeed": ({"speed": 0.5}, {}),
    "TorqueEnable": ({"torque_enable": True}, {}),
    "SetComplianceSlope": ({"slope": 32}, {}),
    "SetComplianceMargin": ({"margin": 255}, {}),
    "SetCompliancePunch": ({"punch": 17}, {}),
    "SetTorqueLimit": ({"torque_limit": 0.75}, {}),
    "StartController": ({"port_name": "/dev/ttyUSB0", "package_path": "biped",
                         "module_name": "joint_position_controller",
                         "class_name": "JointPositionController",
                         "controller_name": "controller_m14", "dependencies": ["m13", "m15"]},
                        {"success": True, "reason": "started controller_m14"}),
    "StopController": ({"controller_name": "controller_m14"},
                       {"success": False, "reason": "no controller_m14 running"}),
    "RestartController": ({"port_name": "pan_tilt_port", "package_path": "", "module_name": "m",
                           "class_name": "C", "controller_name": "c", "dependencies": []},
                          {"success": True, "reason": ""}),
}


def _fields(type_name: str) -> list[tuple[str, str]]:
    out = []
    for name, desc in TYPES.store.fielddefs[type_name][1]:
        if desc[0] == 1:  # BASE
            out.append((name, desc[1][0]))
        else:            # a sequence of a base type (the only other kind these use)
            out.append((name, f"{desc[1][0][1][0]}[]"))
    return out


def test_every_dynamixel_controllers_srv_file_is_registered() -> None:
    assert sorted(DYNAMIXEL_SRVS) == sorted(f"dynamixel_controllers/srv/{n}" for n in SRV_FILES)


@pytest.mark.parametrize("short", sorted(SRV_FILES))
def test_fields_are_the_srv_files(short: str) -> None:
    srv = TYPES.service(f"dynamixel_controllers/srv/{short}")
    request, response = SRV_FILES[short]
    assert _fields(srv.request) == request
    assert _fields(srv.response) == response


@pytest.mark.parametrize("short", sorted(SRV_FILES))
def test_request_and_response_round_trip_through_cdr(short: str) -> None:
    srv = TYPES.service(f"dynamixel_controllers/srv/{short}")
    for type_name, value in zip((srv.request, srv.response), VALUES[short], strict=True):
        msg = TYPES.from_value(type_name, value)
        data = TYPES.serialize(msg)
        assert data[:4] == b"\x00\x01\x00\x00"  # CDR little-endian encapsulation header
        back = TYPES.to_value(TYPES.deserialize(data, type_name))
        fields = {f for f, _ in _fields(type_name)}
        assert {k: v for k, v in back.items() if k in value} == value
        assert set(back) == fields
    assert TYPES.rihs01(srv.name).startswith("RIHS01_")


def test_an_empty_response_is_one_byte_as_in_ros2() -> None:
    response = TYPES.default("dynamixel_controllers/srv/SetTorqueLimit_Response")
    assert TYPES.serialize(response) == b"\x00\x01\x00\x00\x00"


@pytest.mark.parametrize("store", [Stores.ROS2_HUMBLE, Stores.ROS2_JAZZY])
def test_diagnostic_msgs_are_in_the_type_stores(store: Stores) -> None:
    fielddefs = get_typestore(store).fielddefs
    for name in ("DiagnosticArray", "DiagnosticStatus", "KeyValue"):
        assert f"diagnostic_msgs/msg/{name}" in fielddefs
    consts, _ = fielddefs["diagnostic_msgs/msg/DiagnosticStatus"]
    assert [(c[0], c[2]) for c in consts] == [("OK", 0), ("WARN", 1), ("ERROR", 2), ("STALE", 3)]


def test_a_diagnostic_array_round_trips_through_cdr() -> None:
    """What ``dynamixel_serial_proxy`` publishes on ``/diagnostics``: one status per motor."""
    value = {
        "header": {"stamp": {"sec": 12, "nanosec": 500_000_000}, "frame_id": ""},
        "status": [
            {"level": 0, "name": "Robotis Dynamixel Motor 14 on port /dev/ttyUSB0",
             "message": "OK", "hardware_id": "ID: 14",
             "values": [{"key": "Temperature", "value": "41"},
                        {"key": "Load", "value": "0.12"}]},
            {"level": 2, "name": "Robotis Dynamixel Motor 15 on port /dev/ttyUSB0",
             "message": "Overheating", "hardware_id": "ID: 15",
             "values": [{"key": "Temperature", "value": "75"}]},
        ],
    }
    msg = TYPES.from_value("diagnostic_msgs/msg/DiagnosticArray", value)
    back = TYPES.deserialize(TYPES.serialize(msg), "diagnostic_msgs/msg/DiagnosticArray")
    assert TYPES.to_value(back) == value
    assert back.status[1].level == back.status[1].ERROR == 2


@pytest.mark.parametrize(("given", "hint"), [
    ("dynamixel_controllers/srv/SetSped", "did you mean dynamixel_controllers/srv/SetSpeed?"),
    ("SetTorqueLimit", "did you mean dynamixel_controllers/srv/SetTorqueLimit?"),
    ("my_controllers/srv/StopController", "did you mean dynamixel_controllers/srv/StopController?"),
    ("std_msgs/msg/String", "that is a message type, not a service"),
])
def test_an_unknown_service_type_gets_a_guess(given: str, hint: str) -> None:
    with pytest.raises(MessageError) as caught:
        TYPES.service(given)
    assert str(caught.value) == f"unknown service type {given!r} ({hint})"


def test_the_ros1_spelling_of_a_service_type_is_taken() -> None:
    assert TYPES.service("dynamixel_controllers/SetSpeed").name == (
        "dynamixel_controllers/srv/SetSpeed")


@pytest.mark.parametrize(("type_name", "value", "shown"), [
    ("dynamixel_controllers/srv/SetSpeed_Request", {"speed": 0.5},
     "dynamixel_controllers.srv.SetSpeed_Request(speed=0.5)"),
    ("dynamixel_controllers/srv/SetSpeed_Response", {},
     "dynamixel_controllers.srv.SetSpeed_Response()"),
    ("dynamixel_controllers/srv/StopController_Response", {"success": True, "reason": "ok"},
     "dynamixel_controllers.srv.StopController_Response(success=True, reason='ok')"),
    ("dynamixel_controllers/srv/StartController_Request", {"dependencies": ["a"]},
     "dynamixel_controllers.srv.StartController_Request(port_name='', package_path='', "
     "module_name='', class_name='', controller_name='', dependencies=['a'])"),
    ("rcl_interfaces/srv/GetParameterTypes_Response", {"types": [3, 1]},
     "rcl_interfaces.srv.GetParameterTypes_Response(types=[3, 1])"),
    ("diagnostic_msgs/msg/KeyValue", {"key": "k", "value": "v"},
     "diagnostic_msgs.msg.KeyValue(key='k', value='v')"),
])
def test_messages_are_shown_as_rclpy_shows_them(type_name: str, value: dict,
                                                shown: str) -> None:
    assert TYPES.repr_of(TYPES.from_value(type_name, value)) == shown
