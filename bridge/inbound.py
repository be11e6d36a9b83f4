"""Inbound frame decoding, kept pure so the edge may run it in a worker thread."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from schemas import codec_cbor, codec_json
from schemas.errors import DecodeError
from schemas.ops import MAX_NAME_CHARS, reply_id
from schemas.safety import describe_value, frame_problem
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


@dataclass(frozen=True)
class RefusedFrame:
    """A frame that decoded but holds something nothing downstream could carry (a lone
    surrogate, a 100-bit integer, a CBOR set...). `head` keeps what can safely be read of it
    (`op`, `id`, `service`, `action`) so a caller waiting on it still gets its answer."""

    problem: str
    head: dict[str, Any] = field(default_factory=dict)


_JSON_STARTS = (b"{", b"[", b'"')
_HEAD_KEYS = ("op", "service", "action")


def decode_frame(data: bytes | str) -> Any:
    """Text frames are JSON; binary frames are CBOR, or UTF-8 JSON as ROS# sends them.

    A binary frame that begins (after whitespace) like a JSON document is read as JSON first:
    a JSON object's `{` would otherwise be taken for a short CBOR text string. Raises
    DecodeError when neither reading works; returns a `RefusedFrame` for a frame that decodes
    to values no encoder could write again (`schemas.safety.frame_problem`).
    """
    message, strict_json = _decode(data)
    if strict_json and isinstance(message, dict) and isinstance(message.get("msg"), dict):
        # orjson vouched for every value; a publish's message is walked by its type later,
        # so only the rest (small, but possibly relayed untyped) needs the depth check.
        problem = frame_problem({k: v for k, v in message.items() if k != "msg"})
    else:
        problem = frame_problem(message)
    return message if problem is None else RefusedFrame(problem, _head(message))


def _decode(data: bytes | str) -> tuple[Any, bool]:
    """The decoded frame, and whether orjson's strict JSON parser read it."""
    if isinstance(data, str) or bytes(data[:64]).lstrip()[:1] in _JSON_STARTS:
        return codec_json.loads_strictness(data)
    try:
        return codec_cbor.loads(data), False
    except DecodeError as cbor_error:
        try:
            return codec_json.loads_strictness(data)
        except DecodeError:
            raise DecodeError(f"binary frame is neither CBOR nor JSON ({cbor_error})") from None


def _head(message: Any) -> dict[str, Any]:
    """The routing fields of a refused frame that are safe to use and echo."""
    if not isinstance(message, dict):
        return {}
    head = {}
    for key in _HEAD_KEYS:
        value = message.get(key)
        if isinstance(value, str) and len(value) <= MAX_NAME_CHARS and describe_value(
                value) is None:
            head[key] = value
    op_id = reply_id(message.get("id"))
    if op_id is not None and describe_value(op_id) is None:
        head["id"] = op_id
    return head
