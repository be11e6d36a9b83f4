"""A client's outgoing backlog: bounded in bytes, newest-first per topic, answers never dropped.

Items wait here only while the client's socket cannot take more (the edge writes straight
through otherwise). Each item belongs to a stream: its topic (`Send.drop_key`) or, for answers
and forwarded requests (`drop_key` None), the undroppable control stream. Streams keep their
own order. Across streams, small items (at most `SMALL_BYTES`: an IMU sample, an answer) go
before large ones, oldest first; a large message fragmented (`fragment_size`) leaves one
fragment at a time and its rest goes to the back of the line (`requeue`), so a small message
waits for at most one fragment. A stream whose previous item is still being encoded on a worker
(`busy`) is skipped, so a scan being encoded does not hold up the IMU behind it.

Two things drop a topic's oldest waiting message, each counted per topic:
- conflation: a subscription with `queue_length` N (`Send.keep`) keeps only its N newest
  messages waiting (`conflated`);
- the bound: it counts every byte the client has not taken yet (what the edge already handed
  to the transport, `outside_bytes`, plus what waits here); a push that would take the client
  past it drops the oldest waiting items of the pushed item's own topic (`dropped`). A flood on
  one topic never pushes out another topic's messages, and a topic keeps its newest message.
A message already partly sent (`started`) is never dropped: its client holds its first pieces.
"""

from __future__ import annotations

from collections import Counter, deque
from collections.abc import Container
from dataclasses import dataclass
from itertools import count

from bridge.effects import Send
from bridge.outgoing import WireFrame

# Items up to this size go before larger ones when both wait: a few hundred IMU samples or
# answers cost a 10 Mbit/s link less than one 64 KiB fragment.
SMALL_BYTES = 16 * 1024


@dataclass(slots=True)
class Waiting:
    """One queued item: `nbytes` is the size of its frames still to send (estimated until
    `frames` are known); once `started`, `frames[:first]` have left, `sent_bytes` long."""

    send: Send
    nbytes: int
    frames: list[WireFrame] | None
    seq: int
    started: bool = False
    first: int = 0
    sent_bytes: int = 0


class SendQueue:
    """The waiting items of one client, at most `limit_bytes` with what is in flight."""

    def __init__(self, limit_bytes: int) -> None:
        if limit_bytes < 1:
            raise ValueError("send buffer must be at least 1 byte")
        self.limit_bytes = limit_bytes
        self.dropped: Counter[str] = Counter()
        self.conflated: Counter[str] = Counter()
        self.bytes = 0
        self.lossless_bytes = 0  # of items without `keep`: what publishers may be paced for
        self.answers_waiting = 0  # items that can never be dropped, still queued
        self._streams: dict[str | None, deque[Waiting]] = {}
        self._seq = count()
        self._len = 0

    def __len__(self) -> int:
        return self._len

    def push(
        self, send: Send, nbytes: int, frames: list[WireFrame] | None = None, outside_bytes: int = 0
    ) -> list[Send]:
        """Append `send`; return the items dropped to honour `keep` and the bound (oldest
        first)."""
        key = send.drop_key
        stream = self._streams.get(key)
        if stream is None:
            stream = self._streams[key] = deque()
        victims: list[Send] = []
        if key is not None:
            keep = send.keep
            if keep > 0:
                while self._unstarted(stream) >= keep:
                    victims.append(self._drop_oldest(stream))
                    self.conflated[key] += 1
            while outside_bytes + self.bytes + nbytes > self.limit_bytes and self._unstarted(
                stream
            ):
                victims.append(self._drop_oldest(stream))
                self.dropped[key] += 1
        stream.append(Waiting(send, nbytes, frames, next(self._seq)))
        self._count(send, nbytes)
        return victims

    @staticmethod
    def _unstarted(stream: deque[Waiting]) -> int:
        return len(stream) - 1 if stream and stream[0].started else len(stream)

    def _drop_oldest(self, stream: deque[Waiting]) -> Send:
        """Remove the oldest item of `stream` that has not started (one must exist)."""
        if stream[0].started:
            victim = stream[1]
            del stream[1]
        else:
            victim = stream.popleft()
        self._forget(victim)
        return victim.send

    def pop(self, busy: Container[str | None] = ()) -> Waiting | None:
        """The next item to send from a stream that is not `busy`: the oldest small head, else
        the oldest head; None if nothing may go."""
        best: deque[Waiting] | None = None
        best_rank = (True, 0)
        for key, stream in self._streams.items():
            if not stream or key in busy:
                continue
            head = stream[0]
            rank = (head.nbytes > SMALL_BYTES, head.seq)
            if best is None or rank < best_rank:
                best, best_rank = stream, rank
        if best is None:
            return None
        item = best.popleft()
        self._forget(item)
        return item

    def push_front(self, item: Waiting) -> None:
        """Put a popped item back at the head of its stream (keeping its place in line)."""
        key = item.send.drop_key
        self._streams.setdefault(key, deque()).appendleft(item)
        self._count(item.send, item.nbytes)

    def requeue(self, item: Waiting, sent_bytes: int) -> None:
        """`item` after its next frame left (`sent_bytes` long): first in its stream still,
        last in line."""
        item.first += 1
        item.nbytes -= sent_bytes
        item.sent_bytes += sent_bytes
        item.started = True
        item.seq = next(self._seq)
        self.push_front(item)

    def clear(self) -> None:
        self._streams.clear()
        self.bytes = self.lossless_bytes = self._len = self.answers_waiting = 0

    def _count(self, send: Send, nbytes: int) -> None:
        self.bytes += nbytes
        self._len += 1
        if not send.keep:
            self.lossless_bytes += nbytes
        if send.drop_key is None:
            self.answers_waiting += 1

    def _forget(self, item: Waiting) -> None:
        self.bytes -= item.nbytes
        self._len -= 1
        if not item.send.keep:
            self.lossless_bytes -= item.nbytes
        if item.send.drop_key is None:
            self.answers_waiting -= 1
