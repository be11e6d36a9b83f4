import cbor2
import numpy as np

from schemas import codec_cbor, codec_json, frames


def test_publish_json_key_order_and_content():
    frame = frames.publish_json("/chatter", {"data": "hi"})
    assert frame == b'{"op":"publish","topic":"/chatter","msg":{"data":"hi"}}'


def test_publish_cbor_carries_typed_arrays():
    frame = frames.publish_cbor("/scan", {"ranges": np.array([1.0, 2.0], np.float32)})
    raw = cbor2.loads(frame)
    assert list(raw) == ["op", "topic", "msg"]
    assert raw["msg"]["ranges"].tag == 85
    assert codec_cbor.loads(frame)["msg"]["ranges"].tolist() == [1.0, 2.0]


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
