"""ROS 2's graph topic `ros_discovery_info`: the bridge's own node, and everybody else's.

Each ROS 2 participant publishes a `rmw_dds_common/msg/ParticipantEntitiesInfo`
(transient-local, keep-last 1): its GUID and, per node, the GUIDs of the readers and writers
the node owns. ROS 2 tools (`ros2 node list`, `ros2 topic info`) name endpoints through it.
The bridge announces one node that owns all its endpoints and reads the others' announcements
so that rosapi can name remote nodes, in its distribution's layout (`discovery_info`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence

from bridge.dds import discovery_info
from bridge.dds.discovery import NodeEntities
from bridge.dds.discovery_info import GID_BYTES, GUID_BYTES, announcement
from bridge.dds.idl_types import discovery_info_type
from bridge.dds.naming import DISCOVERY_TOPIC, DISCOVERY_TYPE
from bridge.dds.participant import DdsPlumbing, RawReader
from bridge.dds.qos import DISCOVERY, QosProfile

logger = logging.getLogger("bridge.dds")

PARTICIPANT_ENTITY = b"\x00\x00\x01\xc1"  # the entity id ending a participant's GUID (RTPS)
NodeUpdate = Callable[[bytes, tuple[NodeEntities, ...]], object]


class Announcer:
    """Publishes the bridge's node and reports other participants' nodes."""

    def __init__(
        self,
        dds: DdsPlumbing,
        node: str,
        on_nodes: NodeUpdate,
    ) -> None:
        self._dds = dds
        self.node = node
        self._on_nodes = on_nodes  # called on the pump thread
        participant = dds.participant
        data_type = discovery_info_type(GID_BYTES[dds.distro])
        user_data = dds.type_hash(DISCOVERY_TYPE)
        self._writer = participant.writer(DISCOVERY_TOPIC, data_type, DISCOVERY, user_data)
        self._reader = self._new_reader()
        self._last: tuple[tuple[bytes, ...], tuple[bytes, ...]] | None = None
        self._warned = False

    def _new_reader(self) -> RawReader:
        # rmw_cyclonedds reads it keep-all; any depth works as each participant sends its own.
        reader = self._dds.participant.reader(
            DISCOVERY_TOPIC,
            discovery_info_type(GID_BYTES[self._dds.distro]),
            QosProfile(transient_local=True, depth=0),
            self._dds.type_hash(DISCOVERY_TYPE),
        )
        self._dds.pump.watch(reader.condition, self._take)
        return reader

    def renew_reader(self) -> None:
        """Read everybody's announcement again with a new reader.

        A Fast DDS participant's transient-local sample sometimes never reaches the reader
        matched at start-up (seen with rclpy nodes on rmw_fastrtps_cpp: the writer is matched,
        the sample does not come until the node changes its entities); a new reader gets the
        writers' history again. Runs on the loop; after `unwatch` the pump no longer takes
        from the old reader, which is then deleted.
        """
        old = self._reader
        self._dds.pump.unwatch(old.condition)
        self._reader = self._new_reader()
        self._dds.participant.delete(old.entity)  # the next announcement lists the new one

    def own_endpoints(self) -> tuple[list[bytes], list[bytes]]:
        return [self._reader.guid], [self._writer.guid]

    def announce(self, readers: Sequence[bytes], writers: Sequence[bytes]) -> None:
        """Publish the node's endpoints (its own discovery endpoints included) if changed."""
        own_readers, own_writers = self.own_endpoints()
        current = (tuple(sorted([*own_readers, *readers])), tuple(sorted([*own_writers, *writers])))
        if current == self._last:
            return
        self._last = current
        info = announcement(self._dds.participant.guid, self.node, *current)
        cdr = discovery_info.encode(info, self._dds.distro)

        def write() -> None:
            self._writer.write(cdr)

        self._dds.outbox.put(("discovery",), write)

    def hears_from(self, participants: set[bytes]) -> bool:
        """Whether the reader is matched with the `ros_discovery_info` writer of any of these
        participants (a writer of another layout may never match: reading again is no use)."""
        reader = self._reader.entity
        for handle in reader.get_matched_publications():
            try:
                writer = reader.get_matched_publication_data(handle)
            except Exception:  # gone meanwhile
                continue
            if writer is not None and writer.participant_key.bytes in participants:
                return True
        return False

    def _take(self) -> Callable[[], None] | None:
        reader = self._reader
        samples = reader.take()
        if not samples:
            return None

        def decode() -> None:
            for sample in samples:
                try:
                    info = discovery_info.decode(sample.data, self._dds.distro)
                except ValueError as exc:  # e.g. another distribution's layout
                    self._unreadable(exc)
                    writer = reader.writer_guid(sample.publication_handle)
                    if writer is not None:  # heard, but names no node we can read
                        self._on_nodes(writer[:12] + PARTICIPANT_ENTITY, ())
                    continue
                if info.participant != self._dds.participant.guid[:GUID_BYTES]:
                    self._on_nodes(info.participant, info.nodes)

        return decode

    def _unreadable(self, exc: ValueError) -> None:
        if not self._warned:
            self._warned = True
            logger.warning(
                "DDS: a ros_discovery_info sample is not in the %s layout (%s); is a node of "
                "another ROS 2 distribution on the domain? (--ros-distro)",
                self._dds.distro,
                exc,
            )

    def close(self) -> None:
        self._dds.pump.unwatch(self._reader.condition)
        self._dds.participant.delete(self._reader.entity)
        self._dds.participant.delete(self._writer.entity)
