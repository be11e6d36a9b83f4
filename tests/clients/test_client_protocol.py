"""Sans-I/O tests of ClientProtocol: frames per op, routing, ids, resume, normalization."""

from __future__ import annotations

import numpy as np
import orjson
import pytest

from clients.errors import ProtocolError
from clients.events import (
    ActionFeedback,
    ActionOutcome,
    Ignored,
    ServiceReply,
    ServiceRequest,
    TopicMessage,
)
from clients.protocol import ClientProtocol
from schemas import codec_cbor, codec_json
from schemas.errors import SchemaError
from schemas.frames import publish_cbor, publish_json
from schemas.registry import TypeRegistry

NOW_NS = 1_700_000_000_123_456_789


@pytest.fixture
def json_proto(registry: TypeRegistry) -> ClientProtocol:
    return ClientProtocol(encoding="json", spec_lookup=registry.message)


@pytest.fixture
def cbor_proto(registry: TypeRegistry) -> ClientProtocol:
    return ClientProtocol(encoding="cbor", spec_lookup=registry.message)


def op_of(frame) -> dict:
    assert frame.text, "control ops travel as JSON text frames"
    return orjson.loads(frame.data)


def test_subscribe_frame_carries_roslibpy_style_id_and_defaults(json_proto):
    sub_id, frame = json_proto.subscribe("/imu", "sensor_msgs/msg/Imu")
    assert sub_id == "subscribe:/imu:1"
    assert op_of(frame) == {
        "op": "subscribe",
        "id": "subscribe:/imu:1",
        "topic": "/imu",
        "type": "sensor_msgs/msg/Imu",
        "compression": "none",
        "throttle_rate": 0,
        "queue_length": 0,
    }


def test_default_compression_follows_encoding(cbor_proto, json_proto):
    assert op_of(cbor_proto.subscribe("/t")[1])["compression"] == "cbor"
    assert op_of(json_proto.subscribe("/t")[1])["compression"] == "none"
    explicit = op_of(
        cbor_proto.subscribe("/t", compression="png", throttle_rate_ms=50, queue_length=2)[1]
    )
    assert (explicit["compression"], explicit["throttle_rate"], explicit["queue_length"]) == (
        "png",
        50,
        2,
    )
    assert "type" not in explicit


def test_ids_count_up_across_ops(json_proto):
    json_proto.advertise("/a", "std_msgs/msg/String")
    sub_id, _ = json_proto.subscribe("/b")
    call_id, _ = json_proto.call_service("/s")
    goal_id, _ = json_proto.send_action_goal("/act", "example_interfaces/action/Fibonacci")
    assert json_proto.advertisements["/a"].advert_id == "advertise:/a:1"
    assert (sub_id, call_id, goal_id) == (
        "subscribe:/b:2",
        "call_service:/s:3",
        "send_action_goal:/act:4",
    )


def test_subscribe_unknown_type_raises_before_sending(json_proto):
    with pytest.raises(SchemaError):
        json_proto.subscribe("/x", "no_pkg/msg/Nothing")
    assert not json_proto.subscriptions


def test_advertise_unadvertise_frames(json_proto):
    assert op_of(json_proto.advertise("/cmd", "geometry_msgs/Twist", latch=True)) == {
        "op": "advertise",
        "id": "advertise:/cmd:1",
        "type": "geometry_msgs/Twist",
        "topic": "/cmd",
        "latch": True,
        "queue_size": 100,
    }
    assert op_of(json_proto.unadvertise("/cmd")) == {
        "op": "unadvertise",
        "id": "advertise:/cmd:1",
        "topic": "/cmd",
    }
    assert json_proto.unadvertise("/cmd") is None


def test_publish_encoding_per_connection(json_proto, cbor_proto):
    msg = {"data": b"\x00\x01\xff", "values": np.arange(3, dtype=np.float32)}
    as_json = json_proto.encode_publish("/t", msg)
    as_cbor = cbor_proto.encode_publish("/t", msg)
    assert as_json.text and not as_cbor.text
    assert as_json.data == publish_json("/t", msg)
    assert as_cbor.data == publish_cbor("/t", msg)
    decoded = codec_cbor.loads(as_cbor.data)
    assert decoded["msg"]["data"] == b"\x00\x01\xff"
    assert decoded["msg"]["values"].dtype == np.float32


def test_call_service_frame_and_reply_routing(json_proto):
    call_id, frame = json_proto.call_service("/add", {"a": 1}, type="x/srv/Add", timeout_s=2)
    assert op_of(frame) == {
        "op": "call_service",
        "id": call_id,
        "service": "/add",
        "args": {"a": 1},
        "type": "x/srv/Add",
        "timeout": 2.0,
    }
    reply = {
        "op": "service_response",
        "id": call_id,
        "service": "/add",
        "values": {"sum": 3},
        "result": True,
    }
    [event] = json_proto.receive(orjson.dumps(reply).decode(), recv_ns=NOW_NS)
    assert event == ServiceReply(call_id, "/add", True, {"sum": 3})
    [late] = json_proto.receive(orjson.dumps(reply).decode(), recv_ns=NOW_NS)
    assert isinstance(late, Ignored)


def test_failed_service_reply_keeps_error_text(json_proto):
    call_id, _ = json_proto.call_service("/missing")
    text = orjson.dumps(
        {
            "op": "service_response",
            "id": call_id,
            "service": "/missing",
            "values": "Service /missing does not exist",
            "result": False,
        }
    )
    [event] = json_proto.receive(text.decode(), recv_ns=NOW_NS)
    assert event.result is False and event.values == "Service /missing does not exist"


def test_forgotten_call_ignores_its_reply(json_proto):
    call_id, _ = json_proto.call_service("/slow")
    json_proto.forget_call(call_id)
    text = orjson.dumps({"op": "service_response", "id": call_id, "values": {}, "result": True})
    assert isinstance(json_proto.receive(text.decode(), recv_ns=NOW_NS)[0], Ignored)


def test_publish_routes_to_every_id_of_the_topic(json_proto):
    first, _ = json_proto.subscribe("/chatter")
    second, _ = json_proto.subscribe("/chatter")
    json_proto.subscribe("/other")
    frame = publish_json("/chatter", {"data": "hi"})
    [event] = json_proto.receive(frame.decode(), recv_ns=NOW_NS)
    assert isinstance(event, TopicMessage)
    assert event.sub_ids == (first, second)
    assert event.received.msg == {"data": "hi"}
    assert (event.received.recv_ns, event.received.wire_bytes) == (NOW_NS, len(frame))
    json_proto.unsubscribe(first)
    [event] = json_proto.receive(frame.decode(), recv_ns=NOW_NS)
    assert event.sub_ids == (second,)


def test_publish_without_subscription_is_ignored(json_proto):
    events = json_proto.receive(publish_json("/nobody", {}).decode(), recv_ns=NOW_NS)
    assert isinstance(events[0], Ignored)


def test_topic_names_are_matched_exactly(json_proto):
    json_proto.subscribe("chatter")
    events = json_proto.receive(publish_json("/chatter", {}).decode(), recv_ns=NOW_NS)
    assert isinstance(events[0], Ignored)


def test_typed_json_publish_is_normalized(json_proto):
    json_proto.subscribe("/cloud", "sensor_msgs/msg/PointCloud2")
    payload = bytes(range(256)) * 4
    text = publish_json(
        "/cloud",
        {
            "height": 1,
            "width": 64,
            "data": payload,
            "header": {"frame_id": "lidar", "stamp": {"secs": 5, "nsecs": 7}},
        },
    )
    [event] = json_proto.receive(text.decode(), recv_ns=NOW_NS)
    msg = event.received.msg
    assert msg["data"] == payload
    assert msg["header"]["stamp"] == {"sec": 5, "nanosec": 7}
    assert msg["fields"] == [] and msg["is_dense"] is False


def test_typed_cbor_publish_is_normalized(cbor_proto):
    cbor_proto.subscribe("/imu", "sensor_msgs/Imu")
    cov = [float(i) for i in range(9)]
    frame = publish_cbor(
        "/imu",
        {"orientation_covariance": cov, "linear_acceleration": {"x": 0.5, "y": 0.0, "z": 9.81}},
    )
    [event] = cbor_proto.receive(frame, recv_ns=NOW_NS)
    msg = event.received.msg
    assert msg["orientation_covariance"] == cov
    assert msg["linear_acceleration"]["z"] == 9.81
    assert msg["angular_velocity"] == {"x": 0.0, "y": 0.0, "z": 0.0}


def test_cbor_typed_arrays_arrive_as_ndarrays(cbor_proto):
    cbor_proto.subscribe("/scan", "sensor_msgs/msg/LaserScan")
    ranges = np.linspace(0.5, 80.0, 720, dtype=np.float32)
    [event] = cbor_proto.receive(publish_cbor("/scan", {"ranges": ranges}), recv_ns=NOW_NS)
    got = event.received.msg["ranges"]
    assert isinstance(got, np.ndarray) and got.dtype == np.float32
    np.testing.assert_array_equal(got, ranges)


def test_invalid_typed_message_is_a_protocol_error(json_proto):
    json_proto.subscribe("/s", "std_msgs/msg/String")
    with pytest.raises(ProtocolError, match="/s"):
        json_proto.receive(publish_json("/s", {"nope": 1}).decode(), recv_ns=NOW_NS)


def test_cbor_raw_subscription_is_not_normalized(cbor_proto):
    cbor_proto.subscribe("/s", "std_msgs/msg/String")
    cbor_proto.subscribe("/s", compression="cbor-raw")
    raw = {"secs": 1, "nsecs": 2, "bytes": b"\x00\x01\x00\x00abc"}
    [event] = cbor_proto.receive(publish_cbor("/s", raw), recv_ns=NOW_NS)
    assert event.received.msg == raw


@pytest.mark.parametrize("payload", ["not json", b"\xff\x00", "[1, 2]", '{"no_op": 1}'])
def test_garbage_frames_raise_protocol_error(json_proto, payload):
    with pytest.raises(ProtocolError):
        json_proto.receive(payload, recv_ns=NOW_NS)


def test_json_in_binary_frame_is_accepted(json_proto):
    json_proto.subscribe("/t")
    [event] = json_proto.receive(b' {"op":"publish","topic":"/t","msg":{"a":1}}', recv_ns=0)
    assert event.received.msg == {"a": 1}


def test_nan_tokens_are_accepted(json_proto):
    json_proto.subscribe("/scan", "sensor_msgs/msg/LaserScan")
    text = '{"op":"publish","topic":"/scan","msg":{"ranges":[1.0, NaN, Infinity]}}'
    [event] = json_proto.receive(text, recv_ns=NOW_NS)
    ranges = event.received.msg["ranges"]
    assert ranges[0] == 1.0 and np.isnan(ranges[1]) and np.isinf(ranges[2])


def test_unknown_and_status_ops_are_ignored(json_proto):
    [unknown] = json_proto.receive('{"op":"bogus"}', recv_ns=0)
    [status] = json_proto.receive('{"op":"status","level":"error","msg":"boom"}', recv_ns=0)
    assert isinstance(unknown, Ignored) and isinstance(status, Ignored)
    assert "boom" in status.reason


def test_call_service_reaches_advertised_service_only(json_proto):
    frame = json_proto.advertise_service("/add", "example_interfaces/srv/AddTwoInts")
    assert op_of(frame) == {
        "op": "advertise_service",
        "type": "example_interfaces/srv/AddTwoInts",
        "service": "/add",
    }
    request = (
        '{"op":"call_service","id":"service_request:/add:1","service":"/add","args":{"a":1,"b":2}}'
    )
    [event] = json_proto.receive(request, recv_ns=0)
    assert event == ServiceRequest("service_request:/add:1", "/add", {"a": 1, "b": 2})
    answer = op_of(ClientProtocol.service_response(event, {"sum": 3}, result=True))
    assert answer == {
        "op": "service_response",
        "service": "/add",
        "values": {"sum": 3},
        "result": True,
        "id": "service_request:/add:1",
    }
    assert op_of(json_proto.unadvertise_service("/add")) == {
        "op": "unadvertise_service",
        "service": "/add",
    }
    [ignored] = json_proto.receive(request, recv_ns=0)
    assert isinstance(ignored, Ignored)


def test_action_goal_feedback_result_and_cancel(json_proto):
    goal_id, frame = json_proto.send_action_goal(
        "/fib", "example_interfaces/action/Fibonacci", {"order": 4}
    )
    assert op_of(frame) == {
        "op": "send_action_goal",
        "id": goal_id,
        "action": "/fib",
        "action_type": "example_interfaces/action/Fibonacci",
        "args": {"order": 4},
        "feedback": True,
    }
    assert op_of(json_proto.cancel_action_goal(goal_id)) == {
        "op": "cancel_action_goal",
        "id": goal_id,
        "action": "/fib",
    }
    feedback = orjson.dumps(
        {"op": "action_feedback", "id": goal_id, "action": "/fib", "values": {"sequence": [0, 1]}}
    ).decode()
    assert json_proto.receive(feedback, recv_ns=0) == [
        ActionFeedback(goal_id, "/fib", {"sequence": [0, 1]})
    ]
    result = orjson.dumps(
        {
            "op": "action_result",
            "id": goal_id,
            "action": "/fib",
            "values": {"sequence": [0, 1, 1, 2, 3]},
            "status": 4,
            "result": True,
        }
    ).decode()
    assert json_proto.receive(result, recv_ns=0) == [
        ActionOutcome(goal_id, "/fib", 4, True, {"sequence": [0, 1, 1, 2, 3]})
    ]
    assert json_proto.cancel_action_goal(goal_id) is None


def test_resume_frames_restore_registrations_in_order(json_proto):
    json_proto.subscribe("/in", "std_msgs/msg/String")
    json_proto.advertise("/out", "std_msgs/msg/String", latch=True)
    json_proto.advertise_service("/srv", "std_srvs/srv/Trigger")
    gone, _ = json_proto.subscribe("/gone")
    json_proto.unsubscribe(gone)
    ops = [op_of(frame) for frame in json_proto.resume_frames()]
    assert [op["op"] for op in ops] == ["advertise", "advertise_service", "subscribe"]
    assert ops[0]["id"] == "advertise:/out:2" and ops[0]["latch"] is True
    assert ops[2]["id"] == "subscribe:/in:1"


def test_connection_lost_returns_pending_calls_and_goals(json_proto):
    call_id, _ = json_proto.call_service("/s")
    goal_id, _ = json_proto.send_action_goal("/a", "pkg/action/A")
    assert json_proto.connection_lost() == ([call_id], [goal_id])
    assert json_proto.connection_lost() == ([], [])
    reply = orjson.dumps({"op": "service_response", "id": call_id, "result": True}).decode()
    assert isinstance(json_proto.receive(reply, recv_ns=0)[0], Ignored)


def test_service_args_with_bytes_are_base64(json_proto):
    _, frame = json_proto.call_service("/blob", {"data": b"\x01\x02"})
    assert codec_json.loads(frame.data)["args"]["data"] == "AQI="


def test_unknown_encoding_is_rejected(registry):
    with pytest.raises(ValueError):
        ClientProtocol(encoding="bson", spec_lookup=registry.message)  # type: ignore[arg-type]


def test_malformed_ops_raise_protocol_error(json_proto):
    goal_id, _ = json_proto.send_action_goal("/a", "pkg/action/A")
    bad_status = orjson.dumps(
        {"op": "action_result", "id": goal_id, "status": "done", "result": True}
    ).decode()
    for text in ('{"op":"publish","msg":{}}', '{"op":"call_service","id":"x"}', bad_status):
        with pytest.raises(ProtocolError):
            json_proto.receive(text, recv_ns=0)
