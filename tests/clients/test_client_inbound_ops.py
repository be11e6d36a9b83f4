"""What the client makes of the exact bytes of every op a rosbridge server sends, pinned.

Each case is a frame as it comes off the wire (JSON text, CBOR binary, fragments, png) and
the events it must produce. Real servers differ from ours (no ``result``, a float ``total``,
``status`` only inside ``values``, extra keys): reading inbound ops through `schemas.ops`
models must keep every one of these outcomes.
"""

from __future__ import annotations

import json
from dataclasses import replace

import cbor2
import pytest

from clients.errors import ProtocolError
from clients.events import (
    ActionFeedback,
    ActionOutcome,
    Event,
    GoalCancel,
    GoalRequest,
    Ignored,
    Received,
    ServiceReply,
    ServiceRequest,
    TopicMessage,
)
from clients.protocol import ClientProtocol
from schemas.codec_png import encode_png_op
from schemas.registry import TypeRegistry

NOW_NS = 1_700_000_000_000_000_000


@pytest.fixture
def proto(registry: TypeRegistry) -> ClientProtocol:
    """A client with one of everything pending: subscriptions, a call, a goal, a service."""
    p = ClientProtocol(encoding="json", spec_lookup=registry.message)
    p.subscribe("/chatter", "std_msgs/msg/String")  # subscribe:/chatter:1
    p.subscribe("/any")  # subscribe:/any:2
    p.call_service("/add", {"a": 1})  # call_service:/add:3
    p.call_service("/add", {"a": 2})  # call_service:/add:4
    p.send_action_goal("/fib", "example_interfaces/action/Fibonacci")  # ...:/fib:5
    p.send_action_goal("/fib", "example_interfaces/action/Fibonacci")  # ...:/fib:6
    p.advertise_service("/srv", "std_srvs/srv/SetBool")
    p.advertise_action("/serve", "example_interfaces/action/Fibonacci")
    return p


def cbor(op: object) -> bytes:
    return cbor2.dumps(op)


#: Stands for the frame's own length in an expected `Received.wire_bytes`.
WHOLE = -1
CHATTER = ("subscribe:/chatter:1",)
ANY = ("subscribe:/any:2",)

#: (frame as received, the events it yields).
CASES: list[tuple[str | bytes, list[Event]]] = [
    (
        '{"op":"publish","topic":"/chatter","msg":{"data":"hi"}}',
        [TopicMessage(CHATTER, Received("/chatter", {"data": "hi"}, NOW_NS, WHOLE))],
    ),
    (
        '{"op":"publish","topic":"/chatter","msg":{}}',
        [TopicMessage(CHATTER, Received("/chatter", {"data": ""}, NOW_NS, WHOLE))],
    ),
    (
        '{"op":"publish","topic":"/any","msg":{"x":[1,2]},"extra":true}',
        [TopicMessage(ANY, Received("/any", {"x": [1, 2]}, NOW_NS, WHOLE))],
    ),
    (
        '{"op":"publish","topic":"/any"}',
        [TopicMessage(ANY, Received("/any", {}, NOW_NS, WHOLE))],
    ),
    (
        cbor({"op": "publish", "topic": "/any", "msg": {"b": b"\x00\x01"}}),
        [TopicMessage(ANY, Received("/any", {"b": b"\x00\x01"}, NOW_NS, WHOLE))],
    ),
    (
        '{"op":"publish","topic":"/other","msg":{}}',
        [Ignored("publish", "no subscription for /other")],
    ),
    (
        '{"op":"service_response","service":"/add","values":{"sum":3},"result":true,'
        '"id":"call_service:/add:3"}',
        [ServiceReply("call_service:/add:3", "/add", True, {"sum": 3})],
    ),
    (
        '{"op":"service_response","service":"/add","values":"boom","result":false,'
        '"id":"call_service:/add:3"}',
        [ServiceReply("call_service:/add:3", "/add", False, "boom")],
    ),
    (
        '{"values":{"sum":1},"id":"call_service:/add:4","op":"service_response","x":[]}',
        [ServiceReply("call_service:/add:4", "/add", True, {"sum": 1})],
    ),
    (
        cbor(
            {
                "op": "service_response",
                "service": "/add",
                "id": "call_service:/add:3",
                "values": {"sum": 5},
                "result": True,
            }
        ),
        [ServiceReply("call_service:/add:3", "/add", True, {"sum": 5})],
    ),
    (
        '{"op":"service_response","service":"/add","values":{"sum":2},"result":null,'
        '"id":"call_service:/add:4"}',
        [ServiceReply("call_service:/add:4", "/add", True, {"sum": 2})],
    ),
    (
        '{"op":"service_response","service":"/add","values":{},"result":true,"id":"nope"}',
        [Ignored("service_response", "no pending call with id 'nope'")],
    ),
    (
        '{"op":"service_response","service":"/add","values":{},"result":true}',
        [Ignored("service_response", "no pending call with id None")],
    ),
    (
        '{"op":"call_service","id":"service_request:/srv:1","service":"/srv","args":{"data":true}}',
        [ServiceRequest("service_request:/srv:1", "/srv", {"data": True})],
    ),
    (
        '{"op":"call_service","id":7,"service":"/srv","args":[true]}',
        [ServiceRequest(7, "/srv", [True])],
    ),
    ('{"op":"call_service","service":"/srv"}', [ServiceRequest(None, "/srv", {})]),
    (
        '{"op":"call_service","id":"x","service":"/other","args":{}}',
        [Ignored("call_service", "service /other is not advertised here")],
    ),
    (
        '{"op":"action_feedback","action":"/fib","values":{"sequence":[0,1]},'
        '"id":"send_action_goal:/fib:5"}',
        [ActionFeedback("send_action_goal:/fib:5", "/fib", {"sequence": [0, 1]})],
    ),
    (
        '{"op":"action_feedback","action":"/fib","values":{},"id":"other"}',
        [Ignored("action_feedback", "no goal with id 'other'")],
    ),
    (
        '{"op":"action_result","action":"/fib","values":{"sequence":[0,1,1]},"status":4,'
        '"result":true,"id":"send_action_goal:/fib:5"}',
        [ActionOutcome("send_action_goal:/fib:5", "/fib", 4, True, {"sequence": [0, 1, 1]})],
    ),
    (
        '{"op":"action_result","action":"/fib","values":{"status":5},'
        '"id":"send_action_goal:/fib:6"}',
        [ActionOutcome("send_action_goal:/fib:6", "/fib", 5, True, {"status": 5})],
    ),
    (
        '{"op":"action_result","action":"/fib","values":"gave up","status":6,"result":false,'
        '"id":"send_action_goal:/fib:5"}',
        [ActionOutcome("send_action_goal:/fib:5", "/fib", 6, False, "gave up")],
    ),
    (
        '{"op":"send_action_goal","id":"action_goal:/serve:1","action":"/serve",'
        '"action_type":"example_interfaces/action/Fibonacci","args":{"order":3},'
        '"feedback":true}',
        [
            GoalRequest(
                "action_goal:/serve:1",
                "/serve",
                "example_interfaces/action/Fibonacci",
                {"order": 3},
            )
        ],
    ),
    (
        '{"op":"send_action_goal","id":"g","action":"/serve"}',
        [GoalRequest("g", "/serve", None, {})],
    ),
    (
        '{"op":"send_action_goal","id":"g","action":"/other","action_type":"a/action/B"}',
        [Ignored("send_action_goal", "action /other is not advertised here")],
    ),
    (
        '{"op":"cancel_action_goal","id":"action_goal:/serve:1","action":"/serve"}',
        [GoalCancel("action_goal:/serve:1", "/serve")],
    ),
    ('{"op":"cancel_action_goal","id":"g"}', [GoalCancel("g", "")]),
    (
        '{"op":"status","level":"error","msg":"boom","id":"x"}',
        [Ignored("status", "error: boom (id x)")],
    ),
    ('{"op":"status","level":"info","msg":"hello"}', [Ignored("status", "info: hello (id None)")]),
    ('{"op":"bogus","data":1}', [Ignored("bogus", "no handler for this op")]),
    (
        '{"op":"advertise","topic":"/t","type":"a/B"}',
        [Ignored("advertise", "no handler for this op")],
    ),
    (
        encode_png_op(b'{"op":"publish","topic":"/any","msg":{"p":1}}').decode(),
        [TopicMessage(ANY, Received("/any", {"p": 1}, NOW_NS, WHOLE))],
    ),
]


@pytest.mark.parametrize(("frame", "events"), CASES, ids=[str(i) for i in range(len(CASES))])
def test_inbound_frame_yields_pinned_events(
    proto: ClientProtocol, frame: str | bytes, events: list[Event]
) -> None:
    expected = [
        replace(e, received=replace(e.received, wire_bytes=len(frame)))
        if isinstance(e, TopicMessage) and e.received.wire_bytes == WHOLE
        else e
        for e in events
    ]
    assert proto.receive(frame, recv_ns=NOW_NS) == expected


def fragment_frames(text: str, size: int, fragment_id: object, float_total: bool) -> list[str]:
    """rosbridge's fragments of `text`: `total` as its float `(len-1)/size + 1` if asked."""
    count = -(-len(text) // size)
    total = (len(text) - 1) / size + 1 if float_total else count
    return [
        f'{{"op":"fragment","id":{json.dumps(fragment_id)},'
        f'"data":{json.dumps(text[i * size : (i + 1) * size])},"num":{i},"total":{total}}}'
        for i in range(count)
    ]


@pytest.mark.parametrize("float_total", [True, False])
@pytest.mark.parametrize("order", ["forward", "reverse"])
def test_fragmented_ops_reassemble(proto: ClientProtocol, float_total: bool, order: str) -> None:
    reply = (
        '{"op":"service_response","service":"/add","values":{"sum":"'
        + "y" * 50
        + '"},"result":true,"id":"call_service:/add:3"}'
    )
    pieces = fragment_frames(reply, 40, "call_service:/add:3", float_total)
    publish = '{"op":"publish","topic":"/any","msg":{"s":"' + "z" * 30 + '"}}'
    pieces_0 = fragment_frames(publish, 25, 0, float_total)
    if order == "reverse":
        pieces, pieces_0 = pieces[::-1], pieces_0[::-1]
    events: list[Event] = []
    for a, b in zip(pieces, pieces_0, strict=False):
        events += proto.receive(a, recv_ns=NOW_NS) + proto.receive(b, recv_ns=NOW_NS)
    for rest in pieces[len(pieces_0) :]:
        events += proto.receive(rest, recv_ns=NOW_NS)
    wire_0 = sum(len(p) for p in pieces_0)
    assert sorted(events, key=repr) == [
        ServiceReply("call_service:/add:3", "/add", True, {"sum": "y" * 50}),
        TopicMessage(ANY, Received("/any", {"s": "z" * 30}, NOW_NS, wire_0)),
    ]


@pytest.mark.parametrize(
    "frame",
    [
        '{"op":"publish","msg":{}}',
        '{"op":"publish","topic":"/chatter","msg":{"data":5}}',
        '{"op":"call_service","id":"x"}',
        '{"op":"action_result","id":"send_action_goal:/fib:5","status":"done","result":true}',
        '{"op":"send_action_goal","action":"/serve"}',
        '{"op":"fragment","id":0,"num":0,"data":"x"}',
        '{"op":"fragment","id":0,"num":3,"total":2,"data":"x"}',
        '{"op":"fragment","id":[1],"num":0,"total":2,"data":"x"}',
        "[1,2]",
        "not json",
    ],
)
def test_unreadable_inbound_ops_are_protocol_errors(proto: ClientProtocol, frame: str) -> None:
    """The reader logs these as one line each and keeps the connection (clients/reader.py)."""
    with pytest.raises(ProtocolError):
        proto.receive(frame, recv_ns=NOW_NS)
