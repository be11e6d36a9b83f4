"""Inbound frames: decoding, kept pure, and what the edge measured when it read them."""

from __future__ import annotations

from dataclasses import dataclass, field

from bridge.validation import CheckedMessage
from schemas import codec_cbor, codec_json
from schemas.errors import DecodeError
from schemas.ops import MAX_NAME_CHARS, reply_id
from schemas.safety import describe_value, frame_problem
from schemas.values import JsonObject, JsonValue


@dataclass(frozen=True)
class RefusedFrame:
    """A frame that decoded but holds something nothing downstream could carry (a lone
    surrogate, a 100-bit integer, a CBOR set...). `head` keeps what can safely be read of it
    (`op`, `id`, `service`, `action`) so a caller waiting on it still gets its answer."""

    problem: str
    head: JsonObject = field(default_factory=dict)


# Not frozen: one is built per frame, and a frozen dataclass takes ~3x as long to build (its
# __init__ goes through object.__setattr__); treat it as immutable all the same.
@dataclass(slots=True)
class InboundFrame:
    """One decoded frame of a client, with the facts the edge measured when it read it.

    `arrived_ns` is the wall clock when the frame was read from the socket and `wire_bytes`
    its websocket payload size (the tracer's `bridge_in` span and byte counters). `checked` is
    a publish's message already checked against its type off the event loop
    (`BridgeCore.offload`); the publish handler takes it instead of checking again.
    """

    message: JsonValue | RefusedFrame
    arrived_ns: int
    wire_bytes: int
    checked: CheckedMessage | None = None


def read_frame(data: bytes | str, arrived_ns: int) -> InboundFrame:
    """`decode_frame` of a frame read at `arrived_ns`; raises DecodeError like it."""
    return InboundFrame(decode_frame(data), arrived_ns, len(data))


_JSON_STARTS = (b"{", b"[", b'"')
_SCALARS = frozenset((str, int, float, bool, type(None)))
_HEAD_KEYS = ("op", "service", "action")


def decode_frame(data: bytes | str) -> JsonValue | RefusedFrame:
    """Text frames are JSON; binary frames are CBOR, or UTF-8 JSON as ROS# sends them.

    A binary frame that begins (after whitespace) like a JSON document is read as JSON first:
    a JSON object's `{` would otherwise be taken for a short CBOR text string. Raises
    DecodeError when neither reading works; returns a `RefusedFrame` for a frame that decodes
    to values no encoder could write again (`schemas.safety.frame_problem`).
    """
    message, strict_json = _decode(data)
    if strict_json and type(message) is dict and type(message.get("msg")) is dict:
        # orjson vouched for every value; a publish's message is walked by its type later,
        # so only the rest (small, but possibly relayed untyped) needs the depth check, and
        # not even that when it is all scalars (the usual op, topic, id).
        for key, value in message.items():
            if type(value) not in _SCALARS and key != "msg":
                break
        else:
            return message
        problem = frame_problem({k: v for k, v in message.items() if k != "msg"})
    else:
        problem = frame_problem(message)
    return message if problem is None else RefusedFrame(problem, _head(message))


def _decode(data: bytes | str) -> tuple[JsonValue, bool]:
    """The decoded frame, and whether orjson's strict JSON parser read it."""
    # (A byte of 0x80 or above, as every CBOR map's first byte is, starts no JSON document.)
    if isinstance(data, str) or (
        data and data[0] < 0x80 and bytes(data[:64]).lstrip()[:1] in _JSON_STARTS
    ):
        return codec_json.loads_strictness(data)
    try:
        return codec_cbor.loads(data), False
    except DecodeError as cbor_error:
        try:
            return codec_json.loads_strictness(data)
        except DecodeError:
            raise DecodeError(f"binary frame is neither CBOR nor JSON ({cbor_error})") from None


def _head(message: JsonValue) -> JsonObject:
    """The routing fields of a refused frame that are safe to use and echo."""
    if not isinstance(message, dict):
        return {}
    head: JsonObject = {}
    for key in _HEAD_KEYS:
        value = message.get(key)
        if (
            isinstance(value, str)
            and len(value) <= MAX_NAME_CHARS
            and describe_value(value) is None
        ):
            head[key] = value
    op_id = reply_id(message.get("id"))
    if op_id is not None and describe_value(op_id) is None:
        head["id"] = op_id
    return head
