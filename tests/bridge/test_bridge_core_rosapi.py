"""rosapi services answered by the core from its own graph."""

from __future__ import annotations

import pytest


@pytest.fixture
def graph(harness):
    """A publisher of /chatter, a subscriber, a SetBool provider and a Fibonacci server."""
    pub, sub, provider = harness.connect(), harness.connect(), harness.connect()
    harness.send(pub, {"op": "advertise", "topic": "/chatter", "type": "std_msgs/String"})
    harness.send(sub, {"op": "subscribe", "topic": "/chatter"})
    harness.send(
        provider, {"op": "advertise_service", "service": "/set", "type": "std_srvs/SetBool"}
    )
    harness.send(
        provider,
        {"op": "advertise_action", "action": "/fib", "type": "example_interfaces/Fibonacci"},
    )
    return harness, harness.connect()


def values(h, client, service, args=None, **extra):
    response = h.call(client, service, args, **extra)
    assert response["result"] is True, response
    return response["values"]


def test_topics_and_raw_types_always_lists_rosout(harness):
    client = harness.connect()
    result = values(
        harness, client, "/rosapi/topics_and_raw_types", type="rosapi/TopicsAndRawTypes"
    )
    index = result["topics"].index("/rosout")
    assert result["types"][index] == "rcl_interfaces/msg/Log"
    assert "string msg" in result["typedefs_full_text"][index]


def test_topic_queries(graph):
    h, client = graph
    assert values(h, client, "rosapi/topics") == {
        "topics": ["/chatter", "/rosout"],
        "types": ["std_msgs/msg/String", "rcl_interfaces/msg/Log"],
    }
    assert values(h, client, "/rosapi/topic_type", {"topic": "/chatter"}) == {
        "type": "std_msgs/msg/String"
    }
    assert values(h, client, "/rosapi/topic_type", {"topic": "/none"}) == {"type": ""}
    assert values(h, client, "/rosapi/topics_for_type", {"type": "std_msgs/String"}) == {
        "topics": ["/chatter"]
    }
    assert values(h, client, "/rosapi/publishers", {"topic": "/chatter"}) == {
        "publishers": ["/rosbridge_client_1"]
    }
    assert values(h, client, "/rosapi/subscribers", {"topic": "/chatter"}) == {
        "subscribers": ["/rosbridge_client_2"]
    }


def test_service_queries(graph):
    h, client = graph
    services = values(h, client, "/rosapi/services")["services"]
    assert "/set" in services and "/rosapi/services" in services
    assert values(h, client, "/rosapi/service_type", {"service": "/set"}) == {
        "type": "std_srvs/srv/SetBool"
    }
    assert values(h, client, "/rosapi/service_type", {"service": "/rosapi/topics"}) == {
        "type": "rosapi_msgs/srv/Topics"
    }
    assert values(h, client, "/rosapi/services_for_type", {"type": "std_srvs/SetBool"}) == {
        "services": ["/set"]
    }
    assert values(h, client, "/rosapi/service_node", {"service": "/set"}) == {
        "node": "/rosbridge_client_3"
    }
    assert values(h, client, "/rosapi/service_providers", {"service": "/set"}) == {
        "providers": ["/rosbridge_client_3"]
    }


def test_node_queries(graph):
    h, client = graph
    nodes = values(h, client, "/rosapi/nodes")["nodes"]
    assert {"/rosbridge_websocket", "/rosapi", "/rosbridge_client_1"} <= set(nodes)
    assert values(h, client, "/rosapi/node_details", {"node": "/rosbridge_client_1"}) == {
        "subscribing": [],
        "publishing": ["/chatter"],
        "services": [],
    }
    assert values(h, client, "/rosapi/node_details", {"node": "/rosbridge_client_3"}) == {
        "subscribing": [],
        "publishing": [],
        "services": ["/set"],
    }
    failure = h.call(client, "/rosapi/node_details", {"node": "/ghost"})
    assert failure["result"] is False and "ghost" in failure["values"]


def test_action_queries(graph):
    h, client = graph
    assert values(h, client, "/rosapi/action_servers") == {"action_servers": ["/fib"]}
    assert values(h, client, "/rosapi/action_type", {"action": "/fib"}) == {
        "type": "example_interfaces/action/Fibonacci"
    }
    goal = values(
        h, client, "/rosapi/action_goal_details", {"type": "example_interfaces/Fibonacci"}
    )
    assert goal["typedefs"][0]["fieldnames"] == ["order"]


def test_type_details(harness):
    client = harness.connect()
    typedefs = values(
        harness, client, "/rosapi/message_details", {"type": "geometry_msgs/msg/Pose"}
    )["typedefs"]
    assert typedefs[0]["type"] == "geometry_msgs/Pose"
    assert typedefs[0]["fieldnames"] == ["position", "orientation"]
    request = values(
        harness, client, "/rosapi/service_request_details", {"type": "std_srvs/SetBool"}
    )["typedefs"]
    response = values(
        harness, client, "/rosapi/service_response_details", {"type": "std_srvs/srv/SetBool"}
    )["typedefs"]
    assert request[0]["fieldnames"] == ["data"]
    assert response[0]["fieldnames"] == ["success", "message"]
    assert harness.call(client, "/rosapi/message_details", {"type": "no/Such"})["result"] is False
    interfaces = values(harness, client, "/rosapi/interfaces")["interfaces"]
    assert {"std_msgs/msg/String", "std_srvs/srv/SetBool"} <= set(interfaces)


def test_time_and_version(harness):
    client = harness.connect()
    assert values(harness, client, "/rosapi/get_time") == {
        "time": {"sec": harness.now_ns // 10**9, "nanosec": harness.now_ns % 10**9}
    }
    assert values(harness, client, "/rosapi/get_ros_version") == {"version": 2, "distro": "jazzy"}


def test_params_round_trip(harness):
    client = harness.connect()
    name = "/add_two_ints_server:use_sim_time"
    assert values(harness, client, "/rosapi/get_param", {"name": name})["successful"] is False
    assert (
        values(harness, client, "/rosapi/get_param", {"name": name, "default_value": "3"})["value"]
        == "3"
    )
    values(harness, client, "/rosapi/set_param", {"name": name, "value": "true"})
    assert values(harness, client, "/rosapi/get_param", {"name": name})["value"] == "true"
    assert values(harness, client, "/rosapi/has_param", {"name": name}) == {"exists": True}
    assert values(harness, client, "/rosapi/get_param_names") == {"names": [name]}
    bad = harness.call(client, "/rosapi/set_param", {"name": name, "value": "{oops"})
    assert bad["result"] is False
    assert values(harness, client, "/rosapi/delete_param", {"name": name})["successful"]
    assert values(harness, client, "/rosapi/has_param", {"name": name}) == {"exists": False}


def test_rosapi_names_cannot_be_taken_over(harness):
    client = harness.connect()
    harness.send(
        client,
        {"op": "advertise_service", "service": "/rosapi/topics", "type": "rosapi_msgs/Topics"},
    )
    assert "/rosapi/topics" not in harness.state.graph.services


def test_disconnected_clients_vanish_from_rosapi(graph):
    h, client = graph
    for cid in (1, 2, 3):
        h.disconnect(cid)
    assert values(h, client, "/rosapi/topics")["topics"] == ["/rosout"]
    assert "/set" not in values(h, client, "/rosapi/services")["services"]
    assert values(h, client, "/rosapi/action_servers") == {"action_servers": []}
    assert values(h, client, "/rosapi/nodes")["nodes"] == [
        "/rosapi",
        "/rosbridge_client_4",
        "/rosbridge_websocket",
    ]


#: A request for each rosapi service that it can answer with `result: true` in `graph`.
TYPED_REQUESTS = {
    "topics_for_type": {"type": "std_msgs/String"},
    "services_for_type": {"type": "std_srvs/SetBool"},
    "service_type": {"service": "/set"},
    "topic_type": {"topic": "/chatter"},
    "node_details": {"node": "/rosapi"},
    "publishers": {"topic": "/chatter"},
    "subscribers": {"topic": "/chatter"},
    "service_providers": {"service": "/set"},
    "service_node": {"service": "/set"},
    "action_type": {"action": "/fib"},
    "message_details": {"type": "std_msgs/String"},
    "service_request_details": {"type": "std_srvs/SetBool"},
    "service_response_details": {"type": "std_srvs/SetBool"},
    "action_goal_details": {"type": "example_interfaces/Fibonacci"},
    "action_result_details": {"type": "example_interfaces/Fibonacci"},
    "action_feedback_details": {"type": "example_interfaces/Fibonacci"},
    "get_param": {"name": "/p", "default_value": "1"},
    "set_param": {"name": "/p", "value": "1"},
    "has_param": {"name": "/p"},
    "delete_param": {"name": "/p"},
}


def test_every_rosapi_answer_has_the_fields_of_its_srv_response(graph):
    """Requests and responses are typed by the `.srv` files in the registry, both ways."""
    h, client = graph
    for name, service in sorted(h.state.rosapi.items()):
        short = name.removeprefix("/rosapi/")
        answer = values(h, client, name, TYPED_REQUESTS.get(short, {}))
        response = h.state.registry.service(service.type_name).response
        assert list(answer) == [field.name for field in response.fields], name


def test_a_rosapi_answer_its_srv_does_not_declare_fails_the_call(harness):
    from bridge.rosapi import RosapiService

    def misspelt(ctx, request):
        return {"node": ["/a"]}

    harness.state.rosapi["/rosapi/misspelt"] = RosapiService("rosapi_msgs/srv/Nodes", misspelt)
    response = harness.call(harness.connect(), "/rosapi/misspelt")
    assert response["result"] is False
    assert response["values"].startswith("rosapi_msgs/srv/Nodes_Response field 'node': no such")
