"""Inbound frame decoding, kept pure so the edge may run it in a worker thread."""

from __future__ import annotations

from typing import Any

from schemas import codec_cbor, codec_json
from schemas.errors import DecodeError

_JSON_STARTS = (b"{", b"[", b'"')


def decode_frame(data: bytes | str) -> Any:
    """Text frames are JSON; binary frames are CBOR, or UTF-8 JSON as ROS# sends them.

    A binary frame that begins (after whitespace) like a JSON document is read as JSON first:
    a JSON object's `{` would otherwise be taken for a short CBOR text string. Raises
    DecodeError when neither reading works.
    """
    if isinstance(data, str):
        return codec_json.loads(data)
    if bytes(data[:64]).lstrip()[:1] in _JSON_STARTS:
        return codec_json.loads(data)
    try:
        return codec_cbor.loads(data)
    except DecodeError as cbor_error:
        try:
            return codec_json.loads(data)
        except DecodeError:
            raise DecodeError(f"binary frame is neither CBOR nor JSON ({cbor_error})") from None
