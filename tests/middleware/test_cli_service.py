"""``servolab service list`` and ``servolab service call``: in one process on the in-process
transport, and as a user runs them, separate OS processes over Zenoh on loopback (a port
chosen free at run time; every process stopped at the end)."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from collections.abc import Iterator

import pytest

from servolab.apps.service import service_call, service_list
from servolab.errors import UsageError
from servolab.middleware.context import Context
from servolab.middleware.errors import MessageError, ServiceError
from servolab.middleware.messages import MessageTypes
from servolab.middleware.node import Node
from tests.clirun import servolab
from tests.middleware.conftest import free_port
from tests.processes import started
from tests.waiting import wait_for_line

TYPES = MessageTypes()
SET_SPEED = "dynamixel_controllers/srv/SetSpeed"
STOP = "dynamixel_controllers/srv/StopController"


# -- in one process ----------------------------------------------------------------------------


@pytest.fixture
def graph() -> Iterator[tuple[Context, list[float]]]:
    """A context whose node serves a controller's set_speed and the manager's stop_controller,
    as dynamixel_controllers names them; the speeds it was given are listed."""
    speeds: list[float] = []

    def set_speed(request, response):
        speeds.append(request.speed)
        return response

    def stop(request, response):
        response.success = request.controller_name == "controller_m14"
        response.reason = f"stopped {request.controller_name}" if response.success else \
            f"no controller {request.controller_name} is running"
        return response

    with Context.open(types=TYPES) as ctx:
        node = Node(ctx, "dynamixel_manager")
        node.create_service(SET_SPEED, "/controller_m14/set_speed", set_speed)
        node.create_service(STOP, "~/dxl_port/stop_controller", stop)
        yield ctx, speeds


def test_call_prints_request_and_response_as_ros2_does(graph: tuple[Context, list[float]]
                                                      ) -> None:
    ctx, speeds = graph
    lines: list[str] = []
    response = service_call(ctx, "/controller_m14/set_speed", SET_SPEED, "{speed: 0.5}",
                            lines.append)
    assert speeds == [0.5]
    assert response.__msgtype__ == f"{SET_SPEED}_Response"
    assert "\n".join(lines) == (
        "requester: making request: dynamixel_controllers.srv.SetSpeed_Request(speed=0.5)\n"
        "\n"
        "response:\n"
        "dynamixel_controllers.srv.SetSpeed_Response()\n")
    lines.clear()
    service_call(ctx, "/dynamixel_manager/dxl_port/stop_controller", STOP,
                 "{controller_name: controller_m14}", lines.append)
    assert lines[-1] == ("response:\ndynamixel_controllers.srv.StopController_Response("
                         "success=True, reason='stopped controller_m14')\n")


def test_list_shows_every_service_with_its_type(graph: tuple[Context, list[float]]) -> None:
    ctx, _ = graph
    lines: list[str] = []
    names = service_list(ctx, lines.append, show_types=True)
    assert "/controller_m14/set_speed [dynamixel_controllers/srv/SetSpeed]" in lines
    assert ("/dynamixel_manager/dxl_port/stop_controller "
            "[dynamixel_controllers/srv/StopController]") in lines
    # and the parameter services every node offers, as ros2 service list shows them
    assert ("/dynamixel_manager/list_parameters [rcl_interfaces/srv/ListParameters]"
            in lines)
    assert names == sorted(names)


@pytest.mark.parametrize(("name", "type_name", "values", "error", "message"), [
    ("/controller_m14/set_speed", "dynamixel_controllers/srv/SetSped", "{speed: 1}",
     MessageError, "unknown service type 'dynamixel_controllers/srv/SetSped' (did you mean "
     "dynamixel_controllers/srv/SetSpeed?)"),
    ("/controller_m14/set_speed", SET_SPEED, "{sped: 1}", MessageError,
     "request of dynamixel_controllers/srv/SetSpeed: sped: the request has no field 'sped' "
     "(it has speed)"),
    ("/controller_m14/set_speed", SET_SPEED, "{speed: [1", MessageError,
     "request of dynamixel_controllers/srv/SetSpeed: values for the request are not YAML "
     "(line 1): '{speed: [1'"),
    ("/controller_m14/set_speed", SET_SPEED, "{speed: fast}", MessageError,
     "request of dynamixel_controllers/srv/SetSpeed: speed: 'fast' is not a float64"),
    ("/controller_m14/set_sped", SET_SPEED, "{speed: 1}", UsageError,
     "no service /controller_m14/set_sped in the graph (did you mean "
     "/controller_m14/set_speed?); it has /controller_m14/set_speed, "),
    ("/controller_m14/set_speed", STOP, "{}", UsageError,
     "service /controller_m14/set_speed is a dynamixel_controllers/srv/SetSpeed, not a "
     "dynamixel_controllers/srv/StopController"),
])
def test_bad_input_is_refused_naming_it(graph: tuple[Context, list[float]], name: str,
                                        type_name: str, values: str, error: type[Exception],
                                        message: str) -> None:
    ctx, speeds = graph
    lines: list[str] = []
    with pytest.raises(error) as caught:
        service_call(ctx, name, type_name, values, lines.append, timeout=0.3)
    assert str(caught.value).startswith(message)
    assert "\n" not in str(caught.value)
    assert isinstance(caught.value, ValueError)  # bad input: the CLI exits with 2
    assert speeds == []
    assert not any(line.startswith("requester") for line in lines)


def test_a_name_only_a_client_uses_is_listed_but_not_called() -> None:
    """``ros2 service list`` counts a name a client uses; calling it needs a server."""
    with Context.open(types=TYPES) as ctx:
        Node(ctx, "ui").create_client("std_srvs/srv/Trigger", "/reset")
        lines: list[str] = []
        assert "/reset" in service_list(ctx, lines.append, show_types=True)
        assert "/reset [std_srvs/srv/Trigger]" in lines
        with pytest.raises(UsageError, match=r"^no node serves /reset \(only clients use it\)"):
            service_call(ctx, "/reset", "std_srvs/srv/Trigger", "", lines.append, timeout=0.2)


def test_a_failing_handler_is_a_service_error_naming_its_reason() -> None:
    def broken(request, response):
        raise RuntimeError("motor 14 does not answer")

    with Context.open(types=TYPES) as ctx:
        Node(ctx, "m").create_service(SET_SPEED, "/controller_m14/set_speed", broken)
        with pytest.raises(ServiceError, match="failed: motor 14 does not answer") as caught:
            service_call(ctx, "/controller_m14/set_speed", SET_SPEED, "{speed: 1}",
                         lambda _: None)
    assert not isinstance(caught.value, ValueError)  # failed while running: exit 1


# -- separate processes over Zenoh -------------------------------------------------------------

#: A node serving a joint controller's services and the manager's stop_controller, as
#: dynamixel_controllers names them; it prints what it is asked. A second context on the same
#: Zenoh session (so the CLI, connected to that session, sees its services at once), with an
#: executor of its own on a thread, serves /sleepy/hang, whose handler does not answer until
#: the process stops, while the first context's services go on answering.
SERVER = textwrap.dedent("""
    import sys
    import threading
    from servolab.middleware.context import Context
    from servolab.middleware.node import Node
    from servolab.middleware.transport import TransportOptions

    endpoint = sys.argv[1]
    release = threading.Event()

    def set_speed(request, response):
        print(f"speed {request.speed}", flush=True)
        return response

    def torque_enable(request, response):
        print(f"torque {request.torque_enable}", flush=True)
        return response

    def stop(request, response):
        response.success = True
        response.reason = f"stopped {request.controller_name}"
        return response

    def hang(request, response):
        release.wait(120)
        return response

    with Context.open(TransportOptions("zenoh", listen=[endpoint])) as ctx:
        slow = Context(ctx.transport)
        slow.next_node_id()  # its nodes' ids follow the first context's one node's
        node = Node(ctx, "dynamixel_manager")
        node.create_service("dynamixel_controllers/srv/SetSpeed",
                            "/controller_m14/set_speed", set_speed)
        node.create_service("dynamixel_controllers/srv/TorqueEnable",
                            "/controller_m14/torque_enable", torque_enable)
        node.create_service("dynamixel_controllers/srv/StopController",
                            "~/dxl_port/stop_controller", stop)
        Node(slow, "sleepy").create_service("std_srvs/srv/Trigger", "~/hang", hang)
        slow.executor.spin_in_thread()
        print("ready", flush=True)
        try:
            ctx.spin()
        finally:
            release.set()
            slow.executor.shutdown()
""")


@pytest.fixture(scope="module")
def server() -> Iterator[tuple[subprocess.Popen[str], str]]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with started([sys.executable, "-c", SERVER, endpoint]) as proc:
        wait_for_line(proc, "ready", timeout=30.0)
        yield proc, endpoint


@pytest.mark.slow
def test_list_over_zenoh_shows_the_services_with_their_types(
        server: tuple[subprocess.Popen[str], str]) -> None:
    _, endpoint = server
    # The call waits for the graph to show the service (a condition, not a fixed time), so
    # once it has answered the listing must show it.
    assert servolab("service", "call", "/controller_m14/set_speed", SET_SPEED, "{speed: 0.25}",
                    "--connect", endpoint, timeout=30).returncode == 0
    listing = servolab("service", "list", "-t", "--connect", endpoint, timeout=30)
    assert listing.returncode == 0, listing.stderr
    lines = listing.stdout.splitlines()
    for line in ("/controller_m14/set_speed [dynamixel_controllers/srv/SetSpeed]",
                 "/controller_m14/torque_enable [dynamixel_controllers/srv/TorqueEnable]",
                 "/dynamixel_manager/dxl_port/stop_controller "
                 "[dynamixel_controllers/srv/StopController]",
                 "/sleepy/hang [std_srvs/srv/Trigger]",
                 "/dynamixel_manager/get_parameters [rcl_interfaces/srv/GetParameters]"):
        assert line in lines, listing.stdout
    assert lines == sorted(lines)
    assert not any("_servolab" in line for line in lines)  # tools' hidden nodes left out
    plain = servolab("service", "list", "--connect", endpoint, timeout=30)
    assert "/controller_m14/set_speed" in plain.stdout.splitlines()


@pytest.mark.slow
def test_call_over_zenoh_reaches_the_node_and_prints_the_response(
        server: tuple[subprocess.Popen[str], str]) -> None:
    proc, endpoint = server
    result = servolab("service", "call", "/controller_m14/set_speed", SET_SPEED, "{speed: 0.5}",
                      "--connect", endpoint, timeout=30)
    assert result.returncode == 0, result.stderr
    assert "requester: making request: dynamixel_controllers.srv.SetSpeed_Request(speed=0.5)" \
        "\n\nresponse:\ndynamixel_controllers.srv.SetSpeed_Response()\n" in result.stdout
    assert wait_for_line(proc, "speed 0.5", timeout=10.0)[-1] == "speed 0.5"
    result = servolab("service", "call", "/controller_m14/torque_enable",
                      "dynamixel_controllers/TorqueEnable", "{torque_enable: false}", "--connect",
                      endpoint, timeout=30)
    assert result.returncode == 0, result.stderr
    assert wait_for_line(proc, "torque", timeout=10.0)[-1] == "torque False"
    result = servolab("service", "call", "/dynamixel_manager/dxl_port/stop_controller", STOP,
                      "{controller_name: controller_m14}", "--connect", endpoint, timeout=30)
    assert result.returncode == 0, result.stderr
    assert result.stdout.endswith(
        "response:\ndynamixel_controllers.srv.StopController_Response(success=True, "
        "reason='stopped controller_m14')\n\n")


@pytest.mark.slow
@pytest.mark.parametrize(("args", "status", "message"), [
    (["/controller_m14/set_speed", "dynamixel_controllers/srv/SetSped", "{speed: 1}"], 2,
     "servolab service call: error: unknown service type "
     "'dynamixel_controllers/srv/SetSped' (did you mean dynamixel_controllers/srv/SetSpeed?)"),
    (["/controller_m14/set_speed", SET_SPEED, "{speed: 1, accel: 2}"], 2,
     "servolab service call: error: request of dynamixel_controllers/srv/SetSpeed: accel: "
     "the request has no field 'accel' (it has speed)"),
    (["/controller_m14/set_speed", SET_SPEED, "{speed: 1"], 2,
     "servolab service call: error: request of dynamixel_controllers/srv/SetSpeed: values "
     "for the request are not YAML (line 1): '{speed: 1'"),
    (["/controller_m99/set_speed", SET_SPEED, "{speed: 1}", "--timeout", "1"], 2,
     "servolab service call: error: no service /controller_m99/set_speed in the graph (did "
     "you mean /controller_m14/set_speed?); it has "),
    (["/controller_m14/set_speed", "std_srvs/srv/Trigger", "", "--timeout", "1"], 2,
     "servolab service call: error: service /controller_m14/set_speed is a "
     "dynamixel_controllers/srv/SetSpeed, not a std_srvs/srv/Trigger"),
    (["/sleepy/hang", "std_srvs/srv/Trigger", "{}", "--timeout", "1"], 1,
     "servolab service call: error: "),
])
def test_errors_over_zenoh_are_one_line_with_the_clis_exit_status(
        server: tuple[subprocess.Popen[str], str], args: list[str], status: int,
        message: str) -> None:
    _, endpoint = server
    result = servolab("service", "call", *args, "--connect", endpoint, timeout=30)
    assert result.returncode == status, (result.stdout, result.stderr)
    assert result.stderr.startswith(message), result.stderr
    assert result.stderr.count("\n") == 1, result.stderr
    if status == 1:  # no answer within --timeout: the request went out, then the wait ended
        assert "/sleepy/hang" in result.stderr and "1 s" in result.stderr, result.stderr
        assert "requester: making request: std_srvs.srv.Trigger_Request()" in result.stdout


@pytest.mark.slow
def test_an_endpoint_where_nobody_answers_is_said_so() -> None:
    result = servolab("service", "list", "--connect", f"tcp/127.0.0.1:{free_port()}", timeout=30)
    assert result.returncode == 2
    assert result.stderr.startswith("servolab service list: error: no Zenoh peer or router "
                                    "answers at tcp/127.0.0.1:")
