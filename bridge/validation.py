"""A publish's message checked against its type: one path, on the event loop or off it.

Every published message is checked by `check_message`, and the publish handler turns what it
returns into the `TopicMessage` it hands to the graph. For a large message whose check costs
real time (base64 to decode, hundreds of nested messages to walk) the edge asks the core for a
`PublishCheck` first (`BridgeCore.offload`), runs it on a worker thread and hands the result
back with the frame (`InboundFrame.checked`); the handler then takes that result instead of
checking again, as long as the topic still has the type it was checked against.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from schemas.codec_cdr import cdr_size
from schemas.errors import SchemaError
from schemas.message import normalize, payload_bytes
from schemas.registry import TypeRegistry
from schemas.specs import MessageSpec
from schemas.tracing import header_stamp_ns
from schemas.values import JsonObject, Message


# Not frozen, like bridge.inbound.InboundFrame: one per published message; treat as immutable.
@dataclass(slots=True)
class ValidMessage:
    """A message in canonical form for `spec`, with the figures derived from it.

    `size_hint` says how costly encoding it will be (its bulk bytes, or its wire size if that
    is larger: JSON of many small fields); `cdr_bytes` is its serialized size when it was
    measured (stamped messages checked off the loop), else None (the tracer measures it).
    """

    spec: MessageSpec
    msg: Message
    size_hint: int
    cdr_bytes: int | None = None


@dataclass(frozen=True, slots=True)
class InvalidMessage:
    """A message that does not fit `spec`; `problem` names the field."""

    spec: MessageSpec
    problem: str


CheckedMessage = ValidMessage | InvalidMessage


def check_message(
    spec: MessageSpec, raw: JsonObject, *, wire_bytes: int, now_ns: int
) -> CheckedMessage:
    """Validate and complete a published message (`schemas.message.normalize`)."""
    try:
        msg = normalize(spec, raw, now_ns=now_ns)
    except SchemaError as exc:
        return InvalidMessage(spec, str(exc))
    if spec.bulk_free:  # (no bytes or arrays to count)
        return ValidMessage(spec, msg, wire_bytes)
    return ValidMessage(spec, msg, max(wire_bytes, payload_bytes(msg)))


@dataclass(frozen=True, slots=True)
class PublishCheck:
    """The work a large publish needs off the event loop; `run` it on a worker thread.

    It reads nothing but its own fields (the spec was looked up on the loop), so it is safe
    to run beside the core.
    """

    spec: MessageSpec
    raw: JsonObject
    wire_bytes: int
    now_ns: int
    registry: TypeRegistry

    def run(self) -> CheckedMessage:
        checked = check_message(self.spec, self.raw, wire_bytes=self.wire_bytes, now_ns=self.now_ns)
        if isinstance(checked, ValidMessage) and header_stamp_ns(checked.msg) is not None:
            checked = replace(checked, cdr_bytes=self._cdr_bytes(checked.msg))
        return checked

    def _cdr_bytes(self, msg: Message) -> int | None:
        """The serialized size tracing reports for stamped messages (None: not measurable)."""
        try:
            return cdr_size(self.registry, self.spec.name, msg)
        except (SchemaError, KeyError, TypeError, ValueError, AttributeError):
            return None
