"""rmw_cyclonedds_cpp's service request header, on requests and replies alike.

On the wire a request (`rq/<service>Request`) and its reply (`rr/<service>Reply`) are one CDR
stream: the 4-byte encapsulation header, then `cdds_request_header_t { uint64 guid; int64
seq; }`, then the request or response fields. `guid` is the client's request-writer instance
handle and `seq` its request counter; the server copies both into the reply, and a client
keeps only replies carrying its own `guid`. 16 bytes keep the fields 8-aligned, so a message
serialized on its own (rosbags) can be spliced in unchanged.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

ENCAPSULATION_BYTES = 4
_LITTLE = struct.Struct("<Qq")
_BIG = struct.Struct(">Qq")
HEADER_BYTES = _LITTLE.size


@dataclass(frozen=True)
class RequestId:
    """Who asked (the client's writer handle) and which of its requests this is."""

    guid: int
    sequence: int


def wrap(message_cdr: bytes, request: RequestId) -> bytes:
    """A request or reply sample: `message_cdr` (with its header) behind the request id."""
    head = message_cdr[:ENCAPSULATION_BYTES]
    packer = _LITTLE if _is_little(head) else _BIG
    return head + packer.pack(request.guid, request.sequence) + message_cdr[ENCAPSULATION_BYTES:]


def unwrap(sample: bytes) -> tuple[RequestId, bytes]:
    """Split a sample into its request id and the message CDR (header included)."""
    if len(sample) < ENCAPSULATION_BYTES + HEADER_BYTES:
        raise ValueError(f"service sample of {len(sample)} bytes has no request header")
    head = sample[:ENCAPSULATION_BYTES]
    unpacker = _LITTLE if _is_little(head) else _BIG
    guid, sequence = unpacker.unpack_from(sample, ENCAPSULATION_BYTES)
    return RequestId(guid, sequence), head + sample[ENCAPSULATION_BYTES + HEADER_BYTES :]


def _is_little(encapsulation: bytes) -> bool:
    """CDR encapsulation ids are big-endian 16-bit numbers; odd ones are little-endian."""
    return len(encapsulation) >= 2 and bool(encapsulation[1] & 1)
