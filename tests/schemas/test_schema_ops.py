"""Every op parses from what roslibpy, roslibjs, Lichtblick and ROS# actually send."""

import json

import numpy as np
import pydantic
import pytest

from schemas import ops
from schemas.errors import SchemaError
from schemas.ops import OpError, parse_op, to_wire

# Frames as the clients write them (docs: reference/rosbridge-clients.md §2-§5).
CLIENT_FRAMES = {
    "roslibpy subscribe": '{"op": "subscribe", "id": "subscribe:/chatter:3", "type": null, '
    '"topic": "/chatter", "compression": "none", "throttle_rate": 0, "queue_length": 0}',
    "roslibpy advertise": '{"op": "advertise", "id": "advertise:/chatter:4", '
    '"type": "std_msgs/String", "topic": "/chatter", "latch": false, "queue_size": 100}',
    "roslibpy publish": '{"op": "publish", "id": "publish:/chatter:5", "topic": "/chatter", '
    '"msg": {"data": "hi"}, "latch": false}',
    "roslibpy unsubscribe": '{"op": "unsubscribe", "id": "subscribe:/chatter:3", '
    '"topic": "/chatter"}',
    "roslibpy unadvertise": '{"op": "unadvertise", "id": "advertise:/chatter:4", '
    '"topic": "/chatter"}',
    "roslibpy call_service": '{"op": "call_service", "id": "call_service:/rosapi/topics:6", '
    '"service": "/rosapi/topics", "args": {}}',
    "roslibpy advertise_service": '{"op": "advertise_service", "type": "std_srvs/SetBool", '
    '"service": "/set"}',
    "roslibpy unadvertise_service": '{"op": "unadvertise_service", "service": "/set"}',
    "roslibpy service_response": '{"op": "service_response", "service": "/set", '
    '"values": {"success": true, "message": ""}, "result": true, "id": "service_request:/set:1"}',
    "roslibpy send_action_goal": '{"op": "send_action_goal", "id": "send_action_goal:/fib:7", '
    '"action": "/fibonacci", "action_type": "example_interfaces/action/Fibonacci", '
    '"args": {"order": 4}, "feedback": true}',
    "roslibpy cancel_action_goal": '{"op": "cancel_action_goal", '
    '"id": "send_action_goal:/fib:7", "action": "/fibonacci"}',
    "roslibpy set_level": '{"op": "set_level", "level": "error", "id": 1}',
    "roslibpy auth": '{"op": "auth", "mac": "ab12", "client": "192.168.1.101", '
    '"dest": "192.168.1.111", "rand": "xyz", "t": 1700000000.5, '
    '"level": "admin", "end": 1700003600}',
    "roslibjs subscribe cbor": '{"op":"subscribe","id":"subscribe:/scan:0b1c","type":'
    '"sensor_msgs/msg/LaserScan","topic":"/scan","compression":"cbor","throttle_rate":0,'
    '"queue_length":0}',
    "roslibjs call_service timeout": '{"op":"call_service","id":"call_service:rosapi/topics:9",'
    '"service":"rosapi/topics","args":{},"timeout":2.5}',
    "roslibjs service_response without values": '{"op":"service_response","service":"/t",'
    '"result":false,"id":"service_request:/t:2"}',
    "roslibjs advertise_action": '{"op":"advertise_action","type":'
    '"example_interfaces/action/Fibonacci","action":"/fibonacci"}',
    "roslibjs unadvertise_action": '{"op":"unadvertise_action","action":"/fibonacci"}',
    "roslibjs action_feedback": '{"op":"action_feedback","id":"action_goal:/fibonacci:1",'
    '"action":"/fibonacci","values":{"sequence":[0,1]}}',
    "roslibjs action_result": '{"op":"action_result","id":"action_goal:/fibonacci:1",'
    '"action":"/fibonacci","values":{"sequence":[0,1,1]},"status":4,"result":true}',
    "roslibjs action_result failed": '{"op":"action_result","id":"a:1","action":"/fibonacci",'
    '"status":6,"result":false}',
    "lichtblick subscribe": '{"op":"subscribe","id":"subscribe:/points:12","topic":"/points",'
    '"compression":"cbor-raw","throttle_rate":0,"queue_length":0}',
    "lichtblick topics_and_raw_types": '{"op":"call_service","id":'
    '"call_service:/rosapi/topics_and_raw_types:3","service":"/rosapi/topics_and_raw_types",'
    '"type":"rosapi/TopicsAndRawTypes","args":{}}',
    "ros# publish": '{"topic":"/cmd","msg":{"linear":{"x":1.0}},"op":"publish","id":"/cmd"}',
    "ros# subscribe": '{"topic":"/odom","type":"nav_msgs/msg/Odometry","throttle_rate":0,'
    '"queue_length":1,"fragment_size":2147483647,"compression":"none","op":"subscribe",'
    '"id":"/odom:0"}',
    "ros# call_service": '{"service":"/rosapi/get_ros_version","args":{},'
    '"fragment_size":2147483647,"compression":"none","op":"call_service",'
    '"id":"/rosapi/get_ros_version:0"}',
    "ros# advertise_service": '{"type":"std_srvs/srv/Trigger","service":"/trig",'
    '"op":"advertise_service","id":null}',
    "ros# advertise": '{"topic":"/cmd","type":"geometry_msgs/msg/Twist","op":"advertise",'
    '"id":"/cmd"}',
    "fragment float total": '{"op":"fragment","id":0,"data":"{\\"op\\"","num":0,"total":3.4}',
    "png": '{"op":"png","data":"iVBORw0KGgo="}',
    "status": '{"op":"status","level":"error","msg":"bad","id":"x"}',
}


@pytest.mark.parametrize("name", sorted(CLIENT_FRAMES))
def test_client_frames_parse(name):
    obj = json.loads(CLIENT_FRAMES[name])
    model = parse_op(obj)
    assert model.op == obj["op"]
    assert isinstance(model, ops.MODELS[obj["op"]])


def test_every_op_has_a_model():
    assert set(ops.MODELS) == {
        "advertise",
        "unadvertise",
        "publish",
        "subscribe",
        "unsubscribe",
        "call_service",
        "advertise_service",
        "unadvertise_service",
        "service_response",
        "fragment",
        "png",
        "set_level",
        "status",
        "auth",
        "send_action_goal",
        "cancel_action_goal",
        "action_feedback",
        "action_result",
        "advertise_action",
        "unadvertise_action",
    }
    covered = {json.loads(frame)["op"] for frame in CLIENT_FRAMES.values()}
    assert covered == set(ops.MODELS)


def test_defaults():
    sub = parse_op({"op": "subscribe", "topic": "/t"})
    assert (sub.throttle_rate, sub.queue_length, sub.fragment_size, sub.compression) == (
        0,
        0,
        None,
        "none",
    )
    assert sub.type is None and sub.id is None
    adv = parse_op({"op": "advertise", "topic": "/t", "type": "std_msgs/String"})
    assert (adv.latch, adv.queue_size) == (False, 100)
    assert parse_op({"op": "publish", "topic": "/t"}).msg == {}
    call = parse_op({"op": "call_service", "service": "/s"})
    assert call.args == {} and call.timeout is None
    goal = parse_op({"op": "send_action_goal", "action": "/a", "action_type": "p/A"})
    assert goal.feedback is False and goal.args == {}


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        ({"a": 1}, {"a": 1}),
        ([1, 2], [1, 2]),
        ("x", {}),
        (None, {}),
        (5, {}),
    ],
)
def test_call_service_args_shapes(args, expected):
    assert parse_op({"op": "call_service", "service": "/s", "args": args}).args == expected


def test_call_service_type_is_accepted_whatever_it_is():
    for type_value in ("rosapi/Topics", None, 5, {"x": 1}):
        call = parse_op({"op": "call_service", "service": "/s", "type": type_value})
        assert (call.op, call.service, call.type) == ("call_service", "/s", type_value)


def test_extras_are_kept():
    sub = parse_op({"op": "subscribe", "topic": "/t", "message_intervall": 0.1, "x": [1]})
    assert sub.model_extra == {"message_intervall": 0.1, "x": [1]}


def test_fragment_total_is_floored():
    assert parse_op(json.loads(CLIENT_FRAMES["fragment float total"])).total == 3
    assert parse_op({"op": "fragment", "id": 1, "data": "", "num": 0, "total": 2}).total == 2


def test_payloads_are_not_copied_or_walked():
    payload = {"data": np.zeros(4_000_000, np.uint8).tobytes(), "arr": np.ones(10)}
    publish = parse_op({"op": "publish", "topic": "/p", "msg": payload})
    assert publish.msg is payload
    response = parse_op(
        {"op": "service_response", "service": "/s", "values": payload, "result": True}
    )
    assert response.values is payload


@pytest.mark.parametrize(
    ("obj", "message"),
    [
        (
            {"op": "subscribe", "topic": "/a", "throttle_rate": "fast"},
            "subscribe: field 'throttle_rate' must be an integer, got 'fast'",
        ),
        (
            {"op": "subscribe", "topic": "/a", "throttle_rate": 1.5},
            "subscribe: field 'throttle_rate' must be an integer, got 1.5",
        ),
        (
            {"op": "subscribe", "topic": "/a", "fragment_size": "five cubits"},
            "subscribe: field 'fragment_size' must be an integer, got 'five cubits'",
        ),
        (
            {"op": "subscribe", "topic": "/a", "compression": 9000},
            "subscribe: field 'compression' must be a string, got 9000",
        ),
        ({"op": "subscribe"}, "subscribe: field 'topic' is required"),
        (
            {"op": "advertise", "topic": 5, "type": "std_msgs/String"},
            "advertise: field 'topic' must be a string, got 5",
        ),
        (
            {"op": "advertise", "topic": "/t", "type": None},
            "advertise: field 'type' must be a string, got None",
        ),
        (
            {"op": "publish", "topic": "/t", "msg": [1, 2]},
            "publish: field 'msg' must be an object, got [1, 2]",
        ),
        (
            {"op": "service_response", "service": "/s", "values": {}},
            "service_response: field 'result' is required",
        ),
        (
            {"op": "set_level", "level": "loud"},
            "set_level: field 'level' must be 'info', 'warning', 'error' or 'none', got 'loud'",
        ),
        (
            {"op": "action_result", "action": "/a", "result": True, "status": "done"},
            "action_result: field 'status' must be an integer, got 'done'",
        ),
        (
            {"op": "advertise", "topic": "/t", "type": "x", "latch": "yes"},
            "advertise: field 'latch' must be a boolean, got 'yes'",
        ),
    ],
)
def test_bad_ops_give_one_line_errors(obj, message):
    with pytest.raises(OpError) as info:
        parse_op(obj)
    assert str(info.value) == message
    assert "\n" not in str(info.value)
    assert info.value.op == obj["op"]


def test_several_problems_are_counted_in_the_same_line():
    with pytest.raises(OpError, match=r"\(and 1 more problem\(s\)\)$"):
        parse_op({"op": "subscribe", "topic": 1, "throttle_rate": "x"})


@pytest.mark.parametrize(
    ("obj", "message"),
    [
        ([1, 2], "expected a JSON object with an 'op' field, got list"),
        (5, "expected a JSON object with an 'op' field, got int"),
        (None, "expected a JSON object with an 'op' field, got NoneType"),
        ({"topic": "/x"}, "message has no 'op' field (keys: ['topic'])"),
        ({"op": 3}, "field 'op' must be a string, got 3"),
        ({"op": "authenticate", "id": 9}, "unknown op 'authenticate'"),
        ({"op": "auth", "id": 9}, "auth: field 'mac' is required (and 6 more problem(s))"),
    ],
)
def test_non_ops(obj, message):
    with pytest.raises(OpError) as info:
        parse_op(obj)
    assert str(info.value) == message
    assert isinstance(info.value, SchemaError)


def test_error_carries_op_and_id():
    with pytest.raises(OpError) as info:
        parse_op({"op": "call_service", "id": "c:1"})
    assert (info.value.op, info.value.id) == ("call_service", "c:1")


def test_to_wire_key_order_and_unset_fields():
    publish = ops.Publish(topic="/t", msg={"data": 1})
    assert list(to_wire(publish).items()) == [
        ("op", "publish"),
        ("topic", "/t"),
        ("msg", {"data": 1}),
    ]
    ok = ops.ServiceResponse(service="/s", values={"sum": 3}, result=True, id="call:1")
    assert list(to_wire(ok)) == ["op", "service", "values", "result", "id"]
    no_id = ops.ServiceResponse(service="/s", values="Service /s does not exist", result=False)
    assert "id" not in to_wire(no_id)
    request = ops.CallService(id="service_request:/s:1", service="/s", args={"a": 1})
    assert list(to_wire(request)) == ["op", "id", "service", "args"]
    feedback = ops.ActionFeedback(action="/a", values={"sequence": [0]}, id="g")
    assert list(to_wire(feedback)) == ["op", "action", "values", "id"]
    result = ops.ActionResult(action="/a", values={}, status=4, result=True, id="g")
    assert list(to_wire(result)) == ["op", "action", "values", "status", "result", "id"]
    status = ops.Status(level="error", msg="boom", id=None)
    assert to_wire(status) == {"op": "status", "level": "error", "msg": "boom"}
    fragment = ops.Fragment(id=0, data="ab", num=0, total=2)
    assert list(to_wire(fragment)) == ["op", "id", "data", "num", "total"]


def test_to_wire_of_a_parsed_op_keeps_what_was_sent():
    obj = json.loads(CLIENT_FRAMES["roslibpy subscribe"])
    wire = to_wire(parse_op(obj))
    assert wire == {k: v for k, v in obj.items()}


def test_models_are_frozen():
    sub = parse_op({"op": "subscribe", "topic": "/t"})
    with pytest.raises(pydantic.ValidationError):
        sub.topic = "/other"


@pytest.mark.parametrize(
    "obj",
    [
        {"op": "publish", "topic": "/t", "msg": {"data": 1}},
        {"op": "publish", "topic": "t", "msg": None, "id": "p:1", "latch": True},
        {"op": "publish", "topic": "/t", "queue_size": 5, "type": "std_msgs/String", "extra": 1},
        {"op": "publish", "topic": "/t", "msg": {}, "id": 7.5},
    ],
)
def test_parse_publish_reads_what_parse_op_reads(obj):
    fast, full = ops.parse_publish(obj), parse_op(obj)
    assert isinstance(fast, ops.PublishFields)
    for name in ops.PublishFields._fields:
        assert getattr(fast, name) == getattr(full, name), name


@pytest.mark.parametrize(
    "obj",
    [
        {"op": "publish", "topic": 5, "msg": {}},
        {"op": "publish", "msg": {}},
        {"op": "publish", "topic": "/t", "msg": [1, 2]},
        {"op": "publish", "topic": "/t", "latch": 1},
        {"op": "publish", "topic": "/t", "queue_size": True},
        {"op": "publish", "topic": "/t", "type": 3},
        {"op": "publish", "topic": "/t", "msg": {}, "id": {"any": "json"}},
        {"op": "publish", "topic": "/t", "id": "i" * 301},
        {"op": "publish", "topic": "/" + "t" * 600},
    ],
)
def test_parse_publish_refuses_like_parse_op(obj):
    with pytest.raises(OpError) as fast:
        ops.parse_publish(obj)
    with pytest.raises(OpError) as full:
        parse_op(obj)
    assert str(fast.value) == str(full.value)
