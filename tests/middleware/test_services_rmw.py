"""Services as ROS 2 answers them over Zenoh, and no start-up race between client and server.

The facts about rmw_zenoh come from ros2/rmw_zenoh (Jazzy), ``rmw_zenoh_cpp/src/detail/``:

* ``rmw_client_data.cpp``, ``ClientData::send_request``: a request is a ``get`` with target
  ALL_COMPLETE and the 33-byte attachment (sequence number counting from 1, timestamp, the
  client's GID); its reply callback drops any reply that is not OK (``if (!reply.is_ok()) {
  log; return; }``), so an error reply leaves the client waiting for ever.
  ``ClientData::take_response`` deserializes the OK reply's payload as the response and
  reads the sequence number from its attachment: nothing else (no encoding).
* ``rmw_service_data.cpp``, ``ServiceData::send_response``: the reply carries the request's
  sequence number and GID in a fresh attachment; ``ServiceData::make`` declares the queryable
  (complete) and only then the liveliness token.
* ``rmw_client_data.cpp``, ``ClientData::ClientData``: a client declares its liveliness token
  when created; ``ClientData::shutdown`` undeclares it. ``liveliness_utils.cpp``: a client's
  entity kind is ``SC`` (``CLI_STR``), a service's ``SS``.

Offline: loopback only, free ports, no router; waits are on conditions, never fixed sleeps.
"""

from __future__ import annotations

import threading
import time
from typing import Any

import pytest
import zenoh

from servolab.middleware.context import Context
from servolab.middleware.errors import ServiceError
from servolab.middleware.node import Node
from servolab.middleware.rmw_zenoh import (
    ERROR_ENCODING,
    decode_attachment,
    encode_attachment,
    error_encoding,
    error_reason,
    parse_token,
    topic_keyexpr,
)
from tests.waiting import wait_for, wait_for_graph, wait_until

TRIGGER = "std_srvs/srv/Trigger"
ADD = "example_interfaces/srv/AddTwoInts"
REPETITIONS = 200


def _raw_request(ctx: Context, name: str, srv: str, request: Any, sequence_number: int,
                 gid: bytes, *, attachment: bool = True) -> list[zenoh.Reply]:
    """Every reply to one request sent as rmw_zenoh's client sends it (see the module
    docstring), from ``ctx``'s bare Zenoh session."""
    types = ctx.types
    key = topic_keyexpr(0, name, srv, types.rihs01(srv))
    return list(ctx.transport.session.get(  # type: ignore[attr-defined]
        key, payload=types.serialize(request, f"{srv}_Request"),
        attachment=encode_attachment(sequence_number, time.time_ns(), gid) if attachment
        else None,
        target=zenoh.QueryTarget.ALL_COMPLETE, consolidation=zenoh.ConsolidationMode.NONE,
        timeout=10.0))


def _serving(ctx: Context) -> Node:
    """A server node whose handlers run on a spinning executor, as in a server process."""
    server = Node(ctx, "server")

    def fail(request: Any, response: Any) -> Any:
        raise RuntimeError("torque enable refused: overheating")

    server.create_service(TRIGGER, "/fail", fail)
    def fail_at_length(request: Any, response: Any) -> Any:
        raise RuntimeError("é" * 400)

    server.create_service(TRIGGER, "/wrong", lambda request, response: 42)
    server.create_service(TRIGGER, "/long", fail_at_length)

    def ok(request: Any, response: Any) -> Any:
        response.success, response.message = True, "done"
        return response

    server.create_service(TRIGGER, "/ok", ok)
    ctx.executor.spin_in_thread()
    return server


def test_a_failing_handler_answers_an_rmw_zenoh_client_with_a_default_response(
        zenoh_pair) -> None:
    """A raw Zenoh ``get`` shaped as rmw_zenoh's client's gets an OK reply (an error reply
    would be dropped: ``rmw_client_data.cpp``) whose payload decodes as the default response
    (``take_response`` deserializes it) and whose attachment echoes the request's sequence
    number and GID (``rmw_service_data.cpp``, ``send_response``). The failure is only in the
    encoding, which rmw_zenoh does not read."""
    a, b, _ = zenoh_pair
    _serving(a)
    wait_for_graph(b, ("SS", "/server", "/fail"), ("SS", "/server", "/wrong"))
    gid = bytes(range(16))
    for name, reason in (("/fail", "torque enable refused: overheating"),
                         ("/wrong", "returned 42, not a std_srvs/srv/Trigger_Response")):
        replies = _raw_request(b, name, TRIGGER, b.types.default(f"{TRIGGER}_Request"), 7, gid)
        assert len(replies) == 1 and replies[0].ok is not None, replies
        sample = replies[0].ok
        response = b.types.deserialize(sample.payload.to_bytes(), f"{TRIGGER}_Response")
        assert b.types.to_value(response) == {"success": False, "message": ""}
        attachment = decode_attachment(sample.attachment.to_bytes())
        assert (attachment.sequence_number, attachment.gid) == (7, gid)
        assert str(sample.key_expr) == topic_keyexpr(0, name, TRIGGER, b.types.rihs01(TRIGGER))
        why = error_reason(str(sample.encoding))
        assert why is not None and reason in why


def test_a_real_response_is_not_marked(zenoh_pair) -> None:
    """A handler that succeeds answers with its response and no error mark; its attachment
    echoes the request's (``rmw_service_data.cpp``, ``send_response``)."""
    a, b, _ = zenoh_pair
    _serving(a)
    wait_for_graph(b, ("SS", "/server", "/ok"))
    replies = _raw_request(b, "/ok", TRIGGER, b.types.default(f"{TRIGGER}_Request"), 1,
                           bytes(16))
    assert len(replies) == 1 and replies[0].ok is not None
    sample = replies[0].ok
    assert error_reason(str(sample.encoding)) is None
    assert b.types.to_value(b.types.deserialize(sample.payload.to_bytes(),
                                                f"{TRIGGER}_Response")) == {
        "success": True, "message": "done"}
    assert decode_attachment(sample.attachment.to_bytes()).sequence_number == 1


def test_a_request_without_rmw_zenohs_attachment_gets_an_error_reply(zenoh_pair) -> None:
    """No ROS client sends a request without the attachment (``rmw_client_data.cpp``), and
    rmw_zenoh's server cannot answer one (``rmw_service_data.cpp``, ``take_request``): such a
    query gets a Zenoh error reply naming what is missing."""
    a, b, _ = zenoh_pair
    _serving(a)
    wait_for_graph(b, ("SS", "/server", "/ok"))
    replies = _raw_request(b, "/ok", TRIGGER, b.types.default(f"{TRIGGER}_Request"), 1,
                           bytes(16), attachment=False)
    assert len(replies) == 1 and replies[0].err is not None
    assert b"attachment" in replies[0].err.payload.to_bytes()


def test_servolabs_client_raises_the_handlers_reason(zenoh_pair) -> None:
    """servolab's client reads the mark rmw_zenoh ignores: ServiceError with the reason. A
    reason too long for Zenoh's encoding (255 bytes: a longer one would panic the session's
    transmit pipeline) is cut, and the session goes on answering."""
    a, b, _ = zenoh_pair
    _serving(a)
    caller = Node(b, "caller")
    fail, wrong, long, ok = (caller.create_client(TRIGGER, n)
                             for n in ("/fail", "/wrong", "/long", "/ok"))
    assert all(c.wait_for_service(10.0) for c in (fail, wrong, long, ok))
    with pytest.raises(ServiceError, match="service /fail failed: torque enable refused: "
                                           "overheating"):
        fail.call(timeout=10.0)
    with pytest.raises(ServiceError, match="returned 42, not a std_srvs/srv/Trigger_Response"):
        wrong.call(timeout=10.0)
    with pytest.raises(ServiceError, match=r"service /long failed: éééé+…$"):
        long.call(timeout=10.0)
    assert ok.call(timeout=10.0).message == "done"


def test_error_encoding_fits_zenohs_schema_limit() -> None:
    for reason in ("x" * 1000, "é" * 300, "two\nlines", ""):
        text = error_encoding(reason)
        assert len(text.encode()) <= 255 and text.startswith(f"{ERROR_ENCODING};")
        assert "\n" not in text
    assert error_reason(error_encoding("motor bus unplugged")) == "motor bus unplugged"
    assert error_reason("zenoh/bytes") is None


def _client_tokens(ctx: Context) -> list:
    return [parse_token(str(r.ok.key_expr)) for r in ctx.transport.session.liveliness().get(
        "@ros2_lv/0/**", timeout=1.0) if r.ok is not None and "/SC/" in str(r.ok.key_expr)]


def test_a_client_is_in_the_graph_while_it_exists(zenoh_pair) -> None:
    """A client declares its SC liveliness token when created and undeclares it when
    destroyed (``rmw_client_data.cpp``; ``SC``: ``liveliness_utils.cpp``), so the other
    session's graph sees it (no server needed) and then no longer does."""
    a, b, _ = zenoh_pair
    client = Node(b, "caller", "/robot1").create_client(ADD, "add_two_ints")
    wait_for_graph(a, ("SC", "/robot1/caller", "/robot1/add_two_ints"))
    endpoint = next(e for e in a.transport.graph(0.5) if e.kind == "SC")
    assert endpoint.type_name == ADD
    entity, = _client_tokens(a)
    assert (entity.kind, entity.node_name, entity.namespace, entity.topic, entity.type_name,
            entity.session_id) == ("SC", "caller", "/robot1", "/robot1/add_two_ints", ADD,
                                   b.transport.session_id)
    client.destroy()
    client.destroy()  # a second destroy (the node's, at shutdown) is harmless
    wait_for(lambda: not any(e.kind == "SC" for e in a.transport.graph(0.3)),
             "the client's SC token to leave the graph")


def test_a_client_is_in_the_local_graph_while_it_exists() -> None:
    with Context.open() as ctx:
        client = Node(ctx, "caller").create_client(ADD, "/add")
        assert [(e.node, e.name, e.type_name) for e in ctx.transport.graph()
                if e.kind == "SC"] == [("/caller", "/add", ADD)]
        client.destroy()
        assert not [e for e in ctx.transport.graph() if e.kind == "SC"]


@pytest.mark.slow
def test_call_right_after_wait_for_service_is_answered(zenoh_pair) -> None:
    """200 times, across two sessions: create a client, ``wait_for_service`` returns True,
    call at once: every call is answered. Every other time the server is declared on another
    thread while the client waits (the queryable before its SS token, as in
    ``rmw_service_data.cpp``, so a client that has seen the token is routed to the queryable);
    the rest of the times it exists before the client does."""
    a, b, _ = zenoh_pair
    server, caller = Node(a, "server"), Node(b, "caller")
    spinner = a.executor.spin_in_thread()

    def add(request: Any, response: Any) -> Any:
        response.sum = request.a + request.b
        return response

    unanswered: list[str] = []
    for k in range(REPETITIONS):
        name = f"/race_{k}"
        concurrent = k % 2 == 1
        start = threading.Event()
        services: list[Any] = []

        def declare(name: str = name, start: threading.Event = start,
                    services: list[Any] = services) -> None:
            start.wait(10.0)
            services.append(server.create_service(ADD, name, add))

        thread = threading.Thread(target=declare, name=f"declare {name}")
        if not concurrent:
            start.set()
            thread.start()
            thread.join(10.0)
        client = caller.create_client(ADD, name)
        if concurrent:
            thread.start()
            start.set()
        try:
            assert client.wait_for_service(timeout_sec=20.0), f"{name} never appeared"
            try:
                assert client.call(client.request(a=k, b=1), timeout=10.0).sum == k + 1
            except ServiceError as exc:
                unanswered.append(f"{name}: {exc}")
        finally:
            thread.join(10.0)
            client.destroy()
            for service in services:
                service.destroy()
    assert not unanswered, (f"{len(unanswered)} of {REPETITIONS} calls unanswered: "
                            f"{unanswered[:5]}")
    a.shutdown()
    spinner.join(5.0)
    assert wait_until(lambda: not spinner.is_alive(), 5.0)


def test_an_answer_over_zenoh_ends_rclpys_waits_for_it(zenoh_pair) -> None:
    """ros2/examples' async client (issue 32, D1): ``call_async``, then
    ``rclpy.spin_until_future_complete(node, future)`` with no timeout, or ``spin_once``
    with a long one. The answer completes the future on Zenoh's thread; it must end the
    wait, as a response does in rclpy (the executor takes it as work). Before, the first
    waited forever and the second its whole timeout."""
    import threading

    from servolab import rclpy

    a, b, _ = zenoh_pair
    server = Node(a, "adder")
    server.create_service(ADD, "/add", lambda request, response: setattr(
        response, "sum", request.a + request.b) or response)
    serving = threading.Thread(target=a.spin, daemon=True)
    serving.start()
    try:
        caller = Node(b, "caller")
        client = caller.create_client(ADD, "/add")
        assert client.wait_for_service(timeout_sec=10.0)
        results: list[int] = []

        def until_complete() -> None:
            future = client.call_async(client.request(a=2, b=3))
            rclpy.spin_until_future_complete(caller, future)      # no timeout, as upstream
            results.append(future.result().sum)

        def one_spin() -> None:
            future = client.call_async(client.request(a=4, b=5))
            while not future.done():
                rclpy.spin_once(caller, timeout_sec=60.0)           # returns on the answer
            results.append(future.result().sum)

        for body in (until_complete, one_spin):
            worker = threading.Thread(target=body, daemon=True)
            worker.start()
            worker.join(timeout=20.0)
            assert not worker.is_alive(), f"{body.__name__} still waits for the answer"
        assert results == [5, 9]
    finally:
        a.executor.shutdown()
        serving.join(timeout=5.0)
