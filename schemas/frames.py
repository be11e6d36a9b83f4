"""The frames of the ops sent per message: ``publish`` and ``fragment``, without a model.

These ops go out once per message (a scan cut at 1000 characters is thousands of
fragments), so they are written by typed functions instead of building their
`schemas.ops.Publish` / `schemas.ops.Fragment` model each time (~6 µs a model, more than
encoding an Imu frame); tests/schemas/test_schema_frames.py reads every frame back through
those models. Key order is rosbridge's: ``op``, ``topic``, ``msg`` (no ``id``); ``op``,
``id``, ``data``, ``num``, ``total``.
"""

from __future__ import annotations

import functools

from schemas import codec_cbor, codec_json
from schemas.values import Message, OpId

_NS_PER_S = 1_000_000_000


def publish_json(
    topic: str, msg: Message, reduced: Message | None = None, *, widen: bool = True
) -> bytes:
    """Text frame ``{"op":"publish","topic":T,"msg":M}`` (ASCII JSON, bytes as base64), with
    ``"reduced":R`` after ``msg`` when the bridge thinned the message (docs/bridge.md);
    ``widen=False``: `msg` is known to hold no float32 array (`codec_json.dumps`)."""
    if reduced is not None:
        return codec_json.dumps(
            {"op": "publish", "topic": topic, "msg": msg, "reduced": reduced}, widen=widen
        )
    return codec_json.dumps({"op": "publish", "topic": topic, "msg": msg}, widen=widen)


def publish_cbor(topic: str, msg: Message, reduced: Message | None = None) -> bytes:
    """Binary frame of the same map in CBOR, numeric sequences as typed-array tags."""
    if reduced is not None:
        return codec_cbor.dumps({"op": "publish", "topic": topic, "msg": msg, "reduced": reduced})
    return _publish_cbor_head(topic) + codec_cbor.dumps(msg)


@functools.lru_cache(maxsize=4096)
def _publish_cbor_head(topic: str) -> bytes:
    """The bytes of ``{"op":"publish","topic":T,"msg":`` in CBOR: the same for every message
    of a topic, so only the message itself is encoded each time (half the encoder's work
    for a small one)."""
    whole = codec_cbor.dumps({"op": "publish", "topic": topic, "msg": None})
    return whole[:-1]  # less the one byte of null (0xf6)


def publish_cbor_raw(topic: str, cdr: bytes, stamp_ns: int) -> bytes:
    """Binary ``cbor-raw`` frame: ``msg`` is ``{"secs", "nsecs", "bytes"}``.

    ``cdr`` is the serialized message including its 4-byte encapsulation header;
    ``stamp_ns`` is the bridge's clock when sending (wall time, ns).
    """
    secs, nsecs = divmod(int(stamp_ns), _NS_PER_S)
    envelope = {"secs": secs, "nsecs": nsecs, "bytes": bytes(cdr)}
    return codec_cbor.dumps({"op": "publish", "topic": topic, "msg": envelope})


def fragments_json(text: str, fragment_size: int, fragment_id: OpId) -> list[bytes]:
    """Text frames ``{"op":"fragment","id","data","num","total"}`` carrying `text` in slices
    of `fragment_size` characters, with an integer ``total`` (rosbridge sends a float).

    `fragment_id` is the id of the op being cut, whatever the caller chose (a float too).
    """
    total = -(-len(text) // fragment_size)
    return [
        codec_json.dumps(
            {
                "op": "fragment",
                "id": fragment_id,
                "data": text[num * fragment_size : (num + 1) * fragment_size],
                "num": num,
                "total": total,
            }
        )
        for num in range(total)
    ]


def fragments_cbor(data: bytes, fragment_size: int, fragment_id: OpId) -> list[bytes]:
    """Binary frames ``{"op":"fragment","id","data","num","total"}`` carrying the CBOR frame
    `data` in slices of `fragment_size` bytes, ``data`` a byte string (docs/bridge.md, "Over a
    thin link": rosbridge never fragments binary frames, and only clients that join byte
    slices, such as riverbridge's own, can read these; they are sent only on request)."""
    total = -(-len(data) // fragment_size)
    view = memoryview(data)
    return [
        codec_cbor.dumps(
            {
                "op": "fragment",
                "id": fragment_id,
                "data": bytes(view[num * fragment_size : (num + 1) * fragment_size]),
                "num": num,
                "total": total,
            }
        )
        for num in range(total)
    ]
