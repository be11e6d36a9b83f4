"""The exact bytes of every op the client sends, pinned.

Key order and spelling are part of what captured traffic, the compat tests and other rosbridge
servers see; building ops from `schemas.ops` models must not change a byte of them.
"""

from __future__ import annotations

import numpy as np
import pytest

from clients.events import GoalRequest, ServiceRequest
from clients.protocol import ClientProtocol
from clients.wire import Frame
from schemas.ops import OpError
from schemas.registry import TypeRegistry


@pytest.fixture
def proto(registry: TypeRegistry) -> ClientProtocol:
    return ClientProtocol(encoding="json", spec_lookup=registry.message)


def text(frame: Frame | None) -> str:
    assert frame is not None and frame.text
    return frame.data.decode("ascii")


REQUEST = ServiceRequest("call_service:/add:7", "/add", {"a": 1})
GOAL = GoalRequest("send_action_goal:/fib:3", "/fib", "example/action/Fibonacci", {"order": 4})


def test_topic_ops(proto: ClientProtocol) -> None:
    assert text(proto.advertise("/chat", "std_msgs/msg/String")) == (
        '{"op":"advertise","id":"advertise:/chat:1","type":"std_msgs/msg/String",'
        '"topic":"/chat","latch":false,"queue_size":100}'
    )
    assert text(proto.advertise("/map", "std_msgs/msg/String", latch=True, queue_size=1)) == (
        '{"op":"advertise","id":"advertise:/map:2","type":"std_msgs/msg/String",'
        '"topic":"/map","latch":true,"queue_size":1}'
    )
    assert text(proto.unadvertise("/chat")) == (
        '{"op":"unadvertise","id":"advertise:/chat:1","topic":"/chat"}'
    )
    sub_id, frame = proto.subscribe(
        "/imu", "sensor_msgs/msg/Imu", throttle_rate_ms=50, queue_length=2, compression="cbor"
    )
    assert text(frame) == (
        '{"op":"subscribe","id":"subscribe:/imu:3","topic":"/imu","compression":"cbor",'
        '"throttle_rate":50,"queue_length":2,"type":"sensor_msgs/msg/Imu"}'
    )
    assert text(proto.subscribe("/any")[1]) == (
        '{"op":"subscribe","id":"subscribe:/any:4","topic":"/any","compression":"none",'
        '"throttle_rate":0,"queue_length":0}'
    )
    assert text(proto.unsubscribe(sub_id)) == (
        '{"op":"unsubscribe","id":"subscribe:/imu:3","topic":"/imu"}'
    )


def test_publish_json_and_cbor(registry: TypeRegistry) -> None:
    msg = {"data": "hi", "raw": b"\x00\x01", "xs": np.array([1.5, -2.0])}
    json_proto = ClientProtocol(encoding="json", spec_lookup=registry.message)
    frame = json_proto.encode_publish("/chat", msg)
    assert frame.text
    assert frame.data == (
        b'{"op":"publish","topic":"/chat","msg":{"data":"hi","raw":"AAE=","xs":[1.5,-2.0]}}'
    )
    cbor_proto = ClientProtocol(encoding="cbor", spec_lookup=registry.message)
    frame = cbor_proto.encode_publish("/chat", msg)
    assert not frame.text
    assert frame.data.hex() == (
        "a3626f70677075626c69736865746f706963652f63686174636d7367a3646461746162686963726177"
        "420001627873d85650000000000000f83f00000000000000c0"
    )


def test_service_ops(proto: ClientProtocol) -> None:
    call_id, frame = proto.call_service("/add", {"a": 1, "b": 2})
    assert text(frame) == (
        '{"op":"call_service","id":"call_service:/add:1","service":"/add","args":{"a":1,"b":2}}'
    )
    _, frame = proto.call_service("/list", type="rosapi/srv/Topics", timeout_s=2)
    assert text(frame) == (
        '{"op":"call_service","id":"call_service:/list:2",'
        '"service":"/list","args":{},"type":"rosapi/srv/Topics",'
        '"timeout":2.0}'
    )
    _, frame = proto.call_service("/pos", [1, 2])
    assert text(frame) == (
        '{"op":"call_service","id":"call_service:/pos:3","service":"/pos","args":[1,2]}'
    )
    assert text(proto.advertise_service("/add", "example/srv/AddTwoInts")) == (
        '{"op":"advertise_service","type":"example/srv/AddTwoInts","service":"/add"}'
    )
    assert text(proto.unadvertise_service("/add")) == (
        '{"op":"unadvertise_service","service":"/add"}'
    )
    assert text(proto.service_response(REQUEST, {"sum": 3}, result=True)) == (
        '{"op":"service_response","service":"/add","values":{"sum":3},"result":true,'
        '"id":"call_service:/add:7"}'
    )
    assert text(proto.service_response(REQUEST, "boom", result=False)) == (
        '{"op":"service_response","service":"/add","values":"boom","result":false,'
        '"id":"call_service:/add:7"}'
    )
    assert call_id == "call_service:/add:1"


def test_action_ops(proto: ClientProtocol) -> None:
    goal_id, frame = proto.send_action_goal("/fib", "example/action/Fibonacci", {"order": 4})
    assert text(frame) == (
        '{"op":"send_action_goal","id":"send_action_goal:/fib:1","action":"/fib",'
        '"action_type":"example/action/Fibonacci","args":{"order":4},"feedback":true}'
    )
    _, frame = proto.send_action_goal("/fib", "example/action/Fibonacci", feedback=False)
    assert text(frame) == (
        '{"op":"send_action_goal","id":"send_action_goal:/fib:2","action":"/fib",'
        '"action_type":"example/action/Fibonacci","args":{},"feedback":false}'
    )
    assert text(proto.cancel_action_goal(goal_id)) == (
        '{"op":"cancel_action_goal","id":"send_action_goal:/fib:1","action":"/fib"}'
    )
    assert text(proto.advertise_action("/fib", "example/action/Fibonacci")) == (
        '{"op":"advertise_action","type":"example/action/Fibonacci","action":"/fib"}'
    )
    assert text(proto.unadvertise_action("/fib")) == ('{"op":"unadvertise_action","action":"/fib"}')
    assert text(proto.action_feedback(GOAL, {"partial": [0, 1]})) == (
        '{"op":"action_feedback","id":"send_action_goal:/fib:3","action":"/fib",'
        '"values":{"partial":[0,1]}}'
    )
    assert text(proto.action_result(GOAL, {"sequence": [0, 1, 1]}, status=4, result=True)) == (
        '{"op":"action_result","id":"send_action_goal:/fib:3","action":"/fib",'
        '"values":{"sequence":[0,1,1]},"status":4,"result":true}'
    )


def test_resume_frames_repeat_the_registrations(proto: ClientProtocol) -> None:
    proto.advertise("/chat", "std_msgs/msg/String", latch=True)
    proto.advertise_service("/add", "example/srv/AddTwoInts")
    proto.advertise_action("/fib", "example/action/Fibonacci")
    proto.subscribe("/imu", "sensor_msgs/msg/Imu")
    assert [text(frame) for frame in proto.resume_frames()] == [
        '{"op":"advertise","id":"advertise:/chat:1","type":"std_msgs/msg/String",'
        '"topic":"/chat","latch":true,"queue_size":100}',
        '{"op":"advertise_service","type":"example/srv/AddTwoInts","service":"/add"}',
        '{"op":"advertise_action","type":"example/action/Fibonacci","action":"/fib"}',
        '{"op":"subscribe","id":"subscribe:/imu:2","topic":"/imu","compression":"none",'
        '"throttle_rate":0,"queue_length":0,"type":"sensor_msgs/msg/Imu"}',
    ]


def test_an_op_the_bridge_would_refuse_is_refused_before_sending(proto: ClientProtocol) -> None:
    """Ops are built by the bridge's own models: a bad field names itself and records nothing."""
    with pytest.raises(OpError, match="advertise: field 'queue_size' must be an integer"):
        proto.advertise("/chat", "std_msgs/msg/String", queue_size=1.5)  # type: ignore[arg-type]
    assert not proto.advertisements
    with pytest.raises(OpError, match="action_feedback: field 'values' must be an object"):
        proto.action_feedback(GOAL, [1, 2])
    with pytest.raises(OpError, match="subscribe: field 'id' must be a string of at most 300"):
        proto.subscribe("/" + "x" * 600)
    assert not proto.subscriptions
