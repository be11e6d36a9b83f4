"""Per-connection state: everything one client owns, so disconnect can release all of it."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum

from bridge.problems import ProblemLog
from bridge.roles import Grant
from bridge.subscription import Subscription


class StatusLevel(IntEnum):
    """`set_level` levels (protocol §1.5); a client gets `status` ops at or above its level."""

    INFO = 0
    WARNING = 1
    ERROR = 2
    NONE = 3


@dataclass
class FragmentBuffer:
    """Pieces of one fragmented inbound message, keyed by `num`."""

    total: int
    expires_at_ns: int
    pieces: dict[int, str] = field(default_factory=dict)
    size_chars: int = 0


@dataclass
class ClientSession:
    """One websocket client, seen by the graph as node `node`.

    `status_level` starts at NONE: real rosbridge never sends `status` and roslibpy raises on
    one, so only clients that opt in with `set_level` get them.
    """

    client_id: int
    node: str
    peer: str = ""
    fragment_size: int | None = None
    status_level: StatusLevel = StatusLevel.NONE
    subscriptions: dict[str, Subscription] = field(default_factory=dict)
    published: set[str] = field(default_factory=set)
    services: set[str] = field(default_factory=set)
    actions: set[str] = field(default_factory=set)
    fragments: dict[str | int, FragmentBuffer] = field(default_factory=dict)
    problems: ProblemLog = field(default_factory=ProblemLog)
    # Told once that ROS 1's header.seq is dropped (roslibpy's Header(seq=...)).
    ros1_seq_noted: bool = False
    # False until a valid rosauth `auth` op when the bridge has an auth secret.
    authenticated: bool = True
    # Who it is (a token's subject, "" until it authenticates), its role and quota buckets
    # (bridge.roles; `grant` None: no roles file, or an in-process client, so no limits).
    principal: str = ""
    role: str | None = None
    grant: Grant | None = None
    # Set once the core asked the edge to close the connection: later frames are ignored.
    closing: bool = False

    def fragment_chars(self) -> int:
        """Characters held in all of the client's incomplete fragment lists."""
        return sum(buffer.size_chars for buffer in self.fragments.values())

    def fragment_size_for(self, subscription: Subscription | None = None) -> int | None:
        """Outgoing fragment threshold: the client-wide value, lowered by the subscription's.
        (Asked once per message and subscriber: no lists.)"""
        size = self.fragment_size
        if subscription is not None:
            own = subscription.settings.fragment_size
            if own is not None and (size is None or own < size):
                return own
        return size
