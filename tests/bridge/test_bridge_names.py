"""ROS 2 name rules (rcl/rmw validation), expansion, and the globs they feed."""

from __future__ import annotations

import pytest

from bridge.errors import InvalidNameError
from bridge.names import MAX_NAME_CHARS, absolute_name
from tests.bridge.bridge_harness import CoreHarness


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("/a", "/a"),
        ("rosapi/topics", "/rosapi/topics"),
        ("/a/_b1/C", "/a/_b1/C"),
        ("~/x", "/rosbridge_websocket/x"),
        ("{node}/x", "/rosbridge_websocket/x"),
        ("/{ns}/chatter", "/chatter"),
        ("/fibonacci/_action/send_goal", "/fibonacci/_action/send_goal"),
    ],
)
def test_valid_names_are_made_absolute(name, expected):
    assert absolute_name(name) == expected


@pytest.mark.parametrize(
    ("name", "rule"),
    [
        ("", "empty"),
        ("/", "end with '/'"),
        ("/a/", "end with '/'"),
        ("/a//b", "'//'"),
        ("/allowed/../denied", "only letters"),
        ("/a b", "only letters"),
        (" /a", "only letters"),
        ("/a-b", "only letters"),
        ("/é", "only letters"),
        ("/\ud800", "only letters"),
        ("/1a", "digit"),
        ("1a", "digit"),
        ("/a/2", "digit"),
        ("~x", "'~'"),
        ("/a~", "'~'"),
        ("/{ns", "'{}'"),
        ("/{a{b}}", "'{}'"),
        ("/{other}/x", "unknown substitution"),
        ("/" + "a" * MAX_NAME_CHARS, "longer than"),
    ],
)
def test_invalid_names_are_refused_naming_the_rule(name, rule):
    with pytest.raises(InvalidNameError, match=rule.replace("{", "\\{").replace("}", "\\}")):
        absolute_name(name)


def refused(h: CoreHarness, client: int, op: dict) -> str:
    h.send(client, op)
    [status] = h.outbox(client)
    assert status["op"] == "status", status
    return status["msg"]


def test_dot_dot_cannot_escape_a_topics_glob(registry):
    h = CoreHarness(registry, topics_glob=("/allowed/*",))
    client = h.connect()
    h.send(client, {"op": "set_level", "level": "error"})
    assert "not a valid ROS name" in refused(
        h, client, {"op": "advertise", "topic": "/allowed/../denied", "type": "std_msgs/String"}
    )
    assert "topics_glob" in refused(
        h, client, {"op": "advertise", "topic": "/denied", "type": "std_msgs/String"}
    )
    h.send(client, {"op": "advertise", "topic": "/allowed/ok", "type": "std_msgs/String"})
    assert h.outbox(client) == []


@pytest.mark.parametrize(
    "config", [{"services_glob": ("/allowed/*",)}, {"actions_glob": ("/allowed/*",)}]
)
def test_actions_are_gated_like_services(registry, config):
    h = CoreHarness(registry, **config)
    provider, caller = h.connect(), h.connect()
    h.send(provider, {"op": "set_level", "level": "error"})
    assert "actions_glob" in refused(
        h,
        provider,
        {"op": "advertise_action", "action": "/denied", "type": "example_interfaces/Fibonacci"},
    )
    assert h.state.graph.actions == {}
    h.send(
        caller,
        {
            "op": "send_action_goal",
            "action": "/denied",
            "id": "g",
            "action_type": "example_interfaces/Fibonacci",
            "args": {"order": 2},
        },
    )
    [result] = h.outbox(caller)
    assert result["op"] == "action_result" and result["result"] is False
    assert "actions_glob" in result["values"]
    h.send(
        provider,
        {
            "op": "advertise_action",
            "action": "/allowed/fib",
            "type": "example_interfaces/Fibonacci",
        },
    )
    assert set(h.state.graph.actions) == {"/allowed/fib"}


def test_actions_glob_overrides_services_glob(registry):
    h = CoreHarness(registry, services_glob=("/svc/*",), actions_glob=("/act/*",))
    provider = h.connect()
    h.send(
        provider,
        {"op": "advertise_action", "action": "/act/fib", "type": "example_interfaces/Fibonacci"},
    )
    assert set(h.state.graph.actions) == {"/act/fib"}
