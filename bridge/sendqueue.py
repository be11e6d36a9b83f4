"""A client's outgoing queue: a slow reader loses its oldest sensor frames, nothing else.

Items with a drop key (topic deliveries) are bounded per key: when a topic already has
`limit` items waiting, its oldest one is dropped and counted. Items without a drop key
(service responses, forwarded calls, action results, status) are never dropped and never
count, so neither a flood on one topic nor many busy topics can push out an answer or
another topic's only message.
"""

from __future__ import annotations

from collections import Counter, deque

from bridge.effects import Send


class SendQueue:
    """FIFO of `Send` effects for one client, at most `limit` waiting per drop key."""

    def __init__(self, limit: int) -> None:
        if limit < 1:
            raise ValueError("send queue limit must be at least 1")
        self.limit = limit
        self.dropped: Counter[str] = Counter()
        self._items: deque[Send] = deque()
        self._waiting: Counter[str] = Counter()

    def __len__(self) -> int:
        return len(self._items)

    @property
    def answers_waiting(self) -> int:
        """Items that can never be dropped (answers, forwarded requests) still queued."""
        return len(self._items) - sum(self._waiting.values())

    def push(self, item: Send) -> Send | None:
        """Append `item`; return the item dropped to make room for it, if any."""
        key = item.drop_key
        victim = None
        if key is not None:
            if self._waiting[key] >= self.limit:
                victim = self._evict_oldest(key)
            self._waiting[key] += 1
        self._items.append(item)
        return victim

    def pop(self) -> Send | None:
        """The oldest item, or None when empty."""
        if not self._items:
            return None
        item = self._items.popleft()
        if item.drop_key is not None:
            self._release(item.drop_key)
        return item

    def _release(self, key: str) -> None:
        self._waiting[key] -= 1
        if not self._waiting[key]:
            del self._waiting[key]

    def _evict_oldest(self, key: str) -> Send:
        index = next(i for i, s in enumerate(self._items) if s.drop_key == key)
        victim = self._items[index]
        del self._items[index]
        self._release(key)
        self.dropped[key] += 1
        return victim
