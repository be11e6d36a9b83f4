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
from bridge.dds.participant import DdsPlumbing
from bridge.dds.qos import DISCOVERY, QosProfile

logger = logging.getLogger("bridge.dds")

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
        # rmw_cyclonedds reads it keep-all; any depth works as each participant sends its own.
        self._reader = participant.reader(
            DISCOVERY_TOPIC, data_type, QosProfile(transient_local=True, depth=0), user_data
        )
        dds.pump.watch(self._reader.condition, self._take)
        self._last: tuple[tuple[bytes, ...], tuple[bytes, ...]] | None = None
        self._warned = False

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

    def _take(self) -> Callable[[], None] | None:
        samples = self._reader.take()
        if not samples:
            return None

        def decode() -> None:
            for sample in samples:
                try:
                    info = discovery_info.decode(sample.data, self._dds.distro)
                except ValueError as exc:  # e.g. another distribution's layout
                    self._unreadable(exc)
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
