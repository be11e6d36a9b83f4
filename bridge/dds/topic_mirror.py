"""DDS writers and readers for the bridge's topics, kept in step with what clients want.

A topic a websocket client publishes gets one DDS writer on `rt/<topic>` (messages go out
through the outbox); a topic a websocket client subscribes to gets one DDS reader, whose
samples the pump thread takes and decodes before handing them to the event loop. What the
clients want is worked out by the mirror (`bridge.dds.mirror`); here it is only carried out.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import TypeVar

from bridge.dds.naming import topic_to_dds
from bridge.dds.participant import DdsPlumbing, RawReader, RawWriter
from bridge.dds.qos import QosProfile
from bridge.graph_mirror import Arrival, Wanted
from bridge.outgoing import TopicMessage
from schemas.codec_cdr import from_cdr, to_cdr
from schemas.errors import SchemaError
from schemas.registry import TypeRegistry

logger = logging.getLogger("bridge.dds")
EndpointT = TypeVar("EndpointT", RawWriter, RawReader)


@dataclass
class _Writer:
    wanted: Wanted
    raw: RawWriter


@dataclass
class _Reader:
    wanted: Wanted
    raw: RawReader
    writer_guids: dict[int, bytes | None]


def type_hash_user_data(registry: TypeRegistry, type_name: str) -> str:
    """ROS 2 Jazzy's `typehash=RIHS01_…;` endpoint user data (empty if rosbags cannot)."""
    try:
        return f"typehash={registry.typestore.hash_rihs01(type_name)};"
    except Exception:  # older rosbags or a type it cannot hash: the hash is informational
        return ""


class TopicMirror:
    """Creates, replaces and deletes the DDS endpoints of topics; writes and takes samples."""

    def __init__(
        self,
        dds: DdsPlumbing,
        deliver: Callable[[list[Arrival]], object],
    ) -> None:
        self._dds = dds
        self._deliver = deliver  # called on the pump thread; must hop to the loop itself
        self.writers: dict[str, _Writer] = {}
        self.readers: dict[str, _Reader] = {}
        self._refused: set[tuple[str, str]] = set()

    # -- endpoints ---------------------------------------------------------------------------

    def sync(self, writers: dict[str, Wanted], readers: dict[str, Wanted]) -> bool:
        """Make the endpoints match; returns True if any was created or deleted."""
        changed = False
        for topic in [t for t, w in self.writers.items() if writers.get(t) != w.wanted]:
            self._dds.participant.delete(self.writers.pop(topic).raw.entity)
            changed = True
        for topic in [t for t, r in self.readers.items() if readers.get(t) != r.wanted]:
            reader = self.readers.pop(topic)
            self._dds.pump.unwatch(reader.raw.condition)
            self._dds.participant.delete(reader.raw.entity)
            changed = True
        for topic, wanted in writers.items():
            if topic not in self.writers:
                changed |= self._add_writer(topic, wanted)
        for topic, wanted in readers.items():
            if topic not in self.readers:
                changed |= self._add_reader(topic, wanted)
        return changed

    def _idl_class(self, topic: str, type_name: str) -> type | None:
        try:
            return self._dds.participant.types.message(self._dds.registry.message(type_name))
        except (SchemaError, ValueError) as exc:
            self._refuse(topic, type_name, str(exc))
            return None

    def refused(self, topic: str) -> bool:
        """True if the topic cannot be mirrored (its type has no DDS form, Cyclone refused)."""
        return any(name == topic for name, _ in self._refused)

    def _refuse(self, topic: str, type_name: str, why: str) -> None:
        if (topic, type_name) not in self._refused:
            self._refused.add((topic, type_name))
            logger.warning("DDS: topic %s (%s) is not mirrored: %s", topic, type_name, why)

    def _add_writer(self, topic: str, wanted: Wanted) -> bool:
        raw = self._open(topic, wanted, self._dds.participant.writer, "writer")
        if raw is None:
            return False
        self.writers[topic] = _Writer(wanted, raw)
        return True

    def _add_reader(self, topic: str, wanted: Wanted) -> bool:
        raw = self._open(topic, wanted, self._dds.participant.reader, "reader")
        if raw is None:
            return False
        reader = self.readers[topic] = _Reader(wanted, raw, {})
        self._dds.pump.watch(raw.condition, lambda: self._take(topic, reader))
        return True

    def _open(
        self,
        topic: str,
        wanted: Wanted,
        create: Callable[[str, type, QosProfile, str], EndpointT],
        kind: str,
    ) -> EndpointT | None:
        """A DDS `kind` ("writer" or "reader") of `topic` made by `create`, or None (refused
        and logged once: a type with no DDS form, or Cyclone's refusal)."""
        data_type = self._idl_class(topic, wanted.type_name)
        if data_type is None:
            return None
        try:
            raw = create(
                topic_to_dds(topic),
                data_type,
                wanted.profile,
                self._dds.type_hash(wanted.type_name),
            )
        except Exception as exc:  # Cyclone refuses e.g. a second type on one topic name
            self._refuse(topic, wanted.type_name, f"cannot create a DDS {kind}: {exc}")
            return None
        logger.info(
            "DDS: %s %s (%s; %s)",
            "writing" if kind == "writer" else "reading",
            topic_to_dds(topic),
            wanted.type_name,
            wanted.profile.describe(),
        )
        return raw

    def close(self) -> None:
        self.sync({}, {})

    def endpoint_guids(self) -> tuple[list[bytes], list[bytes]]:
        """(reader GUIDs, writer GUIDs) for the bridge's `ros_discovery_info`."""
        return (
            [r.raw.guid for r in self.readers.values()],
            [w.raw.guid for w in self.writers.values()],
        )

    # -- data --------------------------------------------------------------------------------

    def send(self, message: TopicMessage) -> bool:
        """Queue `message` for its topic's writer; False if the topic has none."""
        writer = self.writers.get(message.topic)
        if writer is None or writer.wanted.type_name != message.type_name:
            return False
        self._dds.outbox.put(
            ("topic", message.topic), lambda: self._write(writer.raw, message), message.size_hint
        )
        return True

    def _write(self, raw: RawWriter, message: TopicMessage) -> None:
        """Writer thread: the CDR (cached on the message) out to DDS."""
        cdr = message.cdr
        if cdr is None:
            cdr = to_cdr(message.registry, message.type_name, message.msg)
        result = raw.write(cdr)
        if result < 0:
            logger.warning("DDS: write to %s failed (%d)", topic_to_dds(message.topic), result)

    def _take(self, topic: str, reader: _Reader) -> Callable[[], None] | None:
        """Pump thread, under its lock: take the samples; decoding happens after."""
        samples = reader.raw.take()
        if not samples:
            return None
        guids = [self._writer_guid(reader, s.publication_handle) for s in samples]

        def decode() -> None:
            arrivals = []
            for sample, guid in zip(samples, guids, strict=True):
                try:
                    msg = from_cdr(self._dds.registry, reader.wanted.type_name, sample.data)
                except SchemaError as exc:
                    logger.warning("DDS: dropped a sample on %s: %s", topic, exc)
                    continue
                arrivals.append(Arrival(topic, reader.wanted.type_name, msg, sample.data, guid))
            if arrivals:
                self._deliver(arrivals)

        return decode

    @staticmethod
    def _writer_guid(reader: _Reader, handle: int) -> bytes | None:
        if handle not in reader.writer_guids:
            reader.writer_guids[handle] = reader.raw.writer_guid(handle)
        return reader.writer_guids[handle]
