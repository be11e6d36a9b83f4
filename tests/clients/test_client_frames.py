"""Fragment reassembly and png unwrapping, through the sans-I/O protocol."""

from __future__ import annotations

import numpy as np
import orjson
import pytest
from hypothesis import given
from hypothesis import strategies as st

from clients.errors import ProtocolError
from clients.events import ServiceReply, TopicMessage
from clients.fragments import FragmentAssembler
from clients.protocol import ClientProtocol
from schemas.ops import Fragment, validate_op
from schemas.registry import TypeRegistry
from tests.clients.client_messages import publish_text, rosbridge_fragments, rosbridge_png


def fragment(frame: str) -> Fragment:
    """One of rosbridge's fragment frames read by the model the client reads it with."""
    return validate_op(Fragment, orjson.loads(frame))


@pytest.fixture
def proto(registry: TypeRegistry) -> ClientProtocol:
    return ClientProtocol(encoding="json", spec_lookup=registry.message)


def test_fragmented_publish_reassembles_in_num_order(proto):
    sub_id, _ = proto.subscribe("/cloud", "sensor_msgs/msg/PointCloud2")
    payload = np.random.default_rng(1).bytes(4096)
    frames = rosbridge_fragments(publish_text("/cloud", payload), size=700)
    shuffled = [frames[i] for i in np.random.default_rng(2).permutation(len(frames))]
    events = []
    for frame in shuffled:
        events += proto.receive(frame, recv_ns=7)
    [event] = events
    assert isinstance(event, TopicMessage) and event.sub_ids == (sub_id,)
    assert event.received.msg["data"] == payload
    assert event.received.wire_bytes == sum(len(f) for f in frames)


def test_fragmented_service_response_uses_its_id(proto):
    call_id, _ = proto.call_service("/big")
    text = orjson.dumps(
        {
            "op": "service_response",
            "id": call_id,
            "service": "/big",
            "values": {"blob": "x" * 300},
            "result": True,
        }
    ).decode()
    events = []
    for frame in rosbridge_fragments(text, size=64, frag_id=call_id):
        events += proto.receive(frame, recv_ns=0)
    assert events == [ServiceReply(call_id, "/big", True, {"blob": "x" * 300})]


def test_interleaved_fragment_ids_are_kept_apart():
    assembler = FragmentAssembler()
    a = [fragment(f) for f in rosbridge_fragments('{"op":"a","x":"' + "a" * 40 + '"}', 20, "A")]
    b = [fragment(f) for f in rosbridge_fragments('{"op":"b","x":"' + "b" * 40 + '"}', 20, "B")]
    done = [assembler.add(op, 1) for pair in zip(a, b, strict=True) for op in pair]
    texts = [d.text for d in done if d is not None]
    assert [orjson.loads(t)["op"] for t in texts] == ["a", "b"]
    assert assembler.pending == 0


def test_restarted_fragment_id_discards_the_unfinished_message():
    assembler = FragmentAssembler()
    first = [fragment(f) for f in rosbridge_fragments('{"op":"one"}' + " " * 30, 10)]
    second = [fragment(f) for f in rosbridge_fragments('{"op":"two"}' + " " * 30, 10)]
    assert assembler.add(first[0], 1) is None
    results = [assembler.add(op, 1) for op in second]
    assert orjson.loads(results[-1].text) == {"op": "two"}
    assert assembler.discarded == 1


def test_partial_messages_are_bounded():
    assembler = FragmentAssembler(max_partial=2)
    for key in range(5):
        assembler.add(Fragment(id=key, num=0, total=2, data="{"), 1)
    assert assembler.pending == 2 and assembler.discarded == 3


@pytest.mark.parametrize(
    "bad",
    [
        {"op": "fragment", "id": 0, "num": 0, "data": "x"},
        {"op": "fragment", "id": 0, "num": 5, "total": 2, "data": "x"},
        {"op": "fragment", "id": 0, "num": 0, "total": "2", "data": "x"},
        {"op": "fragment", "id": 0, "num": 0, "total": 2, "data": 3},
    ],
)
def test_malformed_fragments_raise(proto, bad):
    with pytest.raises(ProtocolError):
        proto.receive(orjson.dumps(bad).decode(), recv_ns=0)


def test_png_publish_is_decoded(proto):
    proto.subscribe("/cloud", "sensor_msgs/msg/PointCloud2")
    payload = bytes(range(256)) * 8
    [event] = proto.receive(rosbridge_png(publish_text("/cloud", payload)).decode(), recv_ns=3)
    assert event.received.msg["data"] == payload
    assert event.received.msg["header"]["frame_id"] == "lidar"


def test_fragmented_png_is_decoded(proto):
    proto.subscribe("/chatter", "std_msgs/msg/String")
    png_text = rosbridge_png(
        orjson.dumps(
            {"op": "publish", "topic": "/chatter", "msg": {"data": "hello " * 50}}
        ).decode()
    ).decode()
    events = []
    for frame in rosbridge_fragments(png_text, size=100):
        events += proto.receive(frame, recv_ns=0)
    assert [e.received.msg for e in events] == [{"data": "hello " * 50}]


@given(text=st.text(min_size=1, max_size=400), size=st.integers(1, 64), seed=st.integers(0, 99))
def test_any_text_survives_fragmentation_in_any_order(text, size, seed):
    assembler = FragmentAssembler()
    ops = [fragment(f) for f in rosbridge_fragments(text, size)]
    order = np.random.default_rng(seed).permutation(len(ops))
    results = [assembler.add(ops[i], 1) for i in order]
    assert all(r is None for r in results[:-1])
    assert results[-1].text == text and results[-1].wire_bytes == len(ops)
