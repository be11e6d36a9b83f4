"""Writes to DDS leave the event loop through one thread and a bounded queue.

The loop only queues a closure (serialize to CDR, then `dds_write`); the writer thread runs
them in order. A reliable DDS write may wait for acknowledgements, and a 5.5 MB CDR encode
takes milliseconds: neither may happen on the loop. Each stream (a topic's writer, a
service's reply writer) may hold `limit` waiting items; past that its oldest is dropped and
counted, like the websocket send queues, so a slow domain costs memory for a few messages only.
"""

from __future__ import annotations

import logging
import threading
from collections import Counter, deque
from collections.abc import Callable, Hashable

logger = logging.getLogger("bridge.dds")

Job = Callable[[], None]


class Outbox:
    """A FIFO of jobs, at most `limit` per stream key (oldest of that key dropped)."""

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self._items: deque[tuple[Hashable, Job]] = deque()
        self._per_key: Counter[Hashable] = Counter()
        self.dropped: Counter[Hashable] = Counter()
        self._ready = threading.Condition()
        self._closed = False

    def put(self, key: Hashable, job: Job) -> None:
        with self._ready:
            if self._per_key[key] >= self.limit:
                self._drop_oldest(key)
            self._items.append((key, job))
            self._per_key[key] += 1
            self._ready.notify()

    def _drop_oldest(self, key: Hashable) -> None:
        for index, (item_key, _) in enumerate(self._items):
            if item_key == key:
                del self._items[index]
                self._per_key[key] -= 1
                self.dropped[key] += 1
                return

    def get(self, timeout_s: float | None = None) -> Job | None:
        """The next job, or None when closed (or after `timeout_s` with nothing queued)."""
        with self._ready:
            if not self._items and not self._closed:
                self._ready.wait(timeout_s)
            if self._closed or not self._items:
                return None
            key, job = self._items.popleft()
            self._per_key[key] -= 1
            if not self._per_key[key]:
                del self._per_key[key]
            return job

    def close(self) -> None:
        with self._ready:
            self._closed = True
            self._items.clear()
            self._ready.notify_all()

    @property
    def closed(self) -> bool:
        return self._closed

    def __len__(self) -> int:
        return len(self._items)


class WriterThread:
    """Runs the outbox's jobs until it is closed."""

    def __init__(self, outbox: Outbox) -> None:
        self.outbox = outbox
        self._thread = threading.Thread(target=self._run, name="bridge-dds-writer",
                                        daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self.outbox.close()
        if self._thread.is_alive():
            self._thread.join(timeout=5.0)

    def _run(self) -> None:
        while not self.outbox.closed:
            job = self.outbox.get(timeout_s=1.0)
            if job is None:
                continue
            try:
                job()
            except Exception:  # one unwritable message must not end the writer
                logger.exception("DDS: a write failed")
