"""Property tests: random and mutated frames never crash the core or a live server.

After any input the core must still serve a well-behaved client, and once every client has
left nothing they created may remain in the graph.
"""

from __future__ import annotations

import asyncio
import json
import logging
import threading
from collections.abc import Iterator

import cbor2
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from websockets.sync.client import connect

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from bridge.outgoing import render
from schemas import codec_cbor
from tests.bridge.bridge_harness import CoreHarness

VALID_OPS = [
    {"op": "advertise", "topic": "/a", "type": "std_msgs/String", "id": "ad", "latch": True},
    {"op": "unadvertise", "topic": "/a", "id": "ad"},
    {"op": "publish", "topic": "/a", "msg": {"data": "x"}},
    {
        "op": "publish",
        "topic": "/imu",
        "type": "sensor_msgs/Imu",
        "msg": {"orientation_covariance": [0.0] * 9},
    },
    {
        "op": "subscribe",
        "topic": "/a",
        "type": "std_msgs/String",
        "id": "s",
        "throttle_rate": 10,
        "queue_length": 2,
        "compression": "cbor",
        "fragment_size": 8,
    },
    {"op": "unsubscribe", "topic": "/a", "id": "s"},
    {"op": "call_service", "service": "/rosapi/topics", "id": 1, "args": {}},
    {"op": "call_service", "service": "/svc", "id": 2, "args": [True], "timeout": 0.5},
    {"op": "advertise_service", "service": "/svc", "type": "std_srvs/SetBool"},
    {"op": "unadvertise_service", "service": "/svc"},
    {
        "op": "service_response",
        "service": "/svc",
        "id": "service_request:/svc:1",
        "values": {"success": True},
        "result": True,
    },
    {"op": "advertise_action", "action": "/act", "type": "example_interfaces/Fibonacci"},
    {
        "op": "send_action_goal",
        "action": "/act",
        "action_type": "example_interfaces/Fibonacci",
        "args": {"order": 3},
        "id": "g",
        "feedback": True,
    },
    {
        "op": "action_feedback",
        "action": "/act",
        "id": "action_goal:/act:1",
        "values": {"sequence": [0]},
    },
    {
        "op": "action_result",
        "action": "/act",
        "id": "action_goal:/act:1",
        "values": {"sequence": [0, 1]},
        "status": 4,
        "result": True,
    },
    {"op": "cancel_action_goal", "action": "/act", "id": "g"},
    {"op": "fragment", "id": "f", "num": 0, "total": 2, "data": '{"op":"set_'},
    {"op": "fragment", "id": "f", "num": 1, "total": 2, "data": 'level","level":"info"}'},
    {"op": "set_level", "level": "warning"},
]

json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8),
    lambda children: (
        st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=6), children, max_size=4)
    ),
    max_leaves=12,
)


@st.composite
def mutated_ops(draw) -> dict:
    """A valid op with some fields replaced by, or added as, arbitrary JSON values."""
    op = dict(draw(st.sampled_from(VALID_OPS)))
    keys = [*op, "id", "msg", "args", "values", "fragment_size", "compression", "type"]
    for key in draw(st.lists(st.sampled_from(keys), max_size=3)):
        op[key] = draw(json_values)
    return op


@st.composite
def frames(draw) -> bytes | str:
    """Random bytes and text, mutated ops as JSON or CBOR, and truncated valid frames."""
    kind = draw(st.sampled_from(["bytes", "text", "json", "cbor", "truncated"]))
    if kind == "bytes":
        return draw(st.binary(max_size=64))
    if kind == "text":
        return draw(st.text(max_size=64))
    op = draw(mutated_ops())
    try:
        encoded = json.dumps(op) if kind != "cbor" else codec_cbor.dumps(op)
    except ValueError:
        encoded = json.dumps(op, allow_nan=True)
    if kind == "truncated":
        return encoded[: draw(st.integers(0, max(0, len(encoded) - 1)))]
    return encoded


# Values that decode but that nothing downstream could carry: lone surrogates, integers of any
# size, infinities, CBOR's undefined, sets, tags and non-string keys.
hostile_scalars = (
    st.sampled_from(["\ud800", "ok\udfff", "\udc00\ud800"])
    | st.text(st.characters(codec=None, categories=["Cs", "L", "Nd", "Cc"]), max_size=6)
    | st.integers()
    | st.sampled_from([2**64, -(2**63) - 1, 2**100, 10**30])
    | st.floats()
    | st.none()
    | st.booleans()
)
hostile_values = st.recursive(
    hostile_scalars,
    lambda children: (
        st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=6), children, max_size=4)
    ),
    max_leaves=12,
)
cbor_only = st.sampled_from(
    [
        cbor2.undefined,
        frozenset({1, 2}),
        cbor2.CBORTag(999, 1),
        cbor2.CBORSimpleValue(99),
        {1: "x"},
        10**400,
    ]
)


def encode_hostile(op: dict, as_cbor: bool) -> bytes | str:
    """JSON text (lone surrogates escaped, NaN/Infinity tokens) or CBOR of a hostile op."""
    if as_cbor:
        try:
            return cbor2.dumps(op)
        except (ValueError, TypeError, cbor2.CBOREncodeError):  # surrogates have no UTF-8
            return cbor2.dumps({"op": "publish", "topic": "/a", "msg": cbor2.undefined})
    try:
        return json.dumps(op)
    except ValueError:  # an integer over 4,300 digits
        return json.dumps({**op, "msg": None}, default=str)


UNTYPED_CALL = {"op": "call_service", "service": "/untyped", "id": 3, "args": {"x": 1}}
SETUP_OPS = [
    {"op": "subscribe", "topic": "/a", "type": "std_msgs/String"},
    {"op": "advertise_service", "service": "/svc", "type": "std_srvs/SetBool"},
    {"op": "advertise_service", "service": "/untyped", "type": "unknown_pkg/Srv"},
    {"op": "advertise_action", "action": "/act", "type": "example_interfaces/Fibonacci"},
]


# Ops whose payload reaches another client (a subscriber, a provider): a hostile value there
# is what once broke the encoder on the way out.
PAYLOAD_OPS = [
    ({"op": "publish", "topic": "/a"}, "msg"),
    ({"op": "call_service", "service": "/untyped", "id": 5}, "args"),
    ({"op": "call_service", "service": "/svc", "id": 6}, "args"),
    (
        {
            "op": "send_action_goal",
            "action": "/act",
            "id": "g",
            "feedback": True,
            "action_type": "example_interfaces/Fibonacci",
        },
        "args",
    ),
    ({"op": "advertise", "topic": "/b", "type": "std_msgs/String"}, "id"),
]


@st.composite
def hostile_frames(draw) -> bytes | str:
    """A valid op with header fields, or its payload's fields, replaced by hostile values."""
    as_cbor = draw(st.booleans())
    values = hostile_values | cbor_only if as_cbor else hostile_values
    if draw(st.booleans()):
        base, payload = draw(st.sampled_from(PAYLOAD_OPS))
        key = draw(st.sampled_from(["data", "order", "x"]))
        return encode_hostile({**base, payload: {key: draw(values)}}, as_cbor)
    op = dict(draw(st.sampled_from([*VALID_OPS, UNTYPED_CALL])))
    keys = [
        *(k for k in op if k != "op"),
        "id",
        "msg",
        "args",
        "values",
        "fragment_size",
        "timeout",
        "total",
    ]
    for key in draw(st.lists(st.sampled_from(keys), min_size=1, max_size=3)):
        op[key] = draw(values)
    return encode_hostile(op, as_cbor)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(script=st.lists(st.tuples(st.integers(0, 2), hostile_frames(), st.booleans()), max_size=20))
def test_hostile_values_get_answers_that_can_be_sent_and_one_short_line(registry, script):
    records: list[logging.LogRecord] = []
    handler = logging.Handler()
    handler.emit = records.append  # type: ignore[method-assign]
    logger = logging.getLogger("bridge.core")
    logger.addHandler(handler)
    try:
        h = CoreHarness(registry, offload_threshold_bytes=1)  # off_loop: every check offloaded
        clients = [h.connect() for _ in range(3)]
        h.send(clients[0], {"op": "set_level", "level": "info"})
        for op in SETUP_OPS:  # listeners and providers, so hostile values travel somewhere
            h.send(clients[2], op)
        for index, frame, off_loop in script:
            (h.receive_offloaded if off_loop else h.send)(clients[index], frame)
            for sends in h.sends.values():
                for send in sends:
                    render(send.item, send.fragment_size, "f")  # every answer can be sent
        assert {close.code for close in h.closes} <= {1009}
        assert_still_serving(h)
    finally:
        logger.removeHandler(handler)
    for record in records:
        text = record.getMessage()
        assert record.exc_info is None and len(text) < 700 and text.isprintable(), text


def assert_still_serving(h: CoreHarness) -> None:
    pub, sub = h.connect(), h.connect()
    h.send(sub, {"op": "subscribe", "topic": "/probe", "type": "std_msgs/String"})
    h.send(pub, {"op": "publish", "topic": "/probe", "msg": {"data": "alive"}})
    assert h.outbox(sub) == [{"op": "publish", "topic": "/probe", "msg": {"data": "alive"}}]
    h.disconnect(pub)
    h.disconnect(sub)


def assert_nothing_left(h: CoreHarness) -> None:
    state = h.state
    assert state.sessions == {}
    assert set(state.graph.topics) == {"/rosout"}
    assert state.graph.services == {} and state.graph.actions == {}
    assert state.pending_calls == {} and state.pending_goals == {}
    assert state.topic_subscriptions == {}


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    script=st.lists(
        st.tuples(st.integers(0, 2), frames(), st.floats(0, 1), st.booleans()), max_size=25
    )
)
def test_core_survives_any_frames_and_leaks_nothing(registry, script):
    h = CoreHarness(registry, offload_threshold_bytes=1)  # off_loop: every check offloaded
    clients = [h.connect() for _ in range(3)]
    for index, frame, pause_s, off_loop in script:
        if off_loop:
            h.receive_offloaded(clients[index], frame)
        else:
            h.send(clients[index], frame)
        h.advance(pause_s)
    assert_still_serving(h)
    for client in clients:
        h.disconnect(client)
    h.advance(10.0)
    assert_nothing_left(h)


@settings(max_examples=200, deadline=None)
@given(script=st.lists(st.tuples(st.integers(0, 2), st.sampled_from(VALID_OPS)), max_size=30))
def test_valid_op_sequences_leave_a_clean_graph(registry, script):
    h = CoreHarness(registry)
    clients = [h.connect() for _ in range(3)]
    for index, op in script:
        h.send(clients[index], op)
    for client in clients:
        h.disconnect(client)
    assert_nothing_left(h)


@pytest.fixture(scope="module")
def live_bridge(registry) -> Iterator[str]:
    """A bridge running in its own thread and event loop for synchronous clients."""
    ready, stop = threading.Event(), threading.Event()
    url: list[str] = []

    async def serve() -> None:
        async with run_bridge(BridgeConfig(port=0, max_message_size=1 << 20), registry) as r:
            url.append(r.url)
            ready.set()
            while not stop.is_set():
                await asyncio.sleep(0.02)

    thread = threading.Thread(target=asyncio.run, args=(serve(),), daemon=True)
    thread.start()
    assert ready.wait(10)
    yield url[0]
    stop.set()
    thread.join(10)


def is_end(frame: bytes | str) -> bool:
    return isinstance(frame, str) and json.loads(frame).get("id") == "end"


@pytest.mark.timeout(120)
@settings(
    max_examples=40,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(batch=st.lists(frames(), min_size=1, max_size=20))
def test_live_server_keeps_serving_others_whatever_one_client_sends(live_bridge, batch):
    with connect(live_bridge) as pub, connect(live_bridge) as sub:
        sub.send(json.dumps({"op": "subscribe", "topic": "/probe", "type": "std_msgs/String"}))
        with connect(live_bridge) as vandal:
            for frame in batch:
                vandal.send(frame)
            # fragment_size null undoes any fragmentation the batch may have switched on.
            vandal.send(
                json.dumps(
                    {
                        "op": "call_service",
                        "service": "/rosapi/get_time",
                        "id": "end",
                        "fragment_size": None,
                    }
                )
            )
            while not is_end(vandal.recv(timeout=10)):
                pass
        pub.send(json.dumps({"op": "publish", "topic": "/probe", "msg": {"data": "alive"}}))
        assert json.loads(sub.recv(timeout=10))["msg"] == {"data": "alive"}
