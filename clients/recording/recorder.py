"""Record a running bridge's topics into an MCAP file, as the bridge already serializes them.

The recorder is an ordinary rosbridge client. Every ``discovery_period_s`` it asks
``/rosapi/topics_and_raw_types`` for the topics, their types and full definitions (the same
text rosbags' ``generate_msgdef`` gives, which is what an MCAP ``ros2msg`` schema holds), and
subscribes to each new topic the filter takes with ``compression: cbor-raw``: the bridge then
sends each message as its CDR bytes (``{"secs", "nsecs", "bytes"}``), which it encodes once
per message for every cbor-raw subscriber. So nothing is decoded or re-encoded here: the
bytes go to the file as they arrive.

Times: a message's MCAP ``log_time`` is when its frame reached the recorder (wall clock, ns),
its ``publish_time`` the bridge's ``secs``/``nsecs`` (when the message entered the bridge).
The message's own ``header.stamp`` stays inside the CDR, untouched.

The socket is read on the event loop; compression and file writes run on one writer thread
(zstandard releases the GIL), so a 5.5 MB scan being compressed never holds up the reader.
What waits for that thread is bounded by ``max_backlog_bytes``: past it, new messages are
dropped and counted, and the recorder says so when it stops.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from clients.client import RosbridgeClient
from clients.errors import RosbridgeError
from clients.recording.mcap_file import Compression, McapRecording, TopicCounts
from clients.recording.topics import TopicFilter
from clients.subscription import Subscription

log = logging.getLogger(__name__)

NS_PER_S = 1_000_000_000
# Foxglove polls topics_and_raw_types every 3 s; a recorder should notice new topics sooner.
DISCOVERY_PERIOD_S = 1.0
# Messages waiting for the writer thread, in bytes: ~10 s of the full stack (~11 MB/s).
MAX_BACKLOG_BYTES = 128 * 1024 * 1024
# Per subscription, messages queued between the socket and this recorder's loop.
QUEUE_MESSAGES = 4096


@dataclass
class RecorderStats:
    """Counters of one recording, readable while it runs."""

    started_ns: int = field(default_factory=time.time_ns)
    messages: int = 0
    bytes: int = 0
    dropped_backlog: int = 0
    dropped_queue: int = 0
    skipped_topics: dict[str, str] = field(default_factory=dict)

    def rate(self, now_ns: int | None = None) -> tuple[float, float]:
        """(messages/s, MB/s) since the start."""
        elapsed_s = max(1e-9, ((now_ns or time.time_ns()) - self.started_ns) / NS_PER_S)
        return self.messages / elapsed_s, self.bytes / elapsed_s / 1e6


class Recorder:
    """Records the topics of the bridge at ``url`` that ``topics`` takes into ``output``."""

    def __init__(
        self,
        url: str,
        output: Path,
        *,
        topics: TopicFilter | None = None,
        compression: Compression = "zstd",
        discovery_period_s: float = DISCOVERY_PERIOD_S,
        max_backlog_bytes: int = MAX_BACKLOG_BYTES,
        connect_timeout_s: float = 10.0,
    ) -> None:
        self.url = url
        self.output = output
        self.topics = topics or TopicFilter()
        self.stats = RecorderStats()
        self._compression = compression
        self._discovery_period_s = discovery_period_s
        self._max_backlog_bytes = max_backlog_bytes
        self._connect_timeout_s = connect_timeout_s
        self._backlog_bytes = 0
        self._subscriptions: dict[str, Subscription] = {}
        self._readers: list[asyncio.Task[None]] = []
        self._pool = ThreadPoolExecutor(1, thread_name_prefix="recorder-writer")
        self._file: McapRecording | None = None

    async def run(
        self, stop: asyncio.Event, on_topic: Callable[[str, str], None] | None = None
    ) -> dict[str, TopicCounts]:
        """Record until ``stop`` is set; then finish the file. Returns what was written.

        on_topic : called with (topic, type) when a topic starts being recorded.
        Raises :class:`clients.errors.ConnectionFailed` if the bridge cannot be reached.
        """
        loop = asyncio.get_running_loop()
        self._file = await loop.run_in_executor(
            self._pool, lambda: McapRecording(self.output, self._compression)
        )
        client = RosbridgeClient(
            self.url, encoding="cbor", name="recorder", connect_timeout=self._connect_timeout_s
        )
        try:
            await client.connect()
            await self._discover_until(stop, client, on_topic)
        finally:
            await client.close()  # ends the subscriptions; readers drain what is queued
            await asyncio.gather(*self._readers, return_exceptions=True)
            await loop.run_in_executor(self._pool, self._file.close)
            self._pool.shutdown(wait=True)
        self.stats.dropped_queue = sum(s.dropped for s in self._subscriptions.values())
        return dict(self._file.counts)

    async def _discover_until(
        self,
        stop: asyncio.Event,
        client: RosbridgeClient,
        on_topic: Callable[[str, str], None] | None,
    ) -> None:
        loop = asyncio.get_running_loop()
        while not stop.is_set():
            with contextlib.suppress(RosbridgeError, TimeoutError):
                await self._discover(client, on_topic)
            loop.run_in_executor(self._pool, self._flush_if_due)
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(stop.wait(), self._discovery_period_s)

    async def _discover(
        self, client: RosbridgeClient, on_topic: Callable[[str, str], None] | None
    ) -> None:
        """Subscribe to every topic the bridge lists that is new and wanted."""
        listing = await client.call_service("/rosapi/topics_and_raw_types", timeout=10.0)
        for topic, type_name, definition in zip(
            listing.get("topics", []),
            listing.get("types", []),
            listing.get("typedefs_full_text", []),
            strict=False,
        ):
            if topic in self._subscriptions or topic in self.stats.skipped_topics:
                continue
            if not self.topics(topic):
                continue
            if not definition:
                self.stats.skipped_topics[topic] = f"the bridge has no definition of {type_name}"
                log.warning(
                    "not recording %s: the bridge has no definition of %r (its messages "
                    "cannot be serialized as CDR)",
                    topic,
                    type_name,
                )
                continue
            await self._start_topic(client, topic, type_name, definition)
            if on_topic is not None:
                on_topic(topic, type_name)

    async def _start_topic(
        self, client: RosbridgeClient, topic: str, type_name: str, definition: str
    ) -> None:
        assert self._file is not None
        recording = self._file
        await asyncio.get_running_loop().run_in_executor(
            self._pool, recording.add_topic, topic, type_name, definition
        )
        subscription = await client.subscribe(topic, compression="cbor-raw", maxsize=QUEUE_MESSAGES)
        self._subscriptions[topic] = subscription
        self._readers.append(
            asyncio.create_task(self._read(topic, subscription), name=f"record {topic}")
        )
        log.info("recording %s (%s)", topic, type_name)

    async def _read(self, topic: str, subscription: Subscription) -> None:
        """Hand each received message to the writer thread, in arrival order."""
        async for received in subscription:
            self._write(topic, received.msg, received.recv_ns)

    def _write(self, topic: str, envelope: dict[str, Any], recv_ns: int) -> None:
        cdr = envelope.get("bytes")
        if not isinstance(cdr, bytes | bytearray | memoryview):
            log.warning("%s: a message without CDR bytes (not cbor-raw?); skipped", topic)
            return
        size = len(cdr)
        if self._backlog_bytes + size > self._max_backlog_bytes:
            self.stats.dropped_backlog += 1
            return
        publish_ns = int(envelope.get("secs", 0)) * NS_PER_S + int(envelope.get("nsecs", 0))
        self._backlog_bytes += size
        self.stats.messages += 1
        self.stats.bytes += size
        loop = asyncio.get_running_loop()
        future = self._pool.submit(self._add, topic, bytes(cdr), recv_ns, publish_ns)
        # the callback runs on the writer thread; the count is only ever changed on the loop
        future.add_done_callback(lambda _: loop.call_soon_threadsafe(self._written, size))

    def _written(self, size: int) -> None:
        self._backlog_bytes -= size

    def _add(self, topic: str, cdr: bytes, log_ns: int, publish_ns: int) -> None:
        assert self._file is not None
        try:
            self._file.add_message(topic, cdr, log_ns, publish_ns)
        except Exception:
            log.exception("writing a message of %s failed", topic)

    def _flush_if_due(self) -> None:
        if self._file is not None:
            self._file.flush_if_due()
