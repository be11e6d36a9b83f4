import cbor2
import numpy as np
import pytest

from schemas import codec_cbor, codec_json, frames, ops
from schemas.ops import parse_op, to_wire


def test_publish_json_key_order_and_content():
    frame = frames.publish_json("/chatter", {"data": "hi"})
    assert frame == b'{"op":"publish","topic":"/chatter","msg":{"data":"hi"}}'


def test_publish_cbor_carries_typed_arrays():
    frame = frames.publish_cbor("/scan", {"ranges": np.array([1.0, 2.0], np.float32)})
    raw = cbor2.loads(frame)
    assert list(raw) == ["op", "topic", "msg"]
    assert raw["msg"]["ranges"].tag == 85
    assert codec_cbor.loads(frame)["msg"]["ranges"].tolist() == [1.0, 2.0]


@pytest.mark.parametrize("topic", ["/t", "chatter", "/" + "long_name/" * 30, "/ünïcødé/话题"])
def test_publish_cbor_is_the_whole_map_encoded_at_once(topic):
    """The cached ``op``/``topic`` head plus the message equals encoding the map in one go,
    for topic names whose length takes one, two or three bytes to write."""
    msg = {"data": "x" * 300, "values": np.arange(3, dtype=np.int32), "n": [1, 2]}
    whole = codec_cbor.dumps({"op": "publish", "topic": topic, "msg": msg})
    assert frames.publish_cbor(topic, msg) == whole
    assert frames.publish_cbor(topic, {}) == codec_cbor.dumps(
        {"op": "publish", "topic": topic, "msg": {}}
    )


def test_publish_cbor_raw_envelope():
    cdr = b"\x00\x01\x00\x00" + b"\x05\x00\x00\x00"
    frame = frames.publish_cbor_raw("/t", cdr, stamp_ns=1_700_000_000_123_456_789)
    raw = cbor2.loads(frame)
    assert raw == {
        "op": "publish",
        "topic": "/t",
        "msg": {"secs": 1_700_000_000, "nsecs": 123_456_789, "bytes": cdr},
    }
    assert list(raw["msg"]) == ["secs", "nsecs", "bytes"]


def test_topic_is_echoed_unchanged():
    assert codec_json.loads(frames.publish_json("chatter", {}))["topic"] == "chatter"


def test_publish_frames_read_back_through_the_publish_model():
    """The typed writers and `schemas.ops.Publish` are one definition of the op."""
    msg = {"data": "hi"}
    for frame in (frames.publish_json("/t", msg), frames.publish_cbor("/t", msg)):
        raw = codec_json.loads(frame) if frame[:1] == b"{" else codec_cbor.loads(frame)
        op = parse_op(raw)
        assert isinstance(op, ops.Publish) and to_wire(op) == raw


def test_fragments_read_back_through_the_fragment_model():
    text = '{"op":"publish","topic":"/t","msg":{"data":"' + "x" * 30 + '"}}'
    pieces = frames.fragments_json(text, 25, "call:1")
    read = [parse_op(codec_json.loads(piece)) for piece in pieces]
    assert all(isinstance(op, ops.Fragment) for op in read)
    assert [to_wire(op) for op in read] == [codec_json.loads(piece) for piece in pieces]
    assert "".join(op.data for op in read if isinstance(op, ops.Fragment)) == text


def test_fragments_echo_any_id_and_count_with_an_integer_total():
    pieces = frames.fragments_json("abcde", 2, 1.5)
    assert pieces == [
        b'{"op":"fragment","id":1.5,"data":"ab","num":0,"total":3}',
        b'{"op":"fragment","id":1.5,"data":"cd","num":1,"total":3}',
        b'{"op":"fragment","id":1.5,"data":"e","num":2,"total":3}',
    ]
