"""Parameters and services of a servolab graph, used from Foxglove's own client.

``@foxglove/ws-protocol``'s ``FoxgloveClient`` in Node (tests/view_client, not servolab's code)
sets a node's parameter and calls a node's service through ``servolab view``, with each of
the protocol's two names; the CDR request is written by ``@foxglove/rosmsg2-serialization``'s
``MessageWriter`` from the service definition the server advertised.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.middleware.view import ViewConfig, ViewServer
from tests.viewclient import SDK_V1, WEBSOCKET_V1, node_client, run_client

SUBPROTOCOLS = [WEBSOCKET_V1, SDK_V1]


@pytest.fixture
def served() -> Iterator[tuple[Node, ViewServer, list[bool]]]:
    node_client()  # skips, saying why, where Node or the npm packages are missing
    asked: list[bool] = []
    with Context.open() as ctx:
        node = Node(ctx, "gripper", "/arm")
        node.declare_parameter("force", 2.5)

        def set_bool(request: Any, response: Any) -> Any:
            asked.append(request.data)
            response.success = True
            response.message = f"closed={request.data}"
            return response

        node.create_service("std_srvs/srv/SetBool", "/arm/close", set_bool)
        thread = ctx.executor.spin_in_thread()
        with ViewServer(ctx, ViewConfig(port=0)) as view:
            yield node, view, asked
        ctx.shutdown()
        thread.join()


@pytest.mark.parametrize("subprotocol", SUBPROTOCOLS)
def test_a_parameter_set_from_the_client_reaches_the_node(
        served: tuple[Node, ViewServer, list[bool]], subprotocol: str) -> None:
    node, view, _ = served
    def values(events: list[dict[str, Any]], request: str) -> list[tuple[str, Any]]:
        (answer,) = [e for e in events if e.get("op") == "parameterValues"
                     and e.get("id") == request]
        return [(p["name"], p["value"]) for p in answer["parameters"]]

    got = run_client(view.url, subprotocol, get_parameters=["/arm/gripper.force"], timeout=20)
    assert values(got, "get") == [("/arm/gripper.force", 2.5)]
    # a second connection: the protocol does not order a get after a set sent with it
    done = run_client(view.url, subprotocol, set_parameters={"/arm/gripper.force": 4.0},
                      timeout=20)
    assert values(done, "set") == [("/arm/gripper.force", 4.0)]
    assert node.get_parameter("force").value == 4.0


@pytest.mark.parametrize("subprotocol", SUBPROTOCOLS)
def test_a_service_called_from_the_client_answers(
        served: tuple[Node, ViewServer, list[bool]], subprotocol: str) -> None:
    _, view, asked = served
    events = run_client(view.url, subprotocol, call_service="/arm/close",
                        request={"data": True}, timeout=20)
    (answer,) = [e for e in events if e.get("op") == "serviceResponse"]
    assert answer["response"] == {"success": True, "message": "closed=True"}
    assert asked == [True]
