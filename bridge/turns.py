"""Turns for large writes: the clients of a big message get it one after another, not all at once.

Sixteen subscribers of a 5.5 MB scan, each handed its copy in the same loop turn, share the
loopback and the CPU: every one of them has its scan at about the same time, late, and an IMU
sample written behind a copy waits that long too. Handed in turns, the first has its scan
after one copy's time, the median after half the fan-out, and a link waiting for its turn has
an empty socket, so its small messages go out at once (issue 21, "fair turns across sockets").

A link takes a turn before it writes a frame of at least `LARGE_BYTES`; it gives the turn back
once its socket has almost nothing of it left unsent (`ClientLink` watches), or after
`TURN_MAX_S` so that a slow link (a thin shore link) never holds up fast ones. Waiting links
are granted turns in the order they asked. Pure bookkeeping: the link does the I/O and the
clock reading.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Hashable
from typing import Generic, TypeVar

# A frame this large waits for a turn; smaller frames never wait (an IMU sample, an answer,
# a fragment of a scan sent over a thin link).
LARGE_BYTES = 512 * 1024
# Links that may have a large frame in flight at once. One: with two, sixteen subscribers of a
# scan had it later (relay.py fanout, scan p50 1.9-2.3x the bare relay against 1.06-1.2x).
SLOTS = 1
# A link gives its turn back after this long even if its client has not taken the frame.
TURN_MAX_S = 0.05
# A turn ends once the link's socket holds no more than this of it unsent.
DONE_BYTES = 256 * 1024

L = TypeVar("L", bound=Hashable)


class LargeWriteTurns(Generic[L]):
    """Whose turn it is to write a large frame; `grant` is called with a waiting link when
    its turn comes."""

    def __init__(self, grant: Callable[[L], None], slots: int = SLOTS) -> None:
        if slots < 1:
            raise ValueError("at least one slot")
        self.slots = slots
        self.handoffs = 0  # turns given so far: a waiting link sees the line move
        self._grant = grant
        self._holders: set[L] = set()
        self._waiting: deque[L] = deque()

    def holds(self, link: L) -> bool:
        return link in self._holders

    def take(self, link: L) -> bool:
        """True if `link` may write a large frame now; else it is in line (once) and is
        granted its turn later."""
        if link in self._holders:
            return True
        if len(self._holders) < self.slots and (not self._waiting or self._waiting[0] is link):
            if self._waiting and self._waiting[0] is link:
                self._waiting.popleft()
            self._holders.add(link)
            self.handoffs += 1
            return True
        if link not in self._waiting:
            self._waiting.append(link)
        return False

    def give_back(self, link: L) -> None:
        """`link` is done with its turn (or gone): the next in line gets one."""
        self._holders.discard(link)
        if link in self._waiting:
            self._waiting.remove(link)
        while self._waiting and len(self._holders) < self.slots:
            nxt = self._waiting.popleft()
            self._holders.add(nxt)
            self.handoffs += 1
            self._grant(nxt)


__all__ = ["DONE_BYTES", "LARGE_BYTES", "SLOTS", "TURN_MAX_S", "LargeWriteTurns"]
