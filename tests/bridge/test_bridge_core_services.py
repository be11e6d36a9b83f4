"""Client-provided services in the core: forwarding, routing, failures, time-outs, clean-up."""

from __future__ import annotations

from tests.bridge.bridge_harness import CoreHarness


def provide(
    h: CoreHarness, service: str = "/test_service", type_name: str = "std_srvs/SetBool"
) -> int:
    provider = h.connect()
    h.send(provider, {"op": "advertise_service", "service": service, "type": type_name})
    return provider


def pending_call(h: CoreHarness) -> tuple[int, int, str]:
    """A provider, a caller and the id of the caller's call (id 1) as the provider got it."""
    provider = provide(h)
    caller = h.connect()
    h.send(caller, {"op": "call_service", "service": "/test_service", "id": 1})
    return provider, caller, h.outbox(provider)[0]["id"]


def respond(
    h: CoreHarness, provider: int, request_id: str, service: str = "/test_service", **fields
) -> None:
    h.send(provider, {"op": "service_response", "service": service, "id": request_id, **fields})


def test_round_trip_between_two_clients(harness):
    provider = provide(harness)
    caller = harness.connect()
    harness.send(
        caller,
        {"op": "call_service", "service": "test_service", "id": "c1", "args": {"data": True}},
    )
    request = harness.outbox(provider)
    assert request == [
        {
            "op": "call_service",
            "id": "service_request:/test_service:1",
            "service": "/test_service",
            "args": {"data": True},
        }
    ]
    respond(
        harness,
        provider,
        request[0]["id"],
        result=True,
        values={"success": True, "message": "Hello, world!"},
    )
    assert harness.outbox(caller) == [
        {
            "op": "service_response",
            "service": "test_service",
            "values": {"success": True, "message": "Hello, world!"},
            "result": True,
            "id": "c1",
        }
    ]
    assert harness.state.pending_calls == {}


def test_positional_args_and_defaults_follow_the_request_type(harness):
    provider = provide(harness)
    caller = harness.connect()
    harness.send(caller, {"op": "call_service", "service": "/test_service", "args": [True]})
    harness.send(caller, {"op": "call_service", "service": "/test_service"})
    assert [r["args"] for r in harness.outbox(provider)] == [{"data": True}, {"data": False}]


def test_request_that_does_not_fit_the_type_fails_promptly(harness):
    provide(harness)
    caller = harness.connect()
    response = harness.call(caller, "/test_service", {"data": 42.0})
    assert response["result"] is False and isinstance(response["values"], str)


def test_unknown_service_fails_promptly(harness):
    caller = harness.connect()
    response = harness.call(caller, "/x")
    assert response == {
        "op": "service_response",
        "service": "/x",
        "values": "Service /x does not exist",
        "result": False,
        "id": "call",
    }


def test_values_object_means_success_even_with_result_false(harness):
    provider, caller, request_id = pending_call(harness)
    respond(harness, provider, request_id, result=False, values={"success": True})
    response = harness.outbox(caller)[0]
    assert response["result"] is True
    assert response["values"] == {"success": True, "message": ""}


def test_failure_text_from_provider_is_passed_on(harness):
    provider, caller, request_id = pending_call(harness)
    respond(harness, provider, request_id, result=False, values="broken")
    assert harness.outbox(caller)[0] == {
        "op": "service_response",
        "service": "/test_service",
        "values": "broken",
        "result": False,
        "id": 1,
    }


def test_calls_time_out_with_the_default_or_their_own_timeout(harness):
    provider = provide(harness)
    caller = harness.connect()
    harness.send(caller, {"op": "call_service", "service": "/test_service", "id": "default"})
    harness.send(
        caller, {"op": "call_service", "service": "/test_service", "id": "short", "timeout": 0.5}
    )
    harness.advance(1.0)
    assert [(r["id"], r["result"]) for r in harness.outbox(caller)] == [("short", False)]
    harness.advance(5.0)
    late = harness.outbox(caller)
    assert [(r["id"], r["result"]) for r in late] == [("default", False)]
    assert "timed out" in late[0]["values"]
    first_request = harness.outbox(provider)[0]["id"]
    respond(harness, provider, first_request, result=True, values={})
    assert harness.outbox(caller) == []


def test_unadvertise_and_disconnect_fail_pending_calls(harness):
    provider = provide(harness)
    caller = harness.connect()
    harness.send(caller, {"op": "call_service", "service": "/test_service", "id": 1})
    harness.send(provider, {"op": "unadvertise_service", "service": "/test_service"})
    assert harness.outbox(caller)[0]["values"] == "Service /test_service was unadvertised"
    provider = provide(harness)
    harness.send(caller, {"op": "call_service", "service": "/test_service", "id": 2})
    harness.disconnect(provider)
    failed = harness.outbox(caller)[0]
    assert failed["result"] is False and failed["id"] == 2
    assert "/test_service" not in harness.state.graph.services
    assert harness.call(caller, "/test_service")["values"].endswith("does not exist")


def test_re_advertising_replaces_the_provider_and_restarts_ids(harness):
    first = provide(harness)
    caller = harness.connect()
    harness.send(caller, {"op": "call_service", "service": "/test_service", "id": "old"})
    second = provide(harness)
    assert harness.outbox(caller)[0]["result"] is False
    harness.send(
        caller,
        {"op": "call_service", "service": "/test_service", "id": "new", "args": {"data": False}},
    )
    assert harness.outbox(second) == [
        {
            "op": "call_service",
            "id": "service_request:/test_service:1",
            "service": "/test_service",
            "args": {"data": False},
        }
    ]
    harness.outbox(first)
    harness.disconnect(first)
    assert harness.state.graph.services["/test_service"].provider == "/rosbridge_client_3"


def test_caller_disconnect_leaves_provider_response_harmless(harness):
    provider, caller, request_id = pending_call(harness)
    harness.disconnect(caller)
    respond(harness, provider, request_id, result=True, values={})
    assert harness.state.pending_calls == {}
    assert harness.outbox(provider) == []


def test_untyped_service_is_relayed_as_json(harness):
    provider = provide(harness, "/custom", "my_pkg/srv/Unknown")
    caller = harness.connect()
    harness.send(
        caller,
        {"op": "call_service", "service": "/custom", "id": 1, "args": {"anything": [1, "two"]}},
    )
    request = harness.outbox(provider)[0]
    assert request["args"] == {"anything": [1, "two"]}
    respond(
        harness, provider, request["id"], service="/custom", result=True, values={"free": "form"}
    )
    assert harness.outbox(caller)[0]["values"] == {"free": "form"}


def test_malformed_call_still_gets_an_answer(harness):
    caller = harness.connect()
    harness.send(caller, {"op": "call_service", "service": "/x", "id": 9, "timeout": "soon"})
    response = harness.outbox(caller)[0]
    assert response["result"] is False and response["id"] == 9


def test_malformed_provider_response_fails_the_call_at_once(harness):
    provider, caller, request_id = pending_call(harness)
    respond(harness, provider, request_id, values={}, result="yes")
    response = harness.outbox(caller)[0]
    assert response["result"] is False and "result" in response["values"]


def test_response_without_result_but_with_values_succeeds(harness):
    """roslibjs leaves `result` out when the provider's handler returns nothing."""
    provider, caller, request_id = pending_call(harness)
    respond(harness, provider, request_id, values={"success": True})
    response = harness.outbox(caller)[0]
    assert response["result"] is True
    assert response["values"] == {"success": True, "message": ""}


def test_status_only_after_set_level(harness):
    client = harness.connect()
    harness.send(client, {"op": "subscribe", "topic": "/unknown", "id": "s"})
    harness.send(client, {"op": "bogus"})
    harness.send(client, "{not json")
    assert harness.outbox(client) == []
    harness.send(client, {"op": "set_level", "level": "error"})
    harness.send(client, {"op": "subscribe", "topic": "/unknown", "id": "s"})
    status = harness.outbox(client)
    assert len(status) == 1 and status[0]["op"] == "status"
    assert status[0]["level"] == "error" and status[0]["id"] == "s"
    assert "Cannot infer topic type" in status[0]["msg"]
    harness.send(client, {"op": "set_level", "level": "none"})
    harness.send(client, {"op": "bogus"})
    assert harness.outbox(client) == []


def test_warnings_reach_only_clients_at_warning_level(harness):
    client = harness.connect()
    harness.send(client, {"op": "set_level", "level": "error"})
    fragment = {"op": "fragment", "id": "f", "num": 0, "total": 2, "data": "{"}
    harness.send(client, fragment)
    harness.send(client, fragment)
    assert harness.outbox(client) == []
    harness.send(client, {"op": "set_level", "level": "warning"})
    harness.send(client, fragment)
    assert [m["level"] for m in harness.outbox(client)] == ["warning"]


def test_a_failing_handler_still_answers_the_caller(harness):
    from bridge.rosapi import RosapiService

    def broken(ctx, request):
        raise RuntimeError("bug")

    harness.state.rosapi["/rosapi/broken"] = RosapiService("rosapi_msgs/srv/Nodes", broken)
    caller = harness.connect()
    response = harness.call(caller, "/rosapi/broken")
    assert response["result"] is False and "bug" in response["values"]
    assert harness.call(caller, "/rosapi/nodes")["result"] is True


def test_a_service_suffix_id_is_echoed_only_if_it_is_an_acceptable_id(harness):
    """`/srv#id` names the call's id (protocol §2.6); one longer than an id may be is dropped
    from the answer, as any unacceptable id is, and the caller is still answered."""
    caller = harness.connect()
    harness.send(caller, {"op": "call_service", "service": "/nowhere#mine"})
    harness.send(caller, {"op": "call_service", "service": "/nowhere#" + "x" * 400})
    answers = harness.outbox(caller)
    assert [a.get("id") for a in answers] == ["mine", None]
    assert all(a["result"] is False for a in answers)
