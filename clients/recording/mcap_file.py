"""An MCAP file of ROS 2 messages, written with the ``mcap`` package's Writer.

What makes it readable by Foxglove/Lichtblick, rosbag2's MCAP storage and rosbags: the
``ros2`` profile, one Schema per type with encoding ``ros2msg`` and the full definition text
(the type followed by its dependencies, as rosbags' ``generate_msgdef`` and rosapi give it),
one Channel per topic with message encoding ``cdr`` and the ``offered_qos_profiles`` entry the
profile requires (empty: rosbag2 then offers its default QoS on replay), and each message's
CDR bytes with their 4-byte encapsulation header.

Crash safety: messages are written in chunks (zstd-compressed by default), and a chunk is
closed when it exceeds ``chunk_bytes`` or when ``flush_period_s`` has passed since the last
one, and handed to the operating system at once. A killed recorder
therefore leaves every closed chunk on disk; only the summary at the end of the file (the
index) and the open chunk are missing, and streaming readers read what is there.

Not thread-safe: one thread writes (:class:`clients.recording.recorder.Recorder` runs it on
its writer thread).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO, Literal

from mcap.well_known import MessageEncoding, Profile, SchemaEncoding
from mcap.writer import CompressionType, Writer

Compression = Literal["zstd", "lz4", "none"]
COMPRESSIONS: dict[str, CompressionType] = {
    "zstd": CompressionType.ZSTD,
    "lz4": CompressionType.LZ4,
    "none": CompressionType.NONE,
}
# A chunk of about 4 MiB: one LIDAR scan (~5.5 MB) closes its own chunk, small topics share.
CHUNK_BYTES = 4 * 1024 * 1024
# Longest a message waits in an open chunk: what a crash can lose of the small topics.
FLUSH_PERIOD_S = 1.0
LIBRARY = "riverbridge recorder"


@dataclass
class TopicCounts:
    """What was written for one topic."""

    type_name: str
    messages: int = 0
    bytes: int = 0


@dataclass
class McapRecording:
    """An open MCAP file: register topics, add messages, close.

    path : the file (created or truncated).
    compression : chunk compression, "zstd" (default), "lz4" or "none".
    """

    path: Path
    compression: Compression = "zstd"
    chunk_bytes: int = CHUNK_BYTES
    flush_period_s: float = FLUSH_PERIOD_S
    counts: dict[str, TopicCounts] = field(default_factory=dict)

    def __post_init__(self) -> None:
        # Buffered (the Writer would wrap a raw file in its own buffer it never flushes by
        # itself); emptied after every message, which costs a syscall only after a chunk.
        self._file: BinaryIO = open(self.path, "wb")  # noqa: SIM115 (closed in close)
        self._writer = Writer(
            self._file, chunk_size=self.chunk_bytes, compression=COMPRESSIONS[self.compression]
        )
        self._writer.start(profile=Profile.ROS2, library=LIBRARY)
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._sequence: dict[int, int] = {}
        self._last_flush = time.monotonic()
        self._closed = False

    def add_topic(self, topic: str, type_name: str, definition: str) -> None:
        """Register ``topic`` of ``type_name`` (``pkg/msg/Type``) whose full ``ros2msg``
        definition text is ``definition``. A topic is registered once; later calls for it
        are ignored."""
        if topic in self._channels:
            return
        schema_id = self._schemas.get(type_name)
        if schema_id is None:
            schema_id = self._writer.register_schema(
                type_name, SchemaEncoding.ROS2, definition.encode("utf-8")
            )
            self._schemas[type_name] = schema_id
        channel_id = self._writer.register_channel(
            topic, MessageEncoding.CDR, schema_id, {"offered_qos_profiles": ""}
        )
        self._channels[topic] = channel_id
        self._sequence[channel_id] = 0
        self.counts[topic] = TopicCounts(type_name)

    def has_topic(self, topic: str) -> bool:
        return topic in self._channels

    def add_message(self, topic: str, cdr: bytes, log_time_ns: int, publish_time_ns: int) -> None:
        """Append one message of a registered topic (``cdr`` with its 4-byte header)."""
        channel_id = self._channels[topic]
        self._sequence[channel_id] += 1
        self._writer.add_message(
            channel_id, log_time_ns, cdr, publish_time_ns, self._sequence[channel_id]
        )
        counts = self.counts[topic]
        counts.messages += 1
        counts.bytes += len(cdr)
        self.flush_if_due()
        self._file.flush()

    def flush_if_due(self) -> None:
        """Close the open chunk if it is older than ``flush_period_s``."""
        now = time.monotonic()
        if now - self._last_flush >= self.flush_period_s:
            # closes the chunk and flushes the file (mcap's Writer.flush has no annotations)
            self._writer.flush()  # type: ignore[no-untyped-call]
            self._last_flush = now

    def close(self) -> None:
        """Write the last chunk and the summary (index, statistics); idempotent."""
        if self._closed:
            return
        self._closed = True
        try:
            self._writer.finish()  # type: ignore[no-untyped-call]  # mcap: not annotated
        finally:
            self._file.close()
