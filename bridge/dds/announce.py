"""ROS 2's graph topic `ros_discovery_info`: the bridge's own node, and everybody else's.

Each ROS 2 participant publishes a `rmw_dds_common/msg/ParticipantEntitiesInfo`
(transient-local, keep-last 1): its GUID and, per node, the GUIDs of the readers and writers
the node owns. ROS 2 tools (`ros2 node list`, `ros2 topic info`) name endpoints through it.
The bridge announces one node that owns all its endpoints and reads the others' announcements
so that rosapi can name remote nodes.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence

from bridge.dds.discovery import NodeEntities, nodes_from_discovery_info
from bridge.dds.naming import DISCOVERY_TOPIC, DISCOVERY_TYPE
from bridge.dds.participant import DdsPlumbing
from bridge.dds.qos import DISCOVERY, QosProfile
from bridge.dds.topic_mirror import type_hash_user_data
from schemas.codec_cdr import from_cdr, to_cdr
from schemas.errors import SchemaError
from schemas.values import Message

logger = logging.getLogger("bridge.dds")

NodeUpdate = Callable[[bytes, tuple[NodeEntities, ...]], object]


def split_node_name(node: str) -> tuple[str, str]:
    """`/riverbridge_1` -> (`/`, `riverbridge_1`); `/ns/n` -> (`/ns`, `n`)."""
    namespace, _, name = node.rpartition("/")
    return namespace or "/", name


def participant_entities(
    participant: bytes, node: str, readers: Sequence[bytes], writers: Sequence[bytes]
) -> Message:
    """The canonical ParticipantEntitiesInfo announcing `node` with these endpoints."""
    namespace, name = split_node_name(node)
    return {
        "gid": {"data": participant},
        "node_entities_info_seq": [
            {
                "node_namespace": namespace,
                "node_name": name,
                "reader_gid_seq": [{"data": guid} for guid in readers],
                "writer_gid_seq": [{"data": guid} for guid in writers],
            }
        ],
    }


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
        participant, registry = dds.participant, dds.registry
        data_type = participant.types.message(registry.message(DISCOVERY_TYPE))
        user_data = type_hash_user_data(registry, DISCOVERY_TYPE)
        self._writer = participant.writer(DISCOVERY_TOPIC, data_type, DISCOVERY, user_data)
        # rmw_cyclonedds reads it keep-all; any depth works as each participant sends its own.
        self._reader = participant.reader(
            DISCOVERY_TOPIC, data_type, QosProfile(transient_local=True, depth=0), user_data
        )
        dds.pump.watch(self._reader.condition, self._take)
        self._last: tuple[tuple[bytes, ...], tuple[bytes, ...]] | None = None

    def own_endpoints(self) -> tuple[list[bytes], list[bytes]]:
        return [self._reader.guid], [self._writer.guid]

    def announce(self, readers: Sequence[bytes], writers: Sequence[bytes]) -> None:
        """Publish the node's endpoints (its own discovery endpoints included) if changed."""
        own_readers, own_writers = self.own_endpoints()
        current = (tuple(sorted([*own_readers, *readers])), tuple(sorted([*own_writers, *writers])))
        if current == self._last:
            return
        self._last = current
        msg = participant_entities(self._dds.participant.guid, self.node, *current)
        cdr = to_cdr(self._dds.registry, DISCOVERY_TYPE, msg)

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
                    msg = from_cdr(self._dds.registry, DISCOVERY_TYPE, sample.data)
                except SchemaError as exc:
                    logger.debug("DDS: unreadable ros_discovery_info: %s", exc)
                    continue
                participant, nodes = nodes_from_discovery_info(msg)
                if participant != self._dds.participant.guid:
                    self._on_nodes(participant, nodes)

        return decode

    def close(self) -> None:
        self._dds.pump.unwatch(self._reader.condition)
        self._dds.participant.delete(self._reader.entity)
        self._dds.participant.delete(self._writer.entity)
