import base64
import json
import math

import numpy as np
import pytest

from schemas import codec_json
from schemas.errors import DecodeError, EncodeError, SchemaError
from schemas.message import normalize


def test_bytes_go_out_as_base64():
    out = codec_json.dumps({"data": b"\x00\x01\xff"})
    assert out == b'{"data":"AAH/"}'


def test_non_finite_floats_become_null():
    out = codec_json.loads(codec_json.dumps({"a": math.nan, "b": [math.inf, -math.inf, 1.5]}))
    assert out == {"a": None, "b": [None, None, 1.5]}
    array = np.array([1.0, np.nan, np.inf], dtype=np.float32)
    assert codec_json.loads(codec_json.dumps(array)) == [1.0, None, None]


def test_ndarrays_become_lists_in_any_layout():
    assert codec_json.dumps(np.arange(3, dtype=np.int16)) == b"[0,1,2]"
    assert codec_json.dumps(np.arange(3, dtype=">u4")) == b"[0,1,2]"  # non-native byte order
    assert codec_json.dumps(np.arange(6.0)[::2]) == b"[0.0,2.0,4.0]"  # non-contiguous
    assert codec_json.dumps(np.array([True, False])) == b"[true,false]"
    assert codec_json.dumps({"v": np.float32(0.5), "i": np.uint64(2**64 - 1)}) == (
        b'{"v":0.5,"i":18446744073709551615}'
    )


def test_output_is_ascii_with_json_escapes():
    text = "héllo → 😀"
    out = codec_json.dumps({"s": text})
    assert out.isascii()
    assert out == json.dumps({"s": text}, separators=(",", ":")).encode()
    assert codec_json.loads(out) == {"s": text}


def test_nan_and_infinity_tokens_are_accepted():
    # roslibpy serializes with json.dumps, which writes bare NaN/Infinity tokens.
    text = json.dumps({"ranges": [1.0, math.nan, math.inf, -math.inf]})
    assert "NaN" in text
    out = codec_json.loads(text)
    assert math.isnan(out["ranges"][1]) and out["ranges"][2:] == [math.inf, -math.inf]
    from_bytes = codec_json.loads(text.encode())["ranges"]
    assert from_bytes[0] == 1.0 and math.isnan(from_bytes[1]) and from_bytes[3] == -math.inf


@pytest.mark.parametrize("bad", [b"{", b"{'a': 1}", b"", b"\xff\xfe", "[1,,2]"])
def test_invalid_json_raises_decode_error(bad):
    with pytest.raises(DecodeError):
        codec_json.loads(bad)
    assert issubclass(DecodeError, SchemaError)


def test_unencodable_values_raise_encode_error():
    with pytest.raises(EncodeError):
        codec_json.dumps({"x": 2**70})
    with pytest.raises(EncodeError):
        codec_json.dumps({"x": object()})


def test_canonical_message_round_trip(registry, pointcloud):
    spec = registry.message("sensor_msgs/PointCloud2")
    msg = normalize(spec, pointcloud, now_ns=0)
    wire = codec_json.loads(codec_json.dumps(msg))
    assert wire["data"] == base64.b64encode(pointcloud["data"]).decode()
    assert normalize(spec, wire, now_ns=0) == msg


def test_float32_arrays_are_written_as_their_exact_double_values() -> None:
    """rosbridge widens float32 to double before writing JSON; so must we, in nested arrays too."""
    msg = {"data": np.array([0.1, 2.0**100], np.float32), "items": [{"v": np.float32([0.1])}]}
    decoded = json.loads(codec_json.dumps(msg))
    assert decoded["data"] == [0.10000000149011612, 2.0**100]
    assert decoded["items"][0]["v"] == [0.10000000149011612]
    assert msg["data"].dtype == np.float32, "the caller's message must not change"
