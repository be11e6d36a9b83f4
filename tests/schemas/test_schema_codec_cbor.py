import io
import math
import random
import struct

import cbor2
import numpy as np
import pytest

from schemas import codec_cbor
from schemas.errors import DecodeError, EncodeError
from schemas.message import normalize

TAGS = [
    (np.uint16, 69),
    (np.uint32, 70),
    (np.uint64, 71),
    (np.int8, 72),
    (np.int16, 77),
    (np.int32, 78),
    (np.int64, 79),
    (np.float32, 85),
    (np.float64, 86),
]


@pytest.mark.parametrize(("dtype", "tag"), TAGS)
def test_typed_array_tags_are_little_endian(dtype, tag):
    values = np.array([1, 2, 3], dtype=dtype)
    item = cbor2.loads(codec_cbor.dumps({"a": values}))["a"]
    assert isinstance(item, cbor2.CBORTag) and item.tag == tag
    assert item.value == values.astype(np.dtype(dtype).newbyteorder("<")).tobytes()
    decoded = codec_cbor.loads(codec_cbor.dumps(values))
    assert decoded.dtype == np.dtype(dtype).newbyteorder("<") and decoded.tolist() == [1, 2, 3]


def test_big_endian_input_is_written_little_endian():
    item = cbor2.loads(codec_cbor.dumps(np.array([1.0], dtype=">f4")))
    assert item.tag == 85 and item.value == struct.pack("<f", 1.0)


def test_uint8_arrays_and_bytes_are_plain_byte_strings():
    assert codec_cbor.dumps(np.array([1, 2], dtype=np.uint8)) == b"\x42\x01\x02"
    assert codec_cbor.dumps(b"\x01\x02") == b"\x42\x01\x02"
    assert codec_cbor.loads(cbor2.dumps(cbor2.CBORTag(64, b"\x01\x02"))) == b"\x01\x02"


def test_floats_are_float64_and_keep_nan():
    assert codec_cbor.dumps(1.5) == b"\xfb" + struct.pack(">d", 1.5)
    assert math.isnan(codec_cbor.loads(codec_cbor.dumps(math.nan)))
    assert codec_cbor.dumps(np.float32(0.5)) == b"\xfb" + struct.pack(">d", 0.5)


def test_fixed_arrays_lists_and_bools_stay_plain_arrays():
    assert cbor2.loads(codec_cbor.dumps([0.0] * 9)) == [0.0] * 9
    assert cbor2.loads(codec_cbor.dumps(np.array([True, False]))) == [True, False]
    assert cbor2.loads(codec_cbor.dumps((1, 2))) == [1, 2]


def test_decoded_arrays_are_zero_copy_views():
    frame = codec_cbor.dumps({"a": np.arange(1000, dtype=np.float32)})
    array = codec_cbor.loads(frame)["a"]
    assert array.base is not None and not array.flags.writeable
    assert array.tolist() == list(range(1000))


def test_big_endian_tags_decode():
    item = cbor2.dumps(cbor2.CBORTag(81, struct.pack(">2f", 1.0, 2.0)))
    assert codec_cbor.loads(item).tolist() == [1.0, 2.0]


@pytest.mark.parametrize(
    "bad",
    [b"", b"\xff", b"\x00\x01", cbor2.dumps(cbor2.CBORTag(85, b"abc")), b"\xa1\x61"],
)
def test_invalid_cbor_raises_decode_error(bad):
    with pytest.raises(DecodeError):
        codec_cbor.loads(bad)


def test_unencodable_raises_encode_error():
    with pytest.raises(EncodeError):
        codec_cbor.dumps({"x": object()})


def test_canonical_round_trip_through_normalize(registry, pointcloud):
    for type_name, raw in [
        ("sensor_msgs/PointCloud2", pointcloud),
        ("riverbridge_msgs/RadarImage", {"reflectance": np.linspace(0, 1, 50, dtype=np.float32)}),
        ("sensor_msgs/Imu", {"orientation_covariance": list(range(9)), "header": {}}),
        ("nav_msgs/OccupancyGrid", {"data": np.array([-1, 0, 100], dtype=np.int8)}),
    ]:
        spec = registry.message(type_name)
        msg = normalize(spec, raw, now_ns=7)
        back = normalize(spec, codec_cbor.loads(codec_cbor.dumps(msg)), now_ns=0)
        assert _equal(back, msg), type_name


def _equal(a, b) -> bool:
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_equal(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, np.ndarray):
        return a.dtype == b.dtype and np.array_equal(a, b)
    return a == b and type(a) is type(b)


def _stream_loads(data):
    """The reference reading: cbor2's stream decoder, which knows where the item ended."""
    stream = io.BytesIO(data)
    obj = cbor2.CBORDecoder(stream, tag_hook=codec_cbor._tag_hook).decode()
    if stream.tell() != len(data):
        raise ValueError("trailing bytes")
    return obj


PUBLISH = cbor2.dumps({"op": "publish", "topic": "/chatter", "msg": {"data": "hello world"}})


@pytest.mark.parametrize(
    "tail",
    [b"\x01", b"\xff", b"\xf7", PUBLISH, cbor2.dumps(b"12345678"), b"\x48" + b"\x00" * 8],
    ids=["int", "break", "undefined", "second frame", "byte string", "raw byte string"],
)
@pytest.mark.parametrize("padding", [0, 70_000], ids=["small", "large"])
def test_bytes_after_the_first_item_are_refused(tail, padding):
    frame = cbor2.dumps({"op": "publish", "topic": "/t", "msg": {"data": "x" * padding}})
    with pytest.raises(DecodeError, match="trailing bytes after the first item"):
        codec_cbor.loads(frame + tail)


def test_small_frames_read_as_the_stream_decoder_reads_them():
    """Valid frames, cut short, lengthened and with bytes flipped: each reads to the same
    value, or is refused, exactly when cbor2's stream decoder says so."""
    rng = random.Random(21)
    frames = [
        PUBLISH,
        codec_cbor.dumps({"a": np.arange(5, dtype=np.float32), "b": [1, 2.5, None, True]}),
        cbor2.dumps([[[[[[[[[[1]]]]]]]]]]),
        cbor2.dumps({"x": cbor2.CBORTag(64, b"\x01\x02")}),
    ]
    for frame in frames:
        variants = [frame[:cut] for cut in range(len(frame))]
        variants += [frame + bytes([b]) for b in range(256)]
        for _ in range(300):
            flipped = bytearray(frame)
            flipped[rng.randrange(len(frame))] = rng.randrange(256)
            variants.append(bytes(flipped))
        for data in variants:
            try:
                expected = _stream_loads(data)
            except Exception:  # any refusal
                with pytest.raises(DecodeError):
                    codec_cbor.loads(data)
                continue
            got = codec_cbor.loads(data)
            assert repr(got) == repr(expected), data


def test_the_deepest_allowed_frame_still_reads():
    """One level short of cbor2's depth limit: the small-frame path wraps the item in an array
    (one level more), so it must fall back to the stream decoder rather than refuse it."""
    depth = cbor2.CBORDecoder(io.BytesIO(b"")).max_depth
    frame = b"\x81" * (depth - 1) + b"\x01"
    assert _stream_loads(frame) is not None
    value = codec_cbor.loads(frame)
    for _ in range(depth - 1):
        value = value[0]
    assert value == 1
