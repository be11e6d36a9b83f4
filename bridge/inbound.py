"""Inbound frame decoding, kept pure so the edge may run it in a worker thread."""

from __future__ import annotations

from typing import Any

from schemas import codec_cbor, codec_json
from schemas.errors import DecodeError
from schemas.specs import MessageSpec


class PreparedMessage(dict):
    """A publish's message already normalized against `spec` on a worker thread, with the
    figures the loop would otherwise derive from it: the work a big nested message costs (400
    radar detections: ~6 ms on a busy core) must not run on the event loop twice.

    A dict, so the op model takes it like any message; `handle_publish` unwraps it when the
    topic's type is still `spec`, and normalizes it again otherwise.
    """

    __slots__ = ("cdr_bytes", "size_hint", "spec")

    def __init__(self, msg: dict[str, Any], spec: MessageSpec, size_hint: int,
                 cdr_bytes: int | None) -> None:
        super().__init__(msg)
        self.spec = spec
        self.size_hint = size_hint
        self.cdr_bytes = cdr_bytes

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
