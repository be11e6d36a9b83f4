"""CBOR binary frames with RFC 8746 typed arrays, as rosbridge's ``cbor`` compression writes.

Out: numeric ndarrays become little-endian typed-array tags (69 u16, 70 u32, 71 u64, 72 i8,
77 i16, 78 i32, 79 i64, 85 f32, 86 f64), ``uint8`` arrays and ``bytes`` a plain byte string,
floats float64, lists arrays. In: every typed-array tag becomes a zero-copy ndarray view
(read-only, on the decoded byte string); tag 64 (uint8) becomes ``bytes``.
"""

from __future__ import annotations

import io
import secrets
from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

import cbor2
import numpy as np

from schemas.errors import DecodeError, EncodeError

#: dtype -> little-endian typed-array tag (RFC 8746 §2.1).
_TAG_FOR_DTYPE: Mapping[np.dtype, int] = MappingProxyType(
    {
        np.dtype(np.uint16): 69,
        np.dtype(np.uint32): 70,
        np.dtype(np.uint64): 71,
        np.dtype(np.int8): 72,
        np.dtype(np.int16): 77,
        np.dtype(np.int32): 78,
        np.dtype(np.int64): 79,
        np.dtype(np.float32): 85,
        np.dtype(np.float64): 86,
    }
)

#: typed-array tag -> dtype, both byte orders (64 and 68, uint8, decode to bytes).
_DTYPE_FOR_TAG: Mapping[int, np.dtype] = MappingProxyType(
    {
        65: np.dtype(">u2"),
        66: np.dtype(">u4"),
        67: np.dtype(">u8"),
        69: np.dtype("<u2"),
        70: np.dtype("<u4"),
        71: np.dtype("<u8"),
        72: np.dtype("i1"),
        73: np.dtype(">i2"),
        74: np.dtype(">i4"),
        75: np.dtype(">i8"),
        77: np.dtype("<i2"),
        78: np.dtype("<i4"),
        79: np.dtype("<i8"),
        80: np.dtype(">f2"),
        81: np.dtype(">f4"),
        82: np.dtype(">f8"),
        84: np.dtype("<f2"),
        85: np.dtype("<f4"),
        86: np.dtype("<f8"),
    }
)
_UINT8_TAGS = frozenset({64, 68})


def _encode_array(array: np.ndarray) -> Any:
    native = array.dtype.newbyteorder("=")
    if native == np.uint8:
        return array.tobytes()
    tag = _TAG_FOR_DTYPE.get(native)
    if tag is None or array.ndim != 1:
        return array.tolist()  # bool, float16, multi-dimensional: plain arrays
    return cbor2.CBORTag(tag, array.astype(native.newbyteorder("<"), copy=False).tobytes())


def _default(encoder: cbor2.CBOREncoder, value: Any) -> None:
    if isinstance(value, np.ndarray):
        encoder.encode(_encode_array(value))
    elif isinstance(value, np.generic):
        encoder.encode(value.item())
    elif isinstance(value, memoryview):
        encoder.encode(value.tobytes())
    elif isinstance(value, tuple):
        encoder.encode(list(value))
    else:
        raise EncodeError(f"cannot encode {type(value).__name__} as CBOR")


def dumps(obj: Any) -> bytes:
    """Serialize a canonical message (or any frame dict holding one) to CBOR."""
    try:
        return cbor2.dumps(obj, default=_default)
    except (cbor2.CBOREncodeError, TypeError, ValueError, OverflowError) as exc:
        raise EncodeError(f"cannot encode as CBOR: {exc}") from None


def _tag_hook(*args: Any) -> Any:
    # cbor2 >= 6 calls tag_hook(tag, immutable); cbor2 5 called tag_hook(decoder, tag).
    tag = args[0] if isinstance(args[0], cbor2.CBORTag) else args[1]
    if tag.tag in _UINT8_TAGS and isinstance(tag.value, bytes):
        return tag.value
    dtype = _DTYPE_FOR_TAG.get(tag.tag)
    if dtype is None or not isinstance(tag.value, bytes):
        return tag
    try:
        return np.frombuffer(tag.value, dtype=dtype)
    except ValueError as exc:
        raise DecodeError(f"typed array tag {tag.tag}: {exc}") from None


def loads(data: bytes | bytearray | memoryview) -> Any:
    """Parse one CBOR item; typed-array tags become ndarrays. Raises :class:`DecodeError`."""
    if len(data) < _WRAP_LIMIT:
        # cbor2.loads ignores bytes after the first item, and a decoder on a stream (which can
        # tell where the item ended) costs twice as much to set up as the item takes to read.
        # So a small frame is read as the array [item, sentinel]: the second element is the
        # sentinel only if nothing came between. Anything else (an error too) is read again
        # below, which names the problem exactly.
        try:
            first, last = cbor2.loads(_PAIR + data + _SENTINEL_ITEM, tag_hook=_tag_hook)
        except Exception:  # read again below, for the exact error
            pass
        else:
            if type(last) is bytes and last == _SENTINEL:
                return first
    stream = io.BytesIO(data)
    try:
        obj = cbor2.CBORDecoder(stream, tag_hook=_tag_hook).decode()
    except DecodeError:
        raise
    except (cbor2.CBORDecodeError, ValueError, TypeError, EOFError) as exc:
        detail = f" ({exc.__cause__})" if exc.__cause__ is not None else ""
        raise DecodeError(f"invalid CBOR: {exc}{detail}") from None
    if stream.tell() != len(stream.getbuffer()):
        raise DecodeError("invalid CBOR: trailing bytes after the first item")
    return obj


# Frames below this are read by the sentinel pair (which copies them once); larger ones, where
# setting up a decoder is nothing beside the copy, by the stream decoder.
_WRAP_LIMIT = 64 * 1024
_PAIR = b"\x82"  # an array of two items
# Random per process, so no client can end a frame with it by chance or on purpose.
_SENTINEL = secrets.token_bytes(8)
_SENTINEL_ITEM = cbor2.dumps(_SENTINEL)
