"""Reading the ops a rosbridge server sends into the `schemas.ops` models the bridge writes.

The client speaks to any rosbridge server, not only ours, so it reads leniently where real
servers differ from the models (reference/rosbridge-protocol.md §2.6-2.10,
rosbridge-clients.md): a missing ``result`` means success (roslibpy and roslibjs treat only
``false`` as failure), an ``action_result`` without ``status`` takes ``values.status``
(roslibpy), a missing ``service``/``action`` echo, or a goal without ``action_type``, is filled
with ``""`` (the pending call, goal or advertisement names it). Extra keys are kept by the
models and ignored. Anything else a model refuses is a :class:`ProtocolError` naming the op and
the field; the reader logs it in one line and drops the frame, never the connection.
``publish``, the one op that arrives per message, is read by `schemas.ops.parse_publish`
instead (no pydantic for a well-formed one, ~0.4 µs).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import partial
from types import MappingProxyType
from typing import Generic, Protocol, TypeVar

from clients.events import Event
from schemas.ops import OpBase, op_name, validate_op
from schemas.values import JsonObject, JsonValue

ModelT = TypeVar("ModelT", bound=OpBase)
OpT = TypeVar("OpT")
ReceiverT = TypeVar("ReceiverT")
ReceiverT_contra = TypeVar("ReceiverT_contra", contravariant=True)


def _missing_result_is_success(op: JsonObject) -> None:
    """Only ``false`` is failure (roslibpy, roslibjs): an absent or null ``result`` is not."""
    if op.get("result") is None:
        op["result"] = True


def _status_from_values(op: JsonObject) -> None:
    """roslibpy's rule: ``status`` from the top level, else from ``values``, else 0."""
    if op.get("status") is None:
        values = op.get("values")
        status = values.get("status") if isinstance(values, dict) else None
        op["status"] = status if isinstance(status, int) else 0


def _filled(*names: str) -> Callable[[JsonObject], None]:
    """An echo some servers leave out, read as ``""``."""

    def fill(op: JsonObject) -> None:
        for name in names:
            op.setdefault(name, "")

    return fill


#: op -> what is done to a server's op before its model reads it (on a copy).
LENIENCY: Mapping[str, tuple[Callable[[JsonObject], None], ...]] = MappingProxyType(
    {
        "service_response": (_missing_result_is_success, _filled("service")),
        "action_result": (_missing_result_is_success, _status_from_values, _filled("action")),
        "action_feedback": (_filled("action"),),
        "send_action_goal": (_filled("action_type"),),
        "cancel_action_goal": (_filled("action"),),
    }
)


def read_op(model: type[ModelT], op: Mapping[str, JsonValue]) -> ModelT:
    """`op` (whose ``op`` names `model`) as a `model`, read as leniently as real servers need.

    Raises `schemas.ops.OpError` naming the op and the first bad field (the protocol turns
    it into a :class:`ProtocolError`).
    """
    fixes = LENIENCY.get(str(op.get("op")), ())
    if fixes:
        op = dict(op)
        for fix in fixes:
            fix(op)
    return validate_op(model, op)


class OpRoute(Protocol[ReceiverT_contra]):
    """What a receiver dispatches an inbound op to: read, then handled."""

    def run(
        self,
        receiver: ReceiverT_contra,
        op: Mapping[str, JsonValue],
        recv_ns: int,
        wire_bytes: int,
    ) -> list[Event]: ...


@dataclass(frozen=True, slots=True)
class Route(Generic[ReceiverT, OpT]):
    """`read` turns the decoded op into an `OpT`; `handle` routes exactly that `OpT`."""

    read: Callable[[Mapping[str, JsonValue]], OpT]
    handle: Callable[[ReceiverT, OpT, int, int], list[Event]]

    def run(
        self, receiver: ReceiverT, op: Mapping[str, JsonValue], recv_ns: int, wire_bytes: int
    ) -> list[Event]:
        return self.handle(receiver, self.read(op), recv_ns, wire_bytes)


def route(
    model: type[ModelT], handle: Callable[[ReceiverT, ModelT, int, int], list[Event]]
) -> dict[str, Route[ReceiverT, ModelT]]:
    """``{op: route}`` for an op read by its `schemas.ops` model with `read_op`; mypy checks
    that `handle` takes that model."""
    return {op_name(model): Route(partial(read_op, model), handle)}
