"""What the sans-I/O core asks the edge to do.

The core never touches a socket or a clock; every call returns a list of these effects and
the asyncio edge (`bridge.server`) carries them out in order.
"""

from __future__ import annotations

from dataclasses import dataclass

from bridge.outgoing import Outgoing

#: What a deadline is for: its kind (`"call"`, `"fragment"`, ...) then the kind's arguments.
DeadlineKey = tuple[str | int, ...]


# Not frozen: one is built per message and subscriber, and a frozen dataclass takes ~4x as
# long to build (970 against 260 ns here); treat it as immutable all the same.
@dataclass(slots=True)
class Send:
    """Queue `item` for client `client_id`.

    `drop_key` names the stream the item belongs to (the topic for `publish` deliveries): when
    the client's send queue is full the oldest item with a drop key is discarded. `None` means
    the item must never be dropped (service responses, action results, forwarded requests).
    Frames longer than `fragment_size` go out as `fragment` ops. `keep` is the subscription's
    `queue_length`: while the client cannot take more, only the newest `keep` messages of the
    topic wait (0: all of them, within the client's send buffer).
    """

    client_id: int
    item: Outgoing
    drop_key: str | None = None
    fragment_size: int | None = None
    keep: int = 0


@dataclass(frozen=True, slots=True)
class Close:
    """Close the client's websocket with `code` (RFC 6455) and `reason`."""

    client_id: int
    code: int
    reason: str


@dataclass(frozen=True, slots=True)
class Schedule:
    """Call `BridgeCore.on_deadline(key, now_ns)` once the wall clock reaches `at_ns`.

    Scheduling a key that is already pending replaces the earlier deadline.
    """

    key: DeadlineKey
    at_ns: int


@dataclass(frozen=True, slots=True)
class Hold:
    """Read nothing more from client `client_id` until the wall clock reaches `until_ns`.

    A client past its quota (`bridge.roles`) waits on TCP instead of costing the bridge the
    decoding of messages that would only be dropped: another principal's messages keep
    their pace while one floods.
    """

    client_id: int
    until_ns: int


Effect = Send | Close | Schedule | Hold
