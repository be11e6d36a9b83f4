"""Foxglove WebSocket protocol framing: one typed definition per client op, binary layouts.

No I/O and no state: JSON text ops parse into frozen pydantic models keyed on a literal `op`
(one discriminated union, validated once), binary client frames into small dataclasses, and
server messages are built as bytes. Layouts follow foxglove/ws-protocol's `types.ts` and
parsers (subprotocol `foxglove.websocket.v1`) and the Foxglove SDK's `foxglove.sdk.v1`, which
adds playback control (client opcode 3, server opcode 5) and `dataStartTime`/`dataEndTime`.
All integers are little-endian.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Annotated, Any, Literal

import orjson
from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError

WS_PROTOCOL_V1 = "foxglove.websocket.v1"
SDK_V1 = "foxglove.sdk.v1"  # the SDK's name for v1 plus playback control
SUBPROTOCOLS = (WS_PROTOCOL_V1, SDK_V1)

# Server binary opcodes.
MESSAGE_DATA = 1
TIME = 2
SERVICE_CALL_RESPONSE = 3
FETCH_ASSET_RESPONSE = 4
PLAYBACK_STATE = 5
# Client binary opcodes.
CLIENT_MESSAGE_DATA = 1
SERVICE_CALL_REQUEST = 2
PLAYBACK_CONTROL_REQUEST = 3

# Status levels of the `status` op.
INFO, WARNING, ERROR = 0, 1, 2
# PlaybackState status values.
PLAYING, PAUSED, BUFFERING, ENDED = 0, 1, 2, 3

MAX_IDS = 10_000  # ids one op may carry: beyond it the op is refused, not iterated


class FoxgloveWireError(ValueError):
    """A client frame that does not follow the protocol; its text goes into a `status`."""


class _Op(BaseModel):
    model_config = ConfigDict(frozen=True, extra="ignore", populate_by_name=True)


class SubscriptionRequest(_Op):
    id: int = Field(ge=0, lt=2**32)
    channel_id: int = Field(alias="channelId", ge=0, lt=2**32)


class Subscribe(_Op):
    op: Literal["subscribe"]
    subscriptions: list[SubscriptionRequest] = Field(max_length=MAX_IDS)


class Unsubscribe(_Op):
    op: Literal["unsubscribe"]
    subscription_ids: list[int] = Field(alias="subscriptionIds", max_length=MAX_IDS)


class ClientChannel(_Op):
    id: int = Field(ge=0, lt=2**32)
    topic: str = Field(min_length=1, max_length=256)
    encoding: str = Field(max_length=64)
    schema_name: str = Field(alias="schemaName", max_length=256)


class Advertise(_Op):
    op: Literal["advertise"]
    channels: list[ClientChannel] = Field(max_length=MAX_IDS)


class Unadvertise(_Op):
    op: Literal["unadvertise"]
    channel_ids: list[int] = Field(alias="channelIds", max_length=MAX_IDS)


class Parameter(_Op):
    name: str = Field(min_length=1, max_length=256)
    value: Any = None
    type: str | None = None


class GetParameters(_Op):
    op: Literal["getParameters"]
    parameter_names: list[str] = Field(alias="parameterNames", max_length=MAX_IDS)
    id: str | None = Field(default=None, max_length=256)


class SetParameters(_Op):
    op: Literal["setParameters"]
    parameters: list[Parameter] = Field(max_length=MAX_IDS)
    id: str | None = Field(default=None, max_length=256)


class SubscribeParameterUpdates(_Op):
    op: Literal["subscribeParameterUpdates"]
    parameter_names: list[str] = Field(alias="parameterNames", max_length=MAX_IDS)


class UnsubscribeParameterUpdates(_Op):
    op: Literal["unsubscribeParameterUpdates"]
    parameter_names: list[str] = Field(alias="parameterNames", max_length=MAX_IDS)


class SubscribeConnectionGraph(_Op):
    op: Literal["subscribeConnectionGraph"]


class UnsubscribeConnectionGraph(_Op):
    op: Literal["unsubscribeConnectionGraph"]


class FetchAsset(_Op):
    op: Literal["fetchAsset"]
    uri: str = Field(max_length=4096)
    request_id: int = Field(alias="requestId", ge=0, lt=2**32)


ClientOp = Annotated[
    Subscribe
    | Unsubscribe
    | Advertise
    | Unadvertise
    | GetParameters
    | SetParameters
    | SubscribeParameterUpdates
    | UnsubscribeParameterUpdates
    | SubscribeConnectionGraph
    | UnsubscribeConnectionGraph
    | FetchAsset,
    Field(discriminator="op"),
]
CLIENT_OPS: TypeAdapter[ClientOp] = TypeAdapter(ClientOp)
KNOWN_OPS = frozenset(
    model.model_fields["op"].annotation.__args__[0]  # type: ignore[union-attr]
    for model in (
        Subscribe,
        Unsubscribe,
        Advertise,
        Unadvertise,
        GetParameters,
        SetParameters,
        SubscribeParameterUpdates,
        UnsubscribeParameterUpdates,
        SubscribeConnectionGraph,
        UnsubscribeConnectionGraph,
        FetchAsset,
    )
)


def parse_text(data: str | bytes) -> ClientOp:
    """One client JSON op (raises FoxgloveWireError naming what is wrong)."""
    try:
        raw = orjson.loads(data)
    except orjson.JSONDecodeError as exc:
        raise FoxgloveWireError(f"not JSON: {exc}") from None
    if not isinstance(raw, dict):
        raise FoxgloveWireError(f"expected a JSON object, got {type(raw).__name__}")
    op = raw.get("op")
    if op not in KNOWN_OPS:
        raise FoxgloveWireError(f"unknown op: {str(op)[:60]!r}")
    try:
        return CLIENT_OPS.validate_python(raw)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(part) for part in first["loc"][1:])
        raise FoxgloveWireError(f"malformed {op}: {where}: {first['msg']}") from None


# -- binary client frames ----------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class ClientMessageData:
    channel_id: int
    payload: bytes


@dataclass(frozen=True, slots=True)
class ServiceCallRequest:
    service_id: int
    call_id: int
    encoding: str
    payload: bytes


@dataclass(frozen=True, slots=True)
class PlaybackControlRequest:
    """`play` False means pause; `seek_ns` is None when the request does not seek."""

    play: bool
    speed: float
    seek_ns: int | None
    request_id: str


ClientBinary = ClientMessageData | ServiceCallRequest | PlaybackControlRequest

_U32 = struct.Struct("<I")
_CALL = struct.Struct("<III")
_PLAYBACK_REQUEST = struct.Struct("<BfBQI")


def parse_binary(data: bytes) -> ClientBinary:
    """One client binary frame (raises FoxgloveWireError on an unknown opcode or short frame)."""
    if not data:
        raise FoxgloveWireError("empty binary frame")
    opcode, body = data[0], memoryview(data)[1:]
    try:
        if opcode == CLIENT_MESSAGE_DATA:
            (channel_id,) = _U32.unpack_from(body)
            return ClientMessageData(channel_id, bytes(body[4:]))
        if opcode == SERVICE_CALL_REQUEST:
            service_id, call_id, length = _CALL.unpack_from(body)
            end = _CALL.size + length
            if len(body) < end:
                raise FoxgloveWireError("service call request shorter than its encoding length")
            encoding = bytes(body[_CALL.size : end]).decode("utf-8")
            return ServiceCallRequest(service_id, call_id, encoding, bytes(body[end:]))
        if opcode == PLAYBACK_CONTROL_REQUEST:
            command, speed, seeks, seek_ns, length = _PLAYBACK_REQUEST.unpack_from(body)
            end = _PLAYBACK_REQUEST.size + length
            if command > 1 or len(body) < end:
                raise FoxgloveWireError("malformed playback control request")
            request_id = bytes(body[_PLAYBACK_REQUEST.size : end]).decode("utf-8")
            return PlaybackControlRequest(
                command == 0, speed, seek_ns if seeks else None, request_id
            )
    except (struct.error, UnicodeDecodeError) as exc:
        raise FoxgloveWireError(f"binary opcode {opcode}: {exc}") from None
    raise FoxgloveWireError(f"unknown binary opcode {opcode}")


# -- server messages ---------------------------------------------------------------------------

_MESSAGE_HEADER = struct.Struct("<BIQ")
_TIME = struct.Struct("<BQ")
_ASSET_HEADER = struct.Struct("<BIBI")
_PLAYBACK_STATE = struct.Struct("<BBQfBI")


def message_data_header(subscription_id: int, timestamp_ns: int) -> bytes:
    """The 13 bytes before a message's payload."""
    return _MESSAGE_HEADER.pack(MESSAGE_DATA, subscription_id, timestamp_ns)


def time_frame(timestamp_ns: int) -> bytes:
    return _TIME.pack(TIME, timestamp_ns)


def service_call_response(service_id: int, call_id: int, encoding: str, payload: bytes) -> bytes:
    name = encoding.encode()
    return b"".join(
        (bytes([SERVICE_CALL_RESPONSE]), _CALL.pack(service_id, call_id, len(name)), name, payload)
    )


def fetch_asset_response(request_id: int, data: bytes | None, error: str = "") -> bytes:
    """Success carries `data`; `data` None is an error with `error` as its text."""
    text = error.encode()
    status = 0 if data is not None else 1
    head = _ASSET_HEADER.pack(FETCH_ASSET_RESPONSE, request_id, status, len(text))
    return head + text + (data or b"")


def playback_state(
    status: int, current_ns: int, speed: float, did_seek: bool, request_id: str | None
) -> bytes:
    rid = (request_id or "").encode()
    head = _PLAYBACK_STATE.pack(PLAYBACK_STATE, status, current_ns, speed, did_seek, len(rid))
    return head + rid


def json_frame(op: str, **fields: Any) -> bytes:
    """A server JSON op (UTF-8 bytes)."""
    return orjson.dumps({"op": op, **fields})


def status(level: int, message: str, status_id: str | None = None) -> bytes:
    fields: dict[str, Any] = {"level": level, "message": message}
    if status_id is not None:
        fields["id"] = status_id
    return json_frame("status", **fields)


def stamp(ns: int) -> dict[str, int]:
    """ns as the `{sec, nsec}` of `dataStartTime`/`dataEndTime`."""
    sec, nsec = divmod(ns, 1_000_000_000)
    return {"sec": sec, "nsec": nsec}
