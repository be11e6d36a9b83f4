"""ROS 2 nodes' parameters in Foxglove's shape (bridge.foxglove.node_parameters): names as
foxglove_bridge splits them, values both ways, a SetParameters answer read per parameter."""

from __future__ import annotations

import numpy as np
import orjson
import pytest

from bridge.foxglove import wire
from bridge.foxglove.channels import ChannelTable
from bridge.foxglove.node_parameters import (
    parameter_nodes,
    service_nodes,
    set_failures,
    split_name,
    to_foxglove,
    to_ros,
)
from bridge.foxglove.param_events import event_parameters
from bridge.foxglove.session import FoxgloveSession
from schemas.registry import TypeRegistry

SERVICES = {"/talker/get_parameters", "/talker/list_parameters", "/ns/cam/get_parameters"}


def test_names_split_at_the_first_dot_when_the_node_serves_parameters() -> None:
    assert split_name("/talker.gain", SERVICES) == ("/talker", "gain")
    assert split_name("/talker.pid.kp", SERVICES) == ("/talker", "pid.kp")
    assert split_name("/ns/cam.exposure", SERVICES) == ("/ns/cam", "exposure")
    # The bridge's own: no such node, no dot, or not a node name.
    for own in ("/other.gain", "/compat:answer", "talker.gain", "/talker.", ".gain"):
        assert split_name(own, SERVICES) is None


def test_nodes_that_list_and_get_their_parameters() -> None:
    assert service_nodes(SERVICES) == {"/talker", "/ns/cam"}
    assert parameter_nodes(SERVICES, service_nodes(SERVICES)) == ["/talker"]


@pytest.mark.parametrize(
    ("value", "expected"),
    [
        ({"type": 1, "bool_value": True}, {"value": True}),
        ({"type": 2, "integer_value": 7}, {"value": 7}),
        ({"type": 3, "double_value": 2.0}, {"value": 2.0, "type": "float64"}),
        ({"type": 4, "string_value": "on"}, {"value": "on"}),
        ({"type": 5, "byte_array_value": b"\x01\x02"}, {"value": "AQI=", "type": "byte_array"}),
        ({"type": 7, "integer_array_value": np.array([1, 2])}, {"value": [1, 2]}),
        (
            {"type": 8, "double_array_value": np.array([0.5])},
            {"value": [0.5], "type": "float64_array"},
        ),
        ({"type": 9, "string_array_value": ["a"]}, {"value": ["a"]}),
    ],
)
def test_values_cross_to_foxglove_and_back(value: dict, expected: dict) -> None:
    shown = to_foxglove("/talker", "p", value)
    assert shown == {"name": "/talker.p", **expected}
    back = to_ros(wire.Parameter.model_validate(shown))
    field = next(k for k in value if k != "type")
    assert back["type"] == value["type"]
    assert np.array_equal(np.asarray(back[field]), np.asarray(value[field]))


def test_not_set_and_unholdable_values() -> None:
    assert to_foxglove("/talker", "p", {"type": 0}) is None
    with pytest.raises(ValueError, match="cannot hold"):
        to_ros(wire.Parameter(name="/talker.p", value={"no": "object"}))
    with pytest.raises(ValueError, match="not base64"):
        to_ros(wire.Parameter(name="/talker.p", value="%%", type="byte_array"))
    assert to_ros(wire.Parameter(name="/talker.p", value=2, type="float64")) == {
        "type": 3,
        "double_value": 2.0,
    }


def test_set_answers_name_what_was_refused() -> None:
    answer = {"results": [{"successful": True}, {"successful": False, "reason": "read-only"}]}
    assert set_failures("/talker", ["a", "b"], answer) == [
        ("b", "setting /talker.b failed: read-only")
    ]
    assert set_failures("/talker", ["a"], "timed out") == [
        ("a", "setting /talker.a failed: timed out")
    ]


def test_the_session_sets_a_nodes_parameter_through_the_shell_not_rosapi() -> None:
    """A node's parameter becomes a node set for the shell (no rosapi op); the bridge's own
    still becomes rosapi's set_param; a value no parameter can hold is a status at once."""
    registry = TypeRegistry()
    session = FoxgloveSession(1, ChannelTable(registry), registry)
    session.node_param = lambda name: split_name(name, SERVICES)
    frame = orjson.dumps(
        {
            "op": "setParameters",
            "id": "s",
            "parameters": [
                {"name": "/talker.gain", "value": 2, "type": "float64"},
                {"name": "own", "value": 1},
                {"name": "/talker.bad", "value": {"no": 1}},
            ],
        }
    ).decode()
    reply = session.receive(frame)
    assert reply.node_sets == [("/talker", "gain", {"type": 3, "double_value": 2.0})]
    assert [op["args"]["name"] for op in reply.ops] == ["own"]
    assert reply.parameters_after == (["/talker.gain", "own", "/talker.bad"], "s")
    [problem] = reply.problems
    assert problem.startswith("setting '/talker.bad' failed: a ROS 2 parameter cannot hold")


def test_a_parameter_event_names_its_nodes_new_and_changed_parameters() -> None:
    event = {
        "node": "/talker",
        "new_parameters": [{"name": "mode", "value": {"type": 4, "string_value": "fast"}}],
        "changed_parameters": [{"name": "gain", "value": {"type": 3, "double_value": 2.0}}],
        "deleted_parameters": [{"name": "old", "value": {"type": 0}}],
    }
    assert event_parameters(event) == [
        {"name": "/talker.mode", "value": "fast"},
        {"name": "/talker.gain", "value": 2.0, "type": "float64"},
    ]
