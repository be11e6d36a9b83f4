"""Frames on the wire: turning op dicts into websocket payloads and payloads back into ops.

Pure functions with no state, safe to call from any thread: the client runs them on a worker
thread for large frames so that a 4 MB scan's decode never holds up a 200-byte IMU sample on
the event loop.

Wire rules (reference/rosbridge-protocol.md §1, §4): JSON goes out in text frames; CBOR goes
out in binary frames (the riverbridge bridge accepts CBOR from clients); a binary frame from
the server is CBOR, except that a binary frame whose first non-blank byte is ``{`` is JSON (ROS#
style). A ``png`` op is unwrapped here into the op it carries.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ParamSpec, cast

from clients.errors import ProtocolError
from schemas import codec_cbor, codec_json
from schemas.codec_png import decode_png_data
from schemas.errors import SchemaError
from schemas.ops import OpBase, op_name, validate_op

P = ParamSpec("P")

_JSON_LEAD_BYTES = frozenset(b" \t\r\n{")
"""First bytes of a JSON object text; a CBOR map (major type 5) starts with 0xa0-0xbf."""


@dataclass(frozen=True, slots=True)
class Frame:
    """One outgoing websocket message: ``data`` sent as a text frame when ``text`` is true."""

    data: bytes
    text: bool

    @property
    def wire_bytes(self) -> int:
        """Payload length in bytes (websocket framing overhead not counted)."""
        return len(self.data)


def json_frame(op: dict[str, Any]) -> Frame:
    """Encode a control op (subscribe, call_service, ...) as a JSON text frame."""
    return Frame(codec_json.dumps(op), text=True)


def op_frame(model: Callable[P, OpBase], /, *args: P.args, **fields: P.kwargs) -> Frame:
    """The JSON text frame of one op, built and checked by its :mod:`schemas.ops` model.

    ``op_frame(Unsubscribe, id=sub_id, topic=topic)``: mypy checks the fields against the
    model's signature, pydantic checks the values (the same model the bridge parses the op
    with), so a field the bridge would refuse raises :class:`schemas.ops.OpError` naming it
    here, before anything is sent. The fields go out in the order given, with the values the
    model holds: rosbridge reads keys by name, but the order keeps the client's frames byte for
    byte what they have always been (tests/clients/test_client_wire_bytes.py pins them).
    Costs ~2 µs over a plain dict: fine for control ops; ``publish`` does not come here.
    """
    if args:
        raise TypeError(f"{op_name(cast(type[OpBase], model))}: op fields are keywords")
    op = validate_op(cast(type[OpBase], model), fields)
    wire: dict[str, Any] = {"op": op_name(type(op))}
    for name in fields:
        wire[name] = getattr(op, name)
    return json_frame(wire)


def decode_frame(data: bytes | bytearray | memoryview | str) -> dict[str, Any]:
    """Decode one websocket payload into an op dict.

    ``str`` payloads (text frames) are JSON; bytes payloads are CBOR unless they look like JSON.
    A ``png`` op is replaced by the op it encodes. Raises :class:`ProtocolError` when the
    payload is not an object with a string ``op``.
    """
    try:
        if isinstance(data, str):
            op = codec_json.loads(data)
        elif len(data) > 0 and data[0] in _JSON_LEAD_BYTES:
            op = codec_json.loads(bytes(data))
        else:
            op = codec_cbor.loads(bytes(data))
        if isinstance(op, dict) and op.get("op") == "png":
            op = codec_json.loads(decode_png_data(op["data"]))
    except (SchemaError, ValueError, KeyError, TypeError) as exc:
        raise ProtocolError(f"undecodable frame of {len(data)} bytes: {exc}") from exc
    if not isinstance(op, dict) or not isinstance(op.get("op"), str):
        raise ProtocolError(f"frame is not an op object: {str(op)[:80]!r}")
    return op
