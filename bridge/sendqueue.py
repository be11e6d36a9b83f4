"""A client's outgoing backlog: bounded in bytes, drop-oldest per topic, answers never dropped.

Items wait here only while the client's socket is backed up (the edge writes straight through
otherwise). Each item belongs to a stream: its topic (`Send.drop_key`) or, for answers and
forwarded requests (`drop_key` None), the undroppable control stream. Streams keep their own
order; across streams the oldest item goes first, except that a stream whose previous item is
still being encoded on a worker (`busy`) is skipped, so a scan being encoded does not hold up
the IMU behind it.

The bound counts every byte the client has not taken yet: what the edge already handed to the
transport (`outside_bytes`) plus what waits here. Only a push that would take the client past
the bound drops anything, and then only the oldest waiting items of the pushed item's own topic:
a flood on one topic never pushes out another topic's messages, and a topic always keeps its
newest message. Drops are counted per topic.
"""

from __future__ import annotations

from collections import Counter, deque
from collections.abc import Container
from dataclasses import dataclass
from itertools import count

from bridge.effects import Send
from bridge.outgoing import WireFrame


@dataclass(slots=True)
class Waiting:
    """One queued item: `nbytes` is its frames' size (estimated until `frames` are known)."""

    send: Send
    nbytes: int
    frames: list[WireFrame] | None
    seq: int


class SendQueue:
    """The waiting items of one client, at most `limit_bytes` with what is in flight."""

    def __init__(self, limit_bytes: int) -> None:
        if limit_bytes < 1:
            raise ValueError("send buffer must be at least 1 byte")
        self.limit_bytes = limit_bytes
        self.dropped: Counter[str] = Counter()
        self.bytes = 0
        self.answers_waiting = 0  # items that can never be dropped, still queued
        self._streams: dict[str | None, deque[Waiting]] = {}
        self._seq = count()
        self._len = 0

    def __len__(self) -> int:
        return self._len

    def push(
        self, send: Send, nbytes: int, frames: list[WireFrame] | None = None, outside_bytes: int = 0
    ) -> list[Send]:
        """Append `send`; return the items dropped to stay within the bound (oldest first)."""
        key = send.drop_key
        stream = self._streams.get(key)
        if stream is None:
            stream = self._streams[key] = deque()
        victims: list[Send] = []
        if key is not None:
            while stream and outside_bytes + self.bytes + nbytes > self.limit_bytes:
                victim = stream.popleft()
                self._forget(victim)
                self.dropped[key] += 1
                victims.append(victim.send)
        else:
            self.answers_waiting += 1
        stream.append(Waiting(send, nbytes, frames, next(self._seq)))
        self.bytes += nbytes
        self._len += 1
        return victims

    def pop(self, busy: Container[str | None] = ()) -> Waiting | None:
        """The oldest item of any stream that is not `busy`, or None."""
        best: deque[Waiting] | None = None
        for key, stream in self._streams.items():
            if stream and key not in busy and (best is None or stream[0].seq < best[0].seq):
                best = stream
        if best is None:
            return None
        item = best.popleft()
        self._forget(item)
        return item

    def push_front(self, item: Waiting) -> None:
        """Put a popped item back at the head of its stream (keeping its place in line)."""
        key = item.send.drop_key
        self._streams.setdefault(key, deque()).appendleft(item)
        self.bytes += item.nbytes
        self._len += 1
        if key is None:
            self.answers_waiting += 1

    def clear(self) -> None:
        self._streams.clear()
        self.bytes = self._len = self.answers_waiting = 0

    def _forget(self, item: Waiting) -> None:
        self.bytes -= item.nbytes
        self._len -= 1
        if item.send.drop_key is None:
            self.answers_waiting -= 1
