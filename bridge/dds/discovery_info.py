"""`ros_discovery_info` samples (rmw_dds_common/msg/ParticipantEntitiesInfo) for each ROS 2
distribution, as CDR: the one message whose layout differs between them.

Humble's `rmw_dds_common/msg/Gid` is `char[24] data` (a 16-byte GUID and 8 zero bytes);
Jazzy and Kilted shrank it to `char[16] data`. Everything else (the DDS type name, the
topic, its QoS) is the same, and rmw_cyclonedds sends no XTypes type information, so peers
match either layout by name and only the bytes tell them apart: a bridge must write, and
expects to read, its distribution's layout (`--ros-distro`). Pure: bytes in, bytes out.

    ParticipantEntitiesInfo { Gid gid; sequence<NodeEntitiesInfo> node_entities_info_seq; }
    NodeEntitiesInfo { string node_namespace; string node_name;
                       sequence<Gid> reader_gid_seq; sequence<Gid> writer_gid_seq; }
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from dataclasses import dataclass

from bridge.dds.discovery import NodeEntities

# Bytes of a GID on the wire per distribution (rmw_dds_common's Gid.msg).
GID_BYTES = {"humble": 24, "jazzy": 16, "kilted": 16}
GUID_BYTES = 16  # what a GID holds: the endpoint's or participant's RTPS GUID
_HEADER_LE = b"\x00\x01\x00\x00"  # CDR little-endian encapsulation


@dataclass(frozen=True)
class ParticipantInfo:
    """One participant's announcement: its GUID and its nodes."""

    participant: bytes
    nodes: tuple[NodeEntities, ...]


class _Writer:
    def __init__(self) -> None:
        self.body = bytearray()

    def align(self, size: int) -> None:
        self.body.extend(b"\x00" * (-len(self.body) % size))

    def uint32(self, value: int) -> None:
        self.align(4)
        self.body.extend(struct.pack("<I", value))

    def string(self, text: str) -> None:
        data = text.encode() + b"\x00"
        self.uint32(len(data))
        self.body.extend(data)

    def gid(self, guid: bytes, size: int) -> None:
        self.body.extend(guid[:size].ljust(size, b"\x00"))


def encode(info: ParticipantInfo, distro: str) -> bytes:
    """The CDR sample (encapsulation header included) in `distro`'s layout."""
    size = GID_BYTES[distro]
    out = _Writer()
    out.gid(info.participant, size)
    out.uint32(len(info.nodes))
    for node in info.nodes:
        namespace, _, name = node.name.rpartition("/")
        out.string(namespace or "/")
        out.string(name)
        for gids in (node.readers, node.writers):
            out.uint32(len(gids))
            for guid in sorted(gids):
                out.gid(guid, size)
    return _HEADER_LE + bytes(out.body)


class _Reader:
    def __init__(self, data: bytes) -> None:
        if len(data) < 4:
            raise ValueError("ros_discovery_info sample without a CDR header")
        self.little = bool(data[1] & 1)
        self.body, self.at = data[4:], 0

    def take(self, count: int) -> bytes:
        if self.at + count > len(self.body):
            raise ValueError("ros_discovery_info sample ends early")
        chunk = self.body[self.at : self.at + count]
        self.at += count
        return chunk

    def uint32(self) -> int:
        self.at += -self.at % 4
        (value,) = struct.unpack("<I" if self.little else ">I", self.take(4))
        return int(value)

    def string(self) -> str:
        return self.take(self.uint32()).rstrip(b"\x00").decode("utf-8", "replace")

    def count(self, limit: int) -> int:
        value = self.uint32()
        if value > limit:
            raise ValueError(f"ros_discovery_info sequence of {value} is longer than the sample")
        return value


def decode(data: bytes, distro: str) -> ParticipantInfo:
    """A `ros_discovery_info` sample of `distro`'s layout; ValueError if it is not one
    (e.g. the other distribution's). GIDs come back as their 16 GUID bytes."""
    size = GID_BYTES[distro]
    src = _Reader(data)
    participant = src.take(size)[:GUID_BYTES]
    nodes = []
    for _ in range(src.count(len(data))):
        namespace, name = src.string(), src.string()
        gid_sets = []
        for _ in range(2):
            gid_sets.append(
                frozenset(src.take(size)[:GUID_BYTES] for _ in range(src.count(len(data))))
            )
        full = ("/" + namespace.strip("/")).rstrip("/") + "/" + name
        nodes.append(NodeEntities(full, gid_sets[0], gid_sets[1]))
    if src.at + 3 < len(src.body):  # only CDR padding may follow
        raise ValueError(f"{len(src.body) - src.at} bytes left: not the {distro} layout")
    return ParticipantInfo(participant, tuple(nodes))


def announcement(
    participant: bytes, node: str, readers: Sequence[bytes], writers: Sequence[bytes]
) -> ParticipantInfo:
    """The bridge's one node owning all its endpoints."""
    return ParticipantInfo(
        participant, (NodeEntities(node, frozenset(readers), frozenset(writers)),)
    )
