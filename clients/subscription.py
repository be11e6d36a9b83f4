"""A subscription: an async iterator over :class:`clients.Received` with a bounded queue.

The client's reader puts messages in without ever waiting; when the consumer falls behind, the
oldest queued message is dropped and counted (DESIGN §4: a slow subscriber never blocks the
publisher, the event loop or other subscribers). Sensor consumers want the freshest data, so
"drop oldest" is the right policy, not "block" or "drop newest".
"""

from __future__ import annotations

import asyncio
from collections import deque
from collections.abc import Awaitable, Callable
from typing import Any

import numpy as np

from clients.errors import ClientClosed
from clients.events import Received

DEFAULT_MAXSIZE = 64
"""Messages kept per subscription: ~6 s of a 10 Hz LIDAR, ~0.6 s of a 100 Hz IMU."""


class Subscription:
    """Messages of one subscribe id, in arrival order, as an async iterator.

    ``async for item in sub`` yields :class:`Received` until ``unsubscribe()`` or the client's
    ``close()`` ends the iteration. If the connection is lost on a client without reconnect,
    iteration raises :class:`ConnectionClosed` once the queued messages are consumed. With
    reconnect the iterator simply waits across the outage.

    One consumer per subscription: iterating the same object from two tasks splits the messages
    between them. Counters: ``received`` (delivered into the queue), ``dropped`` (oldest
    discarded because the queue was full).
    """

    def __init__(
        self,
        *,
        topic: str,
        sub_id: str,
        type: str | None,
        maxsize: int,
        bytes_as_numpy: bool,
        unsubscribe: Callable[[Subscription], Awaitable[None]],
    ) -> None:
        if maxsize < 1:
            raise ValueError("maxsize must be at least 1")
        self.topic = topic
        self.id = sub_id
        self.type = type
        self.maxsize = maxsize
        self.bytes_as_numpy = bytes_as_numpy
        self.received = 0
        self.dropped = 0
        self._queue: deque[Received] = deque()
        self._wakeup = asyncio.Event()
        self._end: BaseException | None = None
        self._unsubscribe = unsubscribe

    # ---------------------------------------------------------------- producer side
    def deliver(self, item: Received) -> None:
        """Queue one message without waiting; drops the oldest when full (loop thread only)."""
        if self._end is not None:
            return
        if self.bytes_as_numpy:
            item = Received(item.topic, bytes_as_arrays(item.msg), item.recv_ns, item.wire_bytes)
        if len(self._queue) >= self.maxsize:
            self._queue.popleft()
            self.dropped += 1
        self._queue.append(item)
        self.received += 1
        self._wakeup.set()

    def finish(self, reason: BaseException) -> None:
        """End the iteration: :class:`ClientClosed` ends it quietly, others are raised."""
        if self._end is None:
            self._end = reason
        self._wakeup.set()

    # ---------------------------------------------------------------- consumer side
    def __aiter__(self) -> Subscription:
        return self

    async def __anext__(self) -> Received:
        try:
            return await self.get()
        except ClientClosed:
            raise StopAsyncIteration from None

    async def get(self) -> Received:
        """Wait for the next message; raises :class:`ClientClosed` after the end."""
        while not self._queue:
            if self._end is not None:
                raise self._end
            self._wakeup.clear()
            await self._wakeup.wait()
        return self._queue.popleft()

    def get_nowait(self) -> Received | None:
        """The next queued message, or ``None`` when the queue is empty."""
        return self._queue.popleft() if self._queue else None

    def qsize(self) -> int:
        """Messages waiting in the queue."""
        return len(self._queue)

    @property
    def closed(self) -> bool:
        """True once unsubscribed or the client closed."""
        return self._end is not None

    async def unsubscribe(self) -> None:
        """Tell the bridge to stop this id and end the iteration. Idempotent."""
        if self._end is None:
            self.finish(ClientClosed(f"unsubscribed from {self.topic}"))
            await self._unsubscribe(self)

    async def __aenter__(self) -> Subscription:
        return self

    async def __aexit__(self, *exc_info: object) -> None:
        await self.unsubscribe()

    def __repr__(self) -> str:
        return (
            f"Subscription({self.topic!r}, id={self.id!r}, queued={len(self._queue)}, "
            f"received={self.received}, dropped={self.dropped})"
        )


def bytes_as_arrays(msg: dict[str, Any]) -> dict[str, Any]:
    """Copy of ``msg`` with every ``bytes`` field replaced by a zero-copy uint8 view.

    The views (``np.frombuffer``, read-only, shape (n,)) share memory with the received
    frame, so e.g. a PointCloud2's ``data`` can be reinterpreted with ``.view(dtype)`` without
    copying 4 MB. Walks fields and lists of messages, never array elements.
    """
    out: dict[str, Any] = {}
    for key, value in msg.items():
        if isinstance(value, bytes):
            out[key] = np.frombuffer(value, dtype=np.uint8)
        elif isinstance(value, dict):
            out[key] = bytes_as_arrays(value)
        elif isinstance(value, list) and value and isinstance(value[0], dict):
            out[key] = [bytes_as_arrays(item) for item in value]
        else:
            out[key] = value
    return out
