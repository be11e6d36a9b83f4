"""Shared pieces of the rosapi service tables."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from bridge.context import Context
from bridge.errors import RosapiError
from schemas.values import Message

#: `(ctx, request) -> response values`. The request has exactly the fields of the service's
#: `.srv` request in the registry (`bridge.ops.services.answer_rosapi` fills and checks it);
#: the values are checked against the `.srv` response the same way before they are sent.
RosapiHandler = Callable[[Context, Message], Message]


@dataclass(frozen=True)
class Forward:
    """Answer a rosapi call by calling `service` with `args`; `translate` makes that
    service's response the rosapi response (raising RosapiError fails the call with its
    text). Used for other nodes' parameters (`bridge.rosapi.node_params`)."""

    service: str
    args: Message
    translate: Callable[[Message], Message]


@dataclass(frozen=True)
class Gather:
    """Answer a rosapi call from several services' answers: each of `calls` (service, args)
    is made at once, and `combine` gets every one's response values, or the text of its
    failure (unknown service, timeout), in order. Used to list other nodes' parameters."""

    calls: tuple[tuple[str, Message], ...]
    combine: Callable[[list[Message | str]], Message]


#: `(ctx, request) -> Forward | Gather | None`: None answers the call with the handler.
Forwarder = Callable[[Context, Message], Forward | Gather | None]


@dataclass(frozen=True)
class RosapiService:
    """One rosapi service: its `rosapi_msgs/srv/*` type, its handler and, for services
    that may be answered by another service, the request's forwarder."""

    type_name: str
    handler: RosapiHandler
    forward: Forwarder | None = None


def text_arg(request: Message, field: str) -> str:
    """A `string` field of a request completed against its `.srv`.

    A field the `.srv` does not declare as a string is a bug in the handler, refused here
    rather than read as an empty string.
    """
    value = request.get(field)
    if not isinstance(value, str):
        raise RosapiError(f"the request has no string field {field!r}")
    return value


def table(prefix: str, entries: dict[str, tuple[str, RosapiHandler]]) -> dict[str, RosapiService]:
    """`{"topics": ("Topics", fn)}` -> `{"/rosapi/topics": RosapiService(...)}`."""
    return {
        f"{prefix}/{name}": RosapiService(f"rosapi_msgs/srv/{srv}", handler)
        for name, (srv, handler) in entries.items()
    }
