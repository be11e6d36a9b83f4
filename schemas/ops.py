"""Every rosbridge v2 operation as a pydantic model, validated once at the edge.

Field rules follow the protocol reference §2. Models allow extra keys (clients send
op-specific extras such as ``fragment_size`` anywhere; rosbridge ignores them) and are
frozen. Payloads (``msg``, ``args``, ``values``) are arbitrary JSON (``schemas.values``)
and only checked for their outer shape here, so a 4 MB message is never walked or copied
by pydantic; the message normaliser validates them against their type later.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from types import MappingProxyType
from typing import Annotated, Any, Literal, NamedTuple, TypeVar

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PlainValidator,
    StrictBool,
    StrictBytes,
    StrictInt,
    StrictStr,
    StringConstraints,
    ValidationError,
    field_validator,
)

from schemas.errors import SchemaError
from schemas.safety import echo
from schemas.values import JsonObject, JsonValue, OpId

#: Longest `id` string accepted: ids are echoed in answers (the bridge's own request ids,
#: `service_request:<247-character name>:<n>`, fit).
MAX_ID_CHARS = 300
#: Longest topic, service, action or type string read (valid ROS names have at most 247).
MAX_NAME_CHARS = 512
#: A call_service timeout beyond a day is taken as a day (the deadline must stay a number).
MAX_TIMEOUT_S = 86_400.0


def _check_id(value: JsonValue) -> OpId:
    if value is None or isinstance(value, bool | int | float):
        return value
    if isinstance(value, str) and len(value) <= MAX_ID_CHARS:
        return value
    raise ValueError(f"must be a string of at most {MAX_ID_CHARS} characters, a number or null")


def reply_id(value: JsonValue) -> OpId:
    """The id to echo in an answer to a message: its own if acceptable, else None."""
    try:
        return _check_id(value)
    except ValueError:
        return None


#: An op's `id`: echoed back, so it must be short (rosbridge clients send strings or numbers).
Id = Annotated[OpId, PlainValidator(_check_id)]
#: A topic, service, action or type string; names are validated by the bridge after this.
Name = Annotated[StrictStr, StringConstraints(max_length=MAX_NAME_CHARS)]


class OpError(SchemaError):
    """An incoming op that is malformed; ``op`` and ``id`` are what could be read of it."""

    def __init__(self, message: str, op: str | None = None, id: JsonValue = None) -> None:
        super().__init__(message)
        self.op = op
        self.id = id


class OpBase(BaseModel):
    """Common base: extra keys allowed (kept in ``model_extra``), instances frozen."""

    model_config = ConfigDict(extra="allow", frozen=True)


def _object_or_empty(value: JsonValue) -> JsonObject | list[JsonValue]:
    """``args``: an object or a positional list; anything else means an empty request."""
    return value if isinstance(value, dict | list) else {}


def _object_required(value: JsonValue) -> JsonObject:
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise ValueError("must be an object")
    return value


# Payloads: taken as they are (never walked or copied by pydantic), only their outer shape
# checked.
#: An object; ``null`` means an empty one.
Payload = Annotated[JsonObject, PlainValidator(_object_required)]
#: Request arguments: an object or a positional list; anything else means none.
Arguments = Annotated[JsonObject | list[JsonValue], PlainValidator(_object_or_empty)]


# -- topics -----------------------------------------------------------------------------------


class Advertise(OpBase):
    op: Literal["advertise"] = "advertise"
    id: Id = None
    topic: Name
    type: Name
    latch: StrictBool = False
    queue_size: StrictInt = 100
    qos: JsonObject | None = None


class Unadvertise(OpBase):
    op: Literal["unadvertise"] = "unadvertise"
    id: Id = None
    topic: Name


class Publish(OpBase):
    op: Literal["publish"] = "publish"
    topic: Name
    msg: Payload = Field(default_factory=dict)
    id: Id = None
    latch: StrictBool = False
    queue_size: StrictInt = 100
    type: Name | None = None


class Subscribe(OpBase):
    op: Literal["subscribe"] = "subscribe"
    id: Id = None
    topic: Name
    type: Name | None = None  # roslibpy sends null when the user gave none
    throttle_rate: StrictInt = 0  # ms between messages; a float is rejected like rosbridge
    queue_length: StrictInt = 0
    fragment_size: StrictInt | None = None
    compression: StrictStr = "none"
    qos: JsonObject | None = None
    # riverbridge: thin a PointCloud2 to fit the link (docs/bridge.md, "Over a thin link")
    reduce: JsonObject | None = None


class Unsubscribe(OpBase):
    op: Literal["unsubscribe"] = "unsubscribe"
    id: Id = None
    topic: Name


# -- services ---------------------------------------------------------------------------------


class CallService(OpBase):
    op: Literal["call_service"] = "call_service"
    id: Id = None
    service: Name
    args: Arguments = Field(default_factory=dict)
    type: JsonValue = None  # accepted and ignored: the graph decides (Lichtblick: ROS 1 names)
    fragment_size: StrictInt | None = None
    compression: StrictStr = "none"
    timeout: Annotated[float, Field(allow_inf_nan=False)] | None = None  # seconds


class AdvertiseService(OpBase):
    op: Literal["advertise_service"] = "advertise_service"
    id: Id = None
    type: Name
    service: Name


class UnadvertiseService(OpBase):
    op: Literal["unadvertise_service"] = "unadvertise_service"
    id: Id = None
    service: Name


class ServiceResponse(OpBase):
    op: Literal["service_response"] = "service_response"
    service: Name
    values: JsonValue = None  # an object on success, the error text on failure
    result: StrictBool
    id: Id = None


# -- actions ----------------------------------------------------------------------------------


class SendActionGoal(OpBase):
    op: Literal["send_action_goal"] = "send_action_goal"
    id: Id = None
    action: Name
    action_type: Name
    args: Arguments = Field(default_factory=dict)
    feedback: bool = False
    fragment_size: StrictInt | None = None
    compression: StrictStr = "none"


class CancelActionGoal(OpBase):
    op: Literal["cancel_action_goal"] = "cancel_action_goal"
    id: Id = None
    action: Name


class ActionFeedback(OpBase):
    op: Literal["action_feedback"] = "action_feedback"
    action: Name
    values: Payload = Field(default_factory=dict)
    id: Id = None


class ActionResult(OpBase):
    op: Literal["action_result"] = "action_result"
    action: Name
    values: JsonValue = None  # an object, or the error text when result is false
    status: StrictInt
    result: StrictBool
    id: Id = None


class AdvertiseAction(OpBase):
    op: Literal["advertise_action"] = "advertise_action"
    id: Id = None
    type: Name
    action: Name


class UnadvertiseAction(OpBase):
    op: Literal["unadvertise_action"] = "unadvertise_action"
    id: Id = None
    action: Name


# -- framing and status -----------------------------------------------------------------------


def _fragment_id(value: JsonValue) -> str | int:
    if isinstance(value, bool) or not isinstance(value, str | int):
        raise ValueError("must be a string or an integer")
    _check_id(value)
    return value


class Fragment(OpBase):
    op: Literal["fragment"] = "fragment"
    id: Annotated[str | int, PlainValidator(_fragment_id)]  # keys the pieces of one message
    # text: a slice of a JSON op; bytes: a slice of a CBOR frame (riverbridge's binary
    # fragments, docs/bridge.md "Over a thin link")
    data: StrictStr | StrictBytes
    num: StrictInt  # 0 <= num < total, checked against the first fragment's total
    total: Annotated[StrictInt, Field(ge=1)]  # rosbridge sends a float ((len-1)/size + 1)

    @field_validator("total", mode="before")
    @classmethod
    def _floor_total(cls, value: JsonValue) -> JsonValue:
        if isinstance(value, float) and math.isfinite(value):
            return math.floor(value)
        return value


class Png(OpBase):
    op: Literal["png"] = "png"
    data: StrictStr
    id: Id = None


class SetLevel(OpBase):
    op: Literal["set_level"] = "set_level"
    id: Id = None
    level: Literal["info", "warning", "error", "none"]


class Auth(OpBase):
    """rosauth's `auth` op (schemas.rosauth); `t` and `end` are seconds or ROS times."""

    op: Literal["auth"] = "auth"
    id: Id = None
    mac: StrictStr
    client: StrictStr
    dest: StrictStr
    rand: StrictStr
    t: JsonValue
    level: StrictStr
    end: JsonValue


class Status(OpBase):
    op: Literal["status"] = "status"
    level: StrictStr
    msg: StrictStr
    id: Id = None


OpModel = (
    Advertise
    | Unadvertise
    | Publish
    | Subscribe
    | Unsubscribe
    | CallService
    | AdvertiseService
    | UnadvertiseService
    | ServiceResponse
    | Fragment
    | Png
    | SetLevel
    | Status
    | SendActionGoal
    | CancelActionGoal
    | ActionFeedback
    | ActionResult
    | AdvertiseAction
    | UnadvertiseAction
    | Auth
)
Op = Annotated[OpModel, Field(discriminator="op")]


def op_name(model: type[OpBase]) -> str:
    """The literal ``op`` of a model class (``Publish`` -> ``"publish"``)."""
    name = model.model_fields["op"].default
    assert isinstance(name, str), model
    return name


#: op name -> model class.
MODELS: Mapping[str, type[OpBase]] = MappingProxyType(
    {op_name(model): model for model in OpModel.__args__}
)

_PHRASES = {
    "int_type": "must be an integer",
    "string_type": "must be a string",
    "bool_type": "must be a boolean",
    "bool_parsing": "must be a boolean",
    "float_type": "must be a number",
    "float_parsing": "must be a number",
    "dict_type": "must be an object",
}


def _short_repr(value: JsonValue) -> str:
    return echo(value, 60)


def _describe_error(op: str, error: Mapping[str, Any], more: int) -> str:
    field = ".".join(str(part) for part in error["loc"])
    kind = error["type"]
    if kind == "missing":
        text = f"{op}: field '{field}' is required"
    else:
        phrase = _PHRASES.get(kind)
        if phrase is None:
            message = error["msg"].removeprefix("Value error, ")
            if message.startswith("Input should be "):
                phrase = "must be " + message.removeprefix("Input should be ")
            else:
                phrase = message[:1].lower() + message[1:] if message else "is invalid"
        text = f"{op}: field '{field}' {phrase}, got {_short_repr(error.get('input'))}"
    return text + (f" (and {more} more problem(s))" if more else "")


def parse_op(obj: JsonValue) -> OpModel:
    """Validate one decoded JSON/CBOR object as a rosbridge op.

    Raises :class:`OpError` with a one-line message naming the op and the bad field, e.g.
    ``"subscribe: field 'throttle_rate' must be an integer, got 'fast'"``.
    """
    if not isinstance(obj, Mapping):
        raise OpError(f"expected a JSON object with an 'op' field, got {type(obj).__name__}")
    op_id = obj.get("id")
    op = obj.get("op")
    if op is None:
        keys = sorted(str(key)[:20] for key in obj)[:8]
        raise OpError(f"message has no 'op' field (keys: {keys})", id=op_id)
    if not isinstance(op, str):
        raise OpError(f"field 'op' must be a string, got {_short_repr(op)}", id=op_id)
    model = MODELS.get(op)
    if model is None:
        raise OpError(f"unknown op {_short_repr(op)}", op=op, id=op_id)
    return validate_op(model, obj)  # type: ignore[return-value]  # MODELS holds OpModel's


OpT = TypeVar("OpT", bound=OpBase)


def validate_op(model: type[OpT], obj: Mapping[str, JsonValue]) -> OpT:
    """`obj` (whose ``op`` names `model`) as a `model`; :class:`OpError` naming the bad field
    as `parse_op` does."""
    try:
        return model.model_validate(obj)
    except ValidationError as exc:
        op = op_name(model)
        errors = exc.errors(include_url=False)
        raise OpError(
            _describe_error(op, errors[0], len(errors) - 1), op=op, id=obj.get("id")
        ) from None


class PublishFields(NamedTuple):
    """A well-formed ``publish`` as `parse_publish` reads it: the fields of :class:`Publish`."""

    topic: str
    msg: JsonObject
    id: OpId = None
    latch: bool = False
    queue_size: int = 100
    type: str | None = None


def parse_publish(obj: Mapping[str, JsonValue]) -> PublishFields:
    """`parse_op` for the most frequent op, without pydantic when nothing needs it.

    A ``publish`` whose fields already have the types and sizes :class:`Publish` asks for (the
    normal case, ~0.4 µs instead of ~2 µs) is read directly; anything else goes through
    pydantic, which refuses it with the same message as `parse_op`. Either way the result is
    a `PublishFields`. The message itself is not looked at here: it is validated against its
    topic's type afterwards.
    """
    topic, msg, op_id = obj.get("topic"), obj.get("msg", _ABSENT), obj.get("id")
    latch, queue_size = obj.get("latch", False), obj.get("queue_size", 100)
    type_name = obj.get("type")
    if (
        type(topic) is str
        and len(topic) <= MAX_NAME_CHARS
        and (latch is False or latch is True)
        and type(queue_size) is int
        and (type_name is None or (type(type_name) is str and len(type_name) <= MAX_NAME_CHARS))
        and (
            op_id is None
            or isinstance(op_id, bool | int | float)
            or (type(op_id) is str and len(op_id) <= MAX_ID_CHARS)
        )
    ):
        if type(msg) is dict:
            return PublishFields(topic, msg, op_id, latch, queue_size, type_name)
        if msg is None or msg is _ABSENT:
            return PublishFields(topic, {}, op_id, latch, queue_size, type_name)
    op = validate_op(Publish, obj)
    return PublishFields(op.topic, op.msg, op.id, op.latch, op.queue_size, op.type)


_ABSENT = object()


def to_wire(model: OpBase) -> JsonObject:
    """The op as a dict in rosbridge key order: ``op``, then the fields that were set.

    ``id`` therefore appears only when the op was built (or parsed) with one, and never as
    ``null`` (rosbridge leaves an absent id out). The values are the model's own objects, not
    copies: a 4 MB message in ``msg`` or ``values`` is passed along, never walked. This is how
    the bridge writes every op it sends but ``publish`` and ``fragment`` (`schemas.frames`).
    """
    fields_set = model.model_fields_set
    return {
        name: value
        for name, value in model.__dict__.items()
        if name == "op" or (name in fields_set and (value is not None or name != "id"))
    }
