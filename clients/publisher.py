"""The send path of one topic, with an optional "latest only" slot.

A 10 Hz LIDAR on a link that briefly cannot keep up should send the newest scan, not a growing
backlog of stale ones. With ``latest_only`` a topic keeps at most one message waiting: a newer
``publish`` replaces it (counted in ``dropped_stale``) and the caller never waits for the wire.
A replaced message is never encoded, so a stale scan costs no CPU either.
Without it, ``publish`` waits until its frame is handed to the socket, in order.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any

from clients.errors import ConnectionClosed
from clients.wire import Frame

logger = logging.getLogger(__name__)

Encoder = Callable[[str, dict[str, Any]], Awaitable[Frame]]
Sender = Callable[[Frame], Awaitable[None]]
# (topic, msg, encode_start_ns, frame_ready_ns, sent_ns, wire_bytes): stage tracing hook
SentHook = Callable[[str, dict[str, Any], int, int, int, int], None]


@dataclass(frozen=True, slots=True)
class PublishStats:
    """Counters of one topic's send path since the client was created.

    sent : messages handed to the socket.
    wire_bytes : their payload bytes.
    dropped_stale : replaced by a newer message before being sent (``latest_only`` topics).
    dropped_disconnected : discarded because the connection was down (client reconnecting).
    failed : could not be encoded or sent for another reason (logged).
    """

    sent: int = 0
    wire_bytes: int = 0
    dropped_stale: int = 0
    dropped_disconnected: int = 0
    failed: int = 0


class TopicPublisher:
    """Serialises the messages of one topic onto the connection (event-loop thread only)."""

    def __init__(
        self,
        topic: str,
        *,
        latest_only: bool,
        encode: Encoder,
        send: Sender,
        on_sent: SentHook | None = None,
    ) -> None:
        self.topic = topic
        self.latest_only = latest_only
        self._encode = encode
        self._send = send
        self._on_sent = on_sent
        self._slot: dict[str, Any] | None = None
        self._task: asyncio.Task[None] | None = None
        self._counts = {name: 0 for name in PublishStats.__dataclass_fields__}

    @property
    def stats(self) -> PublishStats:
        """A snapshot of the counters."""
        return PublishStats(**self._counts)

    def count_disconnected(self) -> None:
        """Record a message discarded because the connection is down."""
        self._counts["dropped_disconnected"] += 1

    async def publish(self, msg: dict[str, Any]) -> None:
        """Encode and send ``msg``, or park it in the latest-only slot and return at once.

        Raises :class:`ConnectionClosed` (not on latest-only topics, which count it instead).
        """
        if self.latest_only:
            if self._slot is not None:
                self._counts["dropped_stale"] += 1
            self._slot = msg
            if self._task is None:
                self._task = asyncio.create_task(self._drain(), name=f"publish {self.topic}")
            return
        await self._send_one(msg)

    async def _send_one(self, msg: dict[str, Any]) -> None:
        encode_start_ns = time.time_ns()
        frame = await self._encode(self.topic, msg)
        ready_ns = time.time_ns()
        await self._send(frame)
        self._counts["sent"] += 1
        self._counts["wire_bytes"] += frame.wire_bytes
        if self._on_sent is not None:
            self._on_sent(
                self.topic, msg, encode_start_ns, ready_ns, time.time_ns(), frame.wire_bytes
            )

    async def _drain(self) -> None:
        """Send whatever sits in the slot until it stays empty."""
        try:
            while self._slot is not None:
                msg, self._slot = self._slot, None
                try:
                    await self._send_one(msg)
                except ConnectionClosed:
                    self._counts["dropped_disconnected"] += 1
                except Exception:
                    self._counts["failed"] += 1
                    logger.exception("publish on %s failed", self.topic)
        finally:
            self._task = None

    async def flush(self) -> None:
        """Wait until the latest-only slot has been sent (no-op for ordinary topics)."""
        while self._task is not None:
            await asyncio.shield(self._task)

    def cancel(self) -> None:
        """Stop sending (client closing); a parked message is discarded."""
        self._slot = None
        if self._task is not None:
            self._task.cancel()
