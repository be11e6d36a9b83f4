"""Writes to DDS leave the event loop through one thread and a bounded queue.

The loop only queues a closure (serialize to CDR, then `dds_write`); the writer thread runs
them in order. A reliable DDS write may wait for acknowledgements, and a 5.5 MB CDR encode
takes milliseconds: neither may happen on the loop. The queue is bounded per stream (a
topic's writer, a service's reply writer) by count and by payload bytes, so a burst of small
messages waits while a slow domain costs memory for a few scans only: past either bound the
stream's oldest job is dropped and counted, like the websocket send queues do.
"""

from __future__ import annotations

import logging
import threading
from collections import Counter, deque
from collections.abc import Callable, Hashable
from dataclasses import dataclass

logger = logging.getLogger("bridge.dds")

Job = Callable[[], None]
# A stream may hold this many waiting jobs ...
MAX_ITEMS = 256
# ... and this many payload bytes (three 5.5 MB scans); its newest job is always kept.
MAX_BYTES = 16 * 1024 * 1024


@dataclass
class _Stream:
    items: int = 0
    size: int = 0


class Outbox:
    """A FIFO of jobs, bounded per stream key (oldest of that key dropped)."""

    def __init__(self, max_items: int = MAX_ITEMS, max_bytes: int = MAX_BYTES) -> None:
        self.max_items = max_items
        self.max_bytes = max_bytes
        self._items: deque[tuple[Hashable, Job, int]] = deque()
        self._streams: dict[Hashable, _Stream] = {}
        self.dropped: Counter[Hashable] = Counter()
        self._ready = threading.Condition()
        self._closed = False

    def put(self, key: Hashable, job: Job, size: int = 0) -> None:
        """Queue `job` (carrying about `size` payload bytes) on stream `key`."""
        with self._ready:
            stream = self._streams.setdefault(key, _Stream())
            while stream.items and (
                stream.items >= self.max_items or stream.size + size > self.max_bytes
            ):
                self._drop_oldest(key, stream)
            self._items.append((key, job, size))
            stream.items += 1
            stream.size += size
            self._ready.notify()

    def _drop_oldest(self, key: Hashable, stream: _Stream) -> None:
        for index, (item_key, _, size) in enumerate(self._items):
            if item_key == key:
                del self._items[index]
                stream.items -= 1
                stream.size -= size
                self.dropped[key] += 1
                return

    def get(self, timeout_s: float | None = None) -> Job | None:
        """The next job, or None when closed (or after `timeout_s` with nothing queued)."""
        with self._ready:
            if not self._items and not self._closed:
                self._ready.wait(timeout_s)
            if self._closed or not self._items:
                return None
            key, job, size = self._items.popleft()
            stream = self._streams[key]
            stream.items -= 1
            stream.size -= size
            if not stream.items:
                del self._streams[key]
            return job

    def close(self) -> None:
        with self._ready:
            self._closed = True
            self._items.clear()
            self._streams.clear()
            self._ready.notify_all()

    @property
    def closed(self) -> bool:
        return self._closed

    def __len__(self) -> int:
        return len(self._items)


class WriterThread:
    """Runs the outbox's jobs on one thread until it is closed; a failing job is logged as
    `failure` and ends nothing (one unwritable message, a publisher just closed)."""

    def __init__(
        self,
        outbox: Outbox,
        name: str = "bridge-dds-writer",
        failure: str = "DDS: a write failed",
        log: logging.Logger = logger,
    ) -> None:
        self.outbox = outbox
        self._failure, self._log = failure, log
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

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
            except Exception:
                self._log.exception(self._failure)
