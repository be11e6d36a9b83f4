"""Whole outgoing ``publish`` frames: encode once per (message, encoding), fan out the bytes.

Key order is rosbridge's: ``op``, ``topic``, ``msg``; no ``id``.
"""

from __future__ import annotations

from schemas import codec_cbor, codec_json
from schemas.values import Message

_NS_PER_S = 1_000_000_000


def publish_json(topic: str, msg: Message) -> bytes:
    """Text frame ``{"op":"publish","topic":T,"msg":M}`` (ASCII JSON, bytes as base64)."""
    return codec_json.dumps({"op": "publish", "topic": topic, "msg": msg})


def publish_cbor(topic: str, msg: Message) -> bytes:
    """Binary frame of the same map in CBOR, numeric sequences as typed-array tags."""
    return codec_cbor.dumps({"op": "publish", "topic": topic, "msg": msg})


def publish_cbor_raw(topic: str, cdr: bytes, stamp_ns: int) -> bytes:
    """Binary ``cbor-raw`` frame: ``msg`` is ``{"secs", "nsecs", "bytes"}``.

    ``cdr`` is the serialized message including its 4-byte encapsulation header;
    ``stamp_ns`` is the bridge's clock when sending (wall time, ns).
    """
    secs, nsecs = divmod(int(stamp_ns), _NS_PER_S)
    envelope = {"secs": secs, "nsecs": nsecs, "bytes": bytes(cdr)}
    return codec_cbor.dumps({"op": "publish", "topic": topic, "msg": envelope})
