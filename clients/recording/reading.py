"""Read the ROS 2 messages of an MCAP file in time order, whole or cut short by a crash.

A finished file has a summary (channels, chunk index): the ``mcap`` package's seeking reader
then returns the wanted topics in ``log_time`` order. A file whose writer was killed has no
summary; it is read front to back with the streaming reader up to its last complete record,
in file order (which is arrival order for riverbridge's recorder).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Generator, Iterator
from dataclasses import dataclass
from pathlib import Path

from mcap.exceptions import McapError
from mcap.reader import NonSeekingReader, SeekingReader
from mcap.records import Channel, Message, Schema
from mcap.well_known import MessageEncoding, SchemaEncoding

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class RecordedMessage:
    """One ROS 2 message of a recording: its topic, type, definition and CDR bytes."""

    topic: str
    type_name: str
    definition: str
    cdr: bytes
    log_time_ns: int
    publish_time_ns: int


def is_ros2(schema: Schema | None, channel: Channel) -> bool:
    return (
        schema is not None
        and schema.encoding == SchemaEncoding.ROS2
        and channel.message_encoding == MessageEncoding.CDR
    )


def _message(schema: Schema, channel: Channel, message: Message) -> RecordedMessage:
    return RecordedMessage(
        channel.topic,
        schema.name,
        schema.data.decode("utf-8"),
        bytes(message.data),
        message.log_time,
        message.publish_time,
    )


def read_recording(
    path: Path, wanted: Callable[[str], bool], start_ns: int | None = None
) -> Generator[RecordedMessage, None, None]:
    """The ROS 2 (``ros2msg``/``cdr``) messages of the topics ``wanted`` takes, in time order,
    from log time ``start_ns`` on (a seek: the index finds the first chunk that holds it).

    Raises :class:`McapError` if ``path`` is not an MCAP file at all.
    """
    with open(path, "rb") as stream:
        reader = SeekingReader(stream)
        try:
            summary = reader.get_summary()
        except Exception:  # a truncated file ends in chunk data, not a footer: any error here
            summary = None
        if summary is not None and summary.chunk_indexes:
            topics = [
                c.topic
                for c in summary.channels.values()
                if wanted(c.topic) and is_ros2(summary.schemas.get(c.schema_id), c)
            ]
            for schema, channel, message in reader.iter_messages(
                topics=topics, start_time=start_ns
            ):
                assert schema is not None  # is_ros2 above
                yield _message(schema, channel, message)
            return
        stream.seek(0)
        for recorded in _stream(NonSeekingReader(stream), wanted, path):
            if start_ns is None or recorded.log_time_ns >= start_ns:
                yield recorded


def recording_window(path: Path, wanted: Callable[[str], bool]) -> tuple[int, int]:
    """The first and last log time (ns) of the messages ``read_recording`` gives; (0, 0)
    when there are none. From the summary's statistics when the file has them."""
    with open(path, "rb") as stream:
        try:
            statistics = SeekingReader(stream).get_summary()
        except Exception:  # a truncated file: read it through below
            statistics = None
    stats = statistics.statistics if statistics is not None else None
    if stats is not None and stats.message_count:
        return stats.message_start_time, stats.message_end_time
    first = last = None
    for recorded in read_recording(path, wanted):
        first = recorded.log_time_ns if first is None else first
        last = recorded.log_time_ns
    return (first or 0, last or 0)


def _stream(
    reader: NonSeekingReader, wanted: Callable[[str], bool], path: Path
) -> Iterator[RecordedMessage]:
    messages = reader.iter_messages(log_time_order=False)
    while True:
        try:
            schema, channel, message = next(messages)
        except StopIteration:
            return
        except McapError as exc:  # EndOfFile: the part after the last complete record
            log.warning("%s ends early (%s): read up to its last complete chunk", path, exc)
            return
        if schema is not None and wanted(channel.topic) and is_ros2(schema, channel):
            yield _message(schema, channel, message)


def recorded_topics(path: Path) -> dict[str, str]:
    """Topic -> type of the ROS 2 channels in ``path`` (from the summary, or by reading a file
    that has none)."""
    with open(path, "rb") as stream:
        reader = SeekingReader(stream)
        try:
            summary = reader.get_summary()
        except Exception:  # cut-off file, see read_recording
            summary = None
        if summary is not None:
            return {
                c.topic: summary.schemas[c.schema_id].name
                for c in summary.channels.values()
                if is_ros2(summary.schemas.get(c.schema_id), c)
            }
    return {m.topic: m.type_name for m in read_recording(path, lambda _topic: True)}
