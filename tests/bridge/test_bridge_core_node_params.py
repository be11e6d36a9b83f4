"""rosapi `node_name:param_name` against the node's rcl_interfaces services (the sans-I/O core,
a client standing in for the node): forwarded, translated both ways, bounded by the call
timeout, and kept in the bridge when the node has no parameter services."""

from __future__ import annotations

from bridge.rosapi.node_params import parameter_value, value_json


def serve_parameters(harness, node: str = "/talker") -> int:
    """A client offering `node`'s get_parameters and set_parameters (answered by the test)."""
    provider = harness.connect()
    for name, type_name in (("get", "GetParameters"), ("set", "SetParameters")):
        harness.send(
            provider,
            {
                "op": "advertise_service",
                "service": f"{node}/{name}_parameters",
                "type": f"rcl_interfaces/srv/{type_name}",
            },
        )
    return provider


def forwarded(harness, provider: int) -> dict:
    [request] = [m for m in harness.outbox(provider) if m["op"] == "call_service"]
    return request


def answer(harness, provider: int, request: dict, values: dict) -> None:
    harness.send(
        provider,
        {
            "op": "service_response",
            "service": request["service"],
            "id": request["id"],
            "values": values,
            "result": True,
        },
    )


def reply(harness, caller: int) -> dict:
    [response] = [m for m in harness.outbox(caller) if m["op"] == "service_response"]
    return response


def test_get_param_asks_the_node_and_answers_json_text(harness):
    provider, caller = serve_parameters(harness), harness.connect()
    harness.send(
        caller,
        {"op": "call_service", "service": "/rosapi/get_param", "args": {"name": "/talker:gain"}},
    )
    request = forwarded(harness, provider)
    assert request["service"] == "/talker/get_parameters"
    assert request["args"] == {"names": ["gain"]}
    answer(harness, provider, request, {"values": [{"type": 3, "double_value": 2.5}]})
    assert reply(harness, caller)["values"] == {"value": "2.5", "successful": True, "reason": ""}


def test_set_param_sends_the_value_with_its_json_type(harness):
    provider, caller = serve_parameters(harness), harness.connect()
    harness.send(
        caller,
        {
            "op": "call_service",
            "service": "/rosapi/set_param",
            "args": {"name": "talker:names", "value": '["a", "b"]'},
        },
    )
    request = forwarded(harness, provider)
    assert request["service"] == "/talker/set_parameters"
    [parameter] = request["args"]["parameters"]
    assert parameter["name"] == "names"
    assert parameter["value"]["type"] == 9 and parameter["value"]["string_array_value"] == [
        "a",
        "b",
    ]
    answer(harness, provider, request, {"results": [{"successful": False, "reason": "read-only"}]})
    assert reply(harness, caller)["values"] == {"successful": False, "reason": "read-only"}


def test_a_node_that_does_not_answer_fails_the_call_after_the_timeout(harness):
    serve_parameters(harness)
    caller = harness.connect()
    harness.send(
        caller,
        {"op": "call_service", "service": "/rosapi/get_param", "args": {"name": "/talker:gain"}},
    )
    harness.advance(4.0)
    assert harness.outbox(caller) == []
    harness.advance(2.0)  # the default call timeout is 5 s
    response = reply(harness, caller)
    assert response["result"] is False
    assert "/talker/get_parameters call timed out after 5 s" in response["values"]


def test_a_value_no_parameter_can_hold_is_refused_before_asking(harness):
    provider, caller = serve_parameters(harness), harness.connect()
    harness.send(
        caller,
        {
            "op": "call_service",
            "service": "/rosapi/set_param",
            "args": {"name": "/talker:gain", "value": '{"nested": 1}'},
        },
    )
    response = reply(harness, caller)
    assert response["result"] is False and "cannot hold" in response["values"]
    assert harness.outbox(provider) == []


def test_parameter_values_translate_both_ways():
    assert value_json({"type": 1, "bool_value": True}) == "true"
    assert value_json({"type": 7, "integer_array_value": [1, 2]}) == "[1,2]"
    assert value_json({"type": 0}) == "null"
    assert parameter_value("3") == {"type": 2, "integer_value": 3}
    assert parameter_value("[1, 2.5]") == {"type": 8, "double_array_value": [1, 2.5]}
    assert parameter_value('"x"') == {"type": 4, "string_value": "x"}


def serve_list(harness, node: str) -> int:
    provider = harness.connect()
    harness.send(
        provider,
        {
            "op": "advertise_service",
            "service": f"{node}/list_parameters",
            "type": "rcl_interfaces/srv/ListParameters",
        },
    )
    return provider


def test_get_param_names_gathers_every_nodes_list_after_the_own(harness):
    """`node:param` from each node's list_parameters, asked at once; the caller is answered
    when the last node has; a node that does not answer in time is left out."""
    talker, silent, lidar = (serve_list(harness, n) for n in ("/talker", "/silent", "/lidar"))
    caller = harness.connect()
    harness.send(
        caller,
        {
            "op": "call_service",
            "service": "/rosapi/set_param",
            "args": {"name": "own", "value": "1"},
        },
    )
    harness.outbox(caller)
    harness.send(caller, {"op": "call_service", "service": "/rosapi/get_param_names", "id": "n"})
    for provider, names in ((talker, ["gain", "pid.kp"]), (lidar, ["rate_hz"])):
        request = forwarded(harness, provider)
        assert request["args"] == {"prefixes": [], "depth": 0}
        answer(harness, provider, request, {"result": {"names": names, "prefixes": []}})
    assert forwarded(harness, silent)["service"] == "/silent/list_parameters"
    assert harness.outbox(caller) == []  # /silent has not answered yet
    harness.advance(6.0)
    response = reply(harness, caller)
    assert response["result"] is True and response["id"] == "n"
    assert response["values"]["names"] == [
        "own",
        "/lidar:rate_hz",
        "/talker:gain",
        "/talker:pid.kp",
    ]


def test_get_param_names_without_nodes_is_the_bridges_own(harness):
    caller = harness.connect()
    harness.send(caller, {"op": "call_service", "service": "/rosapi/get_param_names"})
    assert reply(harness, caller)["values"] == {"names": []}
