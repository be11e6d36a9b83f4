"""The Cyclone DDS configuration the bridge gives its domain (no environment lookups).

Cyclone's default discovers peers by multicast on the machine's first real interface. The
bridge never relies on that default: it names the one interface DDS may use (`lo` unless told
otherwise), switches multicast off unless asked, and lists its unicast discovery peers
(127.0.0.1 on the loopback interface). With `ParticipantIndex auto` every participant on a
host takes a well-known port, so a peer address without a port reaches all of them.

Large samples (a 5.5 MB point cloud) need room: socket buffers of a few MB so a burst of
fragments is not dropped by the kernel, and a writer history cache that does not throttle
a single scan (Cyclone's default high watermark is 500 kB); `benchmarks/dds.py` measures it.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass

LOOPBACK = "lo"
# Participants per host that peers probe for (ports 7410 + 250 * domain + 10 + 2 * index).
MAX_PARTICIPANT_INDEX = 20
# Kernel socket buffers: a 5.5 MB scan arrives as ~4,000 fragments in a few milliseconds.
SOCKET_BUFFER_BYTES = 8 * 1024 * 1024
# Writer history cache high watermark (from the start, not grown adaptively from 30 kB): a
# writer blocks only once two full scans are unacknowledged.
WHC_HIGH_BYTES = 16 * 1024 * 1024
_ADDRESS = re.compile(r"[A-Za-z0-9._\-:\[\]]+\Z")
_INTERFACE = re.compile(r"[A-Za-z0-9._\-@]+\Z")
MULTICAST_MODES = ("false", "spdp", "true")


@dataclass(frozen=True)
class CycloneSettings:
    """Where the bridge's DDS traffic may go.

    interface : network interface name (`lo`, `veth0`, `eth0`).
    peers : unicast discovery addresses (`10.0.0.2`, `host:7410`); empty on `lo` means
        127.0.0.1.
    multicast : `false` (default), `spdp` (discovery only) or `true`.
    """

    interface: str = LOOPBACK
    peers: tuple[str, ...] = ()
    multicast: str = "false"

    def __post_init__(self) -> None:
        if not _INTERFACE.match(self.interface):
            raise ValueError(f"dds interface {self.interface!r} is not an interface name")
        for peer in self.peers:
            if not _ADDRESS.match(peer):
                raise ValueError(f"dds peer {peer!r} is not an address")
        if self.multicast not in MULTICAST_MODES:
            raise ValueError(
                f"dds multicast must be one of {MULTICAST_MODES}, got {self.multicast!r}"
            )

    def effective_peers(self) -> tuple[str, ...]:
        if self.peers or self.interface != LOOPBACK:
            return self.peers
        return ("127.0.0.1",)


def cyclone_xml(settings: CycloneSettings, tuned: bool = True) -> str:
    """The `<CycloneDDS>` document for `dds_create_domain` (also valid as CYCLONEDDS_URI)."""
    root = ET.Element("CycloneDDS")
    domain = ET.SubElement(root, "Domain", id="any")
    general = ET.SubElement(domain, "General")
    interfaces = ET.SubElement(general, "Interfaces")
    ET.SubElement(interfaces, "NetworkInterface", name=settings.interface)
    ET.SubElement(general, "AllowMulticast").text = settings.multicast
    discovery = ET.SubElement(domain, "Discovery")
    ET.SubElement(discovery, "ParticipantIndex").text = "auto"
    ET.SubElement(discovery, "MaxAutoParticipantIndex").text = str(MAX_PARTICIPANT_INDEX)
    peers = settings.effective_peers()
    if peers:
        peer_list = ET.SubElement(discovery, "Peers")
        for address in peers:
            ET.SubElement(peer_list, "Peer", address=address)
    if tuned:
        internal = ET.SubElement(domain, "Internal")
        ET.SubElement(internal, "SocketReceiveBufferSize", max=f"{SOCKET_BUFFER_BYTES}B")
        ET.SubElement(internal, "SocketSendBufferSize", max=f"{SOCKET_BUFFER_BYTES}B")
        marks = ET.SubElement(internal, "Watermarks")
        ET.SubElement(marks, "WhcHigh").text = f"{WHC_HIGH_BYTES}B"
        ET.SubElement(marks, "WhcHighInit").text = f"{WHC_HIGH_BYTES}B"
    return ET.tostring(root, encoding="unicode")


def peers_from_text(values: Sequence[str]) -> tuple[str, ...]:
    """`--dds-peer a --dds-peer b,c` -> ("a", "b", "c")."""
    return tuple(p.strip() for value in values for p in value.split(",") if p.strip())
