"""Op handlers, one module per op family, merged into one dispatch table keyed by op.

Each family module exports `ROUTES`: one `Route` per op it handles, pairing the parser that
turns the decoded object into its typed op (a `schemas.ops` model, checked once by pydantic)
with the handler that takes exactly that type. `route(Advertise, handle_advertise)` only
type-checks if `handle_advertise` accepts an `Advertise`, so mypy proves every handler gets
the model it expects; handlers do not check again what the model already did.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from functools import partial
from typing import Generic, Protocol, TypeVar

from bridge.context import Context
from bridge.session import ClientSession
from schemas.ops import OpBase, op_name, validate_op
from schemas.runtime.native import native_first
from schemas.values import JsonValue

# The compiled hot path, if built and current (schemas.runtime.native).
__path__ = native_first(__path__, __name__)

OpT = TypeVar("OpT")
ModelT = TypeVar("ModelT", bound=OpBase)


class OpRoute(Protocol):
    """What the core dispatches to: one op, read and handled."""

    @property
    def op(self) -> str: ...

    def run(self, ctx: Context, session: ClientSession, message: Mapping[str, JsonValue]) -> None:
        """Parse `message` (`schemas.ops.OpError` if malformed) and handle it."""
        ...


@dataclass(frozen=True, slots=True)
class Route(Generic[OpT]):
    """`parse` reads the decoded object as an `OpT`; `handle` acts on that `OpT`."""

    op: str
    parse: Callable[[Mapping[str, JsonValue]], OpT]
    handle: Callable[[Context, ClientSession, OpT], None]

    def run(self, ctx: Context, session: ClientSession, message: Mapping[str, JsonValue]) -> None:
        self.handle(ctx, session, self.parse(message))


def route(
    model: type[ModelT], handle: Callable[[Context, ClientSession, ModelT], None]
) -> Route[ModelT]:
    """The route of an op whose pydantic `model` checks it."""
    return Route(op_name(model), partial(validate_op, model), handle)


def merge_routes(*families: Iterable[OpRoute]) -> dict[str, OpRoute]:
    """One table from several families; an op claimed twice is a programming error."""
    merged: dict[str, OpRoute] = {}
    for family in families:
        for entry in family:
            if entry.op in merged:
                raise ValueError(f"op {entry.op!r} handled twice")
            merged[entry.op] = entry
    return merged
