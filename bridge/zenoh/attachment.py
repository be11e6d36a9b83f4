"""The attachment rmw_zenoh sends with every sample, query and reply. Pure.

rmw_zenoh serialises it with zenoh-ext's serializer: the sequence number (int64), the source
timestamp (int64, ns since the epoch), and the 16-byte source GID as a sequence (a one-byte
LEB128 length, 16, then the bytes): 33 bytes, little-endian. A GID is the entity's identity;
rmw_zenoh derives it from the entity's liveliness key (XXH3-128), we use BLAKE2b-128 of the
same key: other nodes only compare GIDs, they never recompute them.
"""

from __future__ import annotations

import hashlib
import struct
from dataclasses import dataclass

GID_BYTES = 16  # RMW_GID_STORAGE_SIZE
_LAYOUT = struct.Struct(f"<qqB{GID_BYTES}s")
ATTACHMENT_BYTES = _LAYOUT.size  # 33


class AttachmentProblem(ValueError):
    """An attachment that is missing or not rmw_zenoh's 33-byte layout."""


@dataclass(frozen=True)
class Attachment:
    sequence_number: int
    source_timestamp_ns: int
    source_gid: bytes  # GID_BYTES


def encode_attachment(attachment: Attachment) -> bytes:
    return _LAYOUT.pack(
        attachment.sequence_number,
        attachment.source_timestamp_ns,
        GID_BYTES,
        attachment.source_gid,
    )


def decode_attachment(data: bytes | None) -> Attachment:
    """The attachment's fields (AttachmentProblem if absent or of another size or layout)."""
    if data is None:
        raise AttachmentProblem("no attachment")
    if len(data) != ATTACHMENT_BYTES:
        raise AttachmentProblem(f"attachment of {len(data)} bytes, not {ATTACHMENT_BYTES}")
    sequence, stamp_ns, gid_length, gid = _LAYOUT.unpack(data)
    if gid_length != GID_BYTES:
        raise AttachmentProblem(f"attachment GID of length {gid_length}, not {GID_BYTES}")
    return Attachment(sequence, stamp_ns, gid)


def entity_gid(liveliness_key: str) -> bytes:
    """A 16-byte GID for the entity whose liveliness token is `liveliness_key`."""
    return hashlib.blake2b(liveliness_key.encode(), digest_size=GID_BYTES).digest()
